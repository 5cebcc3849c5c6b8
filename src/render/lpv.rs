//! Light propagation volumes (Kaplanyan & Dachsbacher 2010), the host side: the grid, the
//! 2-band spherical harmonics (mirrors glsl/include/sh.glsl) and a CPU reference of one
//! propagation step (mirrors glsl/lpv_propagate.comp), which the GPU tests compare against.
//!
//! Each cell holds, per colour, the SH coefficients of an intensity distribution I(w) (W/sr):
//! light travelling in direction w. A virtual point light of flux Phi and normal n is the
//! clamped-cosine lobe Phi/pi max(0, n.w). A propagation step moves each cell's light into its
//! six neighbours through the five faces of each that it can see, every face a new
//! clamped-cosine emitter carrying the flux I(dir) dOmega the face receives.

use super::voxel::VoxelGrid;
use crate::scene::Scene;
use bytemuck::{Pod, Zeroable};
use glam::{IVec3, Vec3, Vec4};

/// Y00 and the band-1 factor of the real SH basis (order: Y00, Y1-1 ~ y, Y10 ~ z, Y11 ~ x).
pub const SH_C0: f32 = 0.282_094_8;
pub const SH_C1: f32 = 0.488_602_5;
/// SH of the clamped cosine lobe max(0, n.w): sqrt(pi)/2 and sqrt(pi/3) times n.
pub const COS_LOBE_C0: f32 = 0.886_226_9;
pub const COS_LOBE_C1: f32 = 1.023_326_7;
/// Solid angle of the face opposite a neighbour's centre (the one straight ahead), and of each
/// of the four side faces, as seen from that centre (Kaplanyan & Dachsbacher 2010), over pi:
/// the 30 faces of the six neighbours cover the sphere (6 (0.4007 + 4 x 0.4234) = 4 pi).
pub const DIRECT_FACE: f32 = 0.400_669_7 / std::f32::consts::PI;
pub const SIDE_FACE: f32 = 0.423_441_35 / std::f32::consts::PI;

/// The basis evaluated in direction `w` (unit).
pub fn sh_eval(w: Vec3) -> Vec4 {
    Vec4::new(SH_C0, SH_C1 * w.y, SH_C1 * w.z, SH_C1 * w.x)
}

/// The clamped-cosine lobe around `n` (unit).
pub fn cos_lobe(n: Vec3) -> Vec4 {
    Vec4::new(COS_LOBE_C0, COS_LOBE_C1 * n.y, COS_LOBE_C1 * n.z, COS_LOBE_C1 * n.x)
}

/// The flux of an intensity distribution: the integral of its band 0 over the sphere.
pub fn flux(sh: Vec4) -> f32 {
    sh.x * SH_C0 * 4.0 * std::f32::consts::PI
}

/// The propagation grid: `gi.lpv_resolution` cells per side, placed like the voxel grid.
pub fn grid(scene: &Scene) -> VoxelGrid {
    VoxelGrid::for_scene_at(scene, scene.settings.gi.lpv_resolution)
}

/// Mirrors `LpvGrid` in glsl/include/sh.glsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
pub struct GpuLpvGrid {
    /// xyz the grid's min corner, w the cell size.
    pub origin: [f32; 4],
    /// x cells per side, y 1 with occlusion, z leading terms (the injected light, then each
    /// step's) left out of the sum.
    pub dims: [u32; 4],
    /// x, y: the value of one unit of the injection's fixed-point light and geometry sums.
    pub quanta: [f32; 4],
}

/// The injection adds texels into 32-bit integers (deterministic in any order): one unit of
/// light is this fraction of the largest coefficient a cell can reach, which leaves a factor
/// of two of headroom below `i32::MAX`.
const FIXED_POINT_RANGE: f32 = (1u32 << 30) as f32;

