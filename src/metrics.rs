//! Image error metrics of a rendered image against a reference.
//!
//! Both images are linear radiance (W/(sr·m²)), read from 32-bit float EXR. The pixel metrics
//! (RMSE, relMSE) work on that linear radiance; the perceptual metrics (FLIP, SSIM) work on the
//! 8-bit display images that the renderer would show, made with [`display_srgb8`] (exposure,
//! tone curve, sRGB encoding, rounding), so they judge what a viewer sees.
//!
//! Lower is better for every metric except SSIM, where higher is better (1 = identical).
//! SSIM is computed here (Wang et al. 2004, Gaussian window on Rec. 709 luma) because the
//! `image-compare` crate neither exposes the per-pixel map in full precision nor uses the
//! standard windowed statistics; FLIP is NVIDIA's own implementation (the `nv-flip` crate).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

pub use crate::scene::ToneMap;

/// The ε of relMSE, `(test − ref)² / (ref² + ε)` (Rousselle et al. 2011).
pub const RELMSE_EPSILON: f64 = 0.01;

/// Pixels per degree of visual angle for FLIP: the FLIP paper's default viewing setup
/// (0.7 m from a 0.7 m wide 3840-pixel monitor), the same as `nv_flip::DEFAULT_PIXELS_PER_DEGREE`.
pub const FLIP_PIXELS_PER_DEGREE: f32 = 67.0;

/// SSIM constant K1 (Wang et al. 2004); C1 = (K1·L)² with L = 255.
pub const SSIM_K1: f64 = 0.01;
/// SSIM constant K2 (Wang et al. 2004); C2 = (K2·L)² with L = 255.
pub const SSIM_K2: f64 = 0.03;
/// Standard deviation, in pixels, of SSIM's Gaussian window (Wang et al. 2004).
pub const SSIM_SIGMA: f64 = 1.5;
/// Radius of SSIM's Gaussian window: 11×11 taps.
const SSIM_RADIUS: usize = 5;
/// Dynamic range L of the 8-bit display values that SSIM sees.
const SSIM_RANGE: f64 = 255.0;

/// Errors of reading and comparing images. Each names the file, or "test image" /
/// "reference image" where no path is known.
#[derive(Debug, thiserror::Error)]
pub enum MetricsError {
    /// The file could not be opened or read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The file could not be decoded as an image.
    #[error("cannot decode {}: {source}", path.display())]
    Decode {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: image::ImageError,
    },
    /// The file is an image, but not OpenEXR (so not linear radiance).
    #[error("{} is a {format} image, not OpenEXR: metrics need linear radiance", path.display())]
    NotExr {
        /// The file.
        path: PathBuf,
        /// The format that was found, e.g. "Png".
        format: String,
    },
    /// The two images differ in size.
    #[error("size mismatch: {test} is {}x{} but {reference} is {}x{}", test_size.0, test_size.1, reference_size.0, reference_size.1)]
    SizeMismatch {
        /// Name (path) of the test image.
        test: String,
        /// Width and height of the test image.
        test_size: (u32, u32),
        /// Name (path) of the reference image.
        reference: String,
        /// Width and height of the reference image.
        reference_size: (u32, u32),
    },
    /// The image holds NaN or infinite values.
    #[error(
        "{name} has {count} non-finite (NaN or Inf) value(s), the first at pixel ({x}, {y}) channel {channel}: {value}"
    )]
    NonFinite {
        /// Name (path) of the image.
        name: String,
        /// How many channel values are non-finite.
        count: u64,
        /// Column of the first non-finite pixel (row-major scan from the top-left).
        x: u32,
        /// Row of the first non-finite pixel.
        y: u32,
        /// Channel (0 = R, 1 = G, 2 = B) of the first non-finite value.
        channel: u32,
        /// The first non-finite value.
        value: f32,
    },
    /// The image has no pixels.
    #[error("{name} is empty ({width}x{height})")]
    Empty {
        /// Name (path) of the image.
        name: String,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
    },
    /// The pixel buffer's length does not match width × height × 3.
    #[error("{name} is {width}x{height} but holds {len} floats, not {}", *width as u64 * *height as u64 * 3)]
    BadBuffer {
        /// Name (path) of the image.
        name: String,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
        /// The length of its `rgb` buffer.
        len: usize,
    },
}

/// A linear-radiance RGB image.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major, top row first, 3 floats (R, G, B) per pixel.
    pub rgb: Vec<f32>,
}

impl LinearImage {
    /// An image with every pixel set to `rgb`.
    pub fn filled(width: u32, height: u32, rgb: [f32; 3]) -> Self {
        let n = width as usize * height as usize;
        Self { width, height, rgb: rgb.iter().copied().cycle().take(n * 3).collect() }
    }

    /// Number of pixels, width × height.
    pub fn pixels(&self) -> u64 {
        self.width as u64 * self.height as u64
    }

