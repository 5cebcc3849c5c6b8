//! The speed/accuracy sweep: render a scene under a grid of cone-tracing settings, time each
//! configuration with the bench's timing code ([`crate::bench::measure_renderer`]), compare its
//! image with the path-traced reference ([`crate::reference`], rendered once per setup and
//! cached in the output directory), and mark the Pareto-optimal configurations per metric.
//!
//! Output directory: `results.csv` (one row per configuration, appended and flushed as each
//! finishes, so an interrupted sweep resumes where it stopped), `results.json` (the setup, the
//! rows and the fronts), `frontier-<metric>.svg` (time against error, front highlighted),
//! `reference.exr` / `reference.var.exr` / `reference.json` (the cached ground truth, with
//! `reference.png` its display image) and
//! `sweep.json` (the setup a resumed sweep must match).

use crate::bench::{measure_renderer, Measure};
use crate::gpu::Context;
use crate::metrics::{compare, Comparison, LinearImage};
use crate::reference::{PathTracer, ReferenceOptions};
use crate::render::{RenderOptions, Renderer};
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    #[error("--grid {arg}: {message}")]
    BadAxis { arg: String, message: String },
    #[error(
        "{dir} holds a sweep with a different setup ({what} was {old}, now {new}); use another --out \
         directory or delete {dir}"
    )]
    SetupChanged { dir: PathBuf, what: String, old: String, new: String },
    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },
}

fn one() -> u32 {
    1
}

/// One knob the sweep varies: the `[gi]` key it sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Param {
    VoxelResolution,
    DiffuseCones,
    /// `gi.diffuse_cone_angle`, degrees (0 = automatic).
    DiffuseConeAngle,
    /// `gi.step` (beta).
    Step,
    Bounces,
    Downsample,
    /// `gi.ao` (0 = off, 1 = on): whether AO multiplies the traced indirect light.
    Ao,
    /// `gi.bounce_cones` (0 = as `diffuse_cones`).
    BounceCones,
    /// `gi.bounce_interleave`: one in N static voxels gathers the bounce per update.
    BounceInterleave,
    /// `gi.mode`, the technique: values are names (`--grid mode=vct,rsm`), held as their
    /// index in [`TECHNIQUES`].
    Mode,
    /// `gi.rsm_samples`.
    RsmSamples,
    /// `gi.rsm_radius` (a fraction of the map's side).
    RsmRadius,
    /// `gi.rsm_size` (texels per side).
    RsmSize,
    /// `gi.lpv_resolution` (cells per side).
    LpvResolution,
    /// `gi.lpv_steps`.
    LpvSteps,
    /// `gi.specular`, where reflections come from: values are names (`--grid specular=cone,rt`),
    /// held as their index in [`SPECULAR_SOURCES`].
    Specular,
    /// `gi.specular_rays`: rays per traced pixel on glossy surfaces with `specular = "rt"`.
    SpecularRays,
    /// `gi.rt_hit_indirect`, by name (index in [`HIT_INDIRECT`]).
    RtHitIndirect,
    /// `gi.specular_history`: frames the rays are averaged over while the view stands still.
    SpecularHistory,
    /// `gi.shadows`, how direct light is shadowed, by name (index in [`SHADOW_KINDS`]).
    Shadows,
    /// `gi.opacity`, how cone samples follow walls, by name (index in [`OPACITIES`]).
    Opacity,
    /// `gi.voxel_cover`, how opaque a voxel its surfaces make, by name (index in
    /// [`VOXEL_COVERS`]).
    VoxelCover,
    /// `gi.footprint`, how a pixel's cones composite their footprints, by name (index in
    /// [`FOOTPRINTS`]).
    Footprint,
    /// `gi.bounce_footprint`, the same for the voxel bounce's cones (index in [`FOOTPRINTS`]).
    BounceFootprint,
    /// `gi.attenuation`, how the voxel light turns with the voxel's faces, by name (index in
    /// [`ATTENUATIONS`]).
    Attenuation,
    /// `gi.plane_backs`, what cones see of a one-plane voxel from behind, by name (index in
    /// [`PLANE_BACKS`]).
    PlaneBacks,
    /// `gi.cone_filter`, how a cone sample filters the volumes, by name (index in
    /// [`CONE_FILTERS`]).
    ConeFilter,
}

/// The `gi.mode` values a sweep can compare, in the order of their index as a knob value.
pub const TECHNIQUES: [&str; 5] = ["none", "vct", "rsm", "lpv", "rsm+lpv"];

fn technique_index(mode: &str) -> f64 {
    name_index(&TECHNIQUES, mode)
}

/// The `gi.specular` values a sweep can compare, in the order of their index as a knob value.
pub const SPECULAR_SOURCES: [&str; 3] = ["off", "cone", "rt"];

/// The `gi.rt_hit_indirect` values, in the order of their index as a knob value.
pub const HIT_INDIRECT: [&str; 2] = ["cones", "voxel"];

/// The `gi.shadows` values, in the order of their index as a knob value.
pub const SHADOW_KINDS: [&str; 3] = ["shadow-map", "cone", "rt"];

/// The `gi.opacity` values, in the order of their index as a knob value.
pub const OPACITIES: [&str; 2] = ["blend", "layers"];

/// The `gi.voxel_cover` values, in the order of their index as a knob value.
pub const VOXEL_COVERS: [&str; 3] = ["touch", "area", "directional"];

/// The `gi.footprint` values, in the order of their index as a knob value.
pub const FOOTPRINTS: [&str; 3] = ["whole", "quadrants", "shares"];

/// The `gi.attenuation` values, in the order of their index as a knob value.
pub const ATTENUATIONS: [&str; 3] = ["normal-weighted", "n-dot-l", "per-side"];

/// The `gi.plane_backs` values, in the order of their index as a knob value.
pub const PLANE_BACKS: [&str; 3] = ["lit", "dark", "closed"];

/// The `gi.cone_filter` values, in the order of their index as a knob value.
pub const CONE_FILTERS: [&str; 2] = ["trilinear", "two-tap"];

fn trilinear() -> String {
    "trilinear".to_owned()
}

fn lit() -> String {
    "lit".to_owned()
}

fn touch() -> String {
    "touch".to_owned()
}

fn whole() -> String {
    "whole".to_owned()
}

fn blend() -> String {
    "blend".to_owned()
}

/// A name's index among a knob's names (NaN if it is not one).
fn name_index(names: &[&str], name: &str) -> f64 {
    names.iter().position(|t| *t == name).map_or(f64::NAN, |i| i as f64)
}

fn specular_index(source: &str) -> f64 {
    name_index(&SPECULAR_SOURCES, source)
}

fn voxel() -> String {
    "voxel".to_owned()
}

fn cone() -> String {
    "cone".to_owned()
}

fn shadow_map() -> String {
    "shadow-map".to_owned()
}

fn sixteen() -> u32 {
    16
}

fn vct() -> String {
    "vct".to_owned()
}

