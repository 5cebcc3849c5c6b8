//! Image files: PNG is the tone-mapped sRGB display image, EXR is linear radiance
//! (W/(sr m^2), 32-bit float RGB) for measurement. Every output (images, reports, pictures,
//! CSV) is encoded in memory, written to a temporary name beside its target, flushed and
//! synced to the disk, and only then renamed into place, so a full disk or any other write
//! error fails the command and never leaves a partial or truncated file. A command with
//! several outputs writes all of them or none ([`write_all`]).

use crate::render::FrameOutput;
use std::path::{Path, PathBuf};

/// The one error type of the output layer.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{path}: unsupported output format; use a .png (tone-mapped sRGB) or .exr (linear radiance) file name")]
    UnknownFormat { path: PathBuf },
    #[error("{path}: the directory {dir} does not exist")]
    NoDirectory { path: PathBuf, dir: PathBuf },
    #[error("{path} is a directory; name a file")]
    IsDirectory { path: PathBuf },
    #[error("{path}: cannot create files in {dir}; choose a directory you can write to")]
    NotWritable {
        path: PathBuf,
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{second} and {first} are the same file; give each output its own name")]
    SameFile { first: PathBuf, second: PathBuf },
    #[error("{path}: could not encode the image")]
    Encode {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    #[error("{path}: could not write")]
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

/// Check that `path` can be written (format known, directory exists and is writable) before
/// any work is done.
pub fn check_target(path: &Path) -> Result<Format, OutputError> {
    let format = format_of(path)?;
    check_target_dir(path)?;
    Ok(format)
}

/// Check, before any work, that `path` (any file type: reports, pictures) can be written: its
/// directory exists, it is not itself a directory, and a file can be created beside it (a
/// probe is created and removed at once).
pub fn check_target_dir(path: &Path) -> Result<(), OutputError> {
    let dir = parent_dir(path);
    if !dir.is_dir() {
        return Err(OutputError::NoDirectory { path: path.to_path_buf(), dir: dir.to_path_buf() });
    }
    if path.is_dir() {
        return Err(OutputError::IsDirectory { path: path.to_path_buf() });
    }
    let probe = tmp_name(path);
    match std::fs::OpenOptions::new().write(true).create_new(true).open(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(source) => Err(OutputError::NotWritable { path: path.to_path_buf(), dir: dir.to_path_buf(), source }),
    }
}

/// Check a command's output paths together: each writable, and no two the same file (a
/// reference's `X.var.exr` counts as one of its outputs).
pub fn check_targets(paths: &[PathBuf]) -> Result<(), OutputError> {
    for (i, p) in paths.iter().enumerate() {
        check_target_dir(p)?;
        if let Some(q) = paths[..i].iter().find(|q| same_file(p, q)) {
            return Err(OutputError::SameFile { first: q.clone(), second: p.clone() });
        }
    }
    Ok(())
}

/// Whether two output paths name the same file (compared by directory and name, so that
/// `a.png` and `./a.png` match even before either exists).
fn same_file(a: &Path, b: &Path) -> bool {
    let canon = |p: &Path| parent_dir(p).canonicalize().ok().map(|d| d.join(p.file_name().unwrap_or_default()));
    match (canon(a), canon(b)) {
        (Some(x), Some(y)) => x == y,
        _ => a == b,
    }
}

fn parent_dir(path: &Path) -> &Path {
    path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

/// Linear RGB f32 radiance of a frame (alpha dropped).
pub fn radiance_rgb(frame: &FrameOutput) -> Vec<f32> {
    frame.radiance.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect()
}

/// Write `frame` to `path` (.png or .exr), atomically.
pub fn write_frame(path: &Path, frame: &FrameOutput) -> Result<(), OutputError> {
    let bytes = encode_frame(path, frame)?;
    write_bytes(path, &bytes)
}

/// `frame` encoded as the file `path` names (.png: the display image; .exr: radiance).
pub fn encode_frame(path: &Path, frame: &FrameOutput) -> Result<Vec<u8>, OutputError> {
    let format = format_of(path)?;
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
    encode(path, format, &image)
}

/// Linear RGB f32 radiance (`width * height * 3` values) encoded as an EXR file.
pub fn encode_exr(path: &Path, width: u32, height: u32, rgb: &[f32]) -> Result<Vec<u8>, OutputError> {
    let image = image::DynamicImage::ImageRgb32F(
        image::Rgb32FImage::from_raw(width, height, rgb.to_vec()).expect("RGB buffer matches its size"),
    );
    encode(path, Format::Exr, &image)
}

/// Write linear RGB f32 radiance (`width * height * 3` values) to an EXR file, atomically.
pub fn write_exr(path: &Path, width: u32, height: u32, rgb: &[f32]) -> Result<(), OutputError> {
    write_bytes(path, &encode_exr(path, width, height, rgb)?)
}

/// An RGB8 picture encoded as a PNG file.
pub fn encode_png(path: &Path, image: &image::RgbImage) -> Result<Vec<u8>, OutputError> {
    encode(path, Format::Png, &image::DynamicImage::ImageRgb8(image.clone()))
}

/// Write an RGB8 picture to a PNG file, atomically.
pub fn write_png(path: &Path, image: &image::RgbImage) -> Result<(), OutputError> {
    write_bytes(path, &encode_png(path, image)?)
}

/// Linear radiance through the renderer's display transform (exposure, tone map, sRGB),
/// encoded as a PNG file.
pub fn encode_display_png(
    path: &Path,
    image: &crate::metrics::LinearImage,
    exposure: f32,
    tonemap: crate::scene::ToneMap,
) -> Result<Vec<u8>, OutputError> {
    let rgb = crate::metrics::display_srgb8(image, exposure, tonemap);
    encode_png(
        path,
        &image::RgbImage::from_raw(image.width, image.height, rgb).expect("display buffer matches its size"),
    )
}

/// [`encode_display_png`], written atomically.
pub fn write_display_png(
    path: &Path,
    image: &crate::metrics::LinearImage,
    exposure: f32,
    tonemap: crate::scene::ToneMap,
) -> Result<(), OutputError> {
    write_bytes(path, &encode_display_png(path, image, exposure, tonemap)?)
}

/// Write bytes (a report, a picture, an image) to `path` atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    write_all(&[(path, bytes)])
}

/// Write every file or none. Each is written to a temporary sibling, flushed and synced;
/// only when all are on the disk are they renamed into place (and their directories
/// synced). On any error every temporary file is removed and every target keeps the file it
/// had: a rename is atomic for one file only, so before the renames each existing target but
/// the last is hard-linked (or, where links fail, copied) to a backup sibling, and a failed
/// rename puts the targets renamed before it back from their backups (or removes them where
/// there was no file).
pub fn write_all(files: &[(&Path, &[u8])]) -> Result<(), OutputError> {
    let mut written: Vec<PathBuf> = Vec::with_capacity(files.len());
    let remove_all = |paths: &[PathBuf]| {
        for p in paths {
            let _ = std::fs::remove_file(p);
        }
    };
    for (path, bytes) in files {
        match write_synced(path, bytes) {
            Ok(tmp) => written.push(tmp),
            Err(e) => {
                remove_all(&written);
                return Err(e);
            }
        }
    }
    // The last target needs no backup: nothing is renamed after it.
    let mut backups: Vec<Option<PathBuf>> = Vec::with_capacity(files.len());
    for (path, _) in &files[..files.len().saturating_sub(1)] {
        match backup(path) {
            Ok(b) => backups.push(b),
            Err(source) => {
                remove_all(&written);
                remove_all(&backups.into_iter().flatten().collect::<Vec<_>>());
                return Err(OutputError::Io { path: path.to_path_buf(), source });
            }
        }
    }
    for (i, ((path, _), tmp)) in files.iter().zip(&written).enumerate() {
        if let Err(source) = std::fs::rename(tmp, path) {
            for ((renamed, _), old) in files[..i].iter().zip(&backups) {
                let _ = match old {
                    Some(old) => std::fs::rename(old, renamed),
                    None => std::fs::remove_file(renamed),
                };
            }
            remove_all(&written[i..]);
            remove_all(&backups.iter().skip(i).flatten().cloned().collect::<Vec<_>>());
            return Err(OutputError::Io { path: path.to_path_buf(), source });
        }
    }
    remove_all(&backups.into_iter().flatten().collect::<Vec<_>>());
    for (path, _) in files {
        // The renames themselves reach the disk with the directory.
        let dir = parent_dir(path);
        if let Err(source) = std::fs::File::open(dir).and_then(|d| d.sync_all()) {
            return Err(OutputError::Io { path: dir.to_path_buf(), source });
        }
    }
    Ok(())
}

/// `bytes` in a new temporary sibling of `path`, flushed and synced; the temporary's path.
fn write_synced(path: &Path, bytes: &[u8]) -> Result<PathBuf, OutputError> {
    use std::io::Write;
    check_target_dir(path)?;
    let tmp = tmp_name(path);
    let result = std::fs::File::create(&tmp).and_then(|mut f| {
        f.write_all(bytes)?;
        f.flush()?;
        f.sync_all()
    });
    match result {
        Ok(()) => Ok(tmp),
        Err(source) => {
            let _ = std::fs::remove_file(&tmp);
            Err(OutputError::Io { path: path.to_path_buf(), source })
        }
    }
}

/// A backup of the file at `path` beside it (a hard link, or a copy where links fail), or
/// `None` where there is no file.
fn backup(path: &Path) -> std::io::Result<Option<PathBuf>> {
    if std::fs::symlink_metadata(path).is_err() {
        return Ok(None);
    }
    let file_name = path.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
    let old = path.with_file_name(format!(".{file_name}.{}.old.tmp", std::process::id()));
    let _ = std::fs::remove_file(&old);
    if std::fs::hard_link(path, &old).is_err() {
        if let Err(e) = std::fs::copy(path, &old) {
            let _ = std::fs::remove_file(&old);
            return Err(e);
        }
    }
    Ok(Some(old))
}

fn tmp_name(path: &Path) -> PathBuf {
    let file_name = path.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
    path.with_file_name(format!(".{file_name}.{}.tmp", std::process::id()))
}

/// An image encoded in memory (nothing touches the disk here).
fn encode(path: &Path, format: Format, image: &image::DynamicImage) -> Result<Vec<u8>, OutputError> {
    let fmt = match format {
        Format::Png => image::ImageFormat::Png,
        Format::Exr => image::ImageFormat::OpenExr,
    };
    let mut bytes = std::io::Cursor::new(Vec::new());
    image.write_to(&mut bytes, fmt).map_err(|source| OutputError::Encode { path: path.to_path_buf(), source })?;
    Ok(bytes.into_inner())
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The backup [`write_all`] takes before its renames is a second name for the user's file
    /// (a hard link, or a copy where links fail): the file stays at its own path, byte for byte,
    /// from the backup until the new file is renamed over it, so a crash in between (when
    /// nothing is left to put the file back) leaves the user's file where it was. Guards against
    /// a backup made by moving the file (`rename`), which left the path empty until the new
    /// file landed.
    #[test]
    fn a_backup_leaves_the_users_file_at_its_path() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.png");
        let old: &[u8] = b"the user's earlier image";
        std::fs::write(&path, old).unwrap();
        let copy = backup(&path).unwrap().expect("an existing file has a backup");
        let now = std::fs::read(&path);
        assert!(now.as_deref().ok() == Some(old), "{} after its backup: {now:?}", path.display());
        assert_eq!(std::fs::read(&copy).unwrap(), old, "the backup holds the old bytes");
        assert_ne!(copy, path, "the backup is a file of its own");
        // The new file renamed over the target leaves the backup with the old bytes (what a
        // failed sibling's rename puts back).
        let tmp = write_synced(&path, b"the new image").unwrap();
        std::fs::rename(&tmp, &path).unwrap();
        assert_eq!(std::fs::read(&copy).unwrap(), old, "the backup after the new file landed");
        // A path with no file has no backup.
        assert!(backup(&dir.path().join("y.png")).unwrap().is_none());
    }
}
