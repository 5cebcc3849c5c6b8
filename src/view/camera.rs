//! The viewer's camera: fly (WASD and mouse look) or orbit (drag round a pivot, wheel to
//! zoom), always reducible to the scene file's camera keys, so a capture reproduces it.

use crate::scene::Camera;
use glam::Vec3;

/// How mouse drags and keys move the camera.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CameraMode {
    /// Keys move the eye, dragging turns it.
    Fly,
    /// Dragging turns the eye round the pivot, the wheel moves it nearer or further.
    Orbit,
}

/// The movement keys held this frame, as axes in -1..=1.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MoveInput {
    /// Forward (+) / back (-).
    pub forward: f32,
    /// Right (+) / left (-).
    pub right: f32,
    /// Up (+) / down (-), along the scene's up vector.
    pub up: f32,
    /// Move four times faster.
    pub fast: bool,
}

/// The camera the viewer moves, starting from (and reset to) the scene file's.
#[derive(Debug, Clone)]
pub struct CameraRig {
    pub mode: CameraMode,
    home: Camera,
    position: Vec3,
    /// Radians round the up axis, and above the horizontal plane.
    yaw: f32,
    pitch: f32,
    /// The orbit's centre, and the eye's distance from it.
    pivot: Vec3,
    distance: f32,
    /// World units per second when flying (the scene's size over eight seconds).
    pub speed: f32,
}

/// Pitch stays short of straight up or down, where yaw is undefined.
const MAX_PITCH: f32 = 1.55;

impl CameraRig {
    /// A rig at `home`, flying at a speed scaled to the scene's extent (bounds diagonal).
    pub fn new(home: &Camera, scene_extent: f32) -> CameraRig {
        let mut rig = CameraRig {
            mode: CameraMode::Fly,
            home: home.clone(),
            position: home.position,
            yaw: 0.0,
            pitch: 0.0,
            pivot: home.target,
            distance: 1.0,
            speed: (scene_extent / 8.0).max(1e-3),
        };
        rig.reset();
        rig
    }

    /// Back to the scene file's camera.
    pub fn reset(&mut self) {
        let h = &self.home;
        self.position = h.position;
        self.pivot = h.target;
        self.distance = (h.target - h.position).length().max(1e-4);
        let (yaw, pitch) = angles_of(self.frame_dir(h.target - h.position), h.up);
        self.yaw = yaw;
        self.pitch = pitch;
    }

    /// `v` as a unit vector (the scene's check keeps position != target).
    fn frame_dir(&self, v: Vec3) -> Vec3 {
        v.normalize_or(Vec3::Z)
    }

    /// The camera to render: the scene file's, with this rig's position and target.
    pub fn camera(&self) -> Camera {
        let forward = direction(self.yaw, self.pitch, self.home.up);
        Camera { position: self.position, target: self.position + forward * self.distance, ..self.home.clone() }
    }

    /// Move for `dt` seconds with the keys held.
    pub fn fly(&mut self, input: MoveInput, dt: f32) {
        let up = self.home.up.normalize_or(Vec3::Y);
        let forward = direction(self.yaw, self.pitch, up);
        let right = forward.cross(up).normalize_or(Vec3::X);
        let step = self.speed * dt * if input.fast { 4.0 } else { 1.0 };
        let delta = (forward * input.forward + right * input.right + up * input.up) * step;
        self.position += delta;
        self.pivot += delta;
    }

    /// A mouse drag of (dx, dy) radians: turns the eye (fly) or moves it round the pivot (orbit).
    pub fn turn(&mut self, dx: f32, dy: f32) {
        self.yaw -= dx;
        self.pitch = (self.pitch - dy).clamp(-MAX_PITCH, MAX_PITCH);
        if self.mode == CameraMode::Orbit {
            self.position = self.pivot - direction(self.yaw, self.pitch, self.home.up) * self.distance;
        }
    }

    /// The wheel in orbit mode: `steps` notches nearer (+) or further (-), 10% each.
    pub fn zoom(&mut self, steps: f32) {
        if self.mode != CameraMode::Orbit {
            return;
        }
        self.distance = (self.distance * 0.9f32.powf(steps)).max(1e-4);
        self.position = self.pivot - direction(self.yaw, self.pitch, self.home.up) * self.distance;
    }

