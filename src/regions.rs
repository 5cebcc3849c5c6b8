//! Where the error is: every pixel labelled with the surface it shows, and error figures per
//! region (object, mesh, material, and mesh × facing) instead of only per image.
//!
//! The labels come from the scene, not from the images: one ray per pixel centre, cast on the
//! host through the reference path tracer's triangles and BVH with the same camera rays as
//! `dvsgi reference` (and the rasterizer, which samples pixel centres), so a label is exactly
//! the surface both images show there. The facing of a surface is the dominant axis of its
//! geometric normal turned toward the camera, so a block's sides, its top and a wall are
//! separate regions.

use crate::metrics::{LinearImage, RELMSE_EPSILON};
use crate::reference::bvh::Bvh;
use crate::reference::Triangles;
use crate::scene::Scene;
use glam::{Vec3, Vec4};
use serde::{Deserialize, Serialize};

/// Pixels that show no surface (background).
pub const BACKGROUND: u32 = u32::MAX;

/// Regions with fewer pixels than this are listed but flagged (`small`): their ratio is noise.
pub const MIN_REGION_PIXELS: u64 = 16;

/// One distinct surface: a mesh of an object seen from one facing.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Surface {
    pub object: String,
    pub mesh: String,
    pub material: String,
    /// Dominant axis of the normal turned toward the camera: "+x", "-x", "+y", ...
    pub facing: String,
}

/// Each pixel's surface (an index into `surfaces`, or [`BACKGROUND`]).
#[derive(Debug, Clone)]
pub struct RegionMap {
    pub width: u32,
    pub height: u32,
    pub pixel: Vec<u32>,
    pub surfaces: Vec<Surface>,
}

fn facing_label(n: Vec3) -> String {
    let a = n.abs();
    let (axis, v) = if a.x >= a.y && a.x >= a.z {
        ('x', n.x)
    } else if a.y >= a.z {
        ('y', n.y)
    } else {
        ('z', n.z)
    };
    format!("{}{axis}", if v >= 0.0 { '+' } else { '-' })
}

impl RegionMap {
    /// Label every pixel of a `width` × `height` image of `scene` (its camera and time).
    pub fn trace(scene: &Scene, width: u32, height: u32) -> RegionMap {
        let t = scene.settings.time;
        let tris = Triangles::of(scene, t);
        let bvh = Bvh::build(&tris.corners);
        let ordered: Vec<[Vec3; 3]> = bvh.order.iter().map(|&i| tris.corners[i as usize]).collect();
        let cam = &scene.camera;
        let inv = (cam.projection(width as f32 / height as f32) * cam.view()).inverse();
        let mut surfaces: Vec<Surface> = Vec::new();
        let mut pixel = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                // The path tracer's ray through the pixel centre (glsl/pt_trace.comp).
                let ndc = glam::Vec2::new((x as f32 + 0.5) / width as f32, (y as f32 + 0.5) / height as f32) * 2.0
                    - glam::Vec2::ONE;
                let near = inv * Vec4::new(ndc.x, ndc.y, 0.0, 1.0);
                let far = inv * Vec4::new(ndc.x, ndc.y, 1.0, 1.0);
                let o = near.truncate() / near.w;
                let span = far.truncate() / far.w - o;
                let len = span.length();
                let dir = span / len;
                let Some((_, hit)) = bvh.intersect(&ordered, o, dir, len) else {
                    pixel.push(BACKGROUND);
                    continue;
                };
                let i = bvh.order[hit as usize] as usize;
                let [a, b, c] = tris.corners[i];
                let mut n = (b - a).cross(c - a).normalize_or_zero();
                if n.dot(dir) > 0.0 {
                    n = -n;
                }
                let [oi, mi] = tris.sources[i];
                let surface = Surface {
                    object: scene.objects[oi as usize].name.clone(),
                    mesh: scene.meshes[mi as usize].name.clone(),
                    material: scene
                        .materials
                        .get(tris.materials[i] as usize)
                        .map(|m| m.name.clone())
                        .unwrap_or_default(),
                    facing: facing_label(n),
                };
                let id = match surfaces.iter().position(|s| *s == surface) {
                    Some(id) => id,
                    None => {
                        surfaces.push(surface);
                        surfaces.len() - 1
                    }
                };
                pixel.push(id as u32);
            }
        }
        RegionMap { width, height, pixel, surfaces }
    }

    /// The regions of one grouping: (name, member surface indices), in first-seen order.
    pub fn groups(&self, grouping: Grouping) -> Vec<(String, Vec<u32>)> {
        let mut out: Vec<(String, Vec<u32>)> = Vec::new();
        for (i, s) in self.surfaces.iter().enumerate() {
            let name = grouping.name_of(s);
            match out.iter_mut().find(|(n, _)| *n == name) {
                Some((_, v)) => v.push(i as u32),
                None => out.push((name, vec![i as u32])),
            }
        }
        out
    }
}

