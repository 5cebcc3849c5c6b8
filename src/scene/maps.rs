//! Decoding of non-colour texture maps at load: alpha masks, tangent-space normal maps and
//! height maps, each turned into the encoding its `TextureUse` names.

use super::types::TextureUse;
#[cfg(test)]
use super::types::DEFAULT_RELIEF;

/// Coverage of a `map_d` image in every channel: its alpha where it has any (an RGBA cutout),
/// otherwise its red channel (greyscale masks stored as RGB, as in Crytek's Sponza).
pub fn mask_from_image(rgba8: &[u8]) -> Vec<u8> {
    let has_alpha = rgba8.chunks_exact(4).any(|p| p[3] != 255);
    rgba8.chunks_exact(4).flat_map(|p| [if has_alpha { p[3] } else { p[0] }; 4]).collect()
}

/// Height in every channel: the mean of the red, green and blue codes (a greyscale height map
/// has all three equal; a colour image used as a bump map gives its brightness). Shaders read
/// it from alpha, which no sampler decodes (masks too: render::scene_gpu::upload_texture).
pub fn height_from_image(rgba8: &[u8]) -> Vec<u8> {
    rgba8
        .chunks_exact(4)
        .flat_map(|p| {
            let h = ((u16::from(p[0]) + u16::from(p[1]) + u16::from(p[2]) + 1) / 3) as u8;
            [h, h, h, h]
        })
        .collect()
}

/// Texels with every channel under this code are unused space of a normal map's atlas (black,
/// as in Crytek's `lion_ddn`), not normals.
const UNUSED_BELOW: u8 = 16;

fn unused(p: &[u8]) -> bool {
    p[0] < UNUSED_BELOW && p[1] < UNUSED_BELOW && p[2] < UNUSED_BELOW
}

/// Whether an image that a `bump` statement names is a tangent-space normal map rather than a
/// height map: at least 90% of its used texels (not black) decode to vectors of length 0.75
/// to 1.25 pointing out of the surface (z > 0). Height maps (greyscale, r = g = b) decode to
/// lengths from 0 to 1.73 along (1, 1, 1) and fail except in narrow bands; colour images used
/// as bump maps (Crytek's `bricks`) fail too. Measured on Crytek's Sponza: every `_ddn` map
/// 98.5% or more, the bricks' diffuse texture 1.2%.
pub fn looks_like_normal_map(rgba8: &[u8]) -> bool {
    let (mut used, mut unit) = (0usize, 0usize);
    for p in rgba8.chunks_exact(4).filter(|p| !unused(p)) {
        used += 1;
        let [x, y, z] = [p[0], p[1], p[2]].map(|c| f32::from(c) / 127.5 - 1.0);
        let len = (x * x + y * y + z * z).sqrt();
        if (0.75..=1.25).contains(&len) && z > 0.0 {
            unit += 1;
        }
    }
    used > 0 && unit * 10 >= used * 9
}

/// A normal map as stored: unused (black) texels become the flat normal (0, 0, 1), so that
/// filtering at the edge of used regions does not blend in (-1, -1, -1); `y_down` (DirectX
/// convention, as CryEngine's `_ddn` maps) turns green around into the OpenGL convention.
pub fn normal_map(mut rgba8: Vec<u8>, y_down: bool) -> Vec<u8> {
    for p in rgba8.chunks_exact_mut(4) {
        if unused(p) {
            p.copy_from_slice(&[128, 128, 255, 255]);
        } else if y_down {
            p[1] = 255 - p[1];
        }
    }
    rgba8
}

/// A decoded tangent-space vector from a stored texel ((c + 1) / 2 per component, 8 bits).
fn decode_normal(p: &[u8]) -> [f32; 3] {
    [p[0], p[1], p[2]].map(|c| f32::from(c) / 127.5 - 1.0)
}

