//! A capture: the frame as PNG and EXR (exactly what `dvsgi render` writes), the window as
//! shown (UI included) as PNG, and the settings as a scene file, written all or none.

use crate::render::FrameOutput;
use ash::vk;
use std::path::{Path, PathBuf};

/// The window's pixels as read back from its swapchain image.
pub struct WindowPixels {
    pub width: u32,
    pub height: u32,
    pub format: vk::Format,
    pub bytes: Vec<u8>,
}

impl WindowPixels {
    /// As an RGB image (BGRA swapchains swizzled).
    fn rgb(&self) -> image::RgbImage {
        let bgra = matches!(self.format, vk::Format::B8G8R8A8_SRGB | vk::Format::B8G8R8A8_UNORM);
        let rgb = self
            .bytes
            .chunks_exact(4)
            .flat_map(|p| if bgra { [p[2], p[1], p[0]] } else { [p[0], p[1], p[2]] })
            .collect();
        image::RgbImage::from_raw(self.width, self.height, rgb).expect("4 bytes per pixel read back")
    }
}

/// `STEM` with `suffix` appended to its file name (`out/a` + `.png` = `out/a.png`).
pub fn with_suffix(stem: &Path, suffix: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// Write STEM.png, STEM.exr, STEM.toml and (if given: the surface lets its images be read)
/// STEM-window.png; the paths written.
pub fn write(
    stem: &Path,
    frame: &FrameOutput,
    window: Option<&WindowPixels>,
    scene: &str,
) -> crate::Result<Vec<PathBuf>> {
    let png = with_suffix(stem, ".png");
    let exr = with_suffix(stem, ".exr");
    let toml = with_suffix(stem, ".toml");
    let mut files = vec![
        (png.clone(), crate::output::encode_frame(&png, frame)?),
        (exr.clone(), crate::output::encode_frame(&exr, frame)?),
        (toml.clone(), scene.as_bytes().to_vec()),
    ];
    if let Some(w) = window {
        let path = with_suffix(stem, "-window.png");
        files.push((path.clone(), crate::output::encode_png(&path, &w.rgb())?));
    }
    let refs: Vec<(&Path, Vec<u8>)> = files.iter().map(|(p, b)| (p.as_path(), b.clone())).collect();
    crate::cli::write_outputs(&refs)?;
    Ok(files.into_iter().map(|(p, _)| p).collect())
}