/// How surfaces are grouped into regions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Grouping {
    Object,
    Mesh,
    Material,
    /// Mesh and facing: a wall, a block's side, a block's top.
    Surface,
}

impl Grouping {
    pub const ALL: [Grouping; 4] = [Grouping::Object, Grouping::Mesh, Grouping::Material, Grouping::Surface];

    fn name_of(self, s: &Surface) -> String {
        match self {
            Grouping::Object => s.object.clone(),
            Grouping::Mesh => format!("{}/{}", s.object, s.mesh),
            Grouping::Material => s.material.clone(),
            Grouping::Surface => format!("{}/{} {}", s.object, s.mesh, s.facing),
        }
    }
}

/// Error figures of one region (means over its pixels, radiance averaged over R, G, B).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RegionStats {
    pub grouping: Grouping,
    pub name: String,
    pub pixels: u64,
    /// Fewer than [`MIN_REGION_PIXELS`] pixels: too few for the ratio to mean much.
    pub small: bool,
    pub test_rgb: [f64; 3],
    pub reference_rgb: [f64; 3],
    /// Mean test radiance over mean reference radiance (1 = right amount of light).
    pub ratio: f64,
    /// Standard error of that ratio from the reference's noise (when its variance is known).
    pub ratio_noise: Option<f64>,
    pub rmse: f64,
    /// `(t − r)² / (r² + ε)` averaged over the region's pixels and channels.
    pub relmse: f64,
}

/// The pixel values a region report compares: test and reference radiance, and optionally
/// the variance of each reference pixel's mean.
pub struct Pair<'a> {
    pub test: &'a LinearImage,
    pub reference: &'a LinearImage,
    pub reference_variance: Option<&'a LinearImage>,
}

fn mean_of(rgb: [f64; 3]) -> f64 {
    (rgb[0] + rgb[1] + rgb[2]) / 3.0
}

/// Figures for every region of every grouping, plus the whole image (grouping `object`,
/// name "(all surfaces)") first.
pub fn region_stats(map: &RegionMap, pair: &Pair) -> Vec<RegionStats> {
    let all: Vec<u32> = (0..map.surfaces.len() as u32).collect();
    let mut out = vec![stats_of(map, pair, Grouping::Object, "(all surfaces)".into(), &all)];
    for g in Grouping::ALL {
        for (name, members) in map.groups(g) {
            out.push(stats_of(map, pair, g, name, &members));
        }
    }
    out
}