impl Param {
    pub const ALL: [Param; 27] = [
        Param::VoxelResolution,
        Param::DiffuseCones,
        Param::DiffuseConeAngle,
        Param::Step,
        Param::Bounces,
        Param::Downsample,
        Param::Ao,
        Param::BounceCones,
        Param::BounceInterleave,
        Param::Mode,
        Param::RsmSamples,
        Param::RsmRadius,
        Param::RsmSize,
        Param::LpvResolution,
        Param::LpvSteps,
        Param::Specular,
        Param::SpecularRays,
        Param::RtHitIndirect,
        Param::SpecularHistory,
        Param::Shadows,
        Param::Opacity,
        Param::VoxelCover,
        Param::Footprint,
        Param::BounceFootprint,
        Param::Attenuation,
        Param::PlaneBacks,
        Param::ConeFilter,
    ];
    /// The key under `[gi]`.
    pub fn key(self) -> &'static str {
        match self {
            Param::VoxelResolution => "voxel_resolution",
            Param::DiffuseCones => "diffuse_cones",
            Param::DiffuseConeAngle => "diffuse_cone_angle",
            Param::Step => "step",
            Param::Bounces => "bounces",
            Param::Downsample => "downsample",
            Param::Ao => "ao",
            Param::BounceCones => "bounce_cones",
            Param::BounceInterleave => "bounce_interleave",
            Param::Mode => "mode",
            Param::RsmSamples => "rsm_samples",
            Param::RsmRadius => "rsm_radius",
            Param::RsmSize => "rsm_size",
            Param::LpvResolution => "lpv_resolution",
            Param::LpvSteps => "lpv_steps",
            Param::Specular => "specular",
            Param::SpecularRays => "specular_rays",
            Param::RtHitIndirect => "rt_hit_indirect",
            Param::SpecularHistory => "specular_history",
            Param::Shadows => "shadows",
            Param::Opacity => "opacity",
            Param::VoxelCover => "voxel_cover",
            Param::Footprint => "footprint",
            Param::BounceFootprint => "bounce_footprint",
            Param::Attenuation => "attenuation",
            Param::PlaneBacks => "plane_backs",
            Param::ConeFilter => "cone_filter",
        }
    }
    /// Short prefix in configuration labels.
    fn short(self) -> &'static str {
        match self {
            Param::VoxelResolution => "v",
            Param::DiffuseCones => "c",
            Param::DiffuseConeAngle => "a",
            Param::Step => "s",
            Param::Bounces => "b",
            Param::Downsample => "k",
            Param::Ao => "o",
            Param::BounceCones => "bc",
            Param::BounceInterleave => "i",
            Param::Mode => "",
            Param::RsmSamples => "n",
            Param::RsmRadius => "r",
            Param::RsmSize => "m",
            Param::LpvResolution => "g",
            Param::LpvSteps => "p",
            Param::Specular => "spec-",
            Param::SpecularRays => "sr",
            Param::RtHitIndirect => "hit-",
            Param::SpecularHistory => "sh",
            Param::Shadows => "shadow-",
            Param::Opacity => "op-",
            Param::VoxelCover => "cover-",
            Param::Footprint => "fp-",
            Param::BounceFootprint => "bfp-",
            Param::Attenuation => "att-",
            Param::PlaneBacks => "backs-",
            Param::ConeFilter => "filter-",
        }
    }
    /// The names a knob's values are written as, for knobs that take names.
    fn names(self) -> Option<&'static [&'static str]> {
        match self {
            Param::Mode => Some(&TECHNIQUES),
            Param::Specular => Some(&SPECULAR_SOURCES),
            Param::RtHitIndirect => Some(&HIT_INDIRECT),
            Param::Shadows => Some(&SHADOW_KINDS),
            Param::Opacity => Some(&OPACITIES),
            Param::VoxelCover => Some(&VOXEL_COVERS),
            Param::Footprint | Param::BounceFootprint => Some(&FOOTPRINTS),
            Param::Attenuation => Some(&ATTENUATIONS),
            Param::PlaneBacks => Some(&PLANE_BACKS),
            Param::ConeFilter => Some(&CONE_FILTERS),
            _ => None,
        }
    }
    fn integer(self) -> bool {
        !matches!(self, Param::DiffuseConeAngle | Param::Step | Param::RsmRadius)
    }
    pub fn from_key(key: &str) -> Option<Param> {
        let key = key.strip_prefix("gi.").unwrap_or(key);
        Param::ALL.into_iter().find(|p| p.key() == key)
    }
}

/// Values per knob; the sweep runs their Cartesian product.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Grid {
    pub axes: Vec<(Param, Vec<f64>)>,
}

impl Grid {
    /// The grid used when no `--grid` is given: 3 x 3 x 2 x 2 x 3 x 2 = 216 configurations
    /// (AO stays as the scene sets it). The cone counts take in the default, 16 (issue 43).
    pub fn default_grid() -> Grid {
        Grid {
            axes: vec![
                (Param::VoxelResolution, vec![32.0, 64.0, 128.0]),
                (Param::DiffuseCones, vec![4.0, 9.0, 16.0]),
                (Param::DiffuseConeAngle, vec![0.0, 45.0]),
                (Param::Step, vec![0.5, 1.0]),
                (Param::Bounces, vec![0.0, 1.0, 2.0]),
                (Param::Downsample, vec![1.0, 2.0]),
            ],
        }
    }

    /// From `--grid KEY=V1,V2,...` arguments (each knob at most once).
    pub fn parse(args: &[String]) -> Result<Grid, SweepError> {
        let mut axes: Vec<(Param, Vec<f64>)> = Vec::new();
        for arg in args {
            let bad = |message: String| SweepError::BadAxis { arg: arg.clone(), message };
            let (key, values) = arg.split_once('=').ok_or_else(|| bad("expected KEY=V1,V2,...".into()))?;
            let param = Param::from_key(key.trim()).ok_or_else(|| {
                bad(format!(
                    "unknown knob {key:?}; one of {}",
                    Param::ALL.iter().map(|p| p.key()).collect::<Vec<_>>().join(", ")
                ))
            })?;
            if axes.iter().any(|(p, _)| *p == param) {
                return Err(bad(format!("{} given twice", param.key())));
            }
            let mut vals = Vec::new();
            for v in values.split(',').map(str::trim).filter(|v| !v.is_empty()) {
                let x: f64 = if let Some(names) = param.names() {
                    let i = name_index(names, v);
                    if i.is_nan() {
                        return Err(bad(format!("{v:?} is not a {} value; one of {}", param.key(), names.join(", "))));
                    }
                    i
                } else {
                    v.parse().map_err(|_| bad(format!("{v:?} is not a number")))?
                };
                if !x.is_finite() || (param.integer() && x.fract() != 0.0) || x < 0.0 || (param == Param::Ao && x > 1.0)
                {
                    return Err(bad(format!(
                        "{v} is not a valid {} value{}",
                        param.key(),
                        if param.integer() { " (a whole number >= 0)" } else { " (a number >= 0)" }
                    )));
                }
                if !vals.contains(&x) {
                    vals.push(x);
                }
            }
            if vals.is_empty() {
                return Err(bad("no values".into()));
            }
            axes.push((param, vals));
        }
        Ok(Grid { axes })
    }

    /// Every combination, first axis slowest.
    pub fn configs(&self) -> Vec<Config> {
        let mut out = vec![Config { values: Vec::new() }];
        for (param, vals) in &self.axes {
            out = out
                .into_iter()
                .flat_map(|c| {
                    vals.iter().map(move |&v| {
                        let mut c = c.clone();
                        c.values.push((*param, v));
                        c
                    })
                })
                .collect();
        }
        out
    }
}

