//! Scene loading: TOML scene files (format: `scenes/FORMAT.md`) referencing Wavefront OBJ/MTL
//! geometry, with `--set key=value` overrides.

mod types;
pub use types::*;
mod error;
pub use error::SceneError;
mod file;
mod obj;
mod preset;
pub use preset::Preset;
mod check;
pub mod maps;
mod sky;
pub use sky::{equirect_dir, equirect_uv, gradient, load_sky_image, Sky, SkyImage, SkyKind};
mod text;
mod triangulate;

use std::path::{Path, PathBuf};

/// How to load a scene.
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// `--set` overrides as (dotted key, value) pairs, applied in order. Values use TOML
    /// syntax (`45`, `[1,2,3]`, `true`, `"aces"`); anything that is not valid TOML is taken
    /// as a plain string.
    pub overrides: Vec<(String, String)>,
    /// Extra directories searched for relative asset paths (after the scene file's directory,
    /// before `[scene] search_paths`).
    pub asset_paths: Vec<PathBuf>,
}

impl LoadOptions {
    /// The directories in the `DVSGI_ASSET_PATH` environment variable (colon-separated on
    /// Unix); empty entries are skipped. The CLI appends these after its `--asset-path`s.
    pub fn env_asset_paths() -> Vec<PathBuf> {
        std::env::var_os("DVSGI_ASSET_PATH")
            .map(|v| std::env::split_paths(&v).filter(|p| !p.as_os_str().is_empty()).collect())
            .unwrap_or_default()
    }
}

/// Loads and validates a scene file and everything it references.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Scene, SceneError> {
    let text = text::read(path, &text::SCENE_FILE, |p, message| SceneError::Toml { path: p.to_path_buf(), message })?;
    let parsed = file::parse(path, &text, &opts.overrides)?;
    file::build(path, parsed, opts)
}

/// The scene file at `path` with `opts.overrides` applied, as the text of a scene file that
/// loads the same scene from any folder: its `[scene] search_paths` become the original file's
/// folder, then `opts.asset_paths`, then the original search paths, all absolute (so relative
/// asset paths resolve as they did). `dvsgi view` writes its captures' settings with it.
pub fn standalone_file(path: &Path, opts: &LoadOptions) -> Result<String, SceneError> {
    let text = text::read(path, &text::SCENE_FILE, |p, message| SceneError::Toml { path: p.to_path_buf(), message })?;
    let mut file = file::parse(path, &text, &opts.overrides)?;
    let absolute = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let dir = absolute(path.parent().unwrap_or(Path::new(".")));
    let mut search = vec![dir.clone()];
    search.extend(opts.asset_paths.iter().map(|p| absolute(p)));
    search.extend(file.scene.search_paths.iter().map(|s| dir.join(s)));
    file.scene.search_paths = search.iter().map(|p| p.to_string_lossy().into_owned()).collect();
    toml::to_string(&file).map_err(|e| SceneError::Toml {
        path: path.to_path_buf(),
        message: format!("internal error writing the scene with its settings: {e}"),
    })
}

/// For `--set`: split "a.b.c=value" into ("a.b.c", "value"), error if no '='.
pub fn parse_override(s: &str) -> Result<(String, String), SceneError> {
    let Some((k, v)) = s.split_once('=') else {
        return Err(SceneError::BadOverride {
            arg: s.to_owned(),
            message: "expected KEY=VALUE, e.g. camera.fov_y=45 or lights.0.intensity=[1,2,3]".to_owned(),
        });
    };
    let k = k.trim();
    if k.is_empty() {
        return Err(SceneError::BadOverride { arg: s.to_owned(), message: "empty key before '='".to_owned() });
    }
    Ok((k.to_owned(), v.trim().to_owned()))
}

impl Scene {
    /// World-space bounds of all geometry at time `t` (union of the mesh bounds transformed by
    /// their object's model matrix). `Aabb::EMPTY` for a scene without geometry.
    pub fn world_bounds(&self, t: f32) -> Aabb {
        let mut out = Aabb::EMPTY;
        for o in &self.objects {
            let m = o.model_matrix(t);
            for &mi in &o.meshes {
                if let Some(mesh) = self.meshes.get(mi as usize) {
                    if !mesh.bounds.is_empty() {
                        out = out.union(&mesh.bounds.transformed(&m));
                    }
                }
            }
        }
        out
    }

    /// Whether anything changes over time: a dynamic object, or a light with motion.
    pub fn has_dynamic(&self) -> bool {
        self.objects.iter().any(|o| o.dynamic) || self.lights.iter().any(|l| !l.motion.is_static())
    }

    /// Total number of triangles over all meshes.
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.indices.len() / 3).sum()
    }
}

#[cfg(test)]
mod tests;