/// The largest flux all reflective shadow maps together can hold: each light's power that
/// reaches the scene (a sun's irradiance over its whole-scene view's square, a point or spot
/// light's intensity over the sphere), largest channel, reflected with albedo at most 1.
fn max_map_flux(scene: &Scene) -> f32 {
    let t = scene.settings.time;
    let bounds = scene.bounds.unwrap_or_else(|| scene.world_bounds(t));
    let radius = if bounds.is_empty() { 1.0 } else { (bounds.extent().length() * 0.5).max(1e-3) };
    let sphere = 4.0 * std::f32::consts::PI;
    scene
        .lights
        .iter()
        .filter(|l| l.cast_shadows)
        .map(|l| match l.at_time(t) {
            crate::scene::LightKind::Directional { irradiance, .. } => irradiance.max_element() * 4.0 * radius * radius,
            crate::scene::LightKind::Point { intensity, .. } | crate::scene::LightKind::Spot { intensity, .. } => {
                intensity.max_element() * sphere
            }
        })
        .sum()
}

/// The fixed-point units of the injection: light (W/sr per SH coefficient) and geometry
/// (blocking per coefficient; a cell's surfaces, seen from up to `views` views, cover at most
/// 64 cell faces each).
pub fn quanta(scene: &Scene, views: usize) -> [f32; 2] {
    let light = max_map_flux(scene) / std::f32::consts::PI * COS_LOBE_C1;
    let geometry = 64.0 * views.max(1) as f32 * COS_LOBE_C1;
    let unit = |max: f32| if max.is_finite() && max > 0.0 { max / FIXED_POINT_RANGE } else { 1.0 };
    [unit(light), unit(geometry)]
}

/// `rsm+lpv`: the volume sums the light that has travelled this many cells or more; the RSM
/// gather takes the texels nearer than this many cells.
pub const MIX_SPLIT_CELLS: u32 = 2;

impl GpuLpvGrid {
    pub fn new(grid: &VoxelGrid, occlusion: bool, skipped: u32, quanta: [f32; 2]) -> GpuLpvGrid {
        let o = grid.origin;
        GpuLpvGrid {
            origin: [o.x, o.y, o.z, grid.voxel_size],
            dims: [grid.resolution, u32::from(occlusion), skipped, 0],
            quanta: [quanta[0], quanta[1], 0.0, 0.0],
        }
    }
}

/// The six axis directions, in the order the shader walks them.
pub const AXES: [IVec3; 6] = [IVec3::X, IVec3::NEG_X, IVec3::Y, IVec3::NEG_Y, IVec3::Z, IVec3::NEG_Z];

/// The four side faces' normals of a step along `d`.
pub fn sides(d: IVec3) -> [IVec3; 4] {
    let mut out = [IVec3::ZERO; 4];
    let mut i = 0;
    for a in AXES {
        if a.dot(d) == 0 {
            out[i] = a;
            i += 1;
        }
    }
    out
}

/// One colour channel of a grid of `res`³ cells, x fastest.
pub type ShGrid = Vec<Vec4>;