fn stats_of(map: &RegionMap, pair: &Pair, grouping: Grouping, name: String, members: &[u32]) -> RegionStats {
    let mut member = vec![false; map.surfaces.len()];
    for &m in members {
        member[m as usize] = true;
    }
    let (mut t, mut r, mut var) = ([0.0f64; 3], [0.0f64; 3], 0.0f64);
    let (mut se, mut rel, mut n) = (0.0f64, 0.0f64, 0u64);
    for (p, &id) in map.pixel.iter().enumerate() {
        if id == BACKGROUND || !member[id as usize] {
            continue;
        }
        n += 1;
        for c in 0..3 {
            let (tv, rv) = (pair.test.rgb[p * 3 + c] as f64, pair.reference.rgb[p * 3 + c] as f64);
            t[c] += tv;
            r[c] += rv;
            se += (tv - rv) * (tv - rv);
            rel += (tv - rv) * (tv - rv) / (rv * rv + RELMSE_EPSILON);
        }
        if let Some(v) = pair.reference_variance {
            // Variance of the pixel's RGB mean (channels taken as independent).
            var += (v.rgb[p * 3] + v.rgb[p * 3 + 1] + v.rgb[p * 3 + 2]) as f64 / 9.0;
        }
    }
    let k = n.max(1) as f64;
    let (t, r) = (t.map(|v| v / k), r.map(|v| v / k));
    let (tm, rm) = (mean_of(t), mean_of(r));
    let ratio = if rm != 0.0 { tm / rm } else { f64::NAN };
    // Delta method: sd(ratio) = ratio * sd(mean ref) / mean ref.
    let ratio_noise = pair.reference_variance.map(|_| ratio.abs() * (var.sqrt() / k) / rm.abs().max(1e-30));
    RegionStats {
        grouping,
        name,
        pixels: n,
        small: n < MIN_REGION_PIXELS,
        test_rgb: t,
        reference_rgb: r,
        ratio,
        ratio_noise,
        rmse: (se / (3.0 * k)).sqrt(),
        relmse: rel / (3.0 * k),
    }
}

/// Per-region figures of a comparison: for the images as given and, when the reference's
/// direct light is known, for the indirect light alone.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RegionReport {
    /// The test image against the reference (first entry: all surfaces).
    pub regions: Vec<RegionStats>,
    /// The test's indirect light against the reference's (reference − its direct light).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub indirect: Option<Vec<RegionStats>>,
}

/// The indirect light of a test image and of the reference: (test, reference). The test's is
/// `test_indirect` when given, else `test − ref_direct`; the reference's is
/// `reference − ref_direct`.
pub fn indirect_pair(
    test: &LinearImage,
    reference: &LinearImage,
    ref_direct: &LinearImage,
    test_indirect: Option<&LinearImage>,
) -> (LinearImage, LinearImage) {
    let minus = |a: &LinearImage, b: &LinearImage| LinearImage {
        width: a.width,
        height: a.height,
        rgb: a.rgb.iter().zip(&b.rgb).map(|(x, y)| x - y).collect(),
    };
    let t = test_indirect.cloned().unwrap_or_else(|| minus(test, ref_direct));
    (t, minus(reference, ref_direct))
}