/// One configuration: a value for each swept knob (the others keep the scene's values).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Config {
    pub values: Vec<(Param, f64)>,
}

impl Config {
    /// e.g. `v64 c6 a0 s0.5 b1 k1`; a technique by its name (`rsm n128 r0.5 k2`).
    pub fn label(&self) -> String {
        self.values.iter().map(|(p, v)| format!("{}{}", p.short(), value_text(*p, *v))).collect::<Vec<_>>().join(" ")
    }
    /// As `--set` overrides.
    pub fn overrides(&self) -> Vec<(String, String)> {
        self.values
            .iter()
            .map(|(p, v)| {
                let value = match p {
                    Param::Ao => (*v != 0.0).to_string(),
                    _ if p.names().is_some() => format!("{:?}", value_text(*p, *v)),
                    _ => fmt_value(*v),
                };
                (format!("gi.{}", p.key()), value)
            })
            .collect()
    }
    pub fn get(&self, p: Param) -> Option<f64> {
        self.values.iter().find(|(q, _)| *q == p).map(|(_, v)| *v)
    }
}

/// A knob value as written: a technique's name, else the number.
pub fn value_text(p: Param, v: f64) -> String {
    match p.names() {
        Some(names) => names.get(v as usize).copied().unwrap_or("?").to_owned(),
        None => fmt_value(v),
    }
}

fn fmt_value(v: f64) -> String {
    if v.fract() == 0.0 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}

/// The metrics a front is drawn for: name, axis label, the error of a row (lower is better).
pub const METRICS: [(&str, &str); 4] = [
    ("rmse", "RMSE (linear radiance)"),
    ("relmse", "relMSE (linear radiance)"),
    ("flip", "mean FLIP (display image)"),
    ("ssim", "1 - mean SSIM (display image)"),
];

/// The name a setting is written as in scene files (its serde string), if it is one.
fn serde_name(value: impl Serialize) -> Option<String> {
    serde_json::to_value(value).ok().and_then(|v| v.as_str().map(str::to_owned))
}

/// One finished configuration (a CSV row).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    pub label: String,
    pub voxel_resolution: u32,
    pub diffuse_cones: u32,
    pub diffuse_cone_angle: f32,
    pub step: f32,
    pub bounces: u32,
    pub downsample: u32,
    pub ao: bool,
    /// `gi.bounce_cones` (0: as `diffuse_cones`); absent in rows from before it existed.
    #[serde(default)]
    pub bounce_cones: u32,
    /// `gi.bounce_interleave`; absent (1) in rows from before it existed.
    #[serde(default = "one")]
    pub bounce_interleave: u32,
    /// `gi.mode`: the technique ("vct" in rows from before it was recorded).
    #[serde(default = "vct")]
    pub mode: String,
    /// `gi.rsm_samples`, `gi.rsm_radius`, `gi.rsm_size` (0 in rows from before RSM).
    #[serde(default)]
    pub rsm_samples: u32,
    #[serde(default)]
    pub rsm_radius: f32,
    #[serde(default)]
    pub rsm_size: u32,
    /// `gi.lpv_resolution`, `gi.lpv_steps` (0 in rows from before LPV).
    #[serde(default)]
    pub lpv_resolution: u32,
    #[serde(default)]
    pub lpv_steps: u32,
    /// `gi.specular` ("cone" in rows from before it was recorded) and `gi.specular_rays`.
    #[serde(default = "cone")]
    pub specular: String,
    #[serde(default = "sixteen")]
    pub specular_rays: u32,
    /// `gi.rt_hit_indirect` ("voxel" in rows from before it was recorded).
    #[serde(default = "voxel")]
    pub rt_hit_indirect: String,
    /// `gi.specular_history` (1 in rows from before it was recorded: one frame's rays).
    #[serde(default = "one")]
    pub specular_history: u32,
    /// `gi.shadows` ("shadow-map" in rows from before it was recorded).
    #[serde(default = "shadow_map")]
    pub shadows: String,
    /// `gi.opacity` ("blend" in rows from before it was recorded).
    #[serde(default = "blend")]
    pub opacity: String,
    /// `gi.voxel_cover` ("touch" in rows from before it was recorded).
    #[serde(default = "touch")]
    pub voxel_cover: String,
    /// `gi.footprint` ("whole" in rows from before it was recorded).
    #[serde(default = "whole")]
    pub footprint: String,
    /// `gi.bounce_footprint` (empty in rows from before it was recorded: `footprint` then set
    /// the bounce's too, so a row's value is not known from what it recorded).
    #[serde(default)]
    pub bounce_footprint: String,
    /// `gi.attenuation` (empty in rows from before it was recorded: the default has changed,
    /// so their value is not known).
    #[serde(default)]
    pub attenuation: String,
    /// `gi.plane_backs` ("lit" in rows from before it was recorded).
    #[serde(default = "lit")]
    pub plane_backs: String,
    /// `gi.cone_filter` ("trilinear" in rows from before it was recorded).
    #[serde(default = "trilinear")]
    pub cone_filter: String,
    /// Median host wall clock of a frame that updates the voxels (relight, mips, bounces)
    /// and traces: the cost when lights or objects move. The front is drawn against this.
    pub frame_ms: f64,
    pub frame_p95_ms: f64,
    /// Median host wall clock of a frame that reuses the lit voxels (static scene).
    pub static_frame_ms: f64,
    /// GPU memory of the renderer's images and volumes, MiB.
    pub gpu_mib: f64,
    pub rmse: f64,
    pub relmse: f64,
    pub flip_mean: f64,
    pub flip_p95: f64,
    pub ssim_mean: f64,
    /// Mean radiance of the image over the reference's: below 1, energy is missing.
    pub energy_ratio: f64,
    /// Pareto-optimal (time against that metric).
    pub front_rmse: bool,
    pub front_relmse: bool,
    pub front_flip: bool,
    pub front_ssim: bool,
}

impl Row {
    pub fn new(label: String, s: &crate::scene::GiSettings, time: [f64; 3], gpu_mib: f64, c: &Comparison) -> Row {
        Row {
            label,
            voxel_resolution: s.voxel_resolution,
            diffuse_cones: s.diffuse_cones,
            diffuse_cone_angle: s.diffuse_cone_angle,
            step: s.step,
            bounces: s.bounces,
            downsample: s.downsample,
            ao: s.ao,
            bounce_cones: s.bounce_cones,
            bounce_interleave: s.bounce_interleave,
            mode: serde_name(s.mode).unwrap_or_else(vct),
            rsm_samples: s.rsm_samples,
            rsm_radius: s.rsm_radius,
            rsm_size: s.rsm_size,
            lpv_resolution: s.lpv_resolution,
            lpv_steps: s.lpv_steps,
            specular: s.specular.name().to_owned(),
            specular_rays: s.specular_rays,
            rt_hit_indirect: serde_name(s.rt_hit_indirect).unwrap_or_else(voxel),
            specular_history: s.specular_history,
            shadows: s.shadows.name().to_owned(),
            opacity: serde_name(s.opacity).unwrap_or_else(blend),
            voxel_cover: serde_name(s.voxel_cover).unwrap_or_else(touch),
            footprint: serde_name(s.footprint).unwrap_or_else(whole),
            bounce_footprint: serde_name(s.bounce_footprint).unwrap_or_default(),
            attenuation: serde_name(s.attenuation).unwrap_or_default(),
            plane_backs: serde_name(s.plane_backs).unwrap_or_else(lit),
            cone_filter: serde_name(s.cone_filter).unwrap_or_else(trilinear),
            frame_ms: time[0],
            frame_p95_ms: time[1],
            static_frame_ms: time[2],
            gpu_mib,
            rmse: c.rmse,
            relmse: c.relmse,
            flip_mean: c.flip.mean,
            flip_p95: c.flip.p95,
            ssim_mean: c.ssim.mean,
            energy_ratio: c.test_mean / c.reference_mean,
            front_rmse: false,
            front_relmse: false,
            front_flip: false,
            front_ssim: false,
        }
    }