/// A unit vector as a texel of the GPU's normal maps (0..1 each, alpha 1): (x + 1) / 2,
/// (y + 1) / 2 and 1 - z, decoded by `decode_tangent` in glsl/include/material.glsl. Every
/// data texture is stored sRGB-encoded (render::scene_gpu::upload_texture), whose steps are
/// finest near 0 and coarsest (0.9%) near 1: z near 1, the common case, is stored as 1 - z
/// near 0. A stored unit vector's length is within [`STORED_NORMAL_ERROR`] of 1, which the
/// shaders' filtered reads take as agreement. A z under 0 (facing into the surface) is stored
/// as 0.
pub(crate) fn encode_unit(n: [f32; 3]) -> [f32; 4] {
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let n = if len > 1e-6 { n.map(|c| c / len) } else { [0.0, 0.0, 1.0] };
    [n[0] * 0.5 + 0.5, n[1] * 0.5 + 0.5, 1.0 - n[2].max(0.0), 1.0]
}

/// How much shorter than 1 a stored unit vector with z >= 0.5 (tilted up to 60 degrees) can
/// decode (1.23%, at x or y near +-0.87 where the sRGB steps are coarse): mirrors
/// `STORED_NORMAL_ERROR` in glsl/include/material.glsl, checked over every such direction by
/// render::texture's tests.
pub const STORED_NORMAL_ERROR: f32 = 0.013;

/// Level 0 of a normal map as the GPU reads it: every texel a unit vector (a zero one, the
/// flat normal), so that the mean of a mip texel's normals is shorter than 1 exactly where
/// they disagree (what the shaders' filtered reads measure: glsl/include/material.glsl).
pub fn unit_normals(rgba8: &[u8]) -> Vec<[f32; 4]> {
    rgba8.chunks_exact(4).map(|p| encode_unit(decode_normal(p))).collect()
}

/// Level 0 of a height map (heights in alpha) as the GPU reads it: the tangent-space normal
/// map (OpenGL convention) of the surface displaced `relief` of a tile (a unit of UV) per unit
/// of height, from central differences one texel apart (repeat). On a surface whose UVs are
/// conformal (dP/du and dP/dv orthogonal, of one length a), this is exactly the bump-mapped
/// normal of a relief of `relief * a` scene units per unit height (render::relief).
pub fn normals_from_heights(width: u32, height: u32, rgba8: &[u8], relief: f32) -> Vec<[f32; 4]> {
    let (w, h) = (width as usize, height as usize);
    let at = |x: usize, y: usize| f32::from(rgba8[(y * w + x) * 4 + 3]) / 255.0;
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            // Per unit of UV: one texel is 1 / width of u and 1 / height of (top-down) v.
            let dhdu = (at((x + 1) % w, y) - at((x + w - 1) % w, y)) * width as f32 / 2.0;
            let dhdv = (at(x, (y + 1) % h) - at(x, (y + h - 1) % h)) * height as f32 / 2.0;
            // +y of the tangent frame is up the image, against top-down v.
            out.push(encode_unit([-relief * dhdu, relief * dhdv, 1.0]));
        }
    }
    out
}

/// Which use a `bump`/`map_bump` image has, by its content.
pub fn bump_use(rgba8: &[u8]) -> TextureUse {
    if looks_like_normal_map(rgba8) {
        TextureUse::Normal
    } else {
        TextureUse::Height
    }
}