    /// Reads an OpenEXR file (any channel layout and precision the `image` crate decodes;
    /// alpha is dropped) and checks it: not empty, every value finite.
    ///
    /// Other image formats are refused ([`MetricsError::NotExr`]), since they hold
    /// display values, not radiance.
    pub fn read_exr(path: &Path) -> Result<LinearImage, MetricsError> {
        let io = |source| MetricsError::Io { path: path.to_path_buf(), source };
        let reader = image::ImageReader::open(path).map_err(io)?.with_guessed_format().map_err(io)?;
        match reader.format() {
            Some(image::ImageFormat::OpenExr) | None => {}
            Some(other) => return Err(MetricsError::NotExr { path: path.to_path_buf(), format: format!("{other:?}") }),
        }
        let decoded = reader.decode().map_err(|source| match source {
            image::ImageError::IoError(source) => MetricsError::Io { path: path.to_path_buf(), source },
            source => MetricsError::Decode { path: path.to_path_buf(), source },
        })?;
        let rgb = decoded.into_rgb32f();
        let img = LinearImage { width: rgb.width(), height: rgb.height(), rgb: rgb.into_raw() };
        img.validate(&path.display().to_string())?;
        Ok(img)
    }

    /// Checks that the image is usable for metrics: not empty, buffer length
    /// width × height × 3, every value finite. `name` names the image in the error.
    pub fn validate(&self, name: &str) -> Result<(), MetricsError> {
        if self.width == 0 || self.height == 0 {
            return Err(MetricsError::Empty { name: name.to_owned(), width: self.width, height: self.height });
        }
        if self.rgb.len() as u64 != self.pixels() * 3 {
            return Err(MetricsError::BadBuffer {
                name: name.to_owned(),
                width: self.width,
                height: self.height,
                len: self.rgb.len(),
            });
        }
        let count = self.rgb.iter().filter(|v| !v.is_finite()).count() as u64;
        if let Some(first) = self.rgb.iter().position(|v| !v.is_finite()) {
            let pixel = (first / 3) as u64;
            return Err(MetricsError::NonFinite {
                name: name.to_owned(),
                count,
                x: (pixel % self.width as u64) as u32,
                y: (pixel / self.width as u64) as u32,
                channel: (first % 3) as u32,
                value: self.rgb[first],
            });
        }
        Ok(())
    }
}

fn tonemap_aces(x: f32) -> f32 {
    let x = x * 0.6;
    const A: f32 = 2.51;
    const B: f32 = 0.03;
    const C: f32 = 2.43;
    const D: f32 = 0.59;
    const E: f32 = 0.14;
    ((x * (A * x + B)) / (x * (C * x + D) + E)).clamp(0.0, 1.0)
}

fn tonemap(x: f32, mode: ToneMap) -> f32 {
    let x = x.max(0.0);
    match mode {
        ToneMap::Aces => tonemap_aces(x),
        ToneMap::Reinhard => x / (1.0 + x),
        ToneMap::Clamp => x.clamp(0.0, 1.0),
    }
}

fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.0031308 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Middle grey: the display value that an image's log-average luminance is exposed to by
/// `render.exposure = "auto"` (Reinhard's key value).
pub const AUTO_EXPOSURE_KEY: f32 = 0.18;

/// The exposure (EV stops) that takes the log-average luminance (Rec. 709 weights) of the
/// image's lit pixels to [`AUTO_EXPOSURE_KEY`]: `log2(key) - mean(log2 Y)` over the pixels
/// with Y > 0 (black background and unlit pixels left out), clamped to -64..=64. An image with
/// no lit pixel gets 0.
pub fn auto_exposure(img: &LinearImage) -> f32 {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for px in img.rgb.chunks_exact(3) {
        let y = 0.2126 * px[0] + 0.7152 * px[1] + 0.0722 * px[2];
        if y.is_finite() && y > 0.0 {
            sum += f64::from(y).log2();
            n += 1;
        }
    }
    if n == 0 {
        return 0.0;
    }
    (f64::from(AUTO_EXPOSURE_KEY).log2() - sum / n as f64).clamp(-64.0, 64.0) as f32
}

/// The exposure a display image of `img` gets under `settings`: `render.exposure`, or the
/// image's own [`auto_exposure`] where it is "auto".
pub fn display_exposure(settings: &crate::scene::RenderSettings, img: &LinearImage) -> f32 {
    if settings.exposure_auto {
        settings.exposure + auto_exposure(img)
    } else {
        settings.exposure
    }
}

/// The renderer's display transform, in f32 like the GLSL: per channel
/// `linear_to_srgb(tonemap(radiance · 2^exposure))`, quantised to 8 bits by rounding to
/// nearest, `(v · 255 + 0.5) as u8`. Returns RGB8, 3 bytes per pixel, in the image's order.
///
/// A pixel with any non-finite channel becomes magenta (255, 0, 255), as in the renderer.
pub fn display_srgb8(img: &LinearImage, exposure: f32, tonemap_mode: ToneMap) -> Vec<u8> {
    display_unrounded(img, exposure, tonemap_mode).into_iter().map(|v| (v + 0.5) as u8).collect()
}

/// [`display_srgb8`] before its rounding: each value times 255 (magenta for non-finite pixels).
pub fn display_unrounded(img: &LinearImage, exposure: f32, tonemap_mode: ToneMap) -> Vec<f32> {
    let scale = exposure.exp2();
    let mut out = Vec::with_capacity(img.rgb.len());
    for px in img.rgb.chunks_exact(3) {
        if px.iter().any(|v| !v.is_finite()) {
            out.extend_from_slice(&[255.0, 0.0, 255.0]);
            continue;
        }
        out.extend(px.iter().map(|&v| linear_to_srgb(tonemap(v * scale, tonemap_mode)) * 255.0));
    }
    out
}