    /// The error of this row under metric `name` (one of [`METRICS`]).
    pub fn error(&self, name: &str) -> f64 {
        match name {
            "rmse" => self.rmse,
            "relmse" => self.relmse,
            "flip" => self.flip_mean,
            "ssim" => 1.0 - self.ssim_mean,
            _ => f64::NAN,
        }
    }

    fn set_front(&mut self, name: &str, on: bool) {
        match name {
            "rmse" => self.front_rmse = on,
            "relmse" => self.front_relmse = on,
            "flip" => self.front_flip = on,
            "ssim" => self.front_ssim = on,
            _ => {}
        }
    }

    pub fn on_front(&self, name: &str) -> bool {
        match name {
            "rmse" => self.front_rmse,
            "relmse" => self.front_relmse,
            "flip" => self.front_flip,
            "ssim" => self.front_ssim,
            _ => false,
        }
    }
}

/// What raising one knob one step does, averaged over every pair of rows that differ only
/// in that knob.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KnobEffect {
    pub knob: Param,
    pub from: f64,
    pub to: f64,
    /// Pairs of rows averaged.
    pub pairs: usize,
    /// Mean change of the frame time, ms.
    pub delta_ms: f64,
    /// Mean change of mean FLIP (negative: more accurate).
    pub delta_flip: f64,
    /// Mean change of RMSE.
    pub delta_rmse: f64,
}

impl Row {
    fn knob(&self, p: Param) -> f64 {
        match p {
            Param::VoxelResolution => self.voxel_resolution as f64,
            Param::DiffuseCones => self.diffuse_cones as f64,
            Param::DiffuseConeAngle => self.diffuse_cone_angle as f64,
            Param::Step => self.step as f64,
            Param::Bounces => self.bounces as f64,
            Param::Downsample => self.downsample as f64,
            Param::Ao => self.ao as u32 as f64,
            Param::BounceCones => self.bounce_cones as f64,
            Param::BounceInterleave => self.bounce_interleave as f64,
            Param::Mode => technique_index(&self.mode),
            Param::RsmSamples => self.rsm_samples as f64,
            Param::RsmRadius => self.rsm_radius as f64,
            Param::RsmSize => self.rsm_size as f64,
            Param::LpvResolution => self.lpv_resolution as f64,
            Param::LpvSteps => self.lpv_steps as f64,
            Param::Specular => specular_index(&self.specular),
            Param::SpecularRays => self.specular_rays as f64,
            Param::RtHitIndirect => name_index(&HIT_INDIRECT, &self.rt_hit_indirect),
            Param::SpecularHistory => self.specular_history as f64,
            Param::Shadows => name_index(&SHADOW_KINDS, &self.shadows),
            Param::Opacity => name_index(&OPACITIES, &self.opacity),
            Param::VoxelCover => name_index(&VOXEL_COVERS, &self.voxel_cover),
            Param::Footprint => name_index(&FOOTPRINTS, &self.footprint),
            Param::BounceFootprint => name_index(&FOOTPRINTS, &self.bounce_footprint),
            Param::Attenuation => name_index(&ATTENUATIONS, &self.attenuation),
            Param::PlaneBacks => name_index(&PLANE_BACKS, &self.plane_backs),
            Param::ConeFilter => name_index(&CONE_FILTERS, &self.cone_filter),
        }
    }
}

/// Whether two rows hold a knob at the same value: an unrecorded one (NaN: `attenuation` or
/// `bounce_footprint` in rows from before it was recorded) matches only another unrecorded one.
fn same_knob(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9 || (a.is_nan() && b.is_nan())
}

/// The effect of each step of each swept knob (see [`KnobEffect`]).
pub fn knob_effects(grid: &Grid, rows: &[Row]) -> Vec<KnobEffect> {
    let mut out = Vec::new();
    for (param, values) in &grid.axes {
        let others: Vec<Param> = Param::ALL.into_iter().filter(|p| p != param).collect();
        for w in values.windows(2) {
            let (from, to) = (w[0], w[1]);
            let (mut n, mut dms, mut dflip, mut drmse) = (0usize, 0.0, 0.0, 0.0);
            for a in rows.iter().filter(|r| (r.knob(*param) - from).abs() < 1e-9) {
                let twin = rows.iter().find(|b| {
                    (b.knob(*param) - to).abs() < 1e-9 && others.iter().all(|p| same_knob(b.knob(*p), a.knob(*p)))
                });
                if let Some(b) = twin {
                    n += 1;
                    dms += b.frame_ms - a.frame_ms;
                    dflip += b.flip_mean - a.flip_mean;
                    drmse += b.rmse - a.rmse;
                }
            }
            if n > 0 {
                let k = n as f64;
                out.push(KnobEffect {
                    knob: *param,
                    from,
                    to,
                    pairs: n,
                    delta_ms: dms / k,
                    delta_flip: dflip / k,
                    delta_rmse: drmse / k,
                });
            }
        }
    }
    out
}

/// Mark every row's Pareto flags (time against each metric).
pub fn mark_fronts(rows: &mut [Row]) {
    for (name, _) in METRICS {
        let points: Vec<(f64, f64)> = rows.iter().map(|r| (r.frame_ms, r.error(name))).collect();
        for (row, on) in rows.iter_mut().zip(crate::pareto::pareto_front(&points)) {
            row.set_front(name, on);
        }
    }
}

/// What a sweep directory was made with; a resumed sweep must match it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Setup {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    /// Scene time of every frame and of the reference, seconds.
    #[serde(default)]
    pub time: f32,
    pub settings: Vec<String>,
    pub spp: u32,
    pub device: String,
    pub frames: u32,
    pub warmup: u32,
    pub schedule: String,
}

impl Setup {
    /// The first field that differs, as (name, old, new).
    pub fn difference(&self, new: &Setup) -> Option<(String, String, String)> {
        let a = serde_json::to_value(self).ok()?;
        let b = serde_json::to_value(new).ok()?;
        let (a, b) = (a.as_object()?, b.as_object()?);
        a.iter().find(|(k, v)| b.get(*k) != Some(v)).map(|(k, v)| (k.clone(), v.to_string(), b[k].to_string()))
    }
}

/// The JSON summary of a sweep.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Results {
    pub setup: Setup,
    /// Host wall clock the reference took to trace.
    pub reference_seconds: f64,
    /// Mean over pixels of the reference's standard error relative to its value.
    pub reference_relative_standard_error: f64,
    /// The RMSE a perfect renderer would score against the noisy reference: the floor under
    /// every row's RMSE.
    pub reference_noise_rmse: f64,
    pub rows: Vec<Row>,
    /// What each step of each knob costs and buys, on average.
    pub knob_effects: Vec<KnobEffect>,
}