/// Converts a decoded image to the encoding of `usage` (colour is kept as it is).
pub fn encode_for(usage: TextureUse, rgba8: Vec<u8>, y_down: bool) -> Vec<u8> {
    match usage {
        TextureUse::Color => rgba8,
        TextureUse::Normal => normal_map(rgba8, y_down),
        TextureUse::Mask => mask_from_image(&rgba8),
        TextureUse::Height => height_from_image(&rgba8),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn encode(v: [f32; 3]) -> [u8; 4] {
        let c = |x: f32| ((x * 0.5 + 0.5) * 255.0).round() as u8;
        [c(v[0]), c(v[1]), c(v[2]), 255]
    }

    #[test]
    fn masks_come_from_alpha_or_from_grey() {
        // RGB mask (alpha opaque everywhere): red is the coverage.
        assert_eq!(mask_from_image(&[200, 200, 200, 255, 10, 10, 10, 255]), [200, 200, 200, 200, 10, 10, 10, 10]);
        // A cutout with alpha: alpha is the coverage, whatever the colour.
        assert_eq!(mask_from_image(&[255, 0, 0, 255, 255, 0, 0, 0]), [255, 255, 255, 255, 0, 0, 0, 0]);
    }

    #[test]
    fn normal_maps_and_height_maps_are_told_apart() {
        // Tilted unit normals around +z: a normal map.
        let mut nm = Vec::new();
        for k in 0..64 {
            let a = k as f32 * 0.1;
            let (s, c) = (0.5 * a.sin(), 0.5 * a.cos());
            let z = (1.0 - s * s - c * c).sqrt();
            nm.extend(encode([s, c, z]));
        }
        assert_eq!(bump_use(&nm), TextureUse::Normal);
        // A grey ramp (height map) and a flat mid-grey (the worst case: length 0).
        let ramp: Vec<u8> = (0..=255u8).flat_map(|h| [h, h, h, 255]).collect();
        assert_eq!(bump_use(&ramp), TextureUse::Height);
        assert_eq!(bump_use(&[128; 64]), TextureUse::Height);
        // A brick-coloured diffuse texture used as a bump map (Crytek's `bricks`).
        let bricks: Vec<u8> = (0..64u8).flat_map(|k| [150 + k, 120 + k, 90 + k, 255]).collect();
        assert_eq!(bump_use(&bricks), TextureUse::Height);
        // A normal-map atlas with black unused space (Crytek's `lion_ddn`: 26% black).
        let mut atlas = nm.clone();
        atlas.extend([0u8, 0, 0, 255].repeat(30));
        assert_eq!(bump_use(&atlas), TextureUse::Normal);
        assert_eq!(bump_use(&[0, 0, 0, 255]), TextureUse::Height, "nothing used: not a normal map");
    }

    #[test]
    fn normal_maps_are_stored_in_one_convention() {
        let stored = normal_map(vec![0, 0, 0, 255, 100, 60, 240, 255], true);
        assert_eq!(stored, [128, 128, 255, 255, 100, 195, 240, 255]);
        assert_eq!(normal_map(vec![100, 60, 240, 255], false), [100, 60, 240, 255]);
    }

    #[test]
    fn normal_maps_are_read_as_unit_vectors() {
        let n = unit_normals(&[255, 128, 128, 255, 128, 128, 255, 255]);
        // (255, 128, 128): +x, stored (x + 1) / 2, (y + 1) / 2, 1 - z.
        assert!((n[0][0] - 1.0).abs() < 1e-4 && (n[0][1] - 0.5).abs() < 0.01 && (n[0][2] - 1.0).abs() < 0.01);
        assert!(n[1].iter().zip([0.5, 0.5, 0.0, 1.0]).all(|(a, b)| (a - b).abs() < 0.003), "flat: {:?}", n[1]);
    }

    #[test]
    fn a_height_ramp_becomes_the_normal_of_its_slope() {
        // Heights rising along u by 1/255 a texel, over 8 x 2 texels (away from the wrap).
        let heights: Vec<u8> = (0..2).flat_map(|_| (0..8u8).flat_map(|x| [x; 4])).collect();
        let n = normals_from_heights(8, 2, &heights, DEFAULT_RELIEF);
        let slope = DEFAULT_RELIEF * 8.0 / 255.0; // dh/du = 8 / 255 per unit of UV
        let want = encode_unit([-slope, 0.0, 1.0]);
        for c in 0..3 {
            assert!((n[3][c] - want[c]).abs() < 1e-6, "{:?} against {want:?}", n[3]);
        }
        // Rising down the image (top-down v): the normal leans up the image, +y.
        let down: Vec<u8> = (0..8u8).flat_map(|y| [y * 4; 4].repeat(2)).collect();
        let n = normals_from_heights(2, 8, &down, DEFAULT_RELIEF);
        assert!(n[2 * 3][1] > 0.5 && (n[2 * 3][0] - 0.5).abs() < 1e-6, "{:?}", n[6]);
    }

    #[test]
    fn heights_are_the_mean_of_the_colour_codes() {
        assert_eq!(height_from_image(&[30, 60, 90, 255]), [60, 60, 60, 60]);
    }
}
