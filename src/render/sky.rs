//! The sky on the GPU (glsl/include/sky.glsl): its equirectangular radiance map, the same map
//! prefiltered for cones of every aperture, and the tables the path tracer draws sky
//! directions from.
//!
//! * The map: an image sky's texels; a constant or gradient sky baked so that each texel
//!   holds the exact solid-angle mean of its band (the gradient is linear in y, whose mean over
//!   a band of the sphere is the mean of the band's two edge heights).
//! * The cone map: 512x256 at level 0 and a full mip chain, level k holding at each texel the
//!   mean radiance over the spherical cap of half-angle 2^k * ALPHA0 around its direction (the
//!   cap a cone of that aperture sees, two texels of its level in radius). A cone of half-angle
//!   a reads level log2(a / ALPHA0), blended between levels by the sampler: the sky a cone
//!   sees past everything it met, filtered to its aperture. Level 6 (8x4) holds hemisphere
//!   means, level 7 the whole sphere's.
//! * The irradiance map: 128x64, irradiance / pi by normal, what the diffuse cones' sky must
//!   add up to with nothing in the way ([`irradiance_map`]).
//! * The sampling tables: texels drawn in proportion to luminance x sin(theta) (marginal over
//!   rows, conditional within each), and each texel's density per unit of image area.

use crate::gpu::{Bind, Buffer, Context, GpuResult, Image, Sampler};
use crate::render::binding::Binds;
use crate::render::scene_gpu::{upload_buffer, upload_levels};
use crate::scene::{equirect_dir, gradient, GiMode, Opacity, Scene, Sky, SkyKind, SpecularSource};
use ash::vk;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;

/// Width and height of the cone map's level 0.
pub const CONE_MAP_SIZE: (u32, u32) = (512, 256);
/// Levels of the cone map (512x256 down to 4x2).
pub const CONE_LEVELS: u32 = 8;
/// The half-angle (radians) of the cap level 0 averages: two of its texels (pi / 128).
pub const ALPHA0: f64 = PI / 128.0;
/// Height of a baked gradient map (its width is twice that).
const GRADIENT_ROWS: u32 = 128;

/// What the scene's technique does with its sky, in words (`info`, and a warning where it
/// lights nothing with it); `None` without a sky.
pub fn sky_use(scene: &Scene) -> Option<String> {
    let sky = scene.sky.as_ref()?;
    let gi = &scene.settings.gi;
    let what = match gi.mode {
        GiMode::Vct => {
            let rays =
                if gi.specular == SpecularSource::Rt { "; ray-traced reflections see it where they miss" } else { "" };
            let leak = if gi.opacity == Opacity::Blend {
                "; with gi.opacity = \"blend\" a closed room under it gets 0.15-0.25 of the light it would with \
                 its roof open (gi.opacity = \"layers\" with gi.voxel_cover = \"directional\": 0.024, and \
                 gi.footprint and gi.bounce_footprint = \"quadrants\" too: 0.017; with gi.plane_backs = \"closed\" \
                 as well 0.009-0.012 through walls of 1 to 4 voxels, and a room lit through a window gets 0.81-1.01 \
                 of the path tracer's indirect light wall by wall; ACCURACY.md, \"Sky light and leaks\", \"Backs \
                 that close a solid\")"
            } else {
                ""
            };
            format!(
                "lights the scene: cones that leave the voxel grid see it through what they crossed, filtered to \
                 their aperture (diffuse, specular and the voxels' bounce, so it bounces){rays}{leak}"
            )
        }
        GiMode::None => "background only: gi.mode = \"none\" has no indirect light, and sky light is only \
                         gathered by the cones; use gi.mode = \"vct\""
            .to_owned(),
        mode => format!(
            "background only: gi.mode = \"{}\" gathers the light of the lights' reflective shadow maps, which \
             see no sky; use gi.mode = \"vct\" for sky light",
            match mode {
                GiMode::Rsm => "rsm",
                GiMode::Lpv => "lpv",
                _ => "rsm+lpv",
            }
        ),
    };
    Some(format!("sky {}: {what}", sky.describe()))
}

