//! Cone sets and the cone-tracing parameters shared by every pass that traces cones.
//!
//! Diffuse cones integrate the cosine lobe: the hemisphere is split into cells of equal
//! *cosine-weighted* solid angle (equal-area cells of the unit disk, lifted to the hemisphere
//! by Malley's method), so every cone gets weight 1/N and irradiance is
//! `E = pi * sum_i L_i / N`. Each cone's axis is the cosine-weighted mean direction of its cell
//! and, unless an aperture is given, its aperture spans the cell's solid angle.

use crate::scene::{ConeFilter, Footprint, GiSettings, Opacity};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// One cone in tangent space (z = surface normal).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cone {
    pub dir: Vec3,
    pub weight: f32,
    /// tan of the half aperture.
    pub tan_half: f32,
}

/// Cells of the unit disk: rings (outer radius^2 bounds) split into sectors.
fn disk_layout(n: u32) -> &'static [(f32, f32, u32)] {
    // (r0^2, r1^2, sectors): every cell has area pi / n.
    match n {
        1 => &[(0.0, 1.0, 1)],
        4 => &[(0.0, 1.0, 4)],
        6 => &[(0.0, 1.0 / 6.0, 1), (1.0 / 6.0, 1.0, 5)],
        9 => &[(0.0, 1.0 / 9.0, 1), (1.0 / 9.0, 1.0, 8)],
        16 => &[(0.0, 1.0 / 16.0, 1), (1.0 / 16.0, 6.0 / 16.0, 5), (6.0 / 16.0, 1.0, 10)],
        _ => &[],
    }
}

/// Widest half aperture a cone may have (a hemisphere-wide cone would have an infinite
/// footprint).
pub const MAX_HALF_ANGLE_DEG: f32 = 85.0;

/// The diffuse cone set for `n` cones (one of `scene::DIFFUSE_CONE_COUNTS`); `aperture_deg` > 0
/// overrides the full aperture of every cone. Empty for an unsupported count.
pub fn diffuse_cones(n: u32, aperture_deg: f32) -> Vec<Cone> {
    const STEPS: usize = 64;
    let mut cones = Vec::new();
    for &(a0, a1, sectors) in disk_layout(n) {
        for s in 0..sectors {
            // Ring cells are rotated by half a sector between rings so cones interleave.
            let offset = if a0 > 0.0 { 0.5 } else { 0.0 };
            let phi0 = (s as f32 + offset) / sectors as f32 * std::f32::consts::TAU;
            let dphi = std::f32::consts::TAU / sectors as f32;
            // Midpoint quadrature over area (uniform area = cosine-weighted solid angle).
            let mut mean = Vec3::ZERO;
            for i in 0..STEPS {
                let r2 = a0 + (a1 - a0) * (i as f32 + 0.5) / STEPS as f32;
                let r = r2.sqrt();
                let z = (1.0 - r2).max(0.0).sqrt();
                for j in 0..STEPS {
                    let phi = phi0 + dphi * (j as f32 + 0.5) / STEPS as f32;
                    mean += Vec3::new(r * phi.cos(), r * phi.sin(), z);
                }
            }
            // The ring r0..r1 lifts to the spherical zone z1..z0 (z = sqrt(1 - r^2)).
            let solid_angle = dphi * ((1.0 - a0).sqrt() - (1.0 - a1).sqrt());
            let half = if aperture_deg > 0.0 {
                (aperture_deg * 0.5).to_radians()
            } else {
                (1.0 - solid_angle / std::f32::consts::TAU).clamp(-1.0, 1.0).acos()
            };
            let half = half.min(MAX_HALF_ANGLE_DEG.to_radians());
            cones.push(Cone { dir: mean.normalize(), weight: 1.0 / n as f32, tan_half: half.tan() });
        }
    }
    cones
}

pub const MAX_CONES: usize = 16;

/// Mirrors `GiParams` in glsl/include/cone.glsl (std140: vec4 only).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
pub struct GpuGiParams {
    /// xyz tangent-space direction, w weight.
    pub cones: [[f32; 4]; MAX_CONES],
    /// x tan(half aperture).
    pub cone_tan: [[f32; 4]; MAX_CONES],
    /// x diffuse cone count, y downsample factor, z directional mip levels, w flags (1 AO,
    /// 2 two-tap filtering, 4 layers, 8 quadrants).
    pub counts: [u32; 4],
    /// x step factor beta, y max distance (voxels), z start offset (voxels), w AO falloff per
    /// voxel.
    pub trace: [f32; 4],
    /// x tan(half aperture) of shadow cones.
    pub shadow: [f32; 4],
}

