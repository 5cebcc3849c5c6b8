//! `soak`: render a dynamic scene for many frames in every schedule mode and watch host memory,
//! gpu-allocator's figures, validation and the image at a fixed time (see `dvsgi::soak` and
//! docs/ROBUSTNESS.md). Exits non-zero when memory grows, the image drifts or validation
//! reports anything.

use clap::Parser;
use dvsgi::cli::{check_validation, report, CommonArgs};
use dvsgi::gpu::Context;
use dvsgi::outln;
use dvsgi::render::Mode;
use dvsgi::scene::Scene;
use dvsgi::soak::{soak_mode, ModeSoak, Sample, SoakOptions};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;

#[derive(Parser)]
#[command(
    name = "soak",
    version,
    about = "Render a dynamic scene for many frames per schedule mode; memory must stay flat",
    after_help = "Examples:
  soak                                      scenes/dynamic-stress.toml, 3000 frames per mode
  soak --frames 300 --sample-every 50 --json soak.json

Exit status: 0 when every threshold held, 3 when the soak ran and broke one, 1 on an error,
2 on a usage error."
)]
struct Args {
    #[command(flatten)]
    common: CommonArgs,
    /// Scene file (with moving objects and/or lights); default: scenes/dynamic-stress.toml
    /// of this repository, found from any directory.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Schedule modes, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "sync,async,async-lagged")]
    modes: Vec<Mode>,
    /// Frames per mode.
    #[arg(long, default_value_t = 3000, value_parser = clap::value_parser!(u32).range(1..=10_000_000))]
    frames: u32,
    /// Sample memory and the fixed-time image every this many frames.
    #[arg(long, default_value_t = 250, value_parser = clap::value_parser!(u32).range(1..))]
    sample_every: u32,
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: u32,
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: u32,
    /// Scene seconds per frame.
    #[arg(long, default_value_t = 1.0 / 30.0, value_parser = dvsgi::cli::positive)]
    dt: f32,
    /// Largest allowed growth of resident memory after the first sample (MiB).
    #[arg(long, default_value_t = 8.0, value_parser = dvsgi::cli::non_negative)]
    max_rss_growth_mib: f64,
    /// Largest allowed drift of the fixed-time image (fraction of its peak radiance).
    #[arg(long, default_value_t = 0.02, value_parser = dvsgi::cli::non_negative)]
    max_drift: f64,
    /// Write every sample as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(Serialize)]
struct Report<'a> {
    schema: &'static str,
    device: String,
    scene: String,
    settings: Vec<String>,
    width: u32,
    height: u32,
    frames: u32,
    dt: f32,
    modes: &'a [ModeSoak],
}

/// `scenes/dynamic-stress.toml` from the working directory when it is there (a checkout's
/// root), else from the repository this binary was built in.
fn default_scene() -> PathBuf {
    let local = PathBuf::from("scenes/dynamic-stress.toml");
    if local.is_file() {
        return local;
    }
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/dynamic-stress.toml")
}

/// Exit status of a soak that ran and broke one of its thresholds.
const SOAK_FAILED: u8 = 3;