/// Distribution summary of a per-pixel metric map.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Arithmetic mean (accumulated in f64).
    pub mean: f64,
    /// Median (nearest-rank 50th percentile).
    pub p50: f64,
    /// Nearest-rank 90th percentile.
    pub p90: f64,
    /// Nearest-rank 95th percentile.
    pub p95: f64,
    /// Nearest-rank 99th percentile.
    pub p99: f64,
    /// Largest value.
    pub max: f64,
}

impl Summary {
    /// Summarises `values`. Percentiles use the nearest-rank rule on an ascending sorted copy:
    /// the p-th percentile of n values is the value of rank ⌈p/100 · n⌉ (1-based), so it is
    /// always one of the values (for 1..=100, p90 = 90). Sorting uses `f32::total_cmp`; a NaN
    /// input makes the mean NaN. An empty slice gives NaN everywhere.
    pub fn of(values: &[f32]) -> Summary {
        if values.is_empty() {
            return Summary {
                mean: f64::NAN,
                p50: f64::NAN,
                p90: f64::NAN,
                p95: f64::NAN,
                p99: f64::NAN,
                max: f64::NAN,
            };
        }
        let mut sorted = values.to_vec();
        sorted.sort_unstable_by(f32::total_cmp);
        let n = sorted.len();
        let rank = |p: usize| -> f64 {
            // ⌈p·n/100⌉ in integers, at least 1.
            let r = (p * n).div_ceil(100).max(1);
            sorted[r - 1] as f64
        };
        let mean = sorted.iter().map(|&v| v as f64).sum::<f64>() / n as f64;
        Summary { mean, p50: rank(50), p90: rank(90), p95: rank(95), p99: rank(99), max: sorted[n - 1] as f64 }
    }
}

/// Error metrics of a test image against a reference.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// Root mean squared error on linear radiance:
    /// `sqrt(mean over pixels and the 3 channels of (test − ref)²)`. Lower is better.
    pub rmse: f64,
    /// Relative MSE on linear radiance: `mean over pixels and channels of
    /// (test − ref)² / (ref² + ε)`, ε = [`RELMSE_EPSILON`]. Lower is better.
    pub relmse: f64,
    /// LDR-FLIP (NVIDIA's ꟻLIP, via `nv-flip`) between the two display images of
    /// [`display_srgb8`], at [`FLIP_PIXELS_PER_DEGREE`]: summary of the per-pixel error map,
    /// each value in [0, 1]. Lower is better; the mean is FLIP's headline number.
    pub flip: Summary,
    /// SSIM (Wang et al. 2004) of the luma of the two display images: summary of the
    /// per-pixel SSIM map; its mean is the usual mean SSIM. HIGHER is better (1 = identical;
    /// values can be negative). Luma is Rec. 709 `0.2126 R' + 0.7152 G' + 0.0722 B'` of the
    /// 8-bit sRGB values (not rounded), L = 255, K1 = [`SSIM_K1`], K2 = [`SSIM_K2`], 11×11
    /// Gaussian window of σ = [`SSIM_SIGMA`], population (co)variances, one value per pixel
    /// with clamp-to-edge borders (no 'valid' crop and no automatic downsampling).
    ///
    /// As for the other metrics the percentiles are of the upper tail (p90 = the value 90 % of
    /// pixels are at or below), so for SSIM they describe the best pixels and `max` is the
    /// best pixel; the mean is the meaningful number.
    pub ssim: Summary,
    /// Number of pixels compared.
    pub pixels: u64,
    /// Mean radiance of the test image (over pixels and channels): with `reference_mean`, how
    /// much energy the test image gains or loses overall.
    pub test_mean: f64,
    pub reference_mean: f64,
    /// Salt-and-pepper noise: the fraction of lit pixels of each image ([`outlier_fraction`])
    /// whose luminance differs from the median of its 3 x 3 neighbourhood by more than half
    /// of it. An aliasing image (unfiltered bump maps, issue 42) has many more than its
    /// converged reference; a noisy reference has some too, hence both.
    #[serde(default)]
    pub test_outliers: f64,
    #[serde(default)]
    pub reference_outliers: f64,
}

/// The fraction of lit pixels (3 x 3 median of luminance above 0) whose luminance differs
/// from that median by more than half of it (edges clamped).
pub fn outlier_fraction(img: &LinearImage) -> f64 {
    let (w, h) = (img.width as i64, img.height as i64);
    let y = |x: i64, yy: i64| {
        let i = (yy.clamp(0, h - 1) * w + x.clamp(0, w - 1)) as usize * 3;
        0.2126 * img.rgb[i] + 0.7152 * img.rgb[i + 1] + 0.0722 * img.rgb[i + 2]
    };
    let (mut lit, mut far) = (0u64, 0u64);
    for py in 0..h {
        for px in 0..w {
            let mut around: [f32; 9] = std::array::from_fn(|k| y(px + k as i64 % 3 - 1, py + k as i64 / 3 - 1));
            around.sort_by(f32::total_cmp);
            let median = around[4];
            if median > 0.0 {
                lit += 1;
                far += u64::from((y(px, py) - median).abs() > 0.5 * median);
            }
        }
    }
    if lit == 0 {
        0.0
    } else {
        far as f64 / lit as f64
    }
}