/// A picture of where light is missing or in excess: log2(test / reference) of each pixel's
/// RGB mean, blue (too dark) through white (right) to red (too bright), saturating at
/// ±`stops`. Pixels whose reference is below 1% of the image's mean are grey; background
/// pixels (no surface) are black.
pub fn ratio_picture(map: &RegionMap, test: &LinearImage, reference: &LinearImage, stops: f64) -> image::RgbImage {
    let m = |img: &LinearImage, p: usize| {
        (img.rgb[p * 3] as f64 + img.rgb[p * 3 + 1] as f64 + img.rgb[p * 3 + 2] as f64) / 3.0
    };
    let n = map.pixel.len();
    let image_mean = (0..n).map(|p| m(reference, p)).sum::<f64>() / n.max(1) as f64;
    let mut out = image::RgbImage::new(map.width, map.height);
    for (p, px) in out.pixels_mut().enumerate() {
        let (t, r) = (m(test, p), m(reference, p));
        *px = if map.pixel[p] == BACKGROUND {
            image::Rgb([0, 0, 0])
        } else if r.is_nan() || r <= 0.01 * image_mean {
            image::Rgb([128, 128, 128])
        } else {
            let s = ((t.max(0.0) / r).max(1e-6).log2() / stops).clamp(-1.0, 1.0);
            let fade = |v: f64| (255.0 * (1.0 - v.abs())).round() as u8;
            if s < 0.0 {
                image::Rgb([fade(s), fade(s), 255])
            } else {
                image::Rgb([255, fade(s), fade(s)])
            }
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(rgb: Vec<f32>) -> LinearImage {
        LinearImage { width: 2, height: 2, rgb }
    }

    fn map() -> RegionMap {
        let s = |mesh: &str, material: &str, facing: &str| Surface {
            object: "box".into(),
            mesh: mesh.into(),
            material: material.into(),
            facing: facing.into(),
        };
        RegionMap {
            width: 2,
            height: 2,
            pixel: vec![0, 1, 2, BACKGROUND],
            surfaces: vec![s("floor", "white", "+y"), s("block", "white", "+x"), s("block", "white", "+y")],
        }
    }

    #[test]
    fn facing_is_the_dominant_axis() {
        assert_eq!(facing_label(Vec3::new(0.1, 0.9, -0.2)), "+y");
        assert_eq!(facing_label(Vec3::new(-0.8, 0.1, 0.5)), "-x");
        assert_eq!(facing_label(Vec3::new(0.0, 0.1, -0.5)), "-z");
    }

    #[test]
    fn groupings_by_hand() {
        let m = map();
        let names = |g| m.groups(g).into_iter().map(|(n, v)| (n, v.len())).collect::<Vec<_>>();
        assert_eq!(names(Grouping::Object), vec![("box".to_string(), 3)]);
        assert_eq!(names(Grouping::Mesh), vec![("box/floor".to_string(), 1), ("box/block".to_string(), 2)]);
        assert_eq!(names(Grouping::Material), vec![("white".to_string(), 3)]);
        assert_eq!(names(Grouping::Surface).len(), 3);
    }

    #[test]
    fn stats_by_hand() {
        let m = map();
        // Floor half as bright as the reference; block +x right; block top twice; background
        // ignored however wrong it is.
        let test = img(vec![1., 1., 1., 2., 2., 2., 4., 4., 4., 9., 9., 9.]);
        let reference = img(vec![2., 2., 2., 2., 2., 2., 2., 2., 2., 0., 0., 0.]);
        let var = img(vec![0.09; 12]);
        let stats = region_stats(&m, &Pair { test: &test, reference: &reference, reference_variance: Some(&var) });
        let get = |g, n: &str| stats.iter().find(|s| s.grouping == g && s.name == n).unwrap().clone();
        let floor = get(Grouping::Mesh, "box/floor");
        assert_eq!(floor.pixels, 1);
        assert!((floor.ratio - 0.5).abs() < 1e-12);
        assert!((floor.rmse - 1.0).abs() < 1e-12);
        assert!((floor.relmse - 1.0 / (4.0 + RELMSE_EPSILON)).abs() < 1e-12);
        // sd of a pixel's RGB mean = sqrt(3 * 0.09 / 9) = 0.1732; relative 0.0866; times 0.5.
        assert!((floor.ratio_noise.unwrap() - 0.5 * (0.03f64).sqrt() / 2.0).abs() < 1e-6);
        let block = get(Grouping::Mesh, "box/block");
        assert!((block.ratio - 1.5).abs() < 1e-12);
        assert!((get(Grouping::Surface, "box/block +y").ratio - 2.0).abs() < 1e-12);
        let all = &stats[0];
        assert_eq!(all.pixels, 3);
        assert!((all.ratio - 7.0 / 6.0).abs() < 1e-12);
        assert!(all.small);
    }

    #[test]
    fn ratio_picture_colours() {
        let m = map();
        let test = img(vec![1., 1., 1., 2., 2., 2., 8., 8., 8., 1., 1., 1.]);
        let reference = img(vec![2., 2., 2., 2., 2., 2., 2., 2., 2., 0., 0., 0.]);
        let p = ratio_picture(&m, &test, &reference, 1.0);
        assert_eq!(p.get_pixel(0, 0).0, [0, 0, 255]); // one stop dark: saturated blue
        assert_eq!(p.get_pixel(1, 0).0, [255, 255, 255]); // right: white
        assert_eq!(p.get_pixel(0, 1).0, [255, 0, 0]); // two stops bright: clamped red
        assert_eq!(p.get_pixel(1, 1).0, [0, 0, 0]); // background
    }
}
