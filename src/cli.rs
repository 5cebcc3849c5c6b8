//! Command-line pieces shared by the `dvsgi` and `bench` binaries.

use crate::gpu::{Context, ContextDesc};
use crate::scene::{self, LoadOptions, Scene};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Options every command that touches the GPU or a scene accepts.
#[derive(Debug, Clone, clap::Args)]
pub struct CommonArgs {
    /// Enable the Khronos validation layer (also: DVSGI_VALIDATION=1); any validation error
    /// makes the command fail.
    #[arg(long, global = true)]
    pub validation: bool,
    /// Vulkan device: index from `dvsgi info` or part of its name (also: DVSGI_DEVICE).
    #[arg(long, global = true, value_name = "N|NAME")]
    pub device: Option<String>,
    /// Extra directory searched for scene assets (repeatable; also DVSGI_ASSET_PATH,
    /// colon-separated).
    #[arg(long = "asset-path", global = true, value_name = "DIR")]
    pub asset_paths: Vec<PathBuf>,
    /// Override a scene setting, e.g. --set camera.fov_y=45 --set render.exposure=1
    /// (repeatable; keys as in the scene file, array elements by index: lights.0.intensity).
    #[arg(long = "set", global = true, value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Cone-tracing quality from the measured speed/accuracy frontier (ACCURACY.md): sets
    /// [gi] keys before any --set.
    #[arg(long, global = true, value_enum)]
    pub preset: Option<scene::Preset>,
}

impl CommonArgs {
    /// The settings given on the command line, for reports: the preset, then each --set.
    pub fn settings(&self) -> Vec<String> {
        let preset = self.preset.map(|p| format!("preset={}", format!("{p:?}").to_lowercase()));
        preset.into_iter().chain(self.sets.iter().cloned()).collect()
    }

    pub fn context(&self) -> crate::Result<Arc<Context>> {
        Ok(Context::new(&ContextDesc { validation: self.validation, device: self.device.clone() })?)
    }

    /// Load a scene with the `--set` overrides plus `extra` ones (from dedicated flags such
    /// as --width, applied last).
    pub fn load_scene(&self, path: &Path, extra: &[(String, String)]) -> crate::Result<Scene> {
        let mut overrides = self.preset.map(|p| p.overrides()).unwrap_or_default();
        for s in &self.sets {
            overrides.push(scene::parse_override(s)?);
        }
        overrides.extend_from_slice(extra);
        let mut asset_paths = self.asset_paths.clone();
        if let Ok(env) = std::env::var("DVSGI_ASSET_PATH") {
            asset_paths.extend(std::env::split_paths(&env).filter(|p| !p.as_os_str().is_empty()));
        }
        Ok(scene::load(path, &LoadOptions { overrides, asset_paths })?)
    }
}

/// Fail if validation was on and reported errors.
pub fn check_validation(ctx: &Context) -> crate::Result<()> {
    if ctx.validation_enabled && ctx.validation().errors() > 0 {
        return Err(crate::Error::Validation(ctx.validation().errors()));
    }
    Ok(())
}

/// Print an error and its causes, one per line; a cause whose text the lines above already
/// hold is not repeated.
pub fn report(e: &dyn std::error::Error) {
    let mut said = e.to_string();
    eprintln!("error: {said}");
    let mut source = e.source();
    while let Some(s) = source {
        let text = s.to_string();
        if !said.contains(&text) {
            eprintln!("  caused by: {text}");
            said.push('\n');
            said.push_str(&text);
        }
        source = s.source();
    }
}

/// Write a command's outputs, all or none ([`crate::output::write_all`]), and name each.
pub fn write_outputs(files: &[(&Path, Vec<u8>)]) -> crate::Result<()> {
    let refs: Vec<(&Path, &[u8])> = files.iter().map(|(p, b)| (*p, b.as_slice())).collect();
    crate::output::write_all(&refs)?;
    for (p, _) in files {
        crate::outln!("wrote {}", p.display());
    }
    Ok(())
}

/// `println!` for a command's output on stdout ([`out_line`]).
#[macro_export]
macro_rules! outln {
    () => { $crate::cli::out_line(format_args!("")) };
    ($($t:tt)*) => { $crate::cli::out_line(format_args!($($t)*)) };
}

/// One line of command output. A closed stdout (`dvsgi info | head -1`) ends the output
/// quietly, never a panic: the command goes on and still writes its files. Another write
/// error is said once on stderr.
pub fn out_line(args: std::fmt::Arguments) {
    use std::io::Write;
    use std::sync::atomic::{AtomicBool, Ordering};
    static CLOSED: AtomicBool = AtomicBool::new(false);
    if CLOSED.load(Ordering::Relaxed) {
        return;
    }
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(args).and_then(|_| out.write_all(b"\n")) {
        CLOSED.store(true, Ordering::Relaxed);
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            eprintln!("warning: standard output: {e}; no more output is printed");
        }
    }
}

/// Prints this crate's `log` warnings and errors on stderr ("warning: ..."), e.g. the scene
/// loader's warnings about missing textures or unused materials. Other crates' log records
/// are not shown. Calling it more than once is harmless.
pub fn init_logging() {
    struct Stderr;
    impl log::Log for Stderr {
        fn enabled(&self, m: &log::Metadata) -> bool {
            m.level() <= log::Level::Warn && m.target().starts_with("dvsgi")
        }
        fn log(&self, r: &log::Record) {
            if self.enabled(r.metadata()) {
                let level = if r.level() == log::Level::Error { "error" } else { "warning" };
                eprintln!("{level}: {}", r.args());
            }
        }
        fn flush(&self) {}
    }
    static LOGGER: Stderr = Stderr;
    if log::set_logger(&LOGGER).is_ok() {
        log::set_max_level(log::LevelFilter::Warn);
    }
}

/// `clap` value parser: a finite number >= 0 (thresholds, tolerances).
pub fn non_negative(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        Ok(_) => Err(format!("{s} is not a finite number >= 0")),
        Err(_) => Err(format!("{s:?} is not a number")),
    }
}

/// `clap` value parser: a finite number > 0 (time steps).
pub fn positive(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(_) => Err(format!("{s} is not a finite number > 0")),
        Err(_) => Err(format!("{s:?} is not a number")),
    }
}