/// GPU memory of the sky's maps and tables (what [`SkyGpu`] allocates, before alignment): the
/// radiance map (RGBA32F), the cone map with its levels, the irradiance map, the path
/// tracer's tables; a few hundred bytes of black stand-ins without a sky.
pub fn sky_bytes(sky: Option<&Sky>) -> u64 {
    let (w, h) = match sky.map(|s| &s.kind) {
        None => return 1024,
        Some(SkyKind::Image(img)) => (img.width as u64, img.height as u64),
        Some(SkyKind::Constant(_)) => (8, 4),
        Some(SkyKind::Gradient { .. }) => (2 * GRADIENT_ROWS as u64, GRADIENT_ROWS as u64),
    };
    let (cw, ch) = (CONE_MAP_SIZE.0 as u64, CONE_MAP_SIZE.1 as u64);
    let (iw, ih) = (IRRADIANCE_SIZE.0 as u64, IRRADIANCE_SIZE.1 as u64);
    16 * w * h + 16 * cw * ch * 4 / 3 + 16 * iw * ih + 4 * ((h + 1) + h * (w + 1) + w * h)
}

/// Whether the scene's technique lights anything with its sky.
pub fn lit_by_sky(scene: &Scene) -> bool {
    scene.sky.is_some() && scene.settings.gi.mode == GiMode::Vct
}

/// An equirectangular RGB f32 map, top row first (scene::sky for the mapping).
#[derive(Debug, Clone, PartialEq)]
pub struct EquirectMap {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<f32>,
}

impl EquirectMap {
    fn filled(width: u32, height: u32, f: impl Fn(u32, u32) -> Vec3) -> EquirectMap {
        let mut rgb = Vec::with_capacity((width * height * 3) as usize);
        for y in 0..height {
            for x in 0..width {
                rgb.extend_from_slice(&f(x, y).to_array());
            }
        }
        EquirectMap { width, height, rgb }
    }

    pub fn texel(&self, x: u32, y: u32) -> Vec3 {
        let i = (y as usize * self.width as usize + x as usize) * 3;
        Vec3::new(self.rgb[i], self.rgb[i + 1], self.rgb[i + 2])
    }

    /// The polar angle of row y's centre.
    fn theta(&self, y: u32) -> f64 {
        PI * (y as f64 + 0.5) / self.height as f64
    }

    /// RGBA f32 bytes (alpha 1), for the upload.
    fn rgba_bytes(&self) -> Vec<u8> {
        let rgba: Vec<f32> = self.rgb.chunks_exact(3).flat_map(|c| [c[0], c[1], c[2], 1.0]).collect();
        bytemuck::cast_slice(&rgba).to_vec()
    }

    /// The unit direction of texel (x, y)'s centre (unturned).
    fn dir(&self, x: u32, y: u32) -> DVec3 {
        let u = (x as f32 + 0.5) / self.width as f32;
        let v = (y as f32 + 0.5) / self.height as f32;
        equirect_dir(u, v, 0.0).as_dvec3()
    }
}

/// The sky's radiance map (module docs), unturned: the turn is applied where it is read.
pub fn sky_map(sky: &Sky) -> EquirectMap {
    match &sky.kind {
        SkyKind::Constant(c) => EquirectMap::filled(8, 4, |_, _| *c),
        SkyKind::Gradient { zenith, horizon, ground } => {
            let h = GRADIENT_ROWS;
            EquirectMap::filled(2 * h, h, |_, y| {
                let edge = |r: u32| (std::f64::consts::PI * r as f64 / h as f64).cos();
                let mid = ((edge(y) + edge(y + 1)) * 0.5) as f32;
                // The horizon is a row edge (h even): no band straddles the kink.
                gradient(*zenith, *horizon, *ground, mid)
            })
        }
        SkyKind::Image(img) => EquirectMap { width: img.width, height: img.height, rgb: img.rgb.clone() },
    }
}