fn check_pair(
    test: &LinearImage,
    test_name: &str,
    reference: &LinearImage,
    ref_name: &str,
) -> Result<(), MetricsError> {
    test.validate(test_name)?;
    reference.validate(ref_name)?;
    if (test.width, test.height) != (reference.width, reference.height) {
        return Err(MetricsError::SizeMismatch {
            test: test_name.to_owned(),
            test_size: (test.width, test.height),
            reference: ref_name.to_owned(),
            reference_size: (reference.width, reference.height),
        });
    }
    Ok(())
}

/// Computes every metric of `test` against `reference` (see [`Comparison`] for the
/// definitions), with the display transform at `exposure` (EV) and `tonemap_mode` for the
/// perceptual metrics. Both images must be non-empty, the same size and finite.
pub fn compare(
    test: &LinearImage,
    reference: &LinearImage,
    exposure: f32,
    tonemap_mode: ToneMap,
) -> Result<Comparison, MetricsError> {
    check_pair(test, "test image", reference, "reference image")?;
    Ok(compare_checked(test, reference, exposure, tonemap_mode))
}

/// Reads two EXR files with [`LinearImage::read_exr`] and [`compare`]s them; errors name
/// the files.
pub fn compare_files(
    test: &Path,
    reference: &Path,
    exposure: f32,
    tonemap_mode: ToneMap,
) -> Result<Comparison, MetricsError> {
    let t = LinearImage::read_exr(test)?;
    let r = LinearImage::read_exr(reference)?;
    compare_named(&t, &test.display().to_string(), &r, &reference.display().to_string(), exposure, tonemap_mode)
}

/// [`compare`] with the images' names (paths) for the errors.
pub fn compare_named(
    test: &LinearImage,
    test_name: &str,
    reference: &LinearImage,
    ref_name: &str,
    exposure: f32,
    tonemap_mode: ToneMap,
) -> Result<Comparison, MetricsError> {
    check_pair(test, test_name, reference, ref_name)?;
    Ok(compare_checked(test, reference, exposure, tonemap_mode))
}

fn compare_checked(test: &LinearImage, reference: &LinearImage, exposure: f32, tonemap_mode: ToneMap) -> Comparison {
    let mut se = 0.0f64;
    let mut rel = 0.0f64;
    let (mut sum_t, mut sum_r) = (0.0f64, 0.0f64);
    for (&t, &r) in test.rgb.iter().zip(&reference.rgb) {
        sum_t += t as f64;
        sum_r += r as f64;
        let d = t as f64 - r as f64;
        se += d * d;
        rel += d * d / ((r as f64) * (r as f64) + RELMSE_EPSILON);
    }
    let n = test.rgb.len() as f64;
    let test_display = display_srgb8(test, exposure, tonemap_mode);
    let ref_display = display_srgb8(reference, exposure, tonemap_mode);
    let flip = flip_values(&test_display, &ref_display, test.width, test.height);
    let ssim = ssim_map(&luma(&test_display), &luma(&ref_display), test.width as usize, test.height as usize);
    Comparison {
        rmse: (se / n).sqrt(),
        relmse: rel / n,
        flip: Summary::of(&flip.to_vec()),
        ssim: Summary::of(&ssim),
        pixels: test.pixels(),
        test_mean: sum_t / n,
        reference_mean: sum_r / n,
        test_outliers: outlier_fraction(test),
        reference_outliers: outlier_fraction(reference),
    }
}

/// FLIP error map (values in [0, 1], one per pixel) of two RGB8 display images.
fn flip_values(test: &[u8], reference: &[u8], width: u32, height: u32) -> nv_flip::FlipImageFloat {
    let r = nv_flip::FlipImageRgb8::with_data(width, height, reference);
    let t = nv_flip::FlipImageRgb8::with_data(width, height, test);
    nv_flip::flip(r, t, FLIP_PIXELS_PER_DEGREE)
}

/// The FLIP error map of `test` against `reference` (display transform as in [`compare`]),
/// coloured with FLIP's magma look-up table (black = no error, light yellow = 1), for
/// writing a diff picture.
pub fn flip_error_map(
    test: &LinearImage,
    reference: &LinearImage,
    exposure: f32,
    tonemap_mode: ToneMap,
) -> Result<image::RgbImage, MetricsError> {
    check_pair(test, "test image", reference, "reference image")?;
    let map = flip_values(
        &display_srgb8(test, exposure, tonemap_mode),
        &display_srgb8(reference, exposure, tonemap_mode),
        test.width,
        test.height,
    );
    let coloured = map.apply_color_lut(&nv_flip::magma_lut());
    Ok(image::RgbImage::from_raw(coloured.width(), coloured.height(), coloured.to_vec())
        .expect("nv-flip returns width * height * 3 bytes"))
}

/// Rec. 709 luma of RGB8 values, unrounded, in [0, 255].
fn luma(rgb8: &[u8]) -> Vec<f64> {
    rgb8.chunks_exact(3).map(|p| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64).collect()
}

