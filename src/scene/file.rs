//! The TOML scene-file schema (see `scenes/FORMAT.md`), `--set` overrides, and the
//! conversion of a parsed file into a validated [`Scene`].

use super::error::SceneError;
use super::obj::{self, MapKind, ObjData};
use super::sky::{build_sky, SkyContext, SkyDef, SKY_KEYS};
use super::types::*;
use super::LoadOptions;
use glam::{Mat4, Vec3};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

// ---------------------------------------------------------------------------------------------
// Schema
// ---------------------------------------------------------------------------------------------

fn zero3() -> [f32; 3] {
    [0.0; 3]
}
fn up3() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}
fn default_albedo() -> [f32; 3] {
    [0.8; 3]
}
fn one() -> f32 {
    1.0
}
fn yes() -> bool {
    true
}
fn default_fov() -> f32 {
    45.0
}
fn default_near() -> f32 {
    0.01
}
fn default_far() -> f32 {
    1000.0
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SceneFile {
    #[serde(default)]
    pub scene: SceneSection,
    pub camera: CameraDef,
    #[serde(default)]
    pub render: RenderDef,
    #[serde(default)]
    pub gi: GiDef,
    #[serde(default)]
    pub materials: Vec<MaterialDef>,
    #[serde(default)]
    pub objects: Vec<ObjectDef>,
    #[serde(default)]
    pub lights: Vec<LightDef>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sky: Option<SkyDef>,
}

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SceneSection {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    #[serde(default)]
    pub search_paths: Vec<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bounds: Option<BoundsDef>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct BoundsDef {
    pub min: [f32; 3],
    pub max: [f32; 3],
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CameraDef {
    pub position: [f32; 3],
    pub target: [f32; 3],
    #[serde(default = "up3")]
    pub up: [f32; 3],
    #[serde(default = "default_fov")]
    pub fov_y: f32,
    #[serde(default = "default_near")]
    pub near: f32,
    #[serde(default = "default_far")]
    pub far: f32,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct RenderDef {
    pub width: u32,
    pub height: u32,
    pub time: f32,
    pub exposure: ExposureDef,
    pub tonemap: ToneMap,
    pub shadow_map_size: u32,
    pub shadow_cascades: u32,
    pub shadow_filter_radius: f32,
    pub shadow_normal_bias: f32,
    pub view: View,
    pub view_lod: f32,
    pub view_direction: ViewDirection,
    pub supersample: u32,
    pub depth_prepass: DepthPrepass,
}

/// `render.exposure`: EV stops, or "auto" (each display image's own key:
/// metrics::auto_exposure).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum ExposureDef {
    Ev(f32),
    Auto,
}

impl Serialize for ExposureDef {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            ExposureDef::Ev(v) => s.serialize_f32(*v),
            ExposureDef::Auto => s.serialize_str("auto"),
        }
    }
}

impl<'de> Deserialize<'de> for ExposureDef {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = ExposureDef;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("EV stops (a number) or \"auto\"")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<ExposureDef, E> {
                Ok(ExposureDef::Ev(v as f32))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<ExposureDef, E> {
                Ok(ExposureDef::Ev(v as f32))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<ExposureDef, E> {
                Ok(ExposureDef::Ev(v as f32))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<ExposureDef, E> {
                match v {
                    "auto" => Ok(ExposureDef::Auto),
                    _ => Err(E::custom(format!("expected EV stops (a number) or \"auto\", found \"{v}\""))),
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// The `[gi]` table is [`GiSettings`] itself.
pub(crate) type GiDef = GiSettings;

impl Default for RenderDef {
    fn default() -> Self {
        let d = RenderSettings::default();
        RenderDef {
            width: d.width,
            height: d.height,
            time: d.time,
            exposure: if d.exposure_auto { ExposureDef::Auto } else { ExposureDef::Ev(d.exposure) },
            tonemap: d.tonemap,
            shadow_map_size: d.shadow_map_size,
            shadow_cascades: d.shadow_cascades,
            shadow_filter_radius: d.shadow_filter_radius,
            shadow_normal_bias: d.shadow_normal_bias,
            view: d.view,
            view_lod: d.view_lod,
            view_direction: d.view_direction,
            supersample: d.supersample,
            depth_prepass: d.depth_prepass,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct MaterialDef {
    pub name: String,
    #[serde(default = "default_albedo")]
    pub albedo: [f32; 3],
    #[serde(default = "zero3")]
    pub specular: [f32; 3],
    #[serde(default = "one")]
    pub shininess: f32,
    #[serde(default = "zero3")]
    pub emission: [f32; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub albedo_texture: Option<String>,
    /// Alpha-test cutout: coverage from the image's alpha, or its red channel without alpha.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mask_texture: Option<String>,
    /// Tangent-space normal map (OpenGL convention).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal_texture: Option<String>,
    /// Height map (mean of r, g, b): by default a relief of `scene::DEFAULT_RELIEF` of the
    /// texture's tile per unit height, `bump_relief` times that, or `bump_scale` scene units.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bump_texture: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bump_scale: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bump_relief: Option<f32>,
    #[serde(default)]
    pub normal_maps: NormalMaps,
}

/// Which way a normal map's green channel points: up the image, along the OBJ's +v (OpenGL,
/// Blender, most exporters), or down it (DirectX, CryEngine's `_ddn` maps, Unreal).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub(crate) enum NormalMaps {
    #[default]
    OpenGl,
    DirectX,
}

/// `scale = 2.0` or `scale = [sx, sy, sz]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Scale {
    Uniform(f32),
    PerAxis([f32; 3]),
}

impl Default for Scale {
    fn default() -> Self {
        Scale::Uniform(1.0)
    }
}

impl Scale {
    fn vec(self) -> Vec3 {
        match self {
            Scale::Uniform(s) => Vec3::splat(s),
            Scale::PerAxis(a) => Vec3::from_array(a),
        }
    }
}

impl Serialize for Scale {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Scale::Uniform(x) => s.serialize_f32(*x),
            Scale::PerAxis(a) => a.serialize(s),
        }
    }
}

impl<'de> Deserialize<'de> for Scale {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Scale;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number or an array of 3 numbers [sx, sy, sz]")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Scale, E> {
                Ok(Scale::Uniform(v as f32))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Scale, E> {
                Ok(Scale::Uniform(v as f32))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Scale, E> {
                Ok(Scale::Uniform(v as f32))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Scale, A::Error> {
                let mut a = [0.0f32; 3];
                for (k, slot) in a.iter_mut().enumerate() {
                    *slot = seq.next_element()?.ok_or_else(|| serde::de::Error::invalid_length(k, &self))?;
                }
                if seq.next_element::<f32>()?.is_some() {
                    return Err(serde::de::Error::invalid_length(4, &self));
                }
                Ok(Scale::PerAxis(a))
            }
        }
        d.deserialize_any(V)
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ObjectDef {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    pub obj: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<String>,
    #[serde(default)]
    pub materials: BTreeMap<String, String>,
    #[serde(default = "zero3")]
    pub translate: [f32; 3],
    #[serde(default = "zero3")]
    pub rotate: [f32; 3],
    #[serde(default)]
    pub scale: Scale,
    #[serde(default)]
    pub dynamic: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<MotionDef>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub keyframes: Option<Vec<KeyframeDef>>,
    /// The convention of the normal maps its MTL names.
    #[serde(default)]
    pub normal_maps: NormalMaps,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct MotionDef {
    pub axis: [f32; 3],
    pub pivot: [f32; 3],
    pub degrees_per_second: f32,
    pub velocity: [f32; 3],
    pub amplitude: [f32; 3],
    pub period: f32,
}

impl Default for MotionDef {
    fn default() -> Self {
        MotionDef {
            axis: up3(),
            pivot: zero3(),
            degrees_per_second: 0.0,
            velocity: zero3(),
            amplitude: zero3(),
            period: 0.0,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct KeyframeDef {
    pub time: f32,
    #[serde(default = "zero3")]
    pub translate: [f32; 3],
    #[serde(default = "zero3")]
    pub rotate: [f32; 3],
    #[serde(default)]
    pub scale: Scale,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct LightDef {
    #[serde(rename = "type")]
    pub kind: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<[f32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intensity: Option<[f32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub direction: Option<[f32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub irradiance: Option<[f32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inner_angle: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outer_angle: Option<f32>,
    #[serde(default = "yes")]
    pub cast_shadows: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<MotionDef>,
}

// The keys of each table, for `--set` (keys that are optional may be absent from the
// serialized tree but can still be set). A unit test checks these against the structs.
pub(crate) const TOP_KEYS: &[&str] = &["scene", "camera", "render", "gi", "materials", "objects", "lights", "sky"];
pub(crate) const GI_KEYS: &[&str] = &[
    "mode",
    "voxel_resolution",
    "voxel_layout",
    "attenuation",
    "occlusion",
    "voxel_shadow_softness",
    "bounces",
    "bounce_feedback",
    "first_update_bounces",
    "bounce_tail",
    "diffuse_cones",
    "bounce_cones",
    "bounce_interleave",
    "diffuse_rays",
    "diffuse_cone_angle",
    "specular",
    "specular_rays",
    "specular_history",
    "rt_hit_indirect",
    "ao",
    "ao_falloff",
    "shadows",
    "shadow_cone_angle",
    "cone_filter",
    "opacity",
    "footprint",
    "bounce_footprint",
    "voxel_cover",
    "plane_backs",
    "step",
    "max_distance",
    "start_offset",
    "downsample",
    "update_interval",
    "rsm_size",
    "rsm_samples",
    "rsm_radius",
    "lpv_resolution",
    "lpv_steps",
    "lpv_occlusion",
];
pub(crate) const SCENE_KEYS: &[&str] = &["name", "search_paths", "bounds"];
pub(crate) const BOUNDS_KEYS: &[&str] = &["min", "max"];
pub(crate) const CAMERA_KEYS: &[&str] = &["position", "target", "up", "fov_y", "near", "far"];
pub(crate) const RENDER_KEYS: &[&str] = &[
    "width",
    "height",
    "time",
    "exposure",
    "tonemap",
    "shadow_map_size",
    "shadow_cascades",
    "shadow_filter_radius",
    "shadow_normal_bias",
    "view",
    "view_lod",
    "view_direction",
    "supersample",
    "depth_prepass",
];
pub(crate) const MATERIAL_KEYS: &[&str] = &[
    "name",
    "albedo",
    "specular",
    "shininess",
    "emission",
    "albedo_texture",
    "mask_texture",
    "normal_texture",
    "bump_texture",
    "bump_scale",
    "bump_relief",
    "normal_maps",
];
pub(crate) const OBJECT_KEYS: &[&str] = &[
    "name",
    "obj",
    "material",
    "materials",
    "translate",
    "rotate",
    "scale",
    "dynamic",
    "motion",
    "keyframes",
    "normal_maps",
];
pub(crate) const MOTION_KEYS: &[&str] = &["axis", "pivot", "degrees_per_second", "velocity", "amplitude", "period"];
pub(crate) const KEYFRAME_KEYS: &[&str] = &["time", "translate", "rotate", "scale"];
pub(crate) const LIGHT_KEYS: &[&str] = &[
    "type",
    "name",
    "position",
    "intensity",
    "direction",
    "irradiance",
    "inner_angle",
    "outer_angle",
    "cast_shadows",
    "motion",
];

/// What a table at a (normalised, `#` for indices) dotted path may contain.
enum TableSchema {
    Keys(&'static [&'static str]),
    /// Any key (the per-group `materials` map).
    Free,
}

fn table_schema(norm: &str) -> Option<TableSchema> {
    Some(TableSchema::Keys(match norm {
        "" => TOP_KEYS,
        "scene" => SCENE_KEYS,
        "scene.bounds" => BOUNDS_KEYS,
        "camera" => CAMERA_KEYS,
        "render" => RENDER_KEYS,
        "gi" => GI_KEYS,
        "materials.#" => MATERIAL_KEYS,
        "objects.#" => OBJECT_KEYS,
        "objects.#.motion" | "lights.#.motion" => MOTION_KEYS,
        "objects.#.keyframes.#" => KEYFRAME_KEYS,
        "lights.#" => LIGHT_KEYS,
        "sky" => SKY_KEYS,
        "objects.#.materials" => return Some(TableSchema::Free),
        _ => return None,
    }))
}

// ---------------------------------------------------------------------------------------------
// Parsing and overrides
// ---------------------------------------------------------------------------------------------

/// Parses the scene text; with overrides, round-trips through a `toml::Value` tree with all
/// defaults filled in, patches it, and deserializes again.
pub(crate) fn parse(path: &Path, text: &str, overrides: &[(String, String)]) -> Result<SceneFile, SceneError> {
    let file: SceneFile =
        toml::from_str(text).map_err(|e| SceneError::Toml { path: path.to_path_buf(), message: toml_message(&e) })?;
    if overrides.is_empty() {
        return Ok(file);
    }
    let mut tree = toml::Value::try_from(&file).map_err(|e| SceneError::Toml {
        path: path.to_path_buf(),
        message: format!("internal error serializing the scene for --set: {e}"),
    })?;
    for (key, value) in overrides {
        apply_override(&mut tree, path, key, parse_value(value))?;
    }
    tree.try_into().map_err(|e: toml::de::Error| {
        let list = overrides.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(" ");
        SceneError::Toml {
            path: path.to_path_buf(),
            message: format!("after applying --set {list}: {}", toml_message(&e)),
        }
    })
}

/// toml's error text made fit for a terminal: serde's type names (`struct CameraDef`) said as
/// what they are in the file (a table), and the quoted source line, which can be a whole
/// file long, cut to a window around the reported column.
fn toml_message(e: &toml::de::Error) -> String {
    let text = e.to_string();
    let text = text.trim_end();
    let mut out = String::with_capacity(text.len().min(4096));
    let mut rest = text;
    while let Some(at) = rest.find("expected struct ") {
        out.push_str(&rest[..at]);
        let after = &rest[at + "expected struct ".len()..];
        let name_len = after.find(|c: char| !c.is_alphanumeric() && c != '_').unwrap_or(after.len());
        out.push_str("expected a table of settings");
        rest = &after[name_len..];
    }
    out.push_str(rest);
    clip_source_lines(&out)
}

/// The quoted source lines of a toml error longer than a terminal line, shown as a window
/// around the reported column.
fn clip_source_lines(message: &str) -> String {
    const WIDTH: usize = 120;
    let long = message.lines().any(|l| l.chars().count() > WIDTH + 20);
    if !long {
        return message.to_owned();
    }
    // The column toml reports ("at line L, column C").
    let col = message
        .split("column ")
        .nth(1)
        .and_then(|r| r.split(|c: char| !c.is_ascii_digit()).next())
        .and_then(|n| n.parse::<usize>().ok())
        .unwrap_or(1);
    let start = col.saturating_sub(WIDTH / 2);
    message
        .lines()
        .map(|l| {
            // toml's snippet lines: a gutter ("1 | ", "  | ") then the source or the caret.
            let Some(bar) = l.find("| ") else { return l.to_owned() };
            let (gutter, body) = l.split_at(bar + 2);
            let chars: Vec<char> = body.chars().collect();
            if chars.len() <= WIDTH && start == 0 {
                return l.to_owned();
            }
            let from = start.min(chars.len());
            let to = (from + WIDTH).min(chars.len());
            let mut s = String::from(gutter);
            if from > 0 {
                s.push('…');
            }
            s.extend(&chars[from..to]);
            if to < chars.len() {
                s.push_str(&format!("… ({} more characters)", chars.len() - to));
            }
            s
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// A `--set` value: TOML syntax (`45`, `[1,2,3]`, `true`, `"x"`), else the raw string.
pub(crate) fn parse_value(s: &str) -> toml::Value {
    toml::from_str::<toml::Table>(&format!("v = {s}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| toml::Value::String(s.to_owned()))
}

/// Sets one `--set` key (`camera.fov_y`, `lights.0.intensity`) in the scene tree: walks to the
/// table or list that holds it, then sets it there.
fn apply_override(root: &mut toml::Value, path: &Path, key: &str, value: toml::Value) -> Result<(), SceneError> {
    let walk = OverrideKey { path, key, segs: override_segments(key)? };
    // `split` gives at least one segment.
    let last = walk.segs.len() - 1;
    let mut cur = root;
    // The dotted path walked so far, with `#` for list indices (as `table_schema` takes it).
    let mut norm: Vec<&str> = Vec::new();
    for i in 0..last {
        cur = walk.descend(cur, i, &mut norm)?;
    }
    walk.set(cur, last, &norm, value)
}

/// The dotted key's segments, none of them empty.
fn override_segments(key: &str) -> Result<Vec<&str>, SceneError> {
    let segs: Vec<&str> = key.split('.').map(str::trim).collect();
    if segs.iter().any(|s| s.is_empty()) {
        return Err(SceneError::BadOverride {
            arg: key.to_owned(),
            message: "empty component in the dotted key (expected e.g. camera.fov_y or lights.0.intensity)".into(),
        });
    }
    Ok(segs)
}

/// The keys a table may hold: its schema's, else the ones it has.
fn valid_keys(schema: &Option<TableSchema>, t: &toml::Table) -> Vec<String> {
    match schema {
        Some(TableSchema::Keys(k)) => k.iter().map(|s| s.to_string()).collect(),
        _ => t.keys().cloned().collect(),
    }
}

/// The normalised dotted path of `seg` inside the table at `norm`.
fn child_path(norm: &[&str], seg: &str) -> String {
    let mut child = norm.to_vec();
    child.push(seg);
    child.join(".")
}

/// One `--set` key on its way into the scene tree, for the steps of the walk and their errors.
struct OverrideKey<'a> {
    path: &'a Path,
    key: &'a str,
    segs: Vec<&'a str>,
}

impl<'a> OverrideKey<'a> {
    /// An unknown-key error found at the first `upto` segments of the key.
    fn unknown(&self, upto: usize, message: String, valid: Vec<String>) -> SceneError {
        let done = &self.segs[..upto];
        SceneError::UnknownKey {
            path: self.path.to_path_buf(),
            key: self.key.to_owned(),
            at: if done.is_empty() { "<top level>".to_owned() } else { done.join(".") },
            message,
            valid,
        }
    }

    /// Steps from `cur` into its child named by segment `i`.
    fn descend<'t>(
        &self,
        cur: &'t mut toml::Value,
        i: usize,
        norm: &mut Vec<&'a str>,
    ) -> Result<&'t mut toml::Value, SceneError> {
        match cur {
            toml::Value::Table(t) => {
                let next = self.table_child(t, i, norm)?;
                norm.push(self.segs[i]);
                Ok(next)
            }
            toml::Value::Array(a) => {
                let next = self.list_slot(a, i)?;
                norm.push("#");
                Ok(next)
            }
            _ => Err(self.not_a_table(i)),
        }
    }

    /// Sets segment `i`, the last, of `cur` to `value`.
    fn set(&self, cur: &mut toml::Value, i: usize, norm: &[&str], value: toml::Value) -> Result<(), SceneError> {
        match cur {
            toml::Value::Table(t) => self.set_in_table(t, i, norm, value),
            toml::Value::Array(a) => {
                *self.list_slot(a, i)? = value;
                Ok(())
            }
            _ => Err(self.not_a_table(i)),
        }
    }

    /// An error unless the table at `norm` holds segment `i` or may hold it.
    fn check_key(&self, t: &toml::Table, i: usize, norm: &[&str]) -> Result<(), SceneError> {
        let seg = self.segs[i];
        if t.contains_key(seg) {
            return Ok(());
        }
        let schema = table_schema(&norm.join("."));
        let allowed = match &schema {
            Some(TableSchema::Keys(k)) => k.contains(&seg),
            Some(TableSchema::Free) => true,
            None => false,
        };
        if !allowed {
            return Err(self.unknown(i, format!("no key `{seg}`"), valid_keys(&schema, t)));
        }
        Ok(())
    }

    /// The table's child named by segment `i`, started empty when the file leaves out a table
    /// the schema has.
    fn table_child<'t>(
        &self,
        t: &'t mut toml::Table,
        i: usize,
        norm: &[&str],
    ) -> Result<&'t mut toml::Value, SceneError> {
        let seg = self.segs[i];
        self.check_key(t, i, norm)?;
        if !t.contains_key(seg) && table_schema(&child_path(norm, seg)).is_none() {
            return Err(self.unknown(
                i,
                format!(
                    "`{seg}` is not set in the scene file, so nothing inside it can be set; set `{}` as a whole instead",
                    self.segs[..=i].join(".")
                ),
                valid_keys(&table_schema(&norm.join(".")), t),
            ));
        }
        Ok(t.entry(seg).or_insert_with(|| toml::Value::Table(toml::Table::new())))
    }

    /// Sets the table's key named by segment `i`; a single value where a table of settings
    /// belongs is an error that names the keys.
    fn set_in_table(&self, t: &mut toml::Table, i: usize, norm: &[&str], value: toml::Value) -> Result<(), SceneError> {
        let seg = self.segs[i];
        self.check_key(t, i, norm)?;
        let keys: Option<Vec<String>> = match table_schema(&child_path(norm, seg)) {
            Some(TableSchema::Keys(k)) => Some(k.iter().map(|s| s.to_string()).collect()),
            _ => t.get(seg).and_then(|v| v.as_table()).map(|c| c.keys().cloned().collect()),
        };
        if let Some(keys) = keys {
            if !value.is_table() {
                let whole = self.segs[..=i].join(".");
                let example = keys.first().map(|k| format!(", e.g. --set {whole}.{k}=...")).unwrap_or_default();
                let message = format!("`{whole}` is a table of settings, not one value; set one of its keys{example}");
                return Err(self.unknown(i + 1, message, keys));
            }
        }
        t.insert(seg.to_owned(), value);
        Ok(())
    }

    /// The list's entry at the index segment `i` names.
    fn list_slot<'t>(&self, a: &'t mut toml::value::Array, i: usize) -> Result<&'t mut toml::Value, SceneError> {
        let seg = self.segs[i];
        let len = a.len();
        let valid: Vec<String> = (0..len).map(|k| k.to_string()).collect();
        let Ok(idx) = seg.parse::<usize>() else {
            let message = format!("`{}` is a list; expected an index, found `{seg}`", self.segs[..i].join("."));
            return Err(self.unknown(i, message, valid));
        };
        a.get_mut(idx).ok_or_else(|| {
            let entries = if len == 1 { "entry" } else { "entries" };
            self.unknown(i, format!("index {idx} is out of range (the list has {len} {entries})"), valid)
        })
    }

    /// Segment `i` asked of a value that is no table.
    fn not_a_table(&self, i: usize) -> SceneError {
        let done = self.segs[..i].join(".");
        self.unknown(i, format!("`{done}` is a value, not a table, so it has no `{}`", self.segs[i]), Vec::new())
    }
}

// ---------------------------------------------------------------------------------------------
// Validation and conversion
// ---------------------------------------------------------------------------------------------

struct Ctx<'a> {
    path: &'a Path,
    dir: PathBuf,
    opts: &'a LoadOptions,
    search_paths: Vec<PathBuf>,
}

impl<'a> Ctx<'a> {
    /// The context for the scene file at `path`: its directory, and its `[scene]
    /// search_paths` taken from there.
    fn new(path: &'a Path, scene: &SceneSection, opts: &'a LoadOptions) -> Self {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        Ctx { path, search_paths: scene.search_paths.iter().map(|s| dir.join(s)).collect(), dir, opts }
    }

    fn invalid(&self, key: impl Into<String>, message: impl Into<String>) -> SceneError {
        SceneError::InvalidValue { path: self.path.to_path_buf(), key: key.into(), message: message.into() }
    }

    fn finite(&self, key: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
        let v = Vec3::from_array(v);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.invalid(key, format!("{v} is not finite")))
        }
    }

    fn color(&self, key: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
        let c = self.finite(key, v)?;
        if c.min_element() < 0.0 {
            return Err(self.invalid(key, format!("{c}: colour components must be >= 0")));
        }
        Ok(c)
    }

    fn scalar(&self, key: &str, v: f32) -> Result<f32, SceneError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.invalid(key, format!("{v} is not finite")))
        }
    }

    fn scale(&self, key: &str, s: Scale) -> Result<Vec3, SceneError> {
        let v = self.finite(
            key,
            match s {
                Scale::Uniform(x) => [x; 3],
                Scale::PerAxis(a) => a,
            },
        )?;
        if v.cmpeq(Vec3::ZERO).any() {
            return Err(self.invalid(key, "scale must not be zero"));
        }
        Ok(s.vec())
    }

    /// Relative asset names: the scene file's directory, then each `--asset-path` /
    /// `DVSGI_ASSET_PATH` directory, then each `[scene] search_paths` entry.
    fn resolve(&self, name: &str) -> Result<PathBuf, SceneError> {
        let p = Path::new(name);
        let cands: Vec<PathBuf> = if p.is_absolute() {
            vec![p.to_path_buf()]
        } else {
            std::iter::once(self.dir.join(p))
                .chain(self.opts.asset_paths.iter().map(|d| d.join(p)))
                .chain(self.search_paths.iter().map(|d| d.join(p)))
                .collect()
        };
        let mut tried: Vec<PathBuf> = Vec::new();
        for c in cands {
            if c.is_file() {
                return Ok(c);
            }
            if super::text::exists(&c) {
                // It is there but no regular file: say what it is, not "not found".
                super::text::check_regular(&c, u64::MAX)?;
            }
            if !tried.contains(&c) {
                tried.push(c);
            }
        }
        Err(SceneError::AssetNotFound { scene_path: self.path.to_path_buf(), name: name.to_owned(), tried })
    }

    fn motion(&self, key: &str, m: &MotionDef) -> Result<Motion, SceneError> {
        let axis = self.finite(&format!("{key}.axis"), m.axis)?;
        let dps = self.scalar(&format!("{key}.degrees_per_second"), m.degrees_per_second)?;
        if dps != 0.0 && axis.length_squared() == 0.0 {
            return Err(
                self.invalid(format!("{key}.axis"), "rotation axis must not be zero when degrees_per_second is set")
            );
        }
        let period = self.scalar(&format!("{key}.period"), m.period)?;
        if period < 0.0 {
            return Err(self.invalid(format!("{key}.period"), "period must be >= 0 (0 = no oscillation)"));
        }
        Ok(Motion::Parametric {
            axis: axis.normalize_or_zero(),
            pivot: self.finite(&format!("{key}.pivot"), m.pivot)?,
            degrees_per_second: dps,
            velocity: self.finite(&format!("{key}.velocity"), m.velocity)?,
            amplitude: self.finite(&format!("{key}.amplitude"), m.amplitude)?,
            period,
        })
    }
}

impl SkyContext for Ctx<'_> {
    fn color(&self, key: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
        Ctx::color(self, key, v)
    }
    fn scalar(&self, key: &str, v: f32) -> Result<f32, SceneError> {
        Ctx::scalar(self, key, v)
    }
    fn invalid(&self, key: &str, message: String) -> SceneError {
        Ctx::invalid(self, key, message)
    }
    fn resolve(&self, name: &str) -> Result<PathBuf, SceneError> {
        Ctx::resolve(self, name)
    }
}

/// The scene's textures, each file loaded once per way of decoding it.
#[derive(Default)]
struct TextureSet {
    textures: Vec<Texture>,
    cache: HashMap<(PathBuf, MapKind, bool), u32>,
}

impl TextureSet {
    /// `y_down`: normal maps among what `kind` may give are in the DirectX convention.
    fn index(&mut self, path: &Path, referenced_by: &str, kind: MapKind, y_down: bool) -> Result<u32, SceneError> {
        let y_down = y_down && matches!(kind, MapKind::Normal | MapKind::Bump);
        let key = (path.to_path_buf(), kind, y_down);
        if let Some(&i) = self.cache.get(&key) {
            return Ok(i);
        }
        let tex = obj::load_texture(path, referenced_by, kind, y_down)?;
        let i = self.textures.len() as u32;
        self.textures.push(tex);
        self.cache.insert(key, i);
        Ok(i)
    }

    fn map(&mut self, map: &Option<obj::MtlMap>, kind: MapKind) -> Result<Option<u32>, SceneError> {
        map.as_ref().map(|m| self.index(&m.path, &m.referenced_by, kind, false)).transpose()
    }

    /// An MTL material with its maps loaded.
    fn mtl_material(&mut self, m: &obj::MtlMaterial, normal_maps: NormalMaps) -> Result<Material, SceneError> {
        let y_down = normal_maps == NormalMaps::DirectX;
        let normal_texture = match &m.bump {
            Some((map, kind)) => Some(self.index(&map.path, &map.referenced_by, *kind, y_down)?),
            None => None,
        };
        Ok(Material {
            name: m.name.clone(),
            albedo: m.albedo,
            albedo_texture: self.map(&m.albedo_texture, MapKind::Color)?,
            mask_texture: self.map(&m.mask_texture, MapKind::Mask)?,
            normal_texture,
            relief: Relief::Tile(m.bump_multiplier),
            specular: m.specular,
            shininess: m.shininess,
            emission: m.emission,
        })
    }
}

fn default_material() -> Material {
    Material::diffuse("default", Vec3::splat(0.8))
}

/// Validates `file` and loads everything it refers to, a section at a time in the order of
/// the steps below (the first error found is the one reported).
pub(crate) fn build(path: &Path, file: SceneFile, opts: &LoadOptions) -> Result<Scene, SceneError> {
    let ctx = Ctx::new(path, &file.scene, opts);
    let name = scene_name(path, &file.scene);
    let bounds = scene_bounds(&ctx, &file.scene)?;
    let camera = build_camera(&ctx, &file.camera)?;
    let settings = build_render_settings(&ctx, &file.render, file.gi, &camera)?;
    let mut textures = TextureSet::default();
    let (mut materials, ids) = build_materials(&ctx, &file.materials, &mut textures)?;
    let names = MaterialNames { ids, defs: &file.materials };
    let (meshes, objects) = build_objects(&ctx, &file.objects, &names, &mut materials, &mut textures, settings.time)?;
    let lights = build_lights(&ctx, &file.lights, settings.time)?;
    let sky = build_sky(&ctx, file.sky.as_ref())?;
    Ok(Scene {
        path: path.to_path_buf(),
        name,
        meshes,
        objects,
        materials,
        textures: textures.textures,
        camera,
        lights,
        sky,
        settings,
        bounds,
    })
}

/// `[scene] name`, else the file's name without its extension.
fn scene_name(path: &Path, scene: &SceneSection) -> String {
    match &scene.name {
        Some(n) if !n.is_empty() => n.clone(),
        _ => path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".to_owned()),
    }
}

/// `[scene.bounds]`, checked: finite, and min below max on every axis.
fn scene_bounds(ctx: &Ctx, scene: &SceneSection) -> Result<Option<Aabb>, SceneError> {
    let Some(b) = &scene.bounds else { return Ok(None) };
    let min = ctx.finite("scene.bounds.min", b.min)?;
    let max = ctx.finite("scene.bounds.max", b.max)?;
    if min.cmpge(max).any() {
        return Err(ctx.invalid("scene.bounds", format!("min {min} must be smaller than max {max} on every axis")));
    }
    Ok(Some(Aabb { min, max }))
}

/// `[camera]`, checked: finite, a field of view, near and far that make a frustum, and a
/// view direction with an up that is not along it.
fn build_camera(ctx: &Ctx, c: &CameraDef) -> Result<Camera, SceneError> {
    let camera = Camera {
        position: ctx.finite("camera.position", c.position)?,
        target: ctx.finite("camera.target", c.target)?,
        up: ctx.finite("camera.up", c.up)?,
        fov_y_deg: ctx.scalar("camera.fov_y", c.fov_y)?,
        near: ctx.scalar("camera.near", c.near)?,
        far: ctx.scalar("camera.far", c.far)?,
    };
    if !(camera.fov_y_deg > 0.0 && camera.fov_y_deg < 180.0) {
        return Err(ctx.invalid(
            "camera.fov_y",
            format!("{} is not in (0, 180) degrees (vertical field of view)", camera.fov_y_deg),
        ));
    }
    if camera.near <= 0.0 {
        return Err(ctx.invalid("camera.near", format!("{} must be > 0", camera.near)));
    }
    if camera.far <= camera.near {
        return Err(ctx.invalid("camera.far", format!("{} must be greater than near ({})", camera.far, camera.near)));
    }
    check_camera_aim(ctx, &camera)?;
    Ok(camera)
}

/// The camera looks somewhere (target apart from position, at a finite distance) with an up
/// that is not along its view.
fn check_camera_aim(ctx: &Ctx, camera: &Camera) -> Result<(), SceneError> {
    let view_dir = camera.target - camera.position;
    if view_dir.length_squared() == 0.0 {
        return Err(ctx.invalid("camera.target", "camera position and target are the same point"));
    }
    if !view_dir.length().is_finite() {
        return Err(ctx.invalid(
            "camera.target",
            format!("the distance from position {} to target {} overflows", camera.position, camera.target),
        ));
    }
    if view_dir.normalize().cross(camera.up.normalize_or_zero()).length_squared() < 1e-8 {
        return Err(ctx.invalid("camera.up", format!("up {} is zero or parallel to the view direction", camera.up)));
    }
    Ok(())
}

/// `[render]` with the `[gi]` settings, checked: sizes, the camera's matrices at this
/// aspect, finite numbers, the GI settings, then the ranges of the numbers.
fn build_render_settings(ctx: &Ctx, r: &RenderDef, gi: GiDef, camera: &Camera) -> Result<RenderSettings, SceneError> {
    check_render_sizes(ctx, r)?;
    // The camera matrices the renderer builds must be finite (huge coordinates or an extreme
    // near/far can overflow even when every input is finite).
    let aspect = r.width as f32 / r.height as f32;
    if !camera.view().is_finite() || !camera.projection(aspect).is_finite() {
        return Err(
            ctx.invalid("camera", "the view or projection matrix is not finite (coordinates or near/far too extreme)")
        );
    }
    let (exposure, exposure_auto) = match r.exposure {
        ExposureDef::Ev(v) => (ctx.scalar("render.exposure", v)?, false),
        ExposureDef::Auto => (0.0, true),
    };
    let settings = RenderSettings {
        width: r.width,
        height: r.height,
        time: ctx.scalar("render.time", r.time)?,
        exposure,
        exposure_auto,
        tonemap: r.tonemap,
        shadow_map_size: r.shadow_map_size,
        shadow_cascades: r.shadow_cascades,
        shadow_filter_radius: ctx.scalar("render.shadow_filter_radius", r.shadow_filter_radius)?,
        shadow_normal_bias: ctx.scalar("render.shadow_normal_bias", r.shadow_normal_bias)?,
        view: r.view,
        view_lod: ctx.scalar("render.view_lod", r.view_lod)?,
        view_direction: r.view_direction,
        supersample: r.supersample,
        depth_prepass: r.depth_prepass,
        gi: build_gi_settings(ctx, gi)?,
    };
    check_render_ranges(ctx, &settings)?;
    Ok(settings)
}

/// The image, supersampling, shadow cascade and shadow map sizes are in range.
fn check_render_sizes(ctx: &Ctx, r: &RenderDef) -> Result<(), SceneError> {
    for (key, v) in [("render.width", r.width), ("render.height", r.height)] {
        if !(1..=16384).contains(&v) {
            return Err(ctx.invalid(key, format!("{v} is not in 1..=16384")));
        }
    }
    if r.shadow_cascades > 4 {
        return Err(ctx.invalid("render.shadow_cascades", format!("{} is not in 0..=4", r.shadow_cascades)));
    }
    if !(1..=4).contains(&r.supersample) {
        return Err(ctx.invalid(
            "render.supersample",
            format!("{} is not in 1..=4 (samples per pixel: its square)", r.supersample),
        ));
    }
    if r.width.max(r.height) * r.supersample > 16384 {
        return Err(ctx.invalid(
            "render.supersample",
            format!("{} times the image size is over 16384 pixels on a side", r.supersample),
        ));
    }
    if !(16..=8192).contains(&r.shadow_map_size) {
        return Err(ctx.invalid("render.shadow_map_size", format!("{} is not in 16..=8192", r.shadow_map_size)));
    }
    Ok(())
}

/// `[gi]`, checked by [`GiSettings::validate`]; its errors name `gi.<key>`.
fn build_gi_settings(ctx: &Ctx, gi: GiDef) -> Result<GiSettings, SceneError> {
    gi.validate().map_err(|(key, message)| ctx.invalid(format!("gi.{key}"), message))?;
    Ok(gi)
}

/// The exposure, view LOD and shadow filter numbers are in range.
fn check_render_ranges(ctx: &Ctx, settings: &RenderSettings) -> Result<(), SceneError> {
    if !(-64.0..=64.0).contains(&settings.exposure) {
        return Err(ctx.invalid("render.exposure", format!("{} is not in -64..=64 (EV stops)", settings.exposure)));
    }
    if !(0.0..=16.0).contains(&settings.view_lod) {
        return Err(ctx.invalid("render.view_lod", format!("{} is not in 0..=16", settings.view_lod)));
    }
    if settings.shadow_filter_radius < 0.0 {
        return Err(ctx.invalid("render.shadow_filter_radius", "must be >= 0"));
    }
    if settings.shadow_normal_bias < 0.0 {
        return Err(ctx.invalid("render.shadow_normal_bias", "must be >= 0"));
    }
    Ok(())
}

/// `[[materials]]` with their textures loaded, and each one's index by name.
fn build_materials(
    ctx: &Ctx,
    defs: &[MaterialDef],
    textures: &mut TextureSet,
) -> Result<(Vec<Material>, HashMap<String, u32>), SceneError> {
    let mut materials: Vec<Material> = Vec::new();
    let mut by_name: HashMap<String, u32> = HashMap::new();
    for (i, m) in defs.iter().enumerate() {
        let key = format!("materials.{i}");
        if m.name.is_empty() {
            return Err(ctx.invalid(format!("{key}.name"), "material name must not be empty"));
        }
        if by_name.contains_key(&m.name) {
            return Err(ctx.invalid(format!("{key}.name"), format!("material `{}` is defined twice", m.name)));
        }
        let material = build_material(ctx, &key, m, textures)?;
        by_name.insert(m.name.clone(), materials.len() as u32);
        materials.push(material);
    }
    Ok((materials, by_name))
}

/// A material's relief: `bump_scale` (scene units per unit height) or `bump_relief` (times
/// the default relief in texture space), not both; neither is the default.
fn material_relief(ctx: &Ctx, key: &str, m: &MaterialDef) -> Result<Relief, SceneError> {
    match (m.bump_scale, m.bump_relief) {
        (Some(_), Some(_)) => Err(ctx.invalid(
            format!("{key}.bump_relief"),
            "give bump_scale (scene units per unit height) or bump_relief (times the default relief), not both",
        )),
        (Some(v), None) => Ok(Relief::Units(ctx.scalar(&format!("{key}.bump_scale"), v)?)),
        (None, Some(v)) => Ok(Relief::Tile(ctx.scalar(&format!("{key}.bump_relief"), v)?)),
        (None, None) => Ok(Relief::default()),
    }
}

/// One `[[materials]]` entry (at `key`), checked, with its textures loaded.
fn build_material(ctx: &Ctx, key: &str, m: &MaterialDef, textures: &mut TextureSet) -> Result<Material, SceneError> {
    let shininess = ctx.scalar(&format!("{key}.shininess"), m.shininess)?;
    if shininess < 0.0 {
        return Err(ctx.invalid(format!("{key}.shininess"), "must be >= 0"));
    }
    let relief = material_relief(ctx, key, m)?;
    if m.normal_texture.is_some() && m.bump_texture.is_some() {
        return Err(ctx.invalid(format!("{key}.bump_texture"), "give normal_texture or bump_texture, not both"));
    }
    let y_down = m.normal_maps == NormalMaps::DirectX;
    let mut map = |field: &str, file: &Option<String>, kind: MapKind| -> Result<Option<u32>, SceneError> {
        let Some(t) = file else { return Ok(None) };
        let p = ctx.resolve(t)?;
        Ok(Some(textures.index(&p, &format!("{} {key}.{field}", ctx.path.display()), kind, y_down)?))
    };
    let albedo_texture = map("albedo_texture", &m.albedo_texture, MapKind::Color)?;
    let mask_texture = map("mask_texture", &m.mask_texture, MapKind::Mask)?;
    let normal_texture = match map("normal_texture", &m.normal_texture, MapKind::Normal)? {
        Some(t) => Some(t),
        None => map("bump_texture", &m.bump_texture, MapKind::Height)?,
    };
    Ok(Material {
        name: m.name.clone(),
        albedo: ctx.color(&format!("{key}.albedo"), m.albedo)?,
        albedo_texture,
        mask_texture,
        normal_texture,
        relief,
        specular: ctx.color(&format!("{key}.specular"), m.specular)?,
        shininess,
        emission: ctx.color(&format!("{key}.emission"), m.emission)?,
    })
}

/// The `[[materials]]` names, for objects to refer to.
struct MaterialNames<'a> {
    ids: HashMap<String, u32>,
    defs: &'a [MaterialDef],
}

impl MaterialNames<'_> {
    /// The index of the material `name` that `key` refers to; an unknown one is an error that
    /// lists those defined.
    fn id(&self, ctx: &Ctx, key: String, name: &str) -> Result<u32, SceneError> {
        self.ids
            .get(name)
            .copied()
            .ok_or_else(|| ctx.invalid(key, format!("unknown material `{name}` ({})", self.defined())))
    }

    /// The defined names, sorted, for an error message.
    fn defined(&self) -> String {
        let mut v: Vec<&str> = self.defs.iter().map(|m| m.name.as_str()).collect();
        v.sort_unstable();
        if v.is_empty() {
            "none are defined; add a [[materials]] entry".to_owned()
        } else {
            format!("defined: {}", v.join(", "))
        }
    }
}

/// Each OBJ file loaded, per normal-map convention (which decides how its materials' maps
/// load), with the scene material index of each of its MTL materials.
type ObjCache = HashMap<(PathBuf, NormalMaps), (ObjData, Vec<Option<u32>>)>;

/// `[[objects]]`: their meshes (a mesh per OBJ group) and the objects, checked to stay finite
/// in world space at `time`; MTL materials and the default material are added to `materials`.
fn build_objects(
    ctx: &Ctx,
    defs: &[ObjectDef],
    names: &MaterialNames,
    materials: &mut Vec<Material>,
    textures: &mut TextureSet,
    time: f32,
) -> Result<(Vec<Mesh>, Vec<Object>), SceneError> {
    let mut meshes: Vec<Mesh> = Vec::new();
    let mut objects: Vec<Object> = Vec::new();
    let mut obj_cache = ObjCache::new();
    let mut default_mat: Option<u32> = None;
    // Objects with groups that have no material, said once after the loop (3000 objects must
    // not give 3000 warnings).
    let mut defaulted_objects: Vec<String> = Vec::new();
    for (i, o) in defs.iter().enumerate() {
        let key = format!("objects.{i}");
        let (object_mat, group_mats) = object_materials(ctx, &key, o, names)?;
        let translate = ctx.finite(&format!("{key}.translate"), o.translate)?;
        let rotate = ctx.finite(&format!("{key}.rotate"), o.rotate)?;
        let scale = ctx.scale(&format!("{key}.scale"), o.scale)?;
        let motion = object_motion(ctx, &key, o)?;
        let obj_path = ctx.resolve(&o.obj)?;
        let (data, mtl_ids) = load_obj_once(&mut obj_cache, &obj_path, o.normal_maps, materials, textures)?;
        check_groups_exist(ctx, &key, &obj_path, data, &group_mats)?;
        let groups = GroupMaterials { by_group: &group_mats, object: object_mat, mtl: mtl_ids };
        let (mesh_ids, defaulted) = add_group_meshes(data, &groups, &mut meshes, materials, &mut default_mat);
        if !defaulted.is_empty() {
            defaulted_objects.push(format!("{key} ({}): group(s) {}", obj_path.display(), defaulted.join(", ")));
        }
        if mesh_ids.is_empty() {
            log::warn!("{}: {key}: {} contains no triangles", ctx.path.display(), obj_path.display());
        }
        let object = Object {
            name: match &o.name {
                Some(n) if !n.is_empty() => n.clone(),
                _ => obj_path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
            },
            meshes: mesh_ids,
            transform: Mat4::from_scale_rotation_translation(scale, euler_quat(rotate), translate),
            dynamic: o.dynamic,
            motion,
        };
        check_object_finite(ctx, key, &obj_path, &object, &meshes, time)?;
        objects.push(object);
    }
    warn_defaulted(ctx.path, &defaulted_objects);
    Ok((meshes, objects))
}

/// The object's `material` and its per-group `materials`, as material indices.
fn object_materials<'o>(
    ctx: &Ctx,
    key: &str,
    o: &'o ObjectDef,
    names: &MaterialNames,
) -> Result<(Option<u32>, BTreeMap<&'o str, u32>), SceneError> {
    let object_mat = match &o.material {
        Some(m) => Some(names.id(ctx, format!("{key}.material"), m)?),
        None => None,
    };
    let mut group_mats: BTreeMap<&str, u32> = BTreeMap::new();
    for (g, m) in &o.materials {
        group_mats.insert(g.as_str(), names.id(ctx, format!("{key}.materials.{g}"), m)?);
    }
    Ok((object_mat, group_mats))
}

/// The object's `motion` or `keyframes` (not both); a moving object must be `dynamic`.
fn object_motion(ctx: &Ctx, key: &str, o: &ObjectDef) -> Result<Motion, SceneError> {
    let motion = match (&o.motion, &o.keyframes) {
        (Some(_), Some(_)) => return Err(ctx.invalid(key, "an object can have `motion` or `keyframes`, not both")),
        (Some(m), None) => ctx.motion(&format!("{key}.motion"), m)?,
        (None, Some(keys)) => keyframes(ctx, key, keys)?,
        (None, None) => Motion::None,
    };
    if !motion.is_static() && !o.dynamic {
        return Err(ctx.invalid(
            format!("{key}.dynamic"),
            "an object with `motion` or `keyframes` must be marked `dynamic = true`",
        ));
    }
    Ok(motion)
}

/// The object's `keyframes`: not empty, finite, and at increasing times.
fn keyframes(ctx: &Ctx, key: &str, keys: &[KeyframeDef]) -> Result<Motion, SceneError> {
    if keys.is_empty() {
        return Err(ctx.invalid(format!("{key}.keyframes"), "keyframe list is empty"));
    }
    let mut out: Vec<Keyframe> = Vec::with_capacity(keys.len());
    for (k, kf) in keys.iter().enumerate() {
        let kk = format!("{key}.keyframes.{k}");
        let time = ctx.scalar(&format!("{kk}.time"), kf.time)?;
        if let Some(prev) = out.last().map(|p| p.time) {
            if time <= prev {
                return Err(
                    ctx.invalid(format!("{kk}.time"), format!("keyframe times must increase ({time} follows {prev})"))
                );
            }
        }
        out.push(Keyframe {
            time,
            translate: ctx.finite(&format!("{kk}.translate"), kf.translate)?,
            rotate_deg: ctx.finite(&format!("{kk}.rotate"), kf.rotate)?,
            scale: ctx.scale(&format!("{kk}.scale"), kf.scale)?,
        });
    }
    Ok(Motion::Keyframes(out))
}

/// The OBJ file at `obj_path`, loaded the first time it is asked for with these normal maps
/// (its MTL materials then added to `materials`), with its materials' scene indices.
fn load_obj_once<'c>(
    cache: &'c mut ObjCache,
    obj_path: &Path,
    normal_maps: NormalMaps,
    materials: &mut Vec<Material>,
    textures: &mut TextureSet,
) -> Result<&'c (ObjData, Vec<Option<u32>>), SceneError> {
    match cache.entry((obj_path.to_path_buf(), normal_maps)) {
        std::collections::hash_map::Entry::Occupied(e) => Ok(e.into_mut()),
        std::collections::hash_map::Entry::Vacant(e) => {
            let data = obj::load_obj(obj_path)?;
            let mut mtl_ids = Vec::with_capacity(data.materials.len());
            for m in &data.materials {
                mtl_ids.push(Some(materials.len() as u32));
                materials.push(textures.mtl_material(m, normal_maps)?);
            }
            Ok(e.insert((data, mtl_ids)))
        }
    }
}

/// Every group the object's `materials` names is a group of its OBJ file.
fn check_groups_exist(
    ctx: &Ctx,
    key: &str,
    obj_path: &Path,
    data: &ObjData,
    group_mats: &BTreeMap<&str, u32>,
) -> Result<(), SceneError> {
    for g in group_mats.keys() {
        if !data.groups.iter().any(|x| x.name == *g) {
            let mut names: Vec<&str> = data.groups.iter().map(|x| x.name.as_str()).collect();
            names.sort_unstable();
            names.dedup();
            return Err(ctx.invalid(
                format!("{key}.materials.{g}"),
                format!("{} has no group `{g}`; its groups are: {}", obj_path.display(), names.join(", ")),
            ));
        }
    }
    Ok(())
}

/// Where an object's groups get their material: its per-group `materials`, else its
/// `material`, else the group's MTL material (by index in the file's MTL materials).
struct GroupMaterials<'a> {
    by_group: &'a BTreeMap<&'a str, u32>,
    object: Option<u32>,
    mtl: &'a [Option<u32>],
}

/// A mesh for each group of the OBJ file; groups with no material get the default one
/// (added once). Gives the new meshes' indices and the groups defaulted.
fn add_group_meshes<'d>(
    data: &'d ObjData,
    groups: &GroupMaterials,
    meshes: &mut Vec<Mesh>,
    materials: &mut Vec<Material>,
    default_mat: &mut Option<u32>,
) -> (Vec<u32>, Vec<&'d str>) {
    let mut mesh_ids = Vec::with_capacity(data.groups.len());
    let mut defaulted = Vec::new();
    for g in &data.groups {
        let mtl = g.material.and_then(|k| groups.mtl.get(k).copied().flatten());
        let material = match (groups.by_group.get(g.name.as_str()), groups.object, mtl) {
            (Some(&m), _, _) | (None, Some(m), _) | (None, None, Some(m)) => m,
            (None, None, None) => {
                defaulted.push(g.name.as_str());
                *default_mat.get_or_insert_with(|| {
                    materials.push(default_material());
                    (materials.len() - 1) as u32
                })
            }
        };
        mesh_ids.push(meshes.len() as u32);
        meshes.push(Mesh {
            name: g.name.clone(),
            positions: g.positions.clone(),
            normals: g.normals.clone(),
            uvs: g.uvs.clone(),
            indices: g.indices.clone(),
            material,
            bounds: g.bounds,
        });
    }
    (mesh_ids, defaulted)
}

/// The object's matrix and meshes' bounds at `time` are finite: finite inputs can still
/// overflow once transformed (a huge scale, a fast motion at a late render.time), and the
/// renderer must never see non-finite world positions.
fn check_object_finite(
    ctx: &Ctx,
    key: String,
    obj_path: &Path,
    object: &Object,
    meshes: &[Mesh],
    time: f32,
) -> Result<(), SceneError> {
    let m = object.model_matrix(time);
    let finite = m.is_finite()
        && object.meshes.iter().all(|&k| {
            let b = meshes[k as usize].bounds.transformed(&m);
            b.min.is_finite() && b.max.is_finite() && b.extent().is_finite()
        });
    if !finite {
        return Err(ctx.invalid(
            key,
            format!(
                "{} transformed to world space at time {time} is not finite (scale, translation or motion too large)",
                obj_path.display()
            ),
        ));
    }
    Ok(())
}

/// `[[lights]]`, each checked to have a finite position and direction at `time`.
fn build_lights(ctx: &Ctx, defs: &[LightDef], time: f32) -> Result<Vec<Light>, SceneError> {
    let mut lights = Vec::with_capacity(defs.len());
    for (i, l) in defs.iter().enumerate() {
        let l = build_light(ctx, i, l)?;
        let finite = match l.at_time(time) {
            LightKind::Point { position, .. } => position.is_finite(),
            LightKind::Directional { direction, .. } => direction.is_finite() && direction != Vec3::ZERO,
            LightKind::Spot { position, direction, .. } => {
                position.is_finite() && direction.is_finite() && direction != Vec3::ZERO
            }
        };
        if !finite {
            return Err(ctx.invalid(
                format!("lights.{i}"),
                format!("the light's position or direction at time {time} is not finite (motion too large)"),
            ));
        }
        lights.push(l);
    }
    Ok(lights)
}

/// One `[[lights]]` entry (number `i`), checked.
fn build_light(ctx: &Ctx, i: usize, l: &LightDef) -> Result<Light, SceneError> {
    let key = format!("lights.{i}");
    check_light_keys(ctx, &key, l)?;
    let kind = light_kind(ctx, &key, l)?;
    let motion = match &l.motion {
        Some(m) => ctx.motion(&format!("{key}.motion"), m)?,
        None => Motion::None,
    };
    Ok(Light {
        name: match &l.name {
            Some(n) if !n.is_empty() => n.clone(),
            _ => format!("{}{i}", l.kind),
        },
        kind,
        cast_shadows: l.cast_shadows,
        motion,
    })
}

/// The light's `type` is known, and it has the keys that type needs and no others.
fn check_light_keys(ctx: &Ctx, key: &str, l: &LightDef) -> Result<(), SceneError> {
    let (allowed, required): (&[&str], &[&str]) = match l.kind.as_str() {
        "point" => (&["position", "intensity"], &["position", "intensity"]),
        "directional" => (&["direction", "irradiance"], &["direction", "irradiance"]),
        "spot" => (
            &["position", "direction", "intensity", "inner_angle", "outer_angle"],
            &["position", "direction", "intensity"],
        ),
        other => {
            return Err(ctx.invalid(
                format!("{key}.type"),
                format!("unknown light type `{other}`; expected one of: point, directional, spot"),
            ))
        }
    };
    let present = [
        ("position", l.position.is_some()),
        ("intensity", l.intensity.is_some()),
        ("direction", l.direction.is_some()),
        ("irradiance", l.irradiance.is_some()),
        ("inner_angle", l.inner_angle.is_some()),
        ("outer_angle", l.outer_angle.is_some()),
    ];
    let misplaced = |k: &str| {
        let takes = allowed.join(", ");
        let message =
            format!("`{k}` does not apply to {} lights (they take: {takes}, plus name, cast_shadows, motion)", l.kind);
        ctx.invalid(format!("{key}.{k}"), message)
    };
    let missing = |k: &str| ctx.invalid(format!("{key}.{k}"), format!("a {} light needs `{k}`", l.kind));
    check_keys(&present, (allowed, required), misplaced, missing)
}

/// A table whose `type` decides its keys: the first of `present`'s keys that is set but not
/// allowed gives `misplaced(key)`, the first required one that is unset `missing(key)`.
pub(crate) fn check_keys(
    present: &[(&str, bool)],
    (allowed, required): (&[&str], &[&str]),
    misplaced: impl Fn(&str) -> SceneError,
    missing: impl Fn(&str) -> SceneError,
) -> Result<(), SceneError> {
    for &(k, is) in present {
        if is && !allowed.contains(&k) {
            return Err(misplaced(k));
        }
        if !is && required.contains(&k) {
            return Err(missing(k));
        }
    }
    Ok(())
}

/// The light's kind and its checked values (its keys already checked for its `type`).
fn light_kind(ctx: &Ctx, key: &str, l: &LightDef) -> Result<LightKind, SceneError> {
    let get = |v: Option<[f32; 3]>| v.unwrap_or([0.0; 3]);
    let direction = || -> Result<Vec3, SceneError> {
        let d = ctx.finite(&format!("{key}.direction"), get(l.direction))?;
        if d.length_squared() == 0.0 {
            return Err(ctx.invalid(format!("{key}.direction"), "direction must not be zero"));
        }
        Ok(d.normalize())
    };
    Ok(match l.kind.as_str() {
        "point" => LightKind::Point {
            position: ctx.finite(&format!("{key}.position"), get(l.position))?,
            intensity: ctx.color(&format!("{key}.intensity"), get(l.intensity))?,
        },
        "directional" => LightKind::Directional {
            direction: direction()?,
            irradiance: ctx.color(&format!("{key}.irradiance"), get(l.irradiance))?,
        },
        _ => {
            let (inner, outer) = spot_angles(ctx, key, l)?;
            LightKind::Spot {
                position: ctx.finite(&format!("{key}.position"), get(l.position))?,
                direction: direction()?,
                intensity: ctx.color(&format!("{key}.intensity"), get(l.intensity))?,
                inner_deg: inner,
                outer_deg: outer,
            }
        }
    })
}

/// A spot light's inner and outer half-angles in degrees: `outer` in [0, 90), `inner` in
/// [0, outer].
fn spot_angles(ctx: &Ctx, key: &str, l: &LightDef) -> Result<(f32, f32), SceneError> {
    let inner = ctx.scalar(&format!("{key}.inner_angle"), l.inner_angle.unwrap_or(20.0))?;
    let outer = ctx.scalar(&format!("{key}.outer_angle"), l.outer_angle.unwrap_or(30.0))?;
    if !(0.0..90.0).contains(&outer) {
        return Err(ctx
            .invalid(format!("{key}.outer_angle"), format!("{outer} is not in [0, 90) degrees (it is a half-angle)")));
    }
    if !(0.0..=outer).contains(&inner) {
        return Err(
            ctx.invalid(format!("{key}.inner_angle"), format!("{inner} must be in [0, outer_angle = {outer}] degrees"))
        );
    }
    Ok((inner, outer))
}

/// One warning for every object with groups that have no material (the first few named).
fn warn_defaulted(path: &Path, objects: &[String]) {
    const SHOWN: usize = 3;
    match objects {
        [] => {}
        [one] => log::warn!("{}: {one}: no material; using the default white material", path.display()),
        many => log::warn!(
            "{}: {} objects have groups with no material; they use the default white material: {}{}",
            path.display(),
            many.len(),
            many[..SHOWN.min(many.len())].join("; "),
            if many.len() > SHOWN { format!("; and {} more", many.len() - SHOWN) } else { String::new() }
        ),
    }
}
