//! Reading the text files of a scene (TOML, OBJ, MTL). A scene file must be UTF-8 (TOML
//! requires it); OBJ and MTL files, which real exporters write in whatever encoding, may also
//! be UTF-16 with a byte-order mark or an 8-bit encoding (read as Latin-1). Binary files
//! (images, archives, NUL bytes) are refused with the line and column of the first offending
//! byte instead of being parsed as garbage, and only regular files of a bounded size are read.

use super::error::SceneError;
use std::path::Path;

/// Why a file is not usable text: `line` (1-based) where known.
#[derive(Debug)]
pub(crate) struct TextError {
    pub line: Option<usize>,
    pub message: String,
}

impl TextError {
    /// "line N: message" (or just the message), for the `Obj`/`Mtl`/`Toml` error variants.
    pub fn located(&self) -> String {
        match self.line {
            Some(l) => format!("line {l}: {}", self.message),
            None => self.message.clone(),
        }
    }
}

/// Well-known binary signatures, for a friendlier message than "not UTF-8".
const MAGIC: &[(&[u8], &str)] = &[
    (b"\x89PNG", "a PNG image"),
    (b"\xff\xd8\xff", "a JPEG image"),
    (b"GIF8", "a GIF image"),
    (b"\x76\x2f\x31\x01", "an OpenEXR image"),
    (b"\x1f\x8b", "gzip-compressed data"),
    (b"PK\x03\x04", "a ZIP archive"),
    (b"\x7fELF", "an executable (ELF)"),
    (b"\x28\xb5\x2f\xfd", "zstd-compressed data"),
];

/// 1-based line and column of byte offset `at`.
fn line_col(bytes: &[u8], at: usize) -> (usize, usize) {
    let before = &bytes[..at.min(bytes.len())];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let col = before.iter().rev().take_while(|&&b| b != b'\n').count() + 1;
    (line, col)
}

/// A kind of text file: its name in messages, its size limit, and whether encodings other
/// than UTF-8 are read.
pub(crate) struct TextKind {
    /// "an OBJ file", "an MTL file", "a TOML scene file".
    pub what: &'static str,
    pub max_bytes: u64,
    /// UTF-16 (with a byte-order mark) and 8-bit (Latin-1) text are decoded too.
    pub any_encoding: bool,
}

pub(crate) const SCENE_FILE: TextKind =
    TextKind { what: "a TOML scene file", max_bytes: MAX_SCENE_BYTES, any_encoding: false };
pub(crate) const OBJ_FILE: TextKind = TextKind { what: "an OBJ file", max_bytes: MAX_ASSET_BYTES, any_encoding: true };
pub(crate) const MTL_FILE: TextKind = TextKind { what: "an MTL file", max_bytes: MAX_ASSET_BYTES, any_encoding: true };

/// UTF-16 text after its byte-order mark (`big_endian` from the mark).
fn decode_utf16(body: &[u8], big_endian: bool) -> Result<String, TextError> {
    if body.len() % 2 != 0 {
        return Err(TextError { line: None, message: "UTF-16 text with an odd number of bytes".to_owned() });
    }
    let units = body.chunks_exact(2).map(|c| {
        if big_endian {
            u16::from_be_bytes([c[0], c[1]])
        } else {
            u16::from_le_bytes([c[0], c[1]])
        }
    });
    Ok(char::decode_utf16(units).map(|c| c.unwrap_or(char::REPLACEMENT_CHARACTER)).collect())
}

/// [`decode`] for `kind`: OBJ and MTL files may also be UTF-16 (with a byte-order mark) or
/// 8-bit text, read as Latin-1 (names then keep their characters).
pub(crate) fn decode_kind(bytes: Vec<u8>, kind: &TextKind) -> Result<String, TextError> {
    if kind.any_encoding {
        let utf16 = match bytes.get(..2) {
            Some([0xff, 0xfe]) => Some(false),
            Some([0xfe, 0xff]) => Some(true),
            _ => None,
        };
        if let Some(be) = utf16 {
            let text = decode_utf16(&bytes[2..], be)?;
            return decode(text.into_bytes(), kind.what);
        }
        let body = bytes.strip_prefix(b"\xef\xbb\xbf".as_slice()).unwrap_or(&bytes);
        if std::str::from_utf8(body).is_err() && !body.contains(&0) && !MAGIC.iter().any(|(m, _)| body.starts_with(m)) {
            let latin1: String = body.iter().map(|&b| b as char).collect();
            return decode(latin1.into_bytes(), kind.what);
        }
    }
    decode(bytes, kind.what)
}