    /// Switch mode; orbiting starts round the point the eye looks at.
    pub fn set_mode(&mut self, mode: CameraMode) {
        if mode == CameraMode::Orbit && self.mode == CameraMode::Fly {
            self.pivot = self.position + direction(self.yaw, self.pitch, self.home.up) * self.distance;
        }
        self.mode = mode;
    }

    /// Place the eye and aim it (a script's `camera` command).
    pub fn place(&mut self, position: Vec3, target: Vec3) {
        self.position = position;
        self.pivot = target;
        self.distance = (target - position).length().max(1e-4);
        let (yaw, pitch) = angles_of(self.frame_dir(target - position), self.home.up);
        self.yaw = yaw;
        self.pitch = pitch;
    }
}

/// A basis whose third axis is `up`: (east, north) span the horizontal plane.
fn basis(up: Vec3) -> (Vec3, Vec3, Vec3) {
    let up = up.normalize_or(Vec3::Y);
    let east = if up.dot(Vec3::X).abs() < 0.9 { Vec3::X } else { Vec3::Z };
    let north = up.cross(east).normalize();
    let east = north.cross(up).normalize();
    (east, north, up)
}

/// The unit direction of (yaw, pitch) about `up`.
fn direction(yaw: f32, pitch: f32, up: Vec3) -> Vec3 {
    let (east, north, up) = basis(up);
    (east * yaw.cos() + north * yaw.sin()) * pitch.cos() + up * pitch.sin()
}

/// (yaw, pitch) of the unit direction `d` about `up`.
fn angles_of(d: Vec3, up: Vec3) -> (f32, f32) {
    let (east, north, up) = basis(up);
    let pitch = d.dot(up).clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH);
    (d.dot(north).atan2(d.dot(east)), pitch)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cornell() -> Camera {
        Camera {
            position: Vec3::new(0.278, 0.273, -0.8),
            target: Vec3::new(0.278, 0.273, 0.0),
            up: Vec3::Y,
            fov_y_deg: 39.3,
            near: 0.01,
            far: 10.0,
        }
    }

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-5
    }

    #[test]
    fn the_rig_starts_at_the_scene_camera_and_resets_to_it() {
        let mut rig = CameraRig::new(&cornell(), 2.0);
        let c = rig.camera();
        assert!(close(c.position, cornell().position) && close(c.target, cornell().target), "{c:?}");
        rig.fly(MoveInput { forward: 1.0, right: 1.0, ..Default::default() }, 1.0);
        rig.turn(0.3, 0.2);
        assert!(!close(rig.camera().position, cornell().position));
        rig.reset();
        assert!(close(rig.camera().position, cornell().position) && close(rig.camera().target, cornell().target));
    }

    #[test]
    fn flying_forward_moves_along_the_view_at_the_scene_scaled_speed() {
        let mut rig = CameraRig::new(&cornell(), 8.0); // 1 unit per second
        rig.fly(MoveInput { forward: 1.0, ..Default::default() }, 0.5);
        assert!(close(rig.camera().position, Vec3::new(0.278, 0.273, -0.3)), "{:?}", rig.camera().position);
        rig.fly(MoveInput { up: 1.0, fast: true, ..Default::default() }, 0.25);
        assert!(close(rig.camera().position, Vec3::new(0.278, 1.273, -0.3)), "{:?}", rig.camera().position);
    }

    #[test]
    fn orbiting_keeps_the_distance_to_the_pivot_and_looks_at_it() {
        let mut rig = CameraRig::new(&cornell(), 2.0);
        rig.set_mode(CameraMode::Orbit);
        rig.turn(1.0, 0.4);
        let c = rig.camera();
        assert!(((c.position - cornell().target).length() - 0.8).abs() < 1e-5, "{c:?}");
        assert!(close(c.target, cornell().target), "{c:?}");
        rig.zoom(1.0);
        assert!(((rig.camera().position - cornell().target).length() - 0.72).abs() < 1e-5);
    }

    #[test]
    fn pitch_stops_short_of_the_poles() {
        let mut rig = CameraRig::new(&cornell(), 2.0);
        rig.turn(0.0, -10.0);
        let c = rig.camera();
        let d = (c.target - c.position).normalize();
        assert!(d.y < 1.0 && d.y > 0.99, "{d:?}");
    }
}