/// Separable Gaussian blur of `src` (width × height) with clamp-to-edge borders.
fn blur(src: &[f64], width: usize, height: usize, kernel: &[f64]) -> Vec<f64> {
    let r = kernel.len() / 2;
    // Horizontal pass over an edge-replicated copy of each row.
    let mut tmp = vec![0.0; src.len()];
    let mut padded = vec![0.0; width + 2 * r];
    for (row, out) in src.chunks_exact(width).zip(tmp.chunks_exact_mut(width)) {
        padded[..r].fill(row[0]);
        padded[r..r + width].copy_from_slice(row);
        padded[r + width..].fill(row[width - 1]);
        for (x, o) in out.iter_mut().enumerate() {
            *o = padded[x..x + kernel.len()].iter().zip(kernel).map(|(v, w)| v * w).sum();
        }
    }
    // Vertical pass: whole rows at a time.
    let mut out = vec![0.0; src.len()];
    for (y, out_row) in out.chunks_exact_mut(width).enumerate() {
        for (k, w) in kernel.iter().enumerate() {
            let sy = (y + k).saturating_sub(r).min(height - 1);
            for (o, v) in out_row.iter_mut().zip(&tmp[sy * width..(sy + 1) * width]) {
                *o += w * v;
            }
        }
    }
    out
}