/// `map` resampled to `width` x `height`: each output texel the solid-angle mean of the source
/// texels whose centres fall in it, or the nearest source texel where none does (upsampling).
fn resample(map: &EquirectMap, width: u32, height: u32) -> EquirectMap {
    let (sx, sy) = (map.width as f64 / width as f64, map.height as f64 / height as f64);
    EquirectMap::filled(width, height, |x, y| {
        let range = |i: u32, s: f64, n: u32| {
            let lo = ((i as f64 * s - 0.5).ceil().max(0.0)) as u32;
            let hi = ((((i + 1) as f64) * s - 0.5).ceil().max(0.0) as u32).min(n);
            if lo < hi {
                lo..hi
            } else {
                let c = (((i as f64 + 0.5) * s) as u32).min(n - 1);
                c..c + 1
            }
        };
        let (mut sum, mut weight) = (DVec3::ZERO, 0.0);
        for yy in range(y, sy, map.height) {
            let w = map.theta(yy).sin();
            for xx in range(x, sx, map.width) {
                sum += map.texel(xx, yy).as_dvec3() * w;
                weight += w;
            }
        }
        (sum / weight.max(1e-300)).as_vec3()
    })
}

/// The mean of `src` over the cap of half-angle `alpha` around each texel centre of a
/// `width` x `height` map: source texels whose centres lie in the cap, weighted by solid angle.
fn cap_filter(src: &EquirectMap, width: u32, height: u32, alpha: f64) -> EquirectMap {
    let cos_alpha = alpha.min(PI).cos();
    let row_height = PI / src.height as f64;
    let dirs: Vec<DVec3> =
        (0..src.height).flat_map(|y| (0..src.width).map(move |x| (x, y))).map(|(x, y)| src.dir(x, y)).collect();
    let out = EquirectMap { width, height, rgb: Vec::new() };
    EquirectMap::filled(width, height, |x, y| {
        let c = out.dir(x, y);
        let theta = out.theta(y);
        // Rows within alpha of the centre's polar angle, and within them the columns within
        // the cap's azimuth span (all columns where the cap holds a pole).
        let y0 = (((theta - alpha) / row_height).floor().max(0.0)) as u32;
        let y1 = ((((theta + alpha) / row_height).ceil()) as u32).min(src.height);
        let (mut sum, mut weight) = (DVec3::ZERO, 0.0);
        for yy in y0..y1 {
            let sin_row = src.theta(yy).sin();
            let span = if theta - alpha <= 0.0 || theta + alpha >= PI || alpha.sin() >= sin_row {
                src.width
            } else {
                let dphi = (alpha.sin() / sin_row).min(1.0).asin();
                ((dphi / (2.0 * PI) * src.width as f64).ceil() as u32 + 1).min(src.width)
            };
            let cx = ((x as f64 + 0.5) / width as f64 * src.width as f64) as i64;
            let xs: Box<dyn Iterator<Item = u32>> = if span >= src.width / 2 {
                Box::new(0..src.width)
            } else {
                let w = src.width as i64;
                Box::new((cx - span as i64..=cx + span as i64).map(move |i| i.rem_euclid(w) as u32))
            };
            for xx in xs {
                if dirs[(yy * src.width + xx) as usize].dot(c) >= cos_alpha {
                    sum += src.texel(xx, yy).as_dvec3() * sin_row;
                    weight += sin_row;
                }
            }
        }
        if weight > 0.0 {
            (sum / weight).as_vec3()
        } else {
            // A cap narrower than the source's texels: the nearest texel.
            let sx = ((x as f64 + 0.5) / width as f64 * src.width as f64) as u32;
            src.texel(sx.min(src.width - 1), ((theta / row_height) as u32).min(src.height - 1))
        }
    })
}