/// Rows already in `results.csv` (none when it does not exist).
pub fn read_rows(path: &Path) -> Result<Vec<Row>, SweepError> {
    if !path.exists() {
        return Ok(Vec::new());
    }
    let err = |message: String| SweepError::File { path: path.to_path_buf(), message };
    let mut reader = csv::Reader::from_path(path).map_err(|e| err(e.to_string()))?;
    let mut rows = Vec::new();
    for r in reader.deserialize() {
        rows.push(r.map_err(|e: csv::Error| err(format!("{e} (delete the file to start over)")))?);
    }
    Ok(rows)
}

/// Write `rows` as CSV to `path` atomically.
pub fn write_rows(path: &Path, rows: &[Row]) -> crate::Result<()> {
    let err = |message: String| SweepError::File { path: path.to_path_buf(), message };
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).map_err(|e| err(e.to_string()))?;
    }
    let bytes = w.into_inner().map_err(|e| err(e.to_string()))?;
    Ok(crate::output::write_bytes(path, &bytes)?)
}

/// The frontier picture of one metric.
pub fn plot(path: &Path, scene: &str, device: &str, rows: &[Row], metric: (&str, &str)) -> crate::Result<()> {
    let (name, label) = metric;
    let points: Vec<crate::pareto::PlotPoint> = rows
        .iter()
        .map(|r| crate::pareto::PlotPoint {
            x: r.frame_ms,
            y: r.error(name),
            label: r.label.clone(),
            group: r.mode.clone(),
            front: r.on_front(name),
        })
        .collect();
    let title = format!("{scene}: {label} against frame time ({device})");
    crate::pareto::frontier_svg(
        path,
        &title,
        "frame time, ms (host wall clock, voxel update frame)",
        label,
        &points,
        true,
        true,
    )?;
    Ok(())
}

/// What `dvsgi sweep` was asked for.
#[derive(Debug, Clone)]
pub struct SweepOptions {
    pub scene: PathBuf,
    pub out: PathBuf,
    pub grid: Grid,
    /// Reference samples per pixel.
    pub spp: u32,
    /// Timed frames per configuration and scenario, after `warmup`.
    pub frames: u32,
    pub warmup: u32,
    pub schedule: crate::render::Mode,
    /// `--width/--height` as overrides.
    pub size: Vec<(String, String)>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct ReferenceKey {
    key: String,
    seconds: f64,
    relative_standard_error: f64,
    /// sqrt(mean variance of the pixel means): the RMSE a perfect renderer would show
    /// against this reference, from its noise alone.
    noise_rmse: f64,
}

/// Run (or resume) a sweep; returns the finished results (also written to `opts.out`).
pub fn run(common: &crate::cli::CommonArgs, opts: &SweepOptions) -> crate::Result<Results> {
    let dir = &opts.out;
    let base = common.load_scene(&opts.scene, &opts.size)?;
    let configs = opts.grid.configs();
    let scenes = load_config_scenes(common, opts, &configs)?;
    // Only now that everything is known to load: nothing is created for a bad grid.
    create_out_dir(dir)?;
    let ctx = common.context()?;
    let setup = setup_of(common, opts, &base, &ctx.info.name);
    check_or_record_setup(dir, &setup)?;
    eprintln!("sweep: {} configurations of {} on {}", configs.len(), opts.scene.display(), ctx.info.name);

    let key = reference_cache_key(common, opts, &setup);
    let (reference, reference_key) = load_or_trace_reference(&ctx, &base, opts, key)?;
    crate::cli::check_validation(&ctx)?;
    write_reference_png(dir, &base, &reference)?;

    let csv_path = dir.join("results.csv");
    let mut rows = read_rows(&csv_path)?;
    let todo = configs_to_run(&configs, &rows, &csv_path);
    let bar = progress_bar(todo.len() as u64, "configurations");
    for i in todo {
        bar.set_message(configs[i].label());
        rows.push(measure_config(&ctx, opts, &configs[i], &scenes[i], &reference)?);
        // Written after every configuration: an interrupted sweep resumes from here.
        mark_fronts(&mut rows);
        write_rows(&csv_path, &rows)?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    sort_in_grid_order(&mut rows, &configs);
    mark_fronts(&mut rows);
    write_rows(&csv_path, &rows)?;
    let results = Results {
        setup,
        reference_seconds: reference_key.seconds,
        reference_relative_standard_error: reference_key.relative_standard_error,
        reference_noise_rmse: reference_key.noise_rmse,
        knob_effects: knob_effects(&opts.grid, &rows),
        rows,
    };
    write_results(dir, &base.name, &results)?;
    Ok(results)
}

/// Every configuration's scene, all loaded before anything runs (a bad value names its knob).
fn load_config_scenes(
    common: &crate::cli::CommonArgs,
    opts: &SweepOptions,
    configs: &[Config],
) -> crate::Result<Vec<Scene>> {
    let mut scenes = Vec::with_capacity(configs.len());
    for c in configs {
        // Voxels update only when asked: the update frames ask every time, the static ones never.
        let mut extra = opts.size.clone();
        extra.push(("gi.update_interval".into(), "0".into()));
        extra.extend(c.overrides());
        scenes.push(common.load_scene(&opts.scene, &extra)?);
    }
    Ok(scenes)
}

/// Create the output directory and check that `results.csv` can be written in it.
fn create_out_dir(dir: &Path) -> crate::Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| SweepError::File {
        path: dir.to_path_buf(),
        message: format!("cannot create the directory: {e}"),
    })?;
    crate::output::check_target_dir(&dir.join("results.csv"))?;
    Ok(())
}

/// What this sweep is made with, on the device named `device`.
fn setup_of(common: &crate::cli::CommonArgs, opts: &SweepOptions, base: &Scene, device: &str) -> Setup {
    Setup {
        scene: opts.scene.display().to_string(),
        width: base.settings.width,
        height: base.settings.height,
        time: base.settings.time,
        settings: common.settings(),
        spp: opts.spp,
        device: device.to_owned(),
        frames: opts.frames,
        warmup: opts.warmup,
        schedule: opts.schedule.to_string(),
    }
}

/// Check `setup` against the `sweep.json` in `dir` (a resumed sweep must match it), or write it
/// there when there is none.
fn check_or_record_setup(dir: &Path, setup: &Setup) -> crate::Result<()> {
    let setup_path = dir.join("sweep.json");
    if let Ok(text) = std::fs::read_to_string(&setup_path) {
        let old: Setup = serde_json::from_str(&text)
            .map_err(|e| SweepError::File { path: setup_path.clone(), message: format!("not a sweep setup: {e}") })?;
        if let Some((what, old, new)) = old.difference(setup) {
            return Err(SweepError::SetupChanged { dir: dir.to_path_buf(), what, old, new }.into());
        }
    } else {
        crate::output::write_bytes(&setup_path, serde_json::to_string_pretty(setup).expect("JSON").as_bytes())?;
    }
    Ok(())
}

/// The key the reference is cached under: everything that shapes it.
fn reference_cache_key(common: &crate::cli::CommonArgs, opts: &SweepOptions, setup: &Setup) -> String {
    let scene_text = std::fs::read_to_string(&opts.scene).unwrap_or_default();
    format!(
        "dvsgi {} | {}x{} | t {} | spp {} | sets {:?} | scene {}",
        env!("CARGO_PKG_VERSION"),
        setup.width,
        setup.height,
        setup.time,
        opts.spp,
        reference_sets(&common.sets),
        scene_text
    )
}