fn main() -> ExitCode {
    dvsgi::cli::init_logging();
    match run(Args::parse()) {
        Ok(true) => ExitCode::SUCCESS,
        // 2 is clap's usage error; a soak that ran and broke a threshold is 3.
        Ok(false) => ExitCode::from(SOAK_FAILED),
        Err(e) => {
            report(&e);
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> dvsgi::Result<bool> {
    if let Some(j) = &args.json {
        dvsgi::output::check_target_dir(j)?;
    }
    if !(args.dt.is_finite() && args.dt > 0.0) {
        return Err(dvsgi::Error::Usage(format!("--dt must be a positive number of seconds, not {}", args.dt)));
    }
    let extra = [
        ("render.width".to_string(), args.width.to_string()),
        ("render.height".to_string(), args.height.to_string()),
        ("gi.update_interval".to_string(), "1".to_string()),
    ];
    let scene_path = args.scene.clone().unwrap_or_else(default_scene);
    let scene = args.common.load_scene(&scene_path, &extra)?;
    let ctx = args.common.context()?;
    let o = SoakOptions { frames: args.frames, sample_every: args.sample_every, dt: args.dt, frames_in_flight: 2 };
    outln!(
        "soak: {} on {} ({}), {}x{}, {}^3 voxels, {} frames per mode, validation {}",
        scene_path.display(),
        ctx.info.name,
        ctx.info.driver_info,
        args.width,
        args.height,
        scene.settings.gi.voxel_resolution,
        args.frames,
        if ctx.validation_enabled { "on" } else { "off" }
    );
    let mut modes = Vec::new();
    let mut ok = true;
    for &mode in &args.modes {
        let (m, held) = soak_one_mode(&ctx, &scene, mode, &o, &args)?;
        ok &= held;
        modes.push(m);
    }
    if let Some(j) = &args.json {
        write_json(j, &args, &ctx.info.name, &scene_path, &modes)?;
    }
    check_validation(&ctx)?;
    Ok(ok)
}

/// Bytes as MiB.
fn mib(b: u64) -> f64 {
    b as f64 / 1048576.0
}

/// Soak one mode, printing each sample and the growth after the first; the flag says whether
/// every threshold held.
fn soak_one_mode(
    ctx: &Arc<Context>,
    scene: &Scene,
    mode: Mode,
    o: &SoakOptions,
    args: &Args,
) -> dvsgi::Result<(ModeSoak, bool)> {
    outln!("mode {}:", mode.name());
    outln!("  frame   host ms/frame   RSS MiB   GPU alloc MiB (n)   GPU blocks MiB (n)   drift     validation");
    let m = soak_mode(ctx, scene, mode, o, print_sample)?;
    let rss = m.growth(|s| s.rss_bytes) as f64 / 1048576.0;
    let gpu = m.growth(|s| s.gpu_allocated_bytes);
    let blocks = m.growth(|s| s.gpu_block_bytes);
    let allocs = m.growth(|s| s.gpu_allocations as u64);
    outln!(
        "  after the first sample: RSS {rss:+.2} MiB, GPU allocations {gpu:+} B ({allocs:+}), blocks {blocks:+} B; \
         max drift {:.2e}; {:.1} s",
        m.max_drift(),
        m.seconds
    );
    let held = !(rss > args.max_rss_growth_mib
        || gpu != 0
        || blocks != 0
        || allocs != 0
        || f64::from(m.max_drift()) > args.max_drift);
    if !held {
        outln!("  FAILED: memory grew or the image drifted");
    }
    Ok((m, held))
}

/// One line of the sample table.
fn print_sample(s: &Sample) {
    outln!(
        "  {:>6}  {:>12.2}   {:>8.1}   {:>9.3} ({:>3})      {:>9.3} ({:>2})      {:.2e}  {}",
        s.frame,
        s.host_ms,
        mib(s.rss_bytes),
        mib(s.gpu_allocated_bytes),
        s.gpu_allocations,
        mib(s.gpu_block_bytes),
        s.gpu_blocks,
        s.drift,
        s.validation_messages
    )
}

/// Write every mode's samples as JSON (schema dvsgi-soak/1) to `path`.
fn write_json(path: &Path, args: &Args, device: &str, scene_path: &Path, modes: &[ModeSoak]) -> dvsgi::Result<()> {
    let r = Report {
        schema: "dvsgi-soak/1",
        device: device.to_owned(),
        scene: scene_path.display().to_string(),
        settings: args.common.settings(),
        width: args.width,
        height: args.height,
        frames: args.frames,
        dt: args.dt,
        modes,
    };
    let text = serde_json::to_string_pretty(&r).map_err(|e| dvsgi::Error::Usage(format!("JSON: {e}")))?;
    dvsgi::output::write_bytes(path, text.as_bytes())?;
    Ok(())
}
