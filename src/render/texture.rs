//! Texture mip chains, built once on the host at load. Each level is a box filter of the level
//! above in linear light, kept in floating point all the way down; only the stored copy of a
//! level is quantized to 8 bits (colour sRGB-encoded, alpha linear). Averaging the encoded
//! values instead would darken every minified contrast (a black/white checker would go to sRGB
//! 128, linear 0.22, not 0.5), and filtering each level from the quantized one above lets the
//! rounding bias grow level by level (+0.08% per level on Crytek's floor, measured).
//! Data maps are linear and averaged as they are; alpha-test masks then keep their coverage
//! (see [`preserve_coverage`]). Normal maps are unit vectors at level 0 and height maps become
//! normal maps (`scene::maps`), so each level holds the mean normal of the texels it covers,
//! shorter than 1 where they disagree: what the shaders filter at a footprint (issue 42).

use crate::scene::{maps, TextureUse, MASK_CUTOFF};

/// One level of a chain: RGBA8, sRGB-encoded colour, linear alpha.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MipLevel {
    pub width: u32,
    pub height: u32,
    pub rgba8: Vec<u8>,
}

/// Levels of a full chain for a `width` x `height` image: down to 1 x 1.
pub fn level_count(width: u32, height: u32) -> u32 {
    32 - width.max(height).max(1).leading_zeros()
}

/// The full chain, level 0 (a copy of `rgba8`) first. Level n + 1 is max(1, size / 2) on each
/// axis; each of its texels averages the texels of level n it covers: 2 x 2, or 3 along an odd
/// axis at the last texel, so no texel of the level above is left out.
pub fn mip_chain(width: u32, height: u32, rgba8: &[u8]) -> Vec<MipLevel> {
    mip_chain_for(TextureUse::Color, width, height, rgba8, 0.0)
}

/// The full chain of a texture of the given use: colour in linear light, data as it is; a
/// height map as the normal map of `relief` tiles per unit of height (render::relief).
pub fn mip_chain_for(usage: TextureUse, width: u32, height: u32, rgba8: &[u8], relief: f32) -> Vec<MipLevel> {
    let srgb = usage == TextureUse::Color;
    let table: [f32; 256] = if srgb { decode_table() } else { std::array::from_fn(|i| i as f32 / 255.0) };
    let texels = match usage {
        TextureUse::Normal => maps::unit_normals(rgba8),
        TextureUse::Height => maps::normals_from_heights(width, height, rgba8, relief),
        TextureUse::Color | TextureUse::Mask => rgba8
            .chunks_exact(4)
            .map(|p| [table[p[0] as usize], table[p[1] as usize], table[p[2] as usize], f32::from(p[3]) / 255.0])
            .collect(),
    };
    let mut exact = Linear { width, height, texels };
    let first = match usage {
        TextureUse::Normal | TextureUse::Height => exact.quantize(false),
        TextureUse::Color | TextureUse::Mask => MipLevel { width, height, rgba8: rgba8.to_vec() },
    };
    let mut levels = vec![first];
    while exact.width > 1 || exact.height > 1 {
        exact = downsample(&exact);
        let mut next = exact.quantize(srgb);
        if usage == TextureUse::Mask {
            preserve_coverage(&mut next, coverage(&levels[0].rgba8, 1.0));
        }
        levels.push(next);
    }
    levels
}

/// A level before quantization: linear (or data) values, alpha in 0..1.
struct Linear {
    width: u32,
    height: u32,
    texels: Vec<[f32; 4]>,
}

impl Linear {
    /// 8-bit copy of the level: colour to the nearest sRGB code in linear light, data and
    /// alpha to the nearest code. (Error diffusion would keep a smooth level's mean closer
    /// still, but its one-code pattern shows when a level is magnified: 1.2% on a minified
    /// checker, measured in tests/texture.rs.)
    fn quantize(&self, srgb: bool) -> MipLevel {
        let linear = |v: f32| (v * 255.0).round().clamp(0.0, 255.0) as u8;
        let rgba8 = self
            .texels
            .iter()
            .flat_map(|t| {
                let rgb = |c: usize| if srgb { encode_srgb(t[c]) } else { linear(t[c]) };
                [rgb(0), rgb(1), rgb(2), linear(t[3])]
            })
            .collect();
        MipLevel { width: self.width, height: self.height, rgba8 }
    }
}

/// Fraction of texels whose coverage (alpha) times `scale` reaches the cutoff.
fn coverage(rgba8: &[u8], scale: f32) -> f32 {
    let n = rgba8.len() / 4;
    let cut = MASK_CUTOFF * 255.0;
    let hit = rgba8.chunks_exact(4).filter(|p| f32::from(p[3]) * scale >= cut).count();
    hit as f32 / n.max(1) as f32
}