/// The `--set`s that shape the path tracer's image: all but the `[gi]` ones, which (like a
/// `--preset`, made of `[gi]` keys only) set how dvsgi renders, not the scene. So a sweep
/// around a preset, or with a `gi` knob fixed by `--set`, reuses the reference cached without.
fn reference_sets(sets: &[String]) -> Vec<String> {
    let is_gi = |s: &String| crate::scene::parse_override(s).is_ok_and(|(k, _)| k == "gi" || k.starts_with("gi."));
    sets.iter().filter(|s| !is_gi(s)).cloned().collect()
}

/// The reference image: the one cached in `opts.out` when it was made under `key`, else
/// traced anew (and cached).
fn load_or_trace_reference(
    ctx: &Arc<Context>,
    base: &Scene,
    opts: &SweepOptions,
    key: String,
) -> crate::Result<(LinearImage, ReferenceKey)> {
    let ref_path = opts.out.join("reference.exr");
    match cached_reference_key(&opts.out, &key) {
        Some(k) => {
            eprintln!("reference: cached {} ({} spp, {:.1} s to trace)", ref_path.display(), opts.spp, k.seconds);
            Ok((LinearImage::read_exr(&ref_path)?, k))
        }
        None => trace_reference(ctx, base, opts, key),
    }
}