/// One propagation step without occlusion (CPU reference of lpv_propagate.comp): the light
/// each cell receives from its six neighbours. Face fluxes are kept negative where the
/// two-band lobe is (behind a VPL), as on the GPU: dropping them would add the lobe's negative
/// part back as light (+14% flux per step for an axis-aligned lobe). Radiance is clamped at the
/// lookup instead.
pub fn propagate_step(src: &[Vec4], res: i32) -> ShGrid {
    let index = |c: IVec3| (c.x + res * (c.y + res * c.z)) as usize;
    let inside = |c: IVec3| c.cmpge(IVec3::ZERO).all() && c.cmplt(IVec3::splat(res)).all();
    let mut out = vec![Vec4::ZERO; src.len()];
    for z in 0..res {
        for y in 0..res {
            for x in 0..res {
                let c = IVec3::new(x, y, z);
                let mut sum = Vec4::ZERO;
                for d in AXES {
                    let from = c - d;
                    if !inside(from) {
                        continue;
                    }
                    let sh = src[index(from)];
                    let main = d.as_vec3();
                    sum += DIRECT_FACE * sh.dot(sh_eval(main)) * cos_lobe(main);
                    for s in sides(d) {
                        let eval = (main + 0.5 * s.as_vec3()).normalize();
                        sum += SIDE_FACE * sh.dot(sh_eval(eval)) * cos_lobe(s.as_vec3());
                    }
                }
                out[index(c)] = sum;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cosine_lobe_carries_the_flux_of_its_light() {
        // A VPL of flux 1: Phi/pi times the lobe has flux 1.
        let lobe = cos_lobe(Vec3::new(0.0, 0.6, 0.8)) / std::f32::consts::PI;
        assert!((flux(lobe) - 1.0).abs() < 1e-5, "{}", flux(lobe));
        // Along its axis the 2-band lobe is c0 Y00 + c1 Y1 = 0.25 + 0.5 = 0.75, where the true
        // max(0, cos) is 1: the known truncation of two bands.
        let on_axis = cos_lobe(Vec3::Z).dot(sh_eval(Vec3::Z));
        assert!((on_axis - 0.75).abs() < 1e-4, "{on_axis}");
    }

    #[test]
    fn the_faces_of_the_six_neighbours_cover_the_sphere() {
        let total = 6.0 * (DIRECT_FACE + 4.0 * SIDE_FACE) * std::f32::consts::PI;
        assert!((total / (4.0 * std::f32::consts::PI) - 1.0).abs() < 1e-4, "{total}");
        for d in AXES {
            let s = sides(d);
            assert!(s.iter().all(|a| a.dot(d) == 0 && *a != IVec3::ZERO), "{d}: {s:?}");
        }
    }

    /// One step from an isotropic cell in the middle of an empty grid: the neighbours receive
    /// the whole flux (the faces cover the sphere), each the same.
    #[test]
    fn propagation_of_isotropic_light_conserves_its_flux() {
        let res = 5;
        let mut src = vec![Vec4::ZERO; 125];
        src[62] = Vec4::new(1.0, 0.0, 0.0, 0.0);
        let out = propagate_step(&src, res);
        let total: f32 = out.iter().map(|v| flux(*v)).sum();
        assert!((total / flux(src[62]) - 1.0).abs() < 1e-3, "{total} against {}", flux(src[62]));
        let neighbours = [61, 63, 57, 67, 37, 87];
        let f0 = flux(out[61]);
        assert!(neighbours.iter().all(|&i| (flux(out[i]) - f0).abs() < 1e-6));
    }

    /// A VPL's clamped-cosine lobe, in any direction, in the middle of an empty grid: one step
    /// passes on its flux (band 1 cancels over the 30 faces, as band 0 sums to the sphere),
    /// and the light goes the way the lobe points.
    #[test]
    fn propagation_of_a_lobe_conserves_its_flux() {
        let res = 5;
        for n in [Vec3::X, Vec3::NEG_Y, Vec3::new(1.0, 1.0, 0.0).normalize(), Vec3::new(0.3, -0.5, 0.8).normalize()] {
            let mut src = vec![Vec4::ZERO; 125];
            src[62] = cos_lobe(n) / std::f32::consts::PI;
            let out = propagate_step(&src, res);
            let total: f32 = out.iter().map(|v| flux(*v)).sum();
            let ratio = total / flux(src[62]);
            assert!((ratio - 1.0).abs() < 1e-3, "{n}: {ratio}");
            let d = AXES.into_iter().max_by(|a, b| n.dot(a.as_vec3()).total_cmp(&n.dot(b.as_vec3()))).unwrap();
            let (ahead, behind) = (IVec3::splat(2) + d, IVec3::splat(2) - d);
            let at = |c: IVec3| flux(out[(c.x + 5 * (c.y + 5 * c.z)) as usize]);
            assert!(at(ahead) > 3.0 * at(behind), "{n}: ahead {} behind {}", at(ahead), at(behind));
        }
    }
}
