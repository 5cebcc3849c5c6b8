//! The viewer's settings: the command line's (preset, `--set`, size), then every change made
//! in the UI or by the script, kept as scene-file overrides so that a capture can write them
//! as a scene file `dvsgi render` reproduces.

use super::ViewOptions;
use crate::cli::CommonArgs;
use crate::render::Mode;
use crate::scene::{Camera, LoadOptions, Preset, Scene};
use std::path::PathBuf;

pub struct ViewSettings {
    /// `--validation`, `--device`, `--asset-path` and `--set` (the preset is below).
    pub common: CommonArgs,
    pub scene_path: PathBuf,
    pub preset: Option<Preset>,
    pub schedule: Mode,
    /// The size flags, then the changes, in order; a key appears once.
    pub changes: Vec<(String, String)>,
}

impl ViewSettings {
    pub fn new(common: &CommonArgs, opts: &ViewOptions) -> ViewSettings {
        ViewSettings {
            common: common.clone(),
            scene_path: opts.scene.clone(),
            preset: common.preset,
            schedule: opts.schedule,
            changes: opts.size.clone(),
        }
    }

    /// The scene with every setting applied (preset, then `--set`, then the changes).
    pub fn load(&self) -> crate::Result<Scene> {
        let mut common = self.common.clone();
        common.preset = self.preset;
        common.load_scene(&self.scene_path, &self.changes)
    }

    /// Set `key` (replacing an earlier change of it); returns the value it had, to revert.
    pub fn set(&mut self, key: &str, value: &str) -> Option<String> {
        match self.changes.iter_mut().find(|(k, _)| k == key) {
            Some((_, v)) => Some(std::mem::replace(v, value.to_string())),
            None => {
                self.changes.push((key.to_string(), value.to_string()));
                None
            }
        }
    }

    /// Undo a [`ViewSettings::set`] given what it returned.
    pub fn revert(&mut self, key: &str, previous: Option<String>) {
        match previous {
            Some(v) => {
                self.set(key, &v);
            }
            None => self.changes.retain(|(k, _)| k != key),
        }
    }

    /// A new preset: it sets the `[gi]` keys it names, so earlier changes of those go.
    pub fn set_preset(&mut self, preset: Option<Preset>) {
        let keys: Vec<String> = preset.map(|p| p.overrides().into_iter().map(|(k, _)| k).collect()).unwrap_or_default();
        self.changes.retain(|(k, _)| !keys.contains(k));
        self.preset = preset;
    }

    /// Every override of the current frame, in the order they apply: the preset's, `--set`,
    /// the changes, then the camera and the scene time of the frame.
    pub fn overrides(&self, camera: &Camera, time: f32) -> crate::Result<Vec<(String, String)>> {
        let mut all = self.preset.map(|p| p.overrides()).unwrap_or_default();
        for s in &self.common.sets {
            all.push(crate::scene::parse_override(s)?);
        }
        all.extend(self.changes.iter().cloned());
        let v = |v: glam::Vec3| format!("[{:?}, {:?}, {:?}]", v.x, v.y, v.z);
        all.push(("camera.position".into(), v(camera.position)));
        all.push(("camera.target".into(), v(camera.target)));
        all.push(("camera.up".into(), v(camera.up)));
        all.push(("camera.fov_y".into(), format!("{:?}", camera.fov_y_deg)));
        all.push(("render.time".into(), format!("{time:?}")));
        Ok(all)
    }

    /// The text of a scene file with every setting of the frame applied, loadable from anywhere.
    pub fn scene_file(&self, camera: &Camera, time: f32) -> crate::Result<String> {
        let mut asset_paths = self.common.asset_paths.clone();
        asset_paths.extend(LoadOptions::env_asset_paths());
        let opts = LoadOptions { overrides: self.overrides(camera, time)?, asset_paths };
        Ok(crate::scene::standalone_file(&self.scene_path, &opts)?)
    }
}
