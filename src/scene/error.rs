//! The one error type of the scene-loading layer.
//!
//! Every message names the file it is about (and the line where it is known), says what is
//! wrong and, where that helps, what to do about it.

use std::path::PathBuf;

/// Everything that can go wrong while loading a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A file could not be read (missing, unreadable, a directory, ...).
    #[error("{}: cannot read file: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },

    /// The scene file is not valid TOML or does not match the schema. `message` is toml's own
    /// (it includes line and column).
    #[error("{}: {message}", path.display())]
    Toml { path: PathBuf, message: String },

    /// A `--set` key that does not exist in the scene.
    #[error(
        "{}: --set {key}: {message}; valid keys at `{at}`: {}",
        path.display(),
        list(valid)
    )]
    UnknownKey {
        /// The scene file the override was applied to.
        path: PathBuf,
        /// The full dotted `--set` key.
        key: String,
        /// The dotted prefix at which the lookup failed (`<top level>` for the root).
        at: String,
        /// What exactly was not found.
        message: String,
        /// The keys (or indices) that exist at that level.
        valid: Vec<String>,
    },

    /// A malformed `--set` argument (no `=`, empty key, ...).
    #[error("--set {arg}: {message}")]
    BadOverride { arg: String, message: String },

    /// A value in the scene file is out of range or inconsistent. `key` is the dotted path
    /// (the same syntax `--set` uses).
    #[error("{}: {key}: {message}", path.display())]
    InvalidValue { path: PathBuf, key: String, message: String },

    /// An asset named by the scene file was not found in any search location.
    #[error(
        "{}: asset `{name}` not found; tried:{}\n(hint: fix the path, add `search_paths` under [scene], pass --asset-path DIR or set DVSGI_ASSET_PATH)",
        scene_path.display(),
        tried_list(tried)
    )]
    AssetNotFound { scene_path: PathBuf, name: String, tried: Vec<PathBuf> },

    /// A malformed Wavefront OBJ file (message starts with the line number where known).
    #[error("{}: {message}", path.display())]
    Obj { path: PathBuf, message: String },

    /// A malformed or missing MTL material library.
    #[error("{}: {message}", path.display())]
    Mtl { path: PathBuf, message: String },

    /// A path that exists but is no regular file (a directory, FIFO, device or socket, or a
    /// symbolic link that cannot be followed), or a file far larger than its kind can be.
    #[error("{}: {message}", path.display())]
    NotAFile { path: PathBuf, message: String },

    /// A texture that is missing or cannot be decoded.
    #[error("{}: {message}", path.display())]
    Texture { path: PathBuf, message: String },
}

impl SceneError {
    /// The file the error is about (the scene file for `--set` and asset errors), if any.
    /// Its `Display` text always names this path.
    pub fn path(&self) -> Option<&std::path::Path> {
        match self {
            SceneError::Io { path, .. }
            | SceneError::Toml { path, .. }
            | SceneError::UnknownKey { path, .. }
            | SceneError::InvalidValue { path, .. }
            | SceneError::Obj { path, .. }
            | SceneError::Mtl { path, .. }
            | SceneError::Texture { path, .. }
            | SceneError::NotAFile { path, .. } => Some(path),
            SceneError::AssetNotFound { scene_path, .. } => Some(scene_path),
            SceneError::BadOverride { .. } => None,
        }
    }
}

fn list(v: &[String]) -> String {
    if v.is_empty() {
        "(none)".to_owned()
    } else {
        v.join(", ")
    }
}

fn tried_list(v: &[PathBuf]) -> String {
    let mut s = String::new();
    for p in v {
        s.push_str("\n  ");
        s.push_str(&p.display().to_string());
    }
    if v.is_empty() {
        s.push_str(" (nothing)");
    }
    s
}
