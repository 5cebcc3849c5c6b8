//! Reading the text files of a scene (TOML, OBJ, MTL): they must be UTF-8 text. Binary files
//! (images, archives, random bytes), UTF-16 and 8-bit encodings are refused with the line
//! (and column) of the first offending byte instead of being parsed as garbage.

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

/// Reads `path` as UTF-8 text; `err` builds the format-specific error from a message.
pub(crate) fn read(
    path: &Path,
    what: &str,
    err: impl FnOnce(&Path, String) -> SceneError,
) -> Result<String, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io { path: path.to_path_buf(), source })?;
    decode(bytes, what).map_err(|e| err(path, e.located()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn msg(bytes: &[u8]) -> String {
        decode(bytes.to_vec(), "an OBJ file").unwrap_err().located()
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