/// The cone map's levels (module docs): level k is `CONE_MAP_SIZE >> k`, the mean over caps of
/// half-angle 2^k ALPHA0, each computed from a plain resampling of the map with four texels to
/// the cap's radius.
pub fn cone_levels(map: &EquirectMap) -> Vec<EquirectMap> {
    let (w0, h0) = CONE_MAP_SIZE;
    let mut source = resample(map, 2 * w0, 2 * h0);
    (0..CONE_LEVELS)
        .map(|k| {
            if k > 0 {
                source = resample(&source, (2 * w0) >> k, (2 * h0) >> k);
            }
            cap_filter(&source, w0 >> k, h0 >> k, ALPHA0 * (1u32 << k) as f64)
        })
        .collect()
}

/// Width and height of the irradiance map, and of the resampled sky it integrates.
const IRRADIANCE_SIZE: (u32, u32) = (128, 64);
const IRRADIANCE_SOURCE: (u32, u32) = (64, 32);

/// The sky's irradiance / pi at every texel direction n of a 128x64 map: the cosine-weighted
/// mean radiance over n's hemisphere, sum of L max(0, n.w) dw / pi over a 64x32 solid-angle
/// mean resampling of the map. With nothing in the way, what the diffuse cones must add up
/// to (cone.glsl's trace_diffuse scales their sky to it).
pub fn irradiance_map(map: &EquirectMap) -> EquirectMap {
    let src = resample(map, IRRADIANCE_SOURCE.0, IRRADIANCE_SOURCE.1);
    let texels: Vec<(DVec3, DVec3)> = (0..src.height)
        .flat_map(|y| (0..src.width).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (t0, t1) = (PI * y as f64 / src.height as f64, PI * (y + 1) as f64 / src.height as f64);
            let d_omega = 2.0 * PI / src.width as f64 * (t0.cos() - t1.cos());
            (src.dir(x, y), src.texel(x, y).as_dvec3() * d_omega / PI)
        })
        .collect();
    let out = EquirectMap { width: IRRADIANCE_SIZE.0, height: IRRADIANCE_SIZE.1, rgb: Vec::new() };
    EquirectMap::filled(out.width, out.height, |x, y| {
        let n = out.dir(x, y);
        texels.iter().map(|(d, l)| *l * n.dot(*d).max(0.0)).sum::<DVec3>().as_vec3()
    })
}

/// What the path tracer draws sky directions from (module docs).
#[derive(Debug, Clone)]
pub struct SkySampling {
    /// Per texel, its probability per unit of image area (u, v): 1 on average.
    pub density: Vec<f32>,
    /// Cumulative row probabilities, `height + 1` entries from 0 to 1.
    pub marginal: Vec<f32>,
    /// Per row, cumulative texel probabilities within it, `width + 1` entries from 0 to 1.
    pub conditional: Vec<f32>,
    /// Whether any texel gives light (else the tracer does not sample the sky).
    pub lit: bool,
}

/// The luminance the sampling follows: the mean of the channels.
fn weight_of(c: Vec3) -> f64 {
    (c.x as f64 + c.y as f64 + c.z as f64) / 3.0
}

impl SkySampling {
    pub fn of(map: &EquirectMap) -> SkySampling {
        let (w, h) = (map.width as usize, map.height as usize);
        let mut weights = vec![0.0f64; w * h];
        for y in 0..h {
            let s = map.theta(y as u32).sin();
            for x in 0..w {
                weights[y * w + x] = weight_of(map.texel(x as u32, y as u32)) * s;
            }
        }
        let total: f64 = weights.iter().sum();
        let lit = total > 0.0 && total.is_finite();
        let mean = if lit { total / (w * h) as f64 } else { 1.0 };
        let density = weights.iter().map(|&x| (x / mean) as f32).collect();
        let mut marginal = Vec::with_capacity(h + 1);
        let mut conditional = Vec::with_capacity(h * (w + 1));
        let mut acc = 0.0;
        marginal.push(0.0);
        for y in 0..h {
            let row = &weights[y * w..(y + 1) * w];
            let row_sum: f64 = row.iter().sum();
            let mut c = 0.0;
            conditional.push(0.0);
            for (x, v) in row.iter().enumerate() {
                c += v;
                // An empty row is never drawn; its table is uniform.
                conditional.push(if row_sum > 0.0 { (c / row_sum) as f32 } else { (x + 1) as f32 / w as f32 });
            }
            *conditional.last_mut().unwrap() = 1.0;
            acc += row_sum;
            marginal.push(if lit { (acc / total) as f32 } else { (y + 1) as f32 / h as f32 });
        }
        *marginal.last_mut().unwrap() = 1.0;
        SkySampling { density, marginal, conditional, lit }
    }

