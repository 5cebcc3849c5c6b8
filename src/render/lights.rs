//! Lights for the GPU (mirrors glsl/include/lights.glsl and shadow.glsl) and their shadow
//! views: directional = 1 orthographic view fitted to the scene bounds, spot = 1 perspective
//! view covering the outer cone, point = 6 cube faces (+X, -X, +Y, -Y, +Z, -Z).

use crate::scene::{Aabb, LightKind, Scene};
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug, Default)]
pub struct GpuLight {
    pub position: [f32; 4],
    pub direction: [f32; 4],
    pub color: [f32; 4],
    pub cone: [f32; 4],
    pub shadow: [i32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug, Default)]
pub struct GpuShadowView {
    pub view_proj: [[f32; 4]; 4],
    pub params: [f32; 4],
}

pub const LIGHT_DIRECTIONAL: f32 = 0.0;
pub const LIGHT_POINT: f32 = 1.0;
pub const LIGHT_SPOT: f32 = 2.0;

/// The power of two by which every 16-bit radiance target (G-buffer emission, voxel radiance,
/// bounce and directional volumes, cone-tracing targets) holds radiance, so that the scene's
/// typical radiance sits near 1, in the middle of the half-float range (6e-5 .. 65504), whatever
/// the units: a 1e-6 W/sr light neither underflows nor does a 1e6 W/sr one overflow. Typical
/// radiance is the largest of: the brightest emission, the sky's mean radiance, a directional light's E/pi, and a point
/// or spot light's I/pi at 5% of the scene's extent. Exact (a power of two), so scaling and
/// unscaling round nothing; 1 for a scene without light.
pub fn radiance_scale(scene: &Scene) -> f32 {
    let t = scene.settings.time;
    let bounds = scene.bounds.unwrap_or_else(|| scene.world_bounds(t));
    let extent = if bounds.is_empty() { 0.0 } else { bounds.extent().max_element() };
    let near = if extent.is_finite() && extent > 0.0 { 0.05 * extent } else { 1.0 };
    let typical = scene.lights.iter().fold(
        scene
            .materials
            .iter()
            .map(|m| m.emission.max_element())
            .fold(scene.sky.as_ref().map_or(0.0, |s| s.mean_radiance()), f32::max),
        |acc, l| {
            let l = match l.at_time(t) {
                LightKind::Directional { irradiance, .. } => irradiance.max_element() / std::f32::consts::PI,
                LightKind::Point { intensity, .. } | LightKind::Spot { intensity, .. } => {
                    intensity.max_element() / (std::f32::consts::PI * near * near)
                }
            };
            acc.max(l)
        },
    );
    if !(typical.is_finite() && typical > 0.0) {
        return 1.0;
    }
    2f32.powi((-typical.log2().round() as i32).clamp(-100, 100))
}

/// Shadow views of one light: none without shadows, a directional light's cascades and its
/// whole-scene view, a spot light's one view, a point light's six cube faces.
fn views_of(scene: &Scene, light: &crate::scene::Light) -> u32 {
    match (light.cast_shadows, &light.kind) {
        (false, _) => 0,
        (true, LightKind::Point { .. }) => 6,
        (true, LightKind::Directional { .. }) => scene.settings.shadow_cascades + 1,
        (true, LightKind::Spot { .. }) => 1,
    }
}

/// Number of shadow views the scene's lights need (independent of time).
pub fn shadow_view_count(scene: &Scene) -> u32 {
    scene.lights.iter().map(|l| views_of(scene, l)).sum()
}

/// The views that reflective shadow maps are rendered from, as `[shadow view, light, 0, 0]`
/// (`RsmView` in glsl/include/rsm.glsl): a directional light's whole-scene view (the cascades
/// see only the camera's slices), a spot light's view, a point light's six faces. Lights that
/// cast no shadows have no shadow view and get no map.
pub fn rsm_views(scene: &Scene) -> Vec<[u32; 4]> {
    let mut out = Vec::new();
    let mut base = 0;
    for (i, light) in scene.lights.iter().enumerate() {
        let n = views_of(scene, light);
        let own = match light.kind {
            LightKind::Directional { .. } if n > 0 => base + n - 1..base + n,
            _ => base..base + n,
        };
        out.extend(own.map(|v| [v, i as u32, 0, 0]));
        base += n;
    }
    out
}

/// Weight of the logarithmic split in the cascades' split distances (the "practical split
/// scheme", Zhang et al. 2006: 1 logarithmic, 0 uniform).
const SPLIT_LAMBDA: f32 = 0.75;