pub const GI_FLAG_AO: u32 = 1;
/// `gi.cone_filter = "two-tap"`: the directional volumes hold opacity (glsl/include/cone.glsl).
pub const GI_FLAG_TWO_TAP: u32 = 2;
/// `gi.opacity = "layers"` (glsl/include/cone.glsl).
pub const GI_FLAG_LAYERS: u32 = 4;
/// `gi.footprint = "quadrants"` (glsl/include/cone.glsl).
pub const GI_FLAG_QUADRANTS: u32 = 8;
/// `gi.footprint = "shares"` (glsl/include/cone.glsl).
pub const GI_FLAG_SHARES: u32 = 16;

impl GpuGiParams {
    /// The parameters for `gi` on a grid of `resolution` voxels of `voxel_size`, with
    /// `mip_levels` levels in each directional volume.
    pub fn new(gi: &GiSettings, resolution: u32, voxel_size: f32, mip_levels: u32) -> GpuGiParams {
        let mut p = GpuGiParams::zeroed();
        let cones = diffuse_cones(gi.diffuse_cones, gi.diffuse_cone_angle);
        for (i, c) in cones.iter().enumerate().take(MAX_CONES) {
            p.cones[i] = [c.dir.x, c.dir.y, c.dir.z, c.weight];
            p.cone_tan[i] = [c.tan_half, 0.0, 0.0, 0.0];
        }
        let res = resolution as f32;
        let max_distance =
            if gi.max_distance > 0.0 { gi.max_distance / voxel_size.max(f32::MIN_POSITIVE) } else { res * 3f32.sqrt() };
        let flags = if gi.ao { GI_FLAG_AO } else { 0 }
            | if gi.cone_filter == ConeFilter::TwoTap { GI_FLAG_TWO_TAP } else { 0 }
            | if gi.opacity == Opacity::Layers { GI_FLAG_LAYERS } else { 0 }
            | match gi.footprint {
                Footprint::Whole => 0,
                Footprint::Quadrants => GI_FLAG_QUADRANTS,
                Footprint::Shares => GI_FLAG_SHARES,
            };
        p.counts = [cones.len() as u32, gi.downsample, mip_levels, flags];
        p.trace = [gi.step, max_distance.min(res * 3f32.sqrt()), gi.start_offset, gi.ao_falloff / res];
        p.shadow =
            [(gi.shadow_cone_angle * 0.5).to_radians().min(MAX_HALF_ANGLE_DEG.to_radians()).tan(), 0.0, 0.0, 0.0];
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::DIFFUSE_CONE_COUNTS;

    #[test]
    fn every_count_has_a_cone_set_with_unit_weight() {
        for n in DIFFUSE_CONE_COUNTS {
            let cones = diffuse_cones(n, 0.0);
            assert_eq!(cones.len(), n as usize);
            let sum: f32 = cones.iter().map(|c| c.weight).sum();
            assert!((sum - 1.0).abs() < 1e-5, "{n} cones: weights sum to {sum}");
            for c in &cones {
                assert!((c.dir.length() - 1.0).abs() < 1e-5 && c.dir.z > 0.0, "{n}: {c:?}");
                assert!(c.tan_half.is_finite() && c.tan_half > 0.0);
            }
        }
    }

    #[test]
    fn cone_sets_are_balanced_and_integrate_the_cosine_lobe() {
        for n in DIFFUSE_CONE_COUNTS {
            let cones = diffuse_cones(n, 0.0);
            // A radiance field linear in x or y integrates to zero irradiance by symmetry.
            let m: Vec3 = cones.iter().map(|c| c.dir * c.weight).sum();
            assert!(m.x.abs() < 1e-3 && m.y.abs() < 1e-3, "{n} cones: unbalanced {m}");
            // L(w) = cos(theta): E / pi = integral cos^2 / pi = 2/3. The axes are the cells'
            // normalised mean directions, so the estimate is a little high; more cones, closer.
            if n >= 6 {
                let e = m.z;
                assert!((e - 2.0 / 3.0).abs() < 0.08, "{n} cones: {e} vs 2/3");
            }
        }
        let err = |n| (diffuse_cones(n, 0.0).iter().map(|c| c.dir.z * c.weight).sum::<f32>() - 2.0 / 3.0).abs();
        assert!(err(16) < err(6) && err(6) < err(1));
    }

    #[test]
    fn automatic_apertures_cover_the_hemisphere() {
        for n in [4, 6, 9, 16] {
            let total: f32 = diffuse_cones(n, 0.0)
                .iter()
                .map(|c| std::f32::consts::TAU * (1.0 - 1.0 / (1.0 + c.tan_half * c.tan_half).sqrt()))
                .sum();
            assert!((total / std::f32::consts::TAU - 1.0).abs() < 0.02, "{n} cones cover {total} sr");
        }
        // A given aperture overrides.
        let c = diffuse_cones(6, 60.0);
        assert!(c.iter().all(|c| (c.tan_half - 30f32.to_radians().tan()).abs() < 1e-5));
    }
}