    /// The tables as the shader reads them: marginal, then conditional, then density.
    fn words(&self) -> Vec<f32> {
        [&self.marginal[..], &self.conditional[..], &self.density[..]].concat()
    }
}

/// Mirrors the sky fields of FrameData (common.glsl) and PtParams (pt_trace.comp).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SkyParams {
    /// x cos, y sin of the turn; z 1 with a sky (0: black, nothing bound is read); w 1 when
    /// the sampling tables hold light.
    pub params: [f32; 4],
    /// x, y the map's width and height; z the cone map's levels.
    pub size: [u32; 4],
}

/// The sky's GPU resources; a scene without one binds 1x1 black stand-ins.
pub struct SkyGpu {
    pub map: Image,
    pub cones: Image,
    /// Irradiance / pi by normal ([`irradiance_map`]).
    pub irradiance: Image,
    /// The path tracer's sampling tables (`SkySampling::words`).
    pub sampling: Buffer,
    pub sampler: Sampler,
    pub params: SkyParams,
}

impl SkyGpu {
    pub fn new(ctx: &std::sync::Arc<Context>, sky: Option<&Sky>) -> GpuResult<SkyGpu> {
        let black = Sky { kind: SkyKind::Constant(Vec3::ZERO), rotation_deg: 0.0, scale: 1.0 };
        let map = sky_map(sky.unwrap_or(&black));
        let (levels, irradiance) = match sky {
            Some(_) => (cone_levels(&map), irradiance_map(&map)),
            None => (vec![EquirectMap::filled(2, 1, |_, _| Vec3::ZERO)], EquirectMap::filled(2, 1, |_, _| Vec3::ZERO)),
        };
        let sampling = SkySampling::of(&map);
        let format = vk::Format::R32G32B32A32_SFLOAT;
        let map_image = upload_levels(ctx, "sky map", format, &[(map.width, map.height, map.rgba_bytes())])?;
        let cone_bytes: Vec<(u32, u32, Vec<u8>)> = levels.iter().map(|l| (l.width, l.height, l.rgba_bytes())).collect();
        let cones = upload_levels(ctx, "sky cone map", format, &cone_bytes)?;
        let irradiance_image = upload_levels(
            ctx,
            "sky irradiance map",
            format,
            &[(irradiance.width, irradiance.height, irradiance.rgba_bytes())],
        )?;
        let words = sampling.words();
        let sampling_buffer = upload_buffer(
            ctx,
            "sky sampling tables",
            bytemuck::cast_slice(&words),
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        // Bilinear and trilinear, around in azimuth, clamped at the poles.
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .mipmap_mode(vk::SamplerMipmapMode::LINEAR)
            .address_mode_u(vk::SamplerAddressMode::REPEAT)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .max_lod(vk::LOD_CLAMP_NONE);
        let sampler = Sampler::new(ctx, "sky sampler", &info)?;
        let turn = sky.map_or(0.0, |s| s.rotation_deg.to_radians());
        let params = SkyParams {
            params: [turn.cos(), turn.sin(), f32::from(u8::from(sky.is_some())), f32::from(u8::from(sampling.lit))],
            size: [map.width, map.height, levels.len() as u32, 0],
        };
        Ok(SkyGpu { map: map_image, cones, irradiance: irradiance_image, sampling: sampling_buffer, sampler, params })
    }

    /// Two bindings in a row: the cone map, then the irradiance map (what cone.glsl's
    /// CONE_SKY reads).
    pub fn cones_bind(&self) -> Binds<'_> {
        let ro = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        Binds::new().loaded(Bind::Sampled(self.cones.view, self.sampler.raw, ro)).loaded(Bind::Sampled(
            self.irradiance.view,
            self.sampler.raw,
            ro,
        ))
    }