/// View-space distances of the cascade boundaries, `cascades + 1` of them from `near` to `far`.
pub fn cascade_splits(near: f32, far: f32, cascades: u32) -> Vec<f32> {
    (0..=cascades)
        .map(|i| {
            let f = i as f32 / cascades.max(1) as f32;
            SPLIT_LAMBDA * near * (far / near).powf(f) + (1.0 - SPLIT_LAMBDA) * (near + (far - near) * f)
        })
        .collect()
}

/// The eight corners of the box `b`.
fn corners(b: Aabb) -> [Vec3; 8] {
    std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 == 0 { b.min.x } else { b.max.x },
            if i & 2 == 0 { b.min.y } else { b.max.y },
            if i & 4 == 0 { b.min.z } else { b.max.z },
        )
    })
}

/// A directional light's views: `cascades` orthographic views fitted to slices of the camera's
/// view (each the square in light space around the slice, clipped to the scene's bounds, on a
/// texel grid), then one around the whole scene. All keep the scene's whole depth range, so
/// every caster is in every view.
fn sun_views(scene: &Scene, dir: Vec3, bounds: Aabb, center: Vec3, radius: f32, size: f32) -> Vec<GpuShadowView> {
    let view = look_dir(center - dir * (radius * 2.0), dir);
    let ortho = |x0: f32, x1: f32, y0: f32, y1: f32| {
        let proj = flip_y(Mat4::orthographic_rh(x0, x1, y0, y1, radius * 0.5, radius * 3.5));
        GpuShadowView { view_proj: (proj * view).to_cols_array_2d(), params: [(x1 - x0) / size, 1.0, 0.0, 0.0] }
    };
    let mut out = Vec::new();
    let cascades = scene.settings.shadow_cascades;
    let cam = &scene.camera;
    let scene_pts = corners(bounds).map(|p| view.transform_point3(p));
    let (lo, hi) = scene_pts.iter().fold((Vec3::MAX, Vec3::MIN), |(a, b), p| (a.min(*p), b.max(*p)));
    // Beyond the farthest corner of the scene nothing is seen.
    let far = corners(bounds).iter().map(|p| (*p - cam.position).length()).fold(cam.near * 2.0, f32::max).min(cam.far);
    let splits = cascade_splits(cam.near, far, cascades);
    let (w, h) = (scene.settings.width as f32, scene.settings.height as f32);
    let tan_y = (cam.fov_y_deg.to_radians() * 0.5).tan();
    let forward = (cam.target - cam.position).normalize_or(Vec3::NEG_Z);
    let right = forward.cross(cam.up).normalize_or(Vec3::X);
    let up = right.cross(forward);
    for pair in splits.windows(2).take(cascades as usize) {
        let mut a = Vec3::MAX;
        let mut b = Vec3::MIN;
        for d in [pair[0], pair[1]] {
            for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
                let p = cam.position + (forward + right * (sx * tan_y * w / h) + up * (sy * tan_y)) * d;
                let q = view.transform_point3(p);
                a = a.min(q);
                b = b.max(q);
            }
        }
        // Clipped to the scene, squared (square texels), snapped to whole texels.
        let (a, b) = (a.max(lo), b.min(hi));
        let side = (b.x - a.x).max(b.y - a.y).max(radius * 1e-4) * (1.0 + 4.0 / size);
        let texel = side / size;
        let c = ((a + b) * 0.5 / texel).round() * texel;
        out.push(ortho(c.x - side * 0.5, c.x + side * 0.5, c.y - side * 0.5, c.y + side * 0.5));
    }
    out.push(ortho(-radius, radius, -radius, radius));
    out
}

fn flip_y(mut p: Mat4) -> Mat4 {
    p.y_axis.y = -p.y_axis.y;
    p
}

/// A look-at that tolerates `dir` parallel to the preferred up vector.
fn look_dir(eye: Vec3, dir: Vec3) -> Mat4 {
    let up = if dir.normalize_or_zero().dot(Vec3::Y).abs() > 0.99 { Vec3::Z } else { Vec3::Y };
    Mat4::look_to_rh(eye, dir, up)
}