/// Checks that `bytes` are UTF-8 text (a UTF-8 byte-order mark is dropped). `what` names the
/// expected format in messages ("an OBJ file", "an MTL file", "a TOML scene file").
pub(crate) fn decode(bytes: Vec<u8>, what: &str) -> Result<String, TextError> {
    let whole = |message: String| TextError { line: None, message };
    for (magic, name) in MAGIC {
        if bytes.starts_with(magic) {
            return Err(whole(format!("this is {name}, not {what}")));
        }
    }
    if bytes.starts_with(&[0xff, 0xfe]) || bytes.starts_with(&[0xfe, 0xff]) {
        return Err(whole(
            "the file is UTF-16 encoded (it starts with a UTF-16 byte-order mark); save it as UTF-8 text".to_owned(),
        ));
    }
    let body = bytes.strip_prefix(b"\xef\xbb\xbf".as_slice()).unwrap_or(&bytes);
    if let Some(at) = body.iter().position(|&b| b == 0) {
        let (line, col) = line_col(body, at);
        return Err(TextError {
            line: Some(line),
            message: format!(
                "column {col}: NUL byte; this looks like a binary file (or UTF-16 text), not {what} (UTF-8 text)"
            ),
        });
    }
    let text = match std::str::from_utf8(body) {
        Ok(s) => s.to_owned(),
        Err(e) => {
            let at = e.valid_up_to();
            let (line, col) = line_col(body, at);
            return Err(TextError {
                line: Some(line),
                message: format!(
                    "column {col}: byte 0x{:02X} is not valid UTF-8; is this {what}? save it as UTF-8 text \
                     (Latin-1 and other 8-bit encodings are not supported)",
                    body[at]
                ),
            });
        }
    };
    if text.trim().is_empty() {
        return Err(whole(format!(
            "the file is empty{}",
            if text.is_empty() { " (0 bytes)" } else { " (only white space)" }
        )));
    }
    Ok(text)
}

/// The largest scene file read (TOML): far beyond any real scene, so `/dev/zero`-like input or
/// a mistaken multi-gigabyte file is refused before it is read.
pub(crate) const MAX_SCENE_BYTES: u64 = 64 << 20;
/// The largest OBJ or MTL file read (Crytek's Sponza OBJ is about 20 MB).
pub(crate) const MAX_ASSET_BYTES: u64 = 4 << 30;

/// Whether `path` exists in any form (a broken or looping symbolic link included).
pub(crate) fn exists(path: &Path) -> bool {
    std::fs::symlink_metadata(path).is_ok()
}

/// Check that `path` is a regular file (following symbolic links) of at most `max` bytes,
/// before anything opens it: a FIFO would block the open, a device never end the read.
pub(crate) fn check_regular(path: &Path, max: u64) -> Result<u64, SceneError> {
    let not_a_file = |message: String| SceneError::NotAFile { path: path.to_path_buf(), message };
    let meta = match std::fs::metadata(path) {
        Ok(m) => m,
        Err(source) if exists(path) => {
            return Err(not_a_file(format!("a symbolic link that cannot be followed ({source}); point it at a file")))
        }
        Err(source) => return Err(SceneError::Io { path: path.to_path_buf(), source }),
    };
    let kind = kind_of(&meta.file_type());
    if let Some(kind) = kind {
        return Err(not_a_file(format!("this is {kind}, not a file; name a regular file")));
    }
    if meta.len() > max {
        return Err(not_a_file(format!(
            "{} bytes is more than the {} MiB a file of this kind may have; is this the right file?",
            meta.len(),
            max >> 20
        )));
    }
    Ok(meta.len())
}

/// What a non-regular file is, in words (`None` for a regular file).
fn kind_of(t: &std::fs::FileType) -> Option<&'static str> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return Some("a FIFO (named pipe)");
        }
        if t.is_char_device() || t.is_block_device() {
            return Some("a device");
        }
        if t.is_socket() {
            return Some("a socket");
        }
    }
    if t.is_dir() {
        Some("a directory")
    } else if t.is_file() {
        None
    } else {
        Some("not a regular file")
    }
}

/// Reads `path` (a regular file of at most `kind.max_bytes`) as text of `kind`; `err` builds
/// the format-specific error from a message.
pub(crate) fn read(
    path: &Path,
    kind: &TextKind,
    err: impl FnOnce(&Path, String) -> SceneError,
) -> Result<String, SceneError> {
    use std::io::Read;
    let max = kind.max_bytes;
    check_regular(path, max)?;
    let io = |source| SceneError::Io { path: path.to_path_buf(), source };
    let mut bytes = Vec::new();
    // Bounded even if the file grows after the check.
    std::fs::File::open(path).map_err(io)?.take(max + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > max {
        return Err(SceneError::NotAFile {
            path: path.to_path_buf(),
            message: format!("it grew past {} MiB while being read", max >> 20),
        });
    }
    decode_kind(bytes, kind).map_err(|e| err(path, e.located()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn msg(bytes: &[u8]) -> String {
        decode(bytes.to_vec(), "an OBJ file").unwrap_err().located()
    }

    #[test]
    fn files_larger_than_their_kind_are_refused_before_reading() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big.obj");
        std::fs::write(&p, vec![b'#'; 2 << 20]).unwrap();
        let e = check_regular(&p, 1 << 20).unwrap_err().to_string();
        assert!(e.contains("big.obj") && e.contains("2097152 bytes is more than the 1 MiB"), "{e}");
        assert_eq!(check_regular(&p, 4 << 20).unwrap(), 2 << 20);
    }

    #[test]
    fn text_checks() {
        assert_eq!(decode(b"\xef\xbb\xbfv 0 0 0\n".to_vec(), "an OBJ file").unwrap(), "v 0 0 0\n");
        assert!(msg(b"\x89PNG\r\n\x1a\n....").contains("PNG image"));
        assert!(msg(b"\xff\xfev\x00 \x00").contains("UTF-16"));
        let m = msg(b"v 0 0 0\nv 1 \x000 0\n");
        assert!(m.starts_with("line 2: column 5: NUL byte"), "{m}");
        let m = msg(b"# ok\n# caf\xe9\n");
        assert!(m.starts_with("line 2: column 6: byte 0xE9 is not valid UTF-8"), "{m}");
        assert!(msg(b"").contains("empty (0 bytes)"));
        assert!(msg(b" \n\t\n").contains("only white space"));
    }
}