    /// One binding: the radiance map (what the camera sees where nothing is in the way).
    pub fn map_bind(&self) -> Binds<'_> {
        let ro = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        Binds::new().loaded(Bind::Sampled(self.map.view, self.sampler.raw, ro))
    }

    /// GPU memory of the maps and tables.
    pub fn bytes(&self) -> u64 {
        self.map.bytes + self.cones.bytes + self.irradiance.bytes + self.sampling.size
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SkyImage;
    use std::sync::Arc;

    fn mean_over_sphere(m: &EquirectMap) -> Vec3 {
        let (mut s, mut w) = (DVec3::ZERO, 0.0);
        for y in 0..m.height {
            let sw = m.theta(y).sin();
            for x in 0..m.width {
                s += m.texel(x, y).as_dvec3() * sw;
                w += sw;
            }
        }
        (s / w).as_vec3()
    }

    #[test]
    fn info_names_the_leak_of_blend_and_its_remedy_under_a_sky() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/leak/sealed-room-t2.toml");
        let load = |overrides: Vec<(String, String)>| {
            crate::scene::load(&path, &crate::scene::LoadOptions { overrides, asset_paths: Vec::new() }).unwrap()
        };
        let blend = sky_use(&load(Vec::new())).unwrap();
        assert!(blend.contains("gi.opacity = \"layers\" with gi.voxel_cover = \"directional\""), "{blend}");
        assert!(blend.contains("gi.plane_backs = \"closed\""), "{blend}");
        let layers = sky_use(&load(vec![("gi.opacity".into(), "\"layers\"".into())])).unwrap();
        assert!(layers.starts_with("sky gradient") && !layers.contains("roof open"), "{layers}");
    }

    #[test]
    fn a_baked_gradient_keeps_each_bands_mean_and_the_hemispheres_irradiance() {
        let (z, h, g) = (Vec3::new(0.2, 0.4, 1.0), Vec3::splat(0.6), Vec3::new(0.1, 0.08, 0.05));
        let sky = Sky { kind: SkyKind::Gradient { zenith: z, horizon: h, ground: g }, rotation_deg: 0.0, scale: 1.0 };
        let m = sky_map(&sky);
        // Irradiance on an upward plane: pi h + (z - h) 2 pi / 3, here from the texels.
        let mut e = DVec3::ZERO;
        let d_omega = |y: u32| {
            2.0 * PI / m.width as f64
                * ((PI * y as f64 / m.height as f64).cos() - (PI * (y + 1) as f64 / m.height as f64).cos())
        };
        for y in 0..m.height / 2 {
            for x in 0..m.width {
                e += m.texel(x, y).as_dvec3() * m.dir(x, y).y * d_omega(y);
            }
        }
        let exact = h.as_dvec3() * PI + (z - h).as_dvec3() * (2.0 * PI / 3.0);
        assert!((e - exact).abs().max_element() < 1e-3 * exact.max_element(), "{e} vs {exact}");
        let mean = mean_over_sphere(&m);
        assert!((mean.max_element() - sky.mean_radiance()).abs() < 1e-3, "{mean} vs {}", sky.mean_radiance());
    }

    #[test]
    fn cone_levels_average_caps_and_keep_the_spheres_mean() {
        // A sky bright in its upper half only: a hemisphere-wide cap straight up sees all of it,
        // one pointing at the horizon half of it, and the whole-sphere level the mean, 1/2.
        let img = SkyImage {
            path: "test.exr".into(),
            width: 64,
            height: 32,
            rgb: (0..32).flat_map(|y| std::iter::repeat_n(if y < 16 { 1.0 } else { 0.0 }, 64 * 3)).collect(),
        };
        let sky = Sky { kind: SkyKind::Image(Arc::new(img)), rotation_deg: 0.0, scale: 1.0 };
        let levels = cone_levels(&sky_map(&sky));
        assert_eq!(levels.len(), CONE_LEVELS as usize);
        assert_eq!((levels[7].width, levels[7].height), (4, 2));
        for l in &levels[..6] {
            let m = mean_over_sphere(l).x;
            assert!((m - 0.5).abs() < 0.02, "{}x{}: mean {m}", l.width, l.height);
        }
        for x in 0..4 {
            for y in 0..2 {
                assert!((levels[7].texel(x, y).x - 0.5).abs() < 0.01, "whole sphere: {}", levels[7].texel(x, y));
            }
        }
        // Level 6: caps of 90 degrees; its top row's centres sit 22.5 degrees from the zenith.
        let top = levels[6].texel(3, 0).x;
        let exact = {
            // Fraction of a hemispherical cap around polar angle t that lies above the horizon:
            // numerically.
            let c = equirect_dir(0.5, 0.125, 0.0).as_dvec3();
            let (mut inside, mut total) = (0.0, 0.0);
            let n = 400;
            for i in 0..n {
                for j in 0..2 * n {
                    let t = PI * (i as f64 + 0.5) / n as f64;
                    let p = 2.0 * PI * (j as f64 + 0.5) / (2 * n) as f64;
                    let d = DVec3::new(t.sin() * p.sin(), t.cos(), -t.sin() * p.cos());
                    if d.dot(c) >= 0.0 {
                        total += t.sin();
                        if d.y > 0.0 {
                            inside += t.sin();
                        }
                    }
                }
            }
            inside / total
        };
        assert!((top as f64 - exact).abs() < 0.03, "level 6 top {top} vs {exact}");
        assert!((levels[0].texel(10, 3).x - 1.0).abs() < 1e-6 && levels[0].texel(10, 250).x.abs() < 1e-6);
    }

    #[test]
    fn the_irradiance_map_integrates_cosine_weighted_radiance() {
        // A uniform sky: irradiance / pi is the radiance itself, at every normal.
        let flat = irradiance_map(&EquirectMap::filled(16, 8, |_, _| Vec3::splat(2.0)));
        assert!(flat.rgb.iter().all(|&v| (v - 2.0).abs() < 2e-3), "uniform: {:?}", &flat.rgb[..6]);
        // Light from the upper hemisphere only: pi at the zenith (the whole cosine lobe),
        // half of it for a horizontal normal, nothing looking straight down.
        let upper = irradiance_map(&EquirectMap::filled(64, 32, |_, y| if y < 16 { Vec3::ONE } else { Vec3::ZERO }));
        let (top, mid, bottom) = (upper.texel(5, 0).x, upper.texel(5, 31).x, upper.texel(5, 63).x);
        assert!((top - 1.0).abs() < 0.01 && (mid - 0.5).abs() < 0.03 && bottom.abs() < 0.01, "{top} {mid} {bottom}");
    }

    #[test]
    fn sampling_tables_are_cumulative_and_densities_average_one() {
        let img = SkyImage {
            path: "test.exr".into(),
            width: 16,
            height: 8,
            rgb: (0..16 * 8)
                .flat_map(|i| {
                    let v = (i % 7) as f32;
                    [v, v * 0.5, 0.0]
                })
                .collect(),
        };
        let map = EquirectMap { width: 16, height: 8, rgb: img.rgb.clone() };
        let s = SkySampling::of(&map);
        assert!(s.lit);
        assert_eq!(s.marginal.len(), 9);
        assert_eq!(s.conditional.len(), 8 * 17);
        assert!(s.marginal.windows(2).all(|w| w[0] <= w[1]) && *s.marginal.last().unwrap() == 1.0);
        let mean: f64 = s.density.iter().map(|&d| d as f64).sum::<f64>() / s.density.len() as f64;
        assert!((mean - 1.0).abs() < 1e-5, "{mean}");
        let black = SkySampling::of(&EquirectMap::filled(4, 2, |_, _| Vec3::ZERO));
        assert!(!black.lit);
    }
}