/// The cached reference's `reference.json` in `dir`, if it was made under `key` and its image
/// is there.
fn cached_reference_key(dir: &Path, key: &str) -> Option<ReferenceKey> {
    let ref_path = dir.join("reference.exr");
    std::fs::read_to_string(dir.join("reference.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<ReferenceKey>(&t).ok())
        .filter(|k| k.key == key && ref_path.exists())
}

/// Path-trace the reference and cache it in `opts.out`: `reference.exr`, its variance and
/// `reference.json` (under `key`).
fn trace_reference(
    ctx: &Arc<Context>,
    base: &Scene,
    opts: &SweepOptions,
    key: String,
) -> crate::Result<(LinearImage, ReferenceKey)> {
    let ref_path = opts.out.join("reference.exr");
    let start = std::time::Instant::now();
    let ro = ReferenceOptions { spp: opts.spp, ..Default::default() };
    let mut pt = PathTracer::new(ctx, base, ro)?;
    let bar = progress_bar(opts.spp as u64, "reference spp");
    pt.run(|done, _| bar.set_position(done as u64))?;
    bar.finish_and_clear();
    let image = pt.image()?;
    drop(pt);
    let seconds = start.elapsed().as_secs_f64();
    crate::output::write_exr(&ref_path, image.width, image.height, &image.mean)?;
    let var = crate::reference::variance_path(&ref_path);
    crate::output::write_exr(&var, image.width, image.height, &image.variance)?;
    let noise_rmse =
        (image.variance.iter().map(|&v| v as f64).sum::<f64>() / image.variance.len().max(1) as f64).sqrt();
    let k = ReferenceKey { key, seconds, relative_standard_error: image.relative_standard_error(), noise_rmse };
    let key_path = opts.out.join("reference.json");
    crate::output::write_bytes(&key_path, serde_json::to_string_pretty(&k).expect("JSON").as_bytes())?;
    eprintln!(
        "reference: {} spp in {seconds:.1} s, mean relative standard error {:.4}",
        opts.spp, k.relative_standard_error
    );
    Ok((LinearImage { width: image.width, height: image.height, rgb: image.mean }, k))
}

/// Write the reference's display image `reference.png` in `dir`, unless it is there.
fn write_reference_png(dir: &Path, base: &Scene, reference: &LinearImage) -> crate::Result<()> {
    let png_path = dir.join("reference.png");
    if !png_path.exists() {
        let ev = crate::metrics::display_exposure(&base.settings, reference);
        crate::output::write_display_png(&png_path, reference, ev, base.settings.tonemap)?;
    }
    Ok(())
}

/// The indices of the configurations with no row in `rows` yet, saying what is kept and what
/// is resumed.
fn configs_to_run(configs: &[Config], rows: &[Row], csv_path: &Path) -> Vec<usize> {
    // Rows of configurations outside this grid (an earlier sweep with other --grid values in
    // this directory, so of the same setup) are the user's measurements: they stay, and they
    // count in the fronts and the knob effects like the others.
    let earlier = rows.iter().filter(|r| !configs.iter().any(|c| c.label() == r.label)).count();
    if earlier > 0 {
        eprintln!(
            "keeping {earlier} rows of configurations outside this grid (earlier --grid values) in {}",
            csv_path.display()
        );
    }
    let todo: Vec<usize> =
        (0..configs.len()).filter(|&i| !rows.iter().any(|r| r.label == configs[i].label())).collect();
    if todo.len() < configs.len() {
        eprintln!(
            "resuming: {} of {} configurations already in {}",
            configs.len() - todo.len(),
            configs.len(),
            csv_path.display()
        );
    }
    todo
}

/// Time one configuration (frames that update the voxels, then frames that reuse them) and
/// compare its image with the reference: its row, fronts not yet marked.
fn measure_config(
    ctx: &Arc<Context>,
    opts: &SweepOptions,
    config: &Config,
    scene: &Scene,
    reference: &LinearImage,
) -> crate::Result<Row> {
    let t = scene.settings.time;
    let options = RenderOptions { mode: opts.schedule, frames_in_flight: 2 };
    let mut r = Renderer::with_options(ctx, scene.clone(), options)?;
    let gpu_mib = r.images().iter().map(|i| i.bytes as f64).sum::<f64>() / (1024.0 * 1024.0);
    let mut m = Measure {
        mode: opts.schedule,
        frames: opts.frames,
        warmup: opts.warmup,
        frames_in_flight: 2,
        serial_profile: false,
        raster_profile: false,
        dynamic_dt: None,
        redraw: true,
    };
    let (update, _) = measure_renderer(&mut r, scene, &m)?;
    m.redraw = false;
    let (cached, _) = measure_renderer(&mut r, scene, &m)?;
    r.render(t, true)?;
    let frame = r.output();
    drop(r);
    crate::cli::check_validation(ctx)?;
    let test = LinearImage { width: frame.width, height: frame.height, rgb: crate::output::radiance_rgb(&frame) };
    let s = &scene.settings;
    // A test and its reference are shown at one exposure: the reference's, where it is "auto".
    let c = compare(&test, reference, crate::metrics::display_exposure(s, reference), s.tonemap)?;
    let time = [update.frame_host_ms.median, update.frame_host_ms.p95, cached.frame_host_ms.median];
    Ok(Row::new(config.label(), &s.gi, time, gpu_mib, &c))
}

/// The grid's order, whatever order the rows were finished in; earlier rows after them.
fn sort_in_grid_order(rows: &mut [Row], configs: &[Config]) {
    let order = |r: &Row| configs.iter().position(|c| c.label() == r.label).unwrap_or(usize::MAX);
    rows.sort_by_key(order);
}

/// Write `results.json` and the frontier picture of every metric to `dir`.
fn write_results(dir: &Path, scene_name: &str, results: &Results) -> crate::Result<()> {
    crate::output::write_bytes(
        &dir.join("results.json"),
        serde_json::to_string_pretty(results).expect("JSON").as_bytes(),
    )?;
    for metric in METRICS {
        plot(
            &dir.join(format!("frontier-{}.svg", metric.0)),
            scene_name,
            &results.setup.device,
            &results.rows,
            metric,
        )?;
    }
    Ok(())
}

fn progress_bar(len: u64, what: &str) -> indicatif::ProgressBar {
    let style = indicatif::ProgressStyle::with_template(&format!(
        "{{elapsed_precise}} [{{bar:30}}] {{pos}}/{{len}} {what}, eta {{eta}} {{msg}}"
    ))
    .expect("valid template")
    .progress_chars("=> ");
    indicatif::ProgressBar::new(len).with_style(style)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_parses_and_multiplies() {
        let g = Grid::parse(&["voxel_resolution=32,64".into(), "gi.step=0.5, 1".into(), "bounces=1".into()]).unwrap();
        let c = g.configs();
        assert_eq!(c.len(), 4);
        assert_eq!(c[0].label(), "v32 s0.5 b1");
        assert_eq!(c[3].label(), "v64 s1 b1");
        assert_eq!(
            c[1].overrides(),
            vec![
                ("gi.voxel_resolution".to_string(), "32".to_string()),
                ("gi.step".into(), "1".into()),
                ("gi.bounces".into(), "1".into())
            ]
        );
        assert_eq!(Grid::default_grid().configs().len(), 216);
        let ao = Grid::parse(&["ao=0,1".into()]).unwrap().configs();
        assert_eq!(ao[1].overrides(), vec![("gi.ao".to_string(), "true".to_string())]);
        assert_eq!(ao[0].label(), "o0");
        for bad in ["voxels=32", "step", "bounces=1.5", "step=-1", "step=", "step=x", "step=nan", "ao=2"] {
            assert!(Grid::parse(&[bad.into()]).is_err(), "{bad}");
        }
        assert!(Grid::parse(&["step=1".into(), "step=2".into()]).is_err());
    }

    #[test]
    fn the_specular_source_is_a_knob_by_name() {
        let g = Grid::parse(&["specular=cone,rt".into(), "specular_rays=1,8".into()]).unwrap();
        let c = g.configs();
        assert_eq!(c.len(), 4);
        assert_eq!(c[3].label(), "spec-rt sr8");
        assert_eq!(
            c[3].overrides(),
            vec![("gi.specular".to_string(), "\"rt\"".to_string()), ("gi.specular_rays".into(), "8".into())]
        );
        assert!(Grid::parse(&["specular=mirror".into()]).is_err());
        let hit = Grid::parse(&["rt_hit_indirect=cones,voxel".into()]).unwrap().configs();
        assert_eq!(hit[0].overrides(), vec![("gi.rt_hit_indirect".to_string(), "\"cones\"".to_string())]);
        assert_eq!(hit[1].label(), "hit-voxel");
        let settings = crate::scene::GiSettings { specular: crate::scene::SpecularSource::Rt, ..Default::default() };
        let c = Comparison {
            rmse: 0.1,
            relmse: 0.1,
            flip: crate::metrics::Summary::of(&[0.1]),
            ssim: crate::metrics::Summary::of(&[0.9]),
            pixels: 1,
            test_mean: 1.0,
            reference_mean: 1.0,
            test_outliers: 0.0,
            reference_outliers: 0.0,
        };
        let r = Row::new("spec-rt".into(), &settings, [1.0; 3], 1.0, &c);
        assert_eq!((r.knob(Param::Specular), r.specular.as_str()), (2.0, "rt"));
        let shadows = Grid::parse(&["shadows=shadow-map,rt".into()]).unwrap().configs();
        assert_eq!(shadows[1].overrides(), vec![("gi.shadows".to_string(), "\"rt\"".to_string())]);
        assert_eq!(shadows[1].label(), "shadow-rt");
        let settings = crate::scene::GiSettings { shadows: crate::scene::DirectShadows::Rt, ..Default::default() };
        let r = Row::new("shadow-rt".into(), &settings, [1.0; 3], 1.0, &c);
        assert_eq!((r.knob(Param::Shadows), r.shadows.as_str()), (2.0, "rt"));
        let footprints = Grid::parse(&["footprint=whole,quadrants".into()]).unwrap().configs();
        assert_eq!(footprints[1].overrides(), vec![("gi.footprint".to_string(), "\"quadrants\"".to_string())]);
        assert_eq!(footprints[1].label(), "fp-quadrants");
        let settings = crate::scene::GiSettings { footprint: crate::scene::Footprint::Quadrants, ..Default::default() };
        let r = Row::new("fp-quadrants".into(), &settings, [1.0; 3], 1.0, &c);
        assert_eq!((r.knob(Param::Footprint), r.footprint.as_str()), (1.0, "quadrants"));
        assert_eq!((r.knob(Param::BounceFootprint), r.bounce_footprint.as_str()), (0.0, "whole"));
        let settings = crate::scene::GiSettings { footprint: crate::scene::Footprint::Shares, ..Default::default() };
        let r = Row::new("fp-shares".into(), &settings, [1.0; 3], 1.0, &c);
        assert_eq!((r.knob(Param::Footprint), r.footprint.as_str()), (2.0, "shares"));
        let bounce = Grid::parse(&["bounce_footprint=whole,quadrants".into()]).unwrap().configs();
        assert_eq!(bounce[1].overrides(), vec![("gi.bounce_footprint".to_string(), "\"quadrants\"".to_string())]);
        assert_eq!(bounce[1].label(), "bfp-quadrants");
        let settings =
            crate::scene::GiSettings { bounce_footprint: crate::scene::Footprint::Quadrants, ..Default::default() };
        let r = Row::new("bfp-quadrants".into(), &settings, [1.0; 3], 1.0, &c);
        assert_eq!((r.knob(Param::BounceFootprint), r.knob(Param::Footprint)), (1.0, 0.0));
        assert_eq!((r.knob(Param::PlaneBacks), r.plane_backs.as_str()), (2.0, "closed"));
        let backs = Grid::parse(&["plane_backs=lit,dark".into()]).unwrap().configs();
        assert_eq!(backs[1].overrides(), vec![("gi.plane_backs".to_string(), "\"dark\"".to_string())]);
        assert_eq!(backs[1].label(), "backs-dark");
        let settings = crate::scene::GiSettings { plane_backs: crate::scene::PlaneBacks::Dark, ..Default::default() };
        let r = Row::new("backs-dark".into(), &settings, [1.0; 3], 1.0, &c);
        assert_eq!((r.knob(Param::PlaneBacks), r.plane_backs.as_str()), (1.0, "dark"));
        let filters = Grid::parse(&["cone_filter=trilinear,two-tap".into()]).unwrap().configs();
        assert_eq!(filters[1].overrides(), vec![("gi.cone_filter".to_string(), "\"two-tap\"".to_string())]);
        assert_eq!(filters[1].label(), "filter-two-tap");
        let settings = crate::scene::GiSettings { cone_filter: crate::scene::ConeFilter::TwoTap, ..Default::default() };
        let r = Row::new("filter-two-tap".into(), &settings, [1.0; 3], 1.0, &c);
        assert_eq!((r.knob(Param::ConeFilter), r.cone_filter.as_str()), (1.0, "two-tap"));
        let settings = crate::scene::GiSettings { plane_backs: crate::scene::PlaneBacks::Closed, ..Default::default() };
        let r = Row::new("backs-closed".into(), &settings, [1.0; 3], 1.0, &c);
        assert_eq!((r.knob(Param::PlaneBacks), r.plane_backs.as_str()), (2.0, "closed"));
        let attenuations = Grid::parse(&["attenuation=n-dot-l,per-side".into()]).unwrap().configs();
        assert_eq!(attenuations[1].overrides(), vec![("gi.attenuation".to_string(), "\"per-side\"".to_string())]);
        assert_eq!(attenuations[1].label(), "att-per-side");
        let settings =
            crate::scene::GiSettings { attenuation: crate::scene::VoxelAttenuation::PerSide, ..Default::default() };
        let r = Row::new("att-per-side".into(), &settings, [1.0; 3], 1.0, &c);
        assert_eq!((r.knob(Param::Attenuation), r.attenuation.as_str()), (2.0, "per-side"));
        assert!(Grid::parse(&["attenuation=per-face".into()]).unwrap_err().to_string().contains("n-dot-l"));
    }

    fn row(label: &str, ms: f64, rmse: f64, ssim: f64) -> Row {
        let c = Comparison {
            rmse,
            relmse: rmse * 2.0,
            flip: crate::metrics::Summary::of(&[rmse as f32]),
            ssim: crate::metrics::Summary::of(&[ssim as f32]),
            pixels: 1,
            test_mean: 1.0,
            reference_mean: 1.0,
            test_outliers: 0.0,
            reference_outliers: 0.0,
        };
        Row::new(label.into(), &crate::scene::GiSettings::default(), [ms, ms, ms], 1.0, &c)
    }

    #[test]
    fn fronts_are_marked_per_metric() {
        // Hand-made: a (fast, bad), b (slow, good), c dominated by a, d best SSIM only.
        let mut rows = vec![
            row("a", 10.0, 0.5, 0.90),
            row("b", 30.0, 0.1, 0.95),
            row("c", 20.0, 0.6, 0.80),
            row("d", 40.0, 0.2, 0.99),
        ];
        mark_fronts(&mut rows);
        let front = |m: &str| rows.iter().filter(|r| r.on_front(m)).map(|r| r.label.as_str()).collect::<Vec<_>>();
        assert_eq!(front("rmse"), ["a", "b"]);
        assert_eq!(front("relmse"), ["a", "b"]);
        assert_eq!(front("ssim"), ["a", "b", "d"]);
    }

    #[test]
    fn knob_effects_average_matching_pairs() {
        let mut rows = vec![row("a", 10.0, 0.5, 0.9), row("b", 30.0, 0.3, 0.9), row("c", 50.0, 0.2, 0.9)];
        rows[1].bounces = 2;
        rows[2].voxel_resolution = 64;
        let grid = Grid { axes: vec![(Param::Bounces, vec![1.0, 2.0]), (Param::VoxelResolution, vec![128.0, 64.0])] };
        let e = knob_effects(&grid, &rows);
        assert_eq!(e.len(), 2);
        assert_eq!((e[0].knob, e[0].pairs), (Param::Bounces, 1));
        assert!((e[0].delta_ms - 20.0).abs() < 1e-9 && (e[0].delta_rmse + 0.2).abs() < 1e-9);
        assert_eq!((e[1].knob, e[1].from, e[1].to), (Param::VoxelResolution, 128.0, 64.0));
        assert!((e[1].delta_ms - 40.0).abs() < 1e-9);
        // Rows from before `attenuation` was recorded pair with each other, not with rows
        // that name it.
        let old: Vec<Row> = rows.iter().cloned().map(|r| Row { attenuation: String::new(), ..r }).collect();
        assert_eq!(knob_effects(&grid, &old), e);
        let mixed = vec![old[0].clone(), rows[1].clone(), rows[2].clone()];
        assert!(knob_effects(&grid, &mixed).is_empty());
    }

    #[test]
    fn the_reference_is_keyed_by_the_settings_that_shape_it() {
        let sets = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        // A preset sets [gi] keys only, so leaving it out of the key loses nothing.
        for p in <crate::scene::Preset as clap::ValueEnum>::value_variants() {
            assert!(p.overrides().iter().all(|(k, _)| k.starts_with("gi.")), "{p:?}");
        }
        assert!(reference_sets(&sets(&["gi.footprint=\"quadrants\"", " gi.step = 1"])).is_empty());
        let kept = sets(&["lights.0.intensity=[2,2,2]", "render.supersample=4", "camera.fov_y=45"]);
        assert_eq!(reference_sets(&[kept.clone(), sets(&["gi.voxel_resolution=64"])].concat()), kept);
    }

    #[test]
    fn rows_from_before_a_knob_was_recorded_still_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("results.csv");
        write_rows(&path, &[row("a", 10.0, 0.5, 0.9)]).unwrap();
        // Drop the attenuation, footprint, plane_backs and cone_filter columns, as a results.csv of an older
        // dvsgi has them.
        let text = std::fs::read_to_string(&path).unwrap();
        let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        let drop: Vec<usize> = header
            .iter()
            .enumerate()
            .filter(|(_, h)| ["attenuation", "footprint", "bounce_footprint", "plane_backs", "cone_filter"].contains(h))
            .map(|(i, _)| i)
            .collect();
        assert_eq!(drop.len(), 5);
        let older: String = text
            .lines()
            .map(|l| {
                l.split(',')
                    .enumerate()
                    .filter(|(i, _)| !drop.contains(i))
                    .map(|(_, f)| f)
                    .collect::<Vec<_>>()
                    .join(",")
                    + "\n"
            })
            .collect();
        std::fs::write(&path, older).unwrap();
        let r = &read_rows(&path).unwrap()[0];
        assert_eq!((r.footprint.as_str(), r.attenuation.as_str(), r.bounce_footprint.as_str()), ("whole", "", ""));
        assert!(r.knob(Param::Attenuation).is_nan() && r.knob(Param::BounceFootprint).is_nan());
        assert_eq!((r.plane_backs.as_str(), r.knob(Param::PlaneBacks)), ("lit", 0.0));
        assert_eq!((r.cone_filter.as_str(), r.knob(Param::ConeFilter)), ("trilinear", 0.0));
    }

    #[test]
    fn rows_round_trip_through_csv_and_setups_compare() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("results.csv");
        assert!(read_rows(&path).unwrap().is_empty());
        let mut rows = vec![row("a", 10.0, 0.5, 0.9), row("b", 30.0, 0.1, 0.95)];
        mark_fronts(&mut rows);
        write_rows(&path, &rows).unwrap();
        assert_eq!(read_rows(&path).unwrap(), rows);
        std::fs::write(&path, "label,nonsense\nx,1\n").unwrap();
        assert!(read_rows(&path).unwrap_err().to_string().contains("results.csv"));
        let a = Setup {
            scene: "s".into(),
            width: 1,
            height: 1,
            time: 0.0,
            settings: vec![],
            spp: 4,
            device: "d".into(),
            frames: 1,
            warmup: 0,
            schedule: "sync".into(),
        };
        let b = Setup { spp: 8, ..a.clone() };
        assert_eq!(a.difference(&a), None);
        assert_eq!(a.difference(&b), Some(("spp".into(), "4".into(), "8".into())));
    }
}