/// The GPU light table and shadow views at time `t`; `bounds` are the scene's world bounds.
pub fn build(
    scene: &Scene,
    t: f32,
    bounds: Aabb,
    shadow_map_size: u32,
    pcf_radius: f32,
) -> (Vec<GpuLight>, Vec<GpuShadowView>) {
    let mut lights = Vec::new();
    let mut views = Vec::new();
    let (center, radius) = if bounds.is_empty() {
        (Vec3::ZERO, 1.0)
    } else {
        (bounds.center(), (bounds.extent().length() * 0.5).max(1e-3))
    };
    let size = shadow_map_size.max(1) as f32;
    // Widen perspective views slightly so PCF taps near a cube face's edge stay inside it.
    let margin = (1.0 + 2.0 * (pcf_radius + 1.0) / size).min(1.5);
    let near_for = |pos: Vec3| {
        let far = (pos - center).length() + radius;
        let near = (far * 1e-4).max(1e-4);
        (near, far.max(near * 2.0))
    };
    for light in &scene.lights {
        let kind = light.at_time(t);
        let base = views.len() as i32;
        let mut g = GpuLight::default();
        match kind {
            LightKind::Directional { direction, irradiance } => {
                let dir = direction.normalize_or(Vec3::NEG_Y);
                g.position = [0.0, 0.0, 0.0, LIGHT_DIRECTIONAL];
                g.direction = [dir.x, dir.y, dir.z, 0.0];
                g.color = [irradiance.x, irradiance.y, irradiance.z, 0.0];
                if light.cast_shadows {
                    views.extend(sun_views(scene, dir, bounds, center, radius, size));
                }
            }
            LightKind::Point { position, intensity } => {
                g.position = [position.x, position.y, position.z, LIGHT_POINT];
                g.color = [intensity.x, intensity.y, intensity.z, 0.0];
                if light.cast_shadows {
                    let (near, far) = near_for(position);
                    let fov = 2.0 * margin.atan();
                    let proj = flip_y(Mat4::perspective_rh(fov, 1.0, near, far));
                    for dir in [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z] {
                        views.push(GpuShadowView {
                            view_proj: (proj * look_dir(position, dir)).to_cols_array_2d(),
                            params: [2.0 * margin / size, 0.0, 0.0, 0.0],
                        });
                    }
                }
            }
            LightKind::Spot { position, direction, intensity, inner_deg, outer_deg } => {
                let dir = direction.normalize_or(Vec3::NEG_Y);
                g.position = [position.x, position.y, position.z, LIGHT_SPOT];
                g.direction = [dir.x, dir.y, dir.z, 0.0];
                g.color = [intensity.x, intensity.y, intensity.z, 0.0];
                g.cone = [inner_deg.to_radians().cos(), outer_deg.to_radians().cos(), 0.0, 0.0];
                if light.cast_shadows {
                    let (near, far) = near_for(position);
                    let half = (outer_deg.to_radians().tan() * margin).atan().min(89.0f32.to_radians());
                    let proj = flip_y(Mat4::perspective_rh(2.0 * half, 1.0, near, far));
                    views.push(GpuShadowView {
                        view_proj: (proj * look_dir(position, dir)).to_cols_array_2d(),
                        params: [2.0 * half.tan() / size, 0.0, 0.0, 0.0],
                    });
                }
            }
        }
        g.shadow = if light.cast_shadows { [base, views.len() as i32 - base, 0, 0] } else { [-1, 0, 0, 0] };
        lights.push(g);
    }
    (lights, views)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(lights: Vec<LightKind>) -> Scene {
        crate::render::test_scene(lights)
    }

    fn point(i: f32) -> LightKind {
        LightKind::Point { position: Vec3::ONE, intensity: Vec3::splat(i) }
    }

    #[test]
    fn radiance_scale_is_a_power_of_two_bringing_typical_radiance_near_one() {
        assert_eq!(radiance_scale(&scene(vec![])), 1.0, "no light");
        assert_eq!(radiance_scale(&scene(vec![point(0.0)])), 1.0, "black light");
        for i in [1e-20f32, 1e-6, 1.2, 1e6, 1e20] {
            let s = radiance_scale(&scene(vec![point(i)]));
            assert_eq!(s.log2().fract(), 0.0, "{s} is a power of two");
            // extent 2 -> evaluated at 0.1: typical radiance I / (pi 0.01).
            let typical = i / (std::f32::consts::PI * 0.01);
            assert!((0.7..1.42).contains(&(typical * s)), "I = {i}: scale {s}");
        }
        // Beyond 2^+-100 the scale stops (radiance times it stays far inside f32).
        assert_eq!(radiance_scale(&scene(vec![point(3e35)])), 2f32.powi(-100));
        let sun = LightKind::Directional { direction: -Vec3::Y, irradiance: Vec3::new(1000.0, 500.0, 0.0) };
        let s = radiance_scale(&scene(vec![sun, point(1e-3)]));
        assert!((0.7..1.42).contains(&(1000.0 / std::f32::consts::PI * s)), "brightest light sets it: {s}");
    }
}