/// Scales a mask level so that the fraction of its texels at or above the cutoff is as close as
/// it gets to `target`, the fraction in level 0 (Castaño, "Computing alpha mipmaps", 2010).
/// Averaged coverage alone makes thin cutouts (leaves, chains) fall under the cutoff and vanish
/// at a distance; a bisection on the scale keeps their area. A level that already has its
/// coverage keeps its values: the smallest scale that matches would put every opaque texel of a
/// hard-edged mask at the cutoff itself, and filtering across any edge would then cut it away.
fn preserve_coverage(level: &mut MipLevel, target: f32) {
    let (mut lo, mut hi) = (0.0f32, 4.0f32);
    for _ in 0..16 {
        let mid = 0.5 * (lo + hi);
        if coverage(&level.rgba8, mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let miss = |scale: f32| (coverage(&level.rgba8, scale) - target).abs();
    let scale = [hi, lo].into_iter().fold(1.0, |best, s| if miss(s) < miss(best) { s } else { best });
    if scale == 1.0 {
        return;
    }
    for v in &mut level.rgba8 {
        *v = (f32::from(*v) * scale).round().clamp(0.0, 255.0) as u8;
    }
}

fn downsample(src: &Linear) -> Linear {
    let (w, h) = (src.width, src.height);
    let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
    // Source texels [lo, hi) covered by destination texel i of n along an axis of size s.
    let span = |i: u32, n: u32, s: u32| -> (u32, u32) { (i * s / n, ((i + 1) * s / n).max(i * s / n + 1)) };
    let mut texels = Vec::with_capacity((nw * nh) as usize);
    for y in 0..nh {
        let (y0, y1) = span(y, nh, h);
        for x in 0..nw {
            let (x0, x1) = span(x, nw, w);
            let mut sum = [0.0f64; 4];
            for sy in y0..y1 {
                for sx in x0..x1 {
                    let p = src.texels[(sy * w + sx) as usize];
                    sum.iter_mut().zip(p).for_each(|(s, v)| *s += f64::from(v));
                }
            }
            let n = f64::from((x1 - x0) * (y1 - y0));
            texels.push(sum.map(|s| (s / n) as f32));
        }
    }
    Linear { width: nw, height: nh, texels }
}

/// sRGB 8-bit code to linear (IEC 61966-2-1).
pub fn decode_srgb(code: u8) -> f32 {
    let c = f32::from(code) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear to the sRGB 8-bit code whose decoded value is nearest, in linear light. Rounding the
/// encoded value instead is biased bright: the decode is convex, so codes rounded up weigh more
/// than codes rounded down.
pub fn encode_srgb(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let c = if v <= 0.003_130_8 { v * 12.92 } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    let below = (c * 255.0).floor().clamp(0.0, 255.0) as u8;
    let above = below.saturating_add(1);
    if (decode_srgb(above) - v).abs() < (v - decode_srgb(below)).abs() {
        above
    } else {
        below
    }
}

fn decode_table() -> [f32; 256] {
    std::array::from_fn(|i| decode_srgb(i as u8))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn level_counts_reach_one_texel() {
        assert_eq!(level_count(1, 1), 1);
        assert_eq!(level_count(256, 256), 9);
        assert_eq!(level_count(256, 16), 9);
        assert_eq!(level_count(300, 5), 9); // 300 150 75 37 18 9 4 2 1
    }

    #[test]
    fn srgb_round_trips_every_code() {
        for code in 0..=255u8 {
            assert_eq!(encode_srgb(decode_srgb(code)), code);
        }
    }

    #[test]
    fn odd_sizes_keep_every_texel() {
        // 3 x 1: one level-1 texel averaging all three (white, white, black): linear 2/3.
        let src = [255, 255, 255, 255, 255, 255, 255, 255, 0, 0, 0, 255];
        let chain = mip_chain(3, 1, &src);
        assert_eq!(chain.len(), 2);
        assert_eq!(chain[1].rgba8, vec![encode_srgb(2.0 / 3.0); 3].into_iter().chain([255]).collect::<Vec<_>>());
        // Non-square: 4 x 2 -> 2 x 1 -> 1 x 1.
        let chain = mip_chain(4, 2, &[128; 32]);
        let sizes: Vec<_> = chain.iter().map(|l| (l.width, l.height, l.rgba8.len())).collect();
        assert_eq!(sizes, [(4, 2, 32), (2, 1, 8), (1, 1, 4)]);
        assert!(chain.iter().all(|l| l.rgba8.iter().all(|&v| v == 128)), "a flat texture stays flat");
    }

    #[test]
    fn levels_keep_the_mean_in_linear_light() {
        // A smooth 256 x 256 colour texture (gradients with one code of noise): the mean linear
        // value of every level down to 32 x 32 stays within 0.4% of level 0's (one code step at
        // most: nearly equal texels round alike). Filtering each level from the rounded one
        // above drifted 2% by level 3.
        let src: Vec<u8> = (0..256u32 * 256)
            .flat_map(|i| {
                let (x, y, bit) = (i % 256, i / 256, (i.wrapping_mul(2_654_435_761) >> 24) as u8 % 2);
                [((x + y) / 2).min(254) as u8 + bit, (x / 4 + 64) as u8 + bit, (y / 4 + 100) as u8 + bit, 255]
            })
            .collect();
        let mean = |l: &MipLevel, c: usize| {
            l.rgba8.chunks_exact(4).map(|p| f64::from(decode_srgb(p[c]))).sum::<f64>() / (l.rgba8.len() / 4) as f64
        };
        let chain = mip_chain(256, 256, &src);
        for c in 0..3 {
            let m0 = mean(&chain[0], c);
            for (k, level) in chain.iter().enumerate().skip(1).take(3) {
                let m = mean(level, c);
                assert!((m / m0 - 1.0).abs() < 4e-3, "channel {c} level {k}: mean {m}, level 0 {m0}");
            }
        }
    }

    #[test]
    fn encoding_picks_the_nearest_code_in_linear_light() {
        for i in 0..=4096 {
            let v = i as f32 / 4096.0;
            let code = encode_srgb(v);
            let err = (decode_srgb(code) - v).abs();
            for other in [code.saturating_sub(1), code.saturating_add(1)] {
                assert!(err <= (decode_srgb(other) - v).abs(), "{v}: code {code}, {other} is nearer");
            }
        }
    }

    #[test]
    fn stored_unit_normals_keep_their_length() {
        // Directions tilted up to 60 degrees, through the GPU's storage of data textures: the
        // nearest 8-bit code, sRGB-encoded, decoded by the sampler (scene_gpu::upload_texture).
        let stored = |v: f32| decode_srgb(encode_srgb((v * 255.0).round() / 255.0));
        let (mut short, mut long) = (0.0f32, 0.0f32);
        for i in 0..=400 {
            for j in 0..=400 {
                let (x, y) = (i as f32 / 200.0 - 1.0, j as f32 / 200.0 - 1.0);
                let z2 = 1.0 - x * x - y * y;
                if z2 < 0.25 {
                    continue;
                }
                let t = maps::encode_unit([x, y, z2.sqrt()]);
                let d = [stored(t[0]) * 2.0 - 1.0, stored(t[1]) * 2.0 - 1.0, 1.0 - stored(t[2])];
                let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                short = short.max(1.0 - len);
                long = long.max(len - 1.0);
            }
        }
        println!("stored unit normals: up to {short} short, {long} long");
        assert!(short <= maps::STORED_NORMAL_ERROR, "{short}");
    }

    #[test]
    fn data_maps_average_as_they_are() {
        // Normals +x and -x average to the zero vector: x and y at code 128 (not sRGB 188),
        // 1 - z at 254 (code 128 is z = 0.004): a mean normal, as short as its texels disagree.
        let chain = mip_chain_for(TextureUse::Normal, 2, 1, &[255, 128, 128, 255, 0, 128, 128, 255], 0.0);
        assert_eq!(chain[1].rgba8, [128, 128, 254, 255]);
        // A flat height map is the flat normal at every level.
        let chain = mip_chain_for(TextureUse::Height, 2, 2, &[90; 16], 0.0);
        assert!(chain.iter().all(|l| l.rgba8.chunks_exact(4).all(|p| p == [128, 128, 0, 255])));
    }

    #[test]
    fn a_hard_edged_mask_keeps_its_values_where_averaging_keeps_its_coverage() {
        // Opaque on the left half: every level down to 2 x 2 is the same cut, with opaque texels
        // at 255. Scaling them to the cutoff (the smallest scale that keeps the coverage) would
        // make any filtered lookup across the cut fall under it.
        let src: Vec<u8> = (0..64u32 * 64).flat_map(|i| [if i % 64 < 32 { 255 } else { 0 }; 4]).collect();
        let chain = mip_chain_for(TextureUse::Mask, 64, 64, &src, 0.0);
        for (k, level) in chain.iter().enumerate().take(6) {
            let alphas: Vec<u8> = level.rgba8.chunks_exact(4).map(|p| p[3]).collect();
            assert!(alphas.iter().all(|&a| a == 0 || a == 255), "level {k}: {alphas:?}");
        }
    }

    #[test]
    fn mask_mips_keep_their_coverage() {
        // Noise-like coverage, uniform over 0..0.94 (mean 0.47, just under the cutoff): plain
        // averaging loses the cutout at a distance; the kept chain does not.
        let src: Vec<u8> =
            (0..64u32 * 64).flat_map(|i| [(i.wrapping_mul(2_654_435_761) >> 24) as u8 % 241; 4]).collect();
        let c0 = coverage(&src, 1.0);
        let kept = mip_chain_for(TextureUse::Mask, 64, 64, &src, 0.0);
        let plain = mip_chain_for(TextureUse::Color, 64, 64, &src, 0.0); // alpha averaged as it is
        for k in 1..=3 {
            let (c, p) = (coverage(&kept[k].rgba8, 1.0), coverage(&plain[k].rgba8, 1.0));
            assert!((c - c0).abs() <= 0.1, "level {k}: coverage {c}, level 0 {c0}");
            if k == 3 {
                assert!((p - c0).abs() > 0.2, "plain averaging should have lost it: {p} vs {c0}");
            }
        }
    }
}
