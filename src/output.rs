//! Image files: PNG is the tone-mapped sRGB display image, EXR is linear radiance
//! (W/(sr m^2), 32-bit float RGB) for measurement. Files are written to a temporary name
//! beside the target and renamed, so a failure never leaves a partial file.

use crate::render::FrameOutput;
use std::path::{Path, PathBuf};

/// The one error type of the output layer.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{path}: unsupported output format; use a .png (tone-mapped sRGB) or .exr (linear radiance) file name")]
    UnknownFormat { path: PathBuf },
    #[error("{path}: the directory {dir} does not exist")]
    NoDirectory { path: PathBuf, dir: PathBuf },
    #[error("{path}: could not write: {source}")]
    Write {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: could not read image: {source}")]
    Read {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Png,
    Exr,
}

pub fn format_of(path: &Path) -> Result<Format, OutputError> {
    match path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).as_deref() {
        Some("png") => Ok(Format::Png),
        Some("exr") => Ok(Format::Exr),
        _ => Err(OutputError::UnknownFormat { path: path.to_path_buf() }),
    }
}

/// Check that `path` can be written (format known, directory exists) before rendering.
pub fn check_target(path: &Path) -> Result<Format, OutputError> {
    let format = format_of(path)?;
    check_target_dir(path)?;
    Ok(format)
}

/// Check that the directory of `path` exists (any file type; reports, pictures).
pub fn check_target_dir(path: &Path) -> Result<(), OutputError> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if !dir.is_dir() {
        return Err(OutputError::NoDirectory { path: path.to_path_buf(), dir: dir.to_path_buf() });
    }
    Ok(())
}

/// Linear RGB f32 radiance of a frame (alpha dropped).
pub fn radiance_rgb(frame: &FrameOutput) -> Vec<f32> {
    frame.radiance.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect()
}

/// Write `frame` to `path` (.png or .exr), atomically.
pub fn write_frame(path: &Path, frame: &FrameOutput) -> Result<(), OutputError> {
    let format = check_target(path)?;
    let image = match format {
        Format::Png => {
            let rgb: Vec<u8> = frame.display.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
            image::DynamicImage::ImageRgb8(
                image::RgbImage::from_raw(frame.width, frame.height, rgb).expect("display buffer matches its size"),
            )
        }
        Format::Exr => image::DynamicImage::ImageRgb32F(
            image::Rgb32FImage::from_raw(frame.width, frame.height, radiance_rgb(frame))
                .expect("radiance buffer matches its size"),
        ),
    };
    write_atomic(path, format, &image)
}

/// Write linear RGB f32 radiance (`width * height * 3` values) to an EXR file, atomically.
pub fn write_exr(path: &Path, width: u32, height: u32, rgb: &[f32]) -> Result<(), OutputError> {
    check_target_dir(path)?;
    let image = image::DynamicImage::ImageRgb32F(
        image::Rgb32FImage::from_raw(width, height, rgb.to_vec()).expect("RGB buffer matches its size"),
    );
    write_atomic(path, Format::Exr, &image)
}

/// Write an RGB8 picture to a PNG file, atomically.
pub fn write_png(path: &Path, image: &image::RgbImage) -> Result<(), OutputError> {
    check_target_dir(path)?;
    write_atomic(path, Format::Png, &image::DynamicImage::ImageRgb8(image.clone()))
}

/// Write bytes (a report, a picture) to `path` atomically: a temporary sibling, then a rename.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    check_target_dir(path)?;
    let tmp = tmp_name(path);
    std::fs::write(&tmp, bytes).and_then(|_| std::fs::rename(&tmp, path)).map_err(|source| {
        let _ = std::fs::remove_file(&tmp);
        OutputError::Io { path: path.to_path_buf(), source }
    })
}

/// Write linear radiance through the renderer's display transform (exposure, tone map,
/// sRGB) to a PNG file, atomically.
pub fn write_display_png(
    path: &Path,
    image: &crate::metrics::LinearImage,
    exposure: f32,
    tonemap: crate::scene::ToneMap,
) -> Result<(), OutputError> {
    let rgb = crate::metrics::display_srgb8(image, exposure, tonemap);
    write_png(
        path,
        &image::RgbImage::from_raw(image.width, image.height, rgb).expect("display buffer matches its size"),
    )
}

fn tmp_name(path: &Path) -> PathBuf {
    let file_name = path.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
    path.with_file_name(format!(".{file_name}.{}.tmp", std::process::id()))
}

fn write_atomic(path: &Path, format: Format, image: &image::DynamicImage) -> Result<(), OutputError> {
    let tmp = tmp_name(path);
    let fmt = match format {
        Format::Png => image::ImageFormat::Png,
        Format::Exr => image::ImageFormat::OpenExr,
    };
    if let Err(source) = image.save_with_format(&tmp, fmt) {
        let _ = std::fs::remove_file(&tmp);
        return Err(OutputError::Write { path: path.to_path_buf(), source });
    }
    std::fs::rename(&tmp, path).map_err(|source| {
        let _ = std::fs::remove_file(&tmp);
        OutputError::Io { path: path.to_path_buf(), source }
    })
}

/// Linear RGB f32 image read from an EXR (or any format `image` reads, converted).
pub struct RgbImageF32 {
    pub width: u32,
    pub height: u32,
    pub data: Vec<f32>,
}

pub fn read_rgb_f32(path: &Path) -> Result<RgbImageF32, OutputError> {
    let img = image::open(path).map_err(|source| OutputError::Read { path: path.to_path_buf(), source })?;
    let rgb = img.to_rgb32f();
    Ok(RgbImageF32 { width: rgb.width(), height: rgb.height(), data: rgb.into_raw() })
}