/// Per-pixel SSIM map of two luma planes in [0, 255] (see [`Comparison::ssim`]).
fn ssim_map(a: &[f64], b: &[f64], width: usize, height: usize) -> Vec<f32> {
    let kernel: Vec<f64> = {
        let raw: Vec<f64> = (0..=2 * SSIM_RADIUS)
            .map(|i| {
                let d = i as f64 - SSIM_RADIUS as f64;
                (-d * d / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp()
            })
            .collect();
        let sum: f64 = raw.iter().sum();
        raw.iter().map(|w| w / sum).collect()
    };
    let c1 = (SSIM_K1 * SSIM_RANGE).powi(2);
    let c2 = (SSIM_K2 * SSIM_RANGE).powi(2);
    let product = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(p, q)| p * q).collect::<Vec<f64>>();
    let mu_a = blur(a, width, height, &kernel);
    let mu_b = blur(b, width, height, &kernel);
    let aa = blur(&product(a, a), width, height, &kernel);
    let bb = blur(&product(b, b), width, height, &kernel);
    let ab = blur(&product(a, b), width, height, &kernel);
    (0..a.len())
        .map(|i| {
            let (ma, mb) = (mu_a[i], mu_b[i]);
            let var_a = aa[i] - ma * ma;
            let var_b = bb[i] - mb * mb;
            let cov = ab[i] - ma * mb;
            (((2.0 * ma * mb + c1) * (2.0 * cov + c2)) / ((ma * ma + mb * mb + c1) * (var_a + var_b + c2))) as f32
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(width: u32, height: u32, rgb: [f32; 3]) -> LinearImage {
        LinearImage { width, height, rgb: (0..width * height).flat_map(|_| rgb).collect() }
    }

    #[test]
    fn auto_exposure_takes_the_log_average_to_middle_grey() {
        // Luminance 0.72 everywhere: two stops over 0.18.
        assert!((auto_exposure(&flat(4, 4, [0.72; 3])) + 2.0).abs() < 1e-5);
        // Half the pixels at 0.045 and half at 0.72: log-average 0.18, EV 0.
        let mut img = flat(4, 4, [0.72; 3]);
        img.rgb[..24].iter_mut().for_each(|v| *v = 0.045);
        assert!(auto_exposure(&img).abs() < 1e-5);
        // Black pixels (background) are left out; an all-black image gets 0.
        img.rgb.extend([0.0; 30]);
        assert!(auto_exposure(&img).abs() < 1e-5);
        assert_eq!(auto_exposure(&flat(4, 4, [0.0; 3])), 0.0);
        // Scaling the radiance by 2^k moves the exposure by -k.
        let scaled = LinearImage { rgb: img.rgb.iter().map(|v| v * 8.0).collect(), ..img.clone() };
        assert!((auto_exposure(&scaled) - (auto_exposure(&img) - 3.0)).abs() < 1e-4);
        // Clamped to the range render.exposure accepts.
        assert_eq!(auto_exposure(&flat(1, 1, [1e-30; 3])), 64.0);
    }

    #[test]
    fn isolated_pixels_count_as_outliers_and_edges_do_not() {
        let mut speckled = flat(8, 8, [0.5; 3]);
        for i in [9, 30, 52] {
            speckled.rgb[i * 3..i * 3 + 3].copy_from_slice(&[0.0; 3]);
        }
        assert!(close(outlier_fraction(&speckled), 3.0 / 64.0, 1e-9));
        // A step edge and a smooth ramp have none; black pixels are not lit.
        let edge = img(8, 8, (0..64).flat_map(|i| [if i % 8 < 4 { 0.1 } else { 1.0 }; 3]).collect());
        assert_eq!(outlier_fraction(&edge), 0.0);
        assert_eq!(outlier_fraction(&flat(4, 4, [0.0; 3])), 0.0);
    }

    fn img(width: u32, height: u32, rgb: Vec<f32>) -> LinearImage {
        LinearImage { width, height, rgb }
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn rmse_relmse_by_hand() {
        // 2x2, reference all 1.0; test has one channel of one pixel at 2.0: 12 values, one
        // squared error of 1. mse = 1/12, rmse = sqrt(1/12) = 0.288675...; relmse =
        // (1 / (1 + 0.01)) / 12 = 0.0825082...
        let reference = LinearImage::filled(2, 2, [1.0; 3]);
        let mut test = reference.clone();
        test.rgb[4] = 2.0;
        let c = compare(&test, &reference, 0.0, ToneMap::Aces).unwrap();
        assert!(close(c.rmse, (1.0f64 / 12.0).sqrt(), 1e-12), "{}", c.rmse);
        assert!(close(c.relmse, 1.0 / 1.01 / 12.0, 1e-12), "{}", c.relmse);
        assert_eq!(c.pixels, 4);

        // Reference 0 everywhere except one channel of 0.5; test is 0.1 everywhere (4x4 = 48
        // values). 47 values err 0.1: se 0.01 each, rel 0.01/0.01 = 1 each; one errs -0.4:
        // se 0.16, rel 0.16/(0.25+0.01) = 0.615384...
        // mse = (47·0.01 + 0.16)/48 = 0.63/48 = 0.013125, rmse = 0.114564...
        // relmse = (47 + 0.16/0.26)/48 = 47.615384.../48 = 0.991987...
        let mut reference = LinearImage::filled(4, 4, [0.0; 3]);
        reference.rgb[17] = 0.5;
        let test = LinearImage::filled(4, 4, [0.1; 3]);
        let c = compare(&test, &reference, 0.0, ToneMap::Clamp).unwrap();
        // 0.1 is not exact in f32, so the tolerance is loose.
        assert!(close(c.rmse, 0.013125f64.sqrt(), 1e-7), "{}", c.rmse);
        assert!(close(c.relmse, (47.0 + 0.16 / 0.26) / 48.0, 1e-6), "{}", c.relmse);
        assert_eq!(c.pixels, 16);
    }

    #[test]
    fn identical_images_are_perfect() {
        let mut reference = LinearImage::filled(4, 4, [0.2, 0.5, 1.5]);
        for (i, v) in reference.rgb.iter_mut().enumerate() {
            *v *= 1.0 + (i % 7) as f32 * 0.3;
        }
        for mode in [ToneMap::Aces, ToneMap::Reinhard, ToneMap::Clamp] {
            let c = compare(&reference, &reference, 0.5, mode).unwrap();
            assert_eq!(c.rmse, 0.0);
            assert_eq!(c.relmse, 0.0);
            assert!(c.flip.mean.abs() < 1e-6 && c.flip.max.abs() < 1e-6, "{:?}", c.flip);
            assert!(close(c.ssim.mean, 1.0, 1e-6) && close(c.ssim.p50, 1.0, 1e-6), "{:?}", c.ssim);
        }
    }

    #[test]
    fn display_transform_by_hand() {
        let px = |v: f32, ev: f32, mode| display_srgb8(&img(1, 1, vec![v, v, v]), ev, mode);
        for mode in [ToneMap::Aces, ToneMap::Reinhard, ToneMap::Clamp] {
            assert_eq!(px(0.0, 0.0, mode), [0, 0, 0]);
            // Negative radiance is clamped to 0 before the curve.
            assert_eq!(px(-3.0, 0.0, mode), [0, 0, 0]);
        }
        assert_eq!(px(1.0, 0.0, ToneMap::Clamp), [255; 3]);
        assert_eq!(px(7.0, 0.0, ToneMap::Clamp), [255; 3]);
        // sRGB(0.5) = 1.055·0.5^(1/2.4) − 0.055 = 1.055·0.749154 − 0.055 = 0.735357;
        // ·255 = 187.516, +0.5 → 188.
        assert_eq!(px(0.5, 0.0, ToneMap::Clamp), [188; 3]);
        // Exposure: 0.25 · 2^2 = 1.0 → 255; 1.0 · 2^-1 = 0.5 → 188.
        assert_eq!(px(0.25, 2.0, ToneMap::Clamp), [255; 3]);
        assert_eq!(px(1.0, -1.0, ToneMap::Clamp), [188; 3]);
        // Reinhard: 1/(1+1) = 0.5 → 188.
        assert_eq!(px(1.0, 0.0, ToneMap::Reinhard), [188; 3]);
        // Linear segment: 0.002 ≤ 0.0031308 → 0.002·12.92 = 0.02584; ·255 = 6.589, +0.5 → 7.
        assert_eq!(px(0.002, 0.0, ToneMap::Clamp), [7; 3]);
        // ACES of 1.0: x = 0.6; (0.6·(2.51·0.6 + 0.03)) / (0.6·(2.43·0.6 + 0.59) + 0.14)
        // = 0.9216 / 1.3688 = 0.673291; sRGB: 0.673291^(1/2.4) = 0.848040,
        // ·1.055 − 0.055 = 0.839685; ·255 = 214.120, +0.5 → 214.
        assert_eq!(px(1.0, 0.0, ToneMap::Aces), [214; 3]);
        // ACES saturates: at x = 1000·0.6 the curve is 2.51/2.43 > 1, clamped → 255.
        assert_eq!(px(1000.0, 0.0, ToneMap::Aces), [255; 3]);
        // Channels are independent, and non-finite pixels turn magenta like the renderer.
        let two = img(2, 1, vec![0.0, 0.5, 1.0, f32::NAN, 0.0, 0.0]);
        assert_eq!(display_srgb8(&two, 0.0, ToneMap::Clamp), [0, 188, 255, 255, 0, 255]);
    }

    #[test]
    fn summary_nearest_rank() {
        let v: Vec<f32> = (1..=100).map(|i| i as f32).collect();
        let s = Summary::of(&v);
        assert_eq!((s.p50, s.p90, s.p95, s.p99, s.max), (50.0, 90.0, 95.0, 99.0, 100.0));
        assert!(close(s.mean, 50.5, 1e-12));
        // Order does not matter.
        let rev: Vec<f32> = v.iter().rev().copied().collect();
        assert_eq!(Summary::of(&rev), s);
        // 10 values 1..=10: p50 rank ⌈5⌉ = 5, p90 rank 9, p95 rank ⌈9.5⌉ = 10, p99 rank 10.
        let s = Summary::of(&[10.0, 9.0, 8.0, 7.0, 6.0, 5.0, 4.0, 3.0, 2.0, 1.0]);
        assert_eq!((s.p50, s.p90, s.p95, s.p99, s.max), (5.0, 9.0, 10.0, 10.0, 10.0));
        // One value is every percentile.
        let s = Summary::of(&[0.25]);
        assert_eq!((s.mean, s.p50, s.p99, s.max), (0.25, 0.25, 0.25, 0.25));
        assert!(Summary::of(&[]).mean.is_nan());
    }

    #[test]
    fn result_types_are_serde() {
        fn serde<T: Serialize + for<'de> Deserialize<'de>>() {}
        serde::<Summary>();
        serde::<Comparison>();
        serde::<ToneMap>();
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let a = LinearImage::filled(64, 64, [1.0; 3]);
        let b = LinearImage::filled(32, 32, [1.0; 3]);
        let e = compare(&a, &b, 0.0, ToneMap::Aces).unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, MetricsError::SizeMismatch { .. }), "{msg}");
        assert!(msg.contains("test image is 64x64 but reference image is 32x32"), "{msg}");
        assert!(flip_error_map(&a, &b, 0.0, ToneMap::Aces).is_err());
    }

    #[test]
    fn non_finite_and_empty_are_errors() {
        let good = LinearImage::filled(2, 2, [1.0; 3]);
        let mut bad = good.clone();
        bad.rgb[7] = f32::NAN; // pixel 2 = (0, 1), channel 1
        bad.rgb[11] = f32::INFINITY;
        let msg = compare(&good, &bad, 0.0, ToneMap::Aces).unwrap_err().to_string();
        assert!(msg.contains("reference image") && msg.contains("NaN") && msg.contains("non-finite"), "{msg}");
        assert!(msg.contains("2 non-finite") && msg.contains("pixel (0, 1) channel 1"), "{msg}");
        let msg = compare(&bad, &good, 0.0, ToneMap::Aces).unwrap_err().to_string();
        assert!(msg.starts_with("test image has 2 non-finite"), "{msg}");

        let empty = img(0, 0, vec![]);
        let msg = compare(&empty, &empty, 0.0, ToneMap::Aces).unwrap_err().to_string();
        assert!(msg.contains("empty"), "{msg}");
        let short = img(2, 2, vec![0.0; 11]);
        let msg = compare(&short, &good, 0.0, ToneMap::Aces).unwrap_err().to_string();
        assert!(msg.contains("11 floats, not 12"), "{msg}");
    }

    #[test]
    fn flip_black_vs_white_is_large() {
        let black = LinearImage::filled(4, 4, [0.0; 3]);
        let white = LinearImage::filled(4, 4, [1.0; 3]);
        let c = compare(&white, &black, 0.0, ToneMap::Clamp).unwrap();
        assert!(c.flip.mean > 0.5, "{:?}", c.flip);
        assert!(c.flip.max <= 1.0);
        // SSIM of constant planes has no structure term: (2·0·255 + C1) / (0 + 255² + C1)
        // with C1 = (0.01·255)² = 6.5025 → 6.5025 / 65031.5025 = 0.000099990...
        let expect = 6.5025 / (255.0f64 * 255.0 + 6.5025);
        assert!(close(c.ssim.mean, expect, 1e-7), "{:?}", c.ssim);
        assert!(close(c.rmse, 1.0, 1e-12) && close(c.relmse, 100.0, 1e-9), "{c:?}");
    }

    #[test]
    fn flip_and_ssim_grow_with_perturbation() {
        // 16x16 grey ramp, and a growing bright square added to its middle.
        let (w, h) = (16u32, 16u32);
        let mut reference = LinearImage::filled(w, h, [0.0; 3]);
        for (i, v) in reference.rgb.iter_mut().enumerate() {
            *v = 0.05 + 0.4 * ((i / 3) as u32 % w) as f32 / w as f32;
        }
        let mut last = compare(&reference, &reference, 0.0, ToneMap::Aces).unwrap();
        for step in 1..=6 {
            let mut test = reference.clone();
            for y in 6..10 {
                for x in 6..10 {
                    for c in 0..3 {
                        test.rgb[((y * w + x) * 3 + c) as usize] += 0.1 * step as f32;
                    }
                }
            }
            let c = compare(&test, &reference, 0.0, ToneMap::Aces).unwrap();
            assert!(c.flip.mean > last.flip.mean, "step {step}: {:?} vs {:?}", c.flip, last.flip);
            assert!(c.flip.max > last.flip.max, "step {step}: {:?} vs {:?}", c.flip, last.flip);
            assert!(c.ssim.mean < last.ssim.mean, "step {step}: {:?} vs {:?}", c.ssim, last.ssim);
            assert!(c.rmse > last.rmse && c.relmse > last.relmse);
            last = c;
        }
    }

    #[test]
    fn ssim_of_constant_planes_by_hand() {
        // Constant planes 0 and 5: variances 0, so SSIM = C1 / (25 + C1) = 6.5025 / 31.5025 = 0.206412...
        let m = ssim_map(&[0.0; 9], &[5.0; 9], 3, 3);
        assert!(m.iter().all(|&v| close(v as f64, 6.5025 / 31.5025, 1e-6)), "{m:?}");
        // Symmetric in its arguments, and 1 for identical planes with structure.
        let a: Vec<f64> = (0..25).map(|i| (i * 37 % 11) as f64 * 20.0).collect();
        let b: Vec<f64> = a.iter().map(|v| 255.0 - v).collect();
        assert_eq!(ssim_map(&a, &b, 5, 5), ssim_map(&b, &a, 5, 5));
        assert!(ssim_map(&a, &a, 5, 5).iter().all(|&v| close(v as f64, 1.0, 1e-6)));
        // Inverted structure: negative covariance gives negative SSIM.
        assert!(ssim_map(&a, &b, 5, 5).iter().all(|&v| v < 0.0));
    }

    #[test]
    fn flip_error_map_is_magma() {
        let black = LinearImage::filled(4, 2, [0.0; 3]);
        let white = LinearImage::filled(4, 2, [1.0; 3]);
        let same = flip_error_map(&black, &black, 0.0, ToneMap::Clamp).unwrap();
        assert_eq!(same.dimensions(), (4, 2));
        let lut = nv_flip::magma_lut().to_vec();
        // Zero error is the first magma entry (near black).
        assert!(same.pixels().all(|p| p.0 == [lut[0], lut[1], lut[2]]), "{:?}", same.get_pixel(0, 0));
        let diff = flip_error_map(&white, &black, 0.0, ToneMap::Clamp).unwrap();
        let bright = |p: &image::Rgb<u8>| p.0.iter().map(|&c| c as u32).sum::<u32>();
        assert!(bright(diff.get_pixel(0, 0)) > bright(same.get_pixel(0, 0)) + 200);
    }

    #[test]
    fn read_exr_round_trip_and_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("small.exr");
        let values: Vec<f32> = (0..2 * 3 * 3).map(|i| i as f32 * 0.37 - 1.0).collect();
        image::Rgb32FImage::from_raw(3, 2, values.clone()).unwrap().save(&path).unwrap();
        let back = LinearImage::read_exr(&path).unwrap();
        assert_eq!((back.width, back.height), (3, 2));
        assert_eq!(back.rgb, values);

        // RGBA: alpha is dropped.
        let rgba_path = dir.path().join("rgba.exr");
        let rgba: Vec<f32> = (0..4).flat_map(|i| [i as f32, 2.0 * i as f32, 0.5, 0.25]).collect();
        image::Rgba32FImage::from_raw(2, 2, rgba).unwrap().save(&rgba_path).unwrap();
        let back = LinearImage::read_exr(&rgba_path).unwrap();
        assert_eq!(back.rgb, (0..4).flat_map(|i| [i as f32, 2.0 * i as f32, 0.5]).collect::<Vec<_>>());

        // compare_files names the files in a size mismatch.
        let c = compare_files(&path, &path, 0.0, ToneMap::Aces).unwrap();
        assert_eq!(c.rmse, 0.0);
        let msg = compare_files(&path, &rgba_path, 0.0, ToneMap::Aces).unwrap_err().to_string();
        assert!(msg.contains("small.exr is 3x2 but") && msg.contains("rgba.exr is 2x2"), "{msg}");

        // A NaN in the file is an error naming the file.
        let nan_path = dir.path().join("nan.exr");
        image::Rgb32FImage::from_raw(1, 1, vec![0.0, f32::NAN, 0.0]).unwrap().save(&nan_path).unwrap();
        let msg = LinearImage::read_exr(&nan_path).unwrap_err().to_string();
        assert!(msg.contains("nan.exr") && msg.contains("NaN"), "{msg}");

        let missing = dir.path().join("missing.exr");
        let e = LinearImage::read_exr(&missing).unwrap_err();
        assert!(matches!(e, MetricsError::Io { .. }) && e.to_string().contains("missing.exr"), "{e}");

        let garbage = dir.path().join("garbage.exr");
        std::fs::write(&garbage, b"this is not an image at all, just some bytes").unwrap();
        let e = LinearImage::read_exr(&garbage).unwrap_err();
        assert!(e.to_string().contains("garbage.exr"), "{e}");

        let png = dir.path().join("display.png");
        image::RgbImage::new(2, 2).save(&png).unwrap();
        let e = LinearImage::read_exr(&png).unwrap_err();
        assert!(matches!(e, MetricsError::NotExr { .. }) && e.to_string().contains("display.png"), "{e}");
    }
}
