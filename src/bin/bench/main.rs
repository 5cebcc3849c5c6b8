//! `bench`: the async-compute experiment. Runs the same scene in each schedule mode (sync,
//! async, async-lagged), and reports host wall clock per frame beside per-pass GPU timestamps
//! on both queues, the async/sync ratio, the image error each mode's schedule introduces,
//! and a timeline picture of one frame per mode. See BENCHMARKS.md.

use clap::{CommandFactory, FromArgMatches, Parser, ValueEnum};
use dvsgi::bench::{self, ImageError, Measure, ModeReport, Report, Stats};
use dvsgi::cli::{check_validation, report, CommonArgs};
use dvsgi::gpu::{Context, QueueTopology};
use dvsgi::outln;
use dvsgi::render::{Mode, RenderOptions, Renderer};
use dvsgi::scene::Scene;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

mod model;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Scenario {
    /// Nothing moves: after the first frame only what the update policy asks for is redone.
    Static,
    /// Scene time advances by --dt each frame and the voxels are revoxelized, relit and
    /// bounced every frame (needs a scene with moving objects or lights).
    Dynamic,
    /// Nothing moves, but every frame updates the voxels and redraws every map a frame could
    /// reuse (shadow maps, reflective shadow maps and the volume built from them) as if the
    /// lights and casters had moved: what a frame costs when everything changes, in any scene.
    Redraw,
}

#[derive(Parser)]
#[command(
    name = "bench",
    version,
    about = "The async-compute experiment: time dvsgi frames per schedule mode",
    after_help = "Examples:
  bench --scene scenes/cornell-box.toml --width 1920 --height 1080 --json b.json --timeline b.svg
  bench --scene scenes/dynamic-stress.toml --scenario dynamic --serial-profile
  bench --scene scenes/sponza.toml --set gi.mode='\"none\"' --modes sync

BENCHMARKS.md explains the schedules, the report and how to read the timeline."
)]
struct Args {
    #[command(flatten)]
    common: CommonArgs,
    /// Scene file (with --model: the report's, unless given).
    #[arg(long, required_unless_present = "model")]
    scene: Option<PathBuf>,
    /// The schedule model: predict each --modes mode's frame time from this bench report's
    /// per-pass GPU times (its device) and the submits this device's scheduler records for
    /// the report's scene, scenario, settings, frames and frames in flight (any of which the
    /// flags given here override; the image is --width x --height, else 96x54, as the submits
    /// do not depend on it). Compares with what the report measured (BENCHMARKS.md).
    #[arg(long, value_name = "REPORT.json", conflicts_with_all = ["timeline", "serial_profile", "raster_profile"])]
    model: Option<PathBuf>,
    /// Schedule modes to compare, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "sync,async,async-lagged,async-pipelined")]
    modes: Vec<Mode>,
    /// Frames measured per mode (after warm-up; with --model, the report's unless given).
    #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    frames: u32,
    /// Frames rendered first and not measured (with --model, the report's unless given).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(0..=10_000))]
    warmup: u32,
    /// Image width in pixels (overrides render.width).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: Option<u32>,
    /// Image height in pixels (overrides render.height).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: Option<u32>,
    /// What changes between frames (with --model, the report's unless given).
    #[arg(long, value_enum, default_value = "static")]
    scenario: Scenario,
    /// Scene seconds per frame in the dynamic scenario.
    #[arg(long, default_value_t = 1.0 / 30.0, value_parser = dvsgi::cli::positive)]
    dt: f32,
    /// Frames recorded ahead of the GPU (the same in every mode; with --model, the report's
    /// unless given).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=8))]
    frames_in_flight: u32,
    /// Also host-time every pass (submitted alone and waited for), for devices whose
    /// timestamps cannot be trusted (lavapipe). Runs 3 extra frames per mode.
    #[arg(long)]
    serial_profile: bool,
    /// Also split the G-buffer's time: the pass, a depth prepass of its opaque draws (vertex,
    /// raster, depth) and the G-buffer over that depth (each covered pixel shaded once), each
    /// submitted alone three times; with pipeline statistics, the shader invocations and the
    /// overdraw.
    #[arg(long)]
    raster_profile: bool,
    /// Frames compared against sync to measure each mode's image error (0: skip).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(0..=10_000))]
    error_frames: u32,
    /// Write the report as JSON (schema dvsgi-bench/1, see BENCHMARKS.md).
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write the timeline picture (SVG): one lane per queue per mode.
    #[arg(long)]
    timeline: Option<PathBuf>,
}

fn main() -> ExitCode {
    dvsgi::cli::init_logging();
    let matches = Args::command().get_matches();
    let given = Given(matches.clone());
    let args = match Args::from_arg_matches(&matches) {
        Ok(a) => a,
        Err(e) => e.exit(),
    };
    match run(args, &given) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            report(&e);
            ExitCode::FAILURE
        }
    }
}

/// Which arguments the command line gave (not their defaults).
struct Given(clap::ArgMatches);

impl Given {
    fn has(&self, id: &str) -> bool {
        self.0.value_source(id) == Some(clap::parser::ValueSource::CommandLine)
    }
}

impl Args {
    fn scene_path(&self) -> &std::path::Path {
        self.scene.as_deref().expect("--scene (clap requires it without --model)")
    }
}

fn has_extension(p: &std::path::Path, ext: &str) -> bool {
    p.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

fn usage(msg: String) -> dvsgi::Error {
    dvsgi::Error::Usage(msg)
}

fn run(args: Args, given: &Given) -> dvsgi::Result<()> {
    if let Some(report) = args.model.clone() {
        return model::run(args, given, &report);
    }
    check_outputs(&args)?;
    let scene = load_bench_scene(&args)?;
    let ctx = args.common.context()?;
    eprintln!("device: {} ({}); {}", ctx.info.name, ctx.info.driver_info, ctx.topology.describe());
    let (mut modes, calibrated) = measure_modes(&ctx, &scene, &args)?;
    if args.error_frames > 0 {
        add_image_errors(&ctx, &scene, &args, &mut modes)?;
    }
    check_validation(&ctx)?;
    add_ratios_to_sync(&mut modes);
    let report = build_report(&ctx, &args, &scene, modes, calibrated);
    print_table(&ctx, &report);
    write_files(&args, &report)
}

/// Check the output arguments before anything runs: writable targets, an SVG timeline, a mode.
fn check_outputs(args: &Args) -> dvsgi::Result<()> {
    let outs: Vec<PathBuf> = args.json.iter().chain(&args.timeline).cloned().collect();
    dvsgi::output::check_targets(&outs)?;
    if let Some(t) = args.timeline.as_ref().filter(|t| !has_extension(t, "svg")) {
        return Err(usage(format!("--timeline {}: the timeline is an SVG picture; give a .svg name", t.display())));
    }
    if args.modes.is_empty() {
        return Err(usage("--modes: give at least one of sync, async, async-lagged, async-pipelined".into()));
    }
    Ok(())
}

/// The scene with `--width/--height` (and, dynamic, a voxel update every frame), checked to
/// suit the scenario.
fn load_bench_scene(args: &Args) -> dvsgi::Result<Scene> {
    let mut extra = Vec::new();
    if let Some(w) = args.width {
        extra.push(("render.width".to_string(), w.to_string()));
    }
    if let Some(h) = args.height {
        extra.push(("render.height".to_string(), h.to_string()));
    }
    if args.scenario != Scenario::Static {
        extra.push(("gi.update_interval".to_string(), "1".to_string()));
    }
    let scene = args.common.load_scene(args.scene_path(), &extra)?;
    let moves =
        scene.objects.iter().any(|o| !o.motion.is_static()) || scene.lights.iter().any(|l| !l.motion.is_static());
    if args.scenario == Scenario::Dynamic && !moves {
        return Err(usage(format!(
            "{}: the dynamic scenario needs moving objects or lights, and nothing in this scene moves \
             (try scenes/dynamic-stress.toml)",
            args.scene_path().display()
        )));
    }
    if args.scenario == Scenario::Dynamic && !(args.dt.is_finite() && args.dt > 0.0) {
        return Err(usage(format!("--dt must be a positive number of seconds, not {}", args.dt)));
    }
    Ok(scene)
}

/// Time every `--modes` mode; the flag says whether every timestamp was calibrated.
fn measure_modes(ctx: &Arc<Context>, scene: &Scene, args: &Args) -> dvsgi::Result<(Vec<ModeReport>, bool)> {
    let mut modes = Vec::new();
    let mut calibrated = true;
    for &mode in &args.modes {
        eprintln!("{mode}: {} frames after {} warm-up", args.frames, args.warmup);
        let (m, cal) = bench::measure(ctx, scene, &measure_spec(args, mode))?;
        calibrated &= cal;
        modes.push(m);
    }
    Ok((modes, calibrated))
}

/// Each mode's image error against sync (all but sync itself).
fn add_image_errors(ctx: &Arc<Context>, scene: &Scene, args: &Args, modes: &mut [ModeReport]) -> dvsgi::Result<()> {
    for m in modes {
        let mode: Mode = m.mode.parse().map_err(usage)?;
        if mode != Mode::Sync {
            eprintln!("{mode}: image error against sync over {} frames", args.error_frames);
            m.image_error_vs_sync = Some(image_error(ctx, scene, args, mode)?);
        }
    }
    Ok(())
}

/// Each mode's median host frame time over sync's (where sync ran; not for sync itself).
fn add_ratios_to_sync(modes: &mut [ModeReport]) {
    let sync_median = modes.iter().find(|m| m.mode == "sync").map(|m| m.frame_host_ms.median);
    for m in modes {
        if m.mode != "sync" {
            m.frame_ratio_to_sync = sync_median.map(|s| m.frame_host_ms.median / s);
        }
    }
}

/// The report (schema dvsgi-bench/1) of the measured `modes`.
fn build_report(ctx: &Context, args: &Args, scene: &Scene, modes: Vec<ModeReport>, calibrated: bool) -> Report {
    Report {
        schema: bench::SCHEMA.to_string(),
        device: bench::DeviceReport {
            name: ctx.info.name.clone(),
            driver: ctx.info.driver_info.clone(),
            device_type: format!("{:?}", ctx.info.device_type),
            queue_topology: ctx.topology.describe().to_string(),
            separate_queues: ctx.topology != QueueTopology::SingleQueue,
            timestamps_calibrated: calibrated,
            timestamps_trusted: !ctx.info.is_cpu(),
        },
        scene: args.scene_path().display().to_string(),
        scenario: format!("{:?}", args.scenario).to_lowercase(),
        width: scene.settings.width,
        height: scene.settings.height,
        gi_mode: serde_json::to_value(scene.settings.gi.mode)
            .ok()
            .and_then(|v| v.as_str().map(str::to_owned))
            .unwrap_or_default(),
        voxel_resolution: scene.settings.gi.voxel_resolution,
        frames: args.frames,
        warmup: args.warmup,
        frames_in_flight: args.frames_in_flight,
        settings: args.common.settings(),
        modes,
    }
}

/// Write `--json` and `--timeline`: both or neither.
fn write_files(args: &Args, report: &Report) -> dvsgi::Result<()> {
    let mut files: Vec<(&std::path::Path, Vec<u8>)> = Vec::new();
    if let Some(path) = &args.json {
        files.push((path, serde_json::to_string_pretty(report).expect("JSON serialisation").into_bytes()));
    }
    if let Some(path) = &args.timeline {
        files.push((path, bench::timeline_svg(report).into_bytes()));
    }
    dvsgi::cli::write_outputs(&files)
}

/// The bench's timing settings for one mode.
fn measure_spec(args: &Args, mode: Mode) -> Measure {
    Measure {
        mode,
        frames: args.frames,
        warmup: args.warmup,
        frames_in_flight: args.frames_in_flight,
        serial_profile: args.serial_profile,
        raster_profile: args.raster_profile,
        dynamic_dt: (args.scenario == Scenario::Dynamic).then_some(args.dt),
        redraw: args.scenario == Scenario::Redraw,
    }
}

/// Scene time of frame `i`.
fn time_of(scene: &Scene, args: &Args, i: u32) -> f32 {
    measure_spec(args, Mode::Sync).time_of(scene, i)
}

/// `mode`'s image against sync's over `--error-frames` frames at the same scene times.
fn image_error(ctx: &Arc<Context>, scene: &Scene, args: &Args, mode: Mode) -> dvsgi::Result<ImageError> {
    let opts = |mode| RenderOptions { mode, frames_in_flight: args.frames_in_flight };
    let mut reference = Renderer::with_options(ctx, scene.clone(), opts(Mode::Sync))?;
    let mut other = Renderer::with_options(ctx, scene.clone(), opts(mode))?;
    let mut errors = Vec::new();
    for i in 0..args.error_frames {
        let t = time_of(scene, args, i);
        if args.scenario != Scenario::Static {
            reference.request_voxel_update();
            other.request_voxel_update();
        }
        if args.scenario == Scenario::Redraw {
            reference.request_redraw();
            other.request_redraw();
        }
        reference.render(t, true)?;
        other.render(t, true)?;
        errors.push(bench::relative_error(&reference.output().radiance, &other.output().radiance));
    }
    Ok(ImageError {
        frames: args.error_frames,
        mean_relative: errors.iter().sum::<f64>() / errors.len() as f64,
        max_relative: errors.iter().copied().fold(0.0, f64::max),
    })
}

/// The report as a table on stdout: one column per mode.
fn print_table(ctx: &Context, r: &Report) {
    print_table_heading(r);
    let t = Table::new(r);
    t.head();
    t.row("frame, host wall clock", &|m| fmt_stats(Some(m.frame_host_ms)));
    t.row("  mean, with the final drain", &|m| format!("{:.2}", m.frame_host_mean_ms));
    t.row("frame GPU span (timestamps)", &|m| fmt_stats(m.gpu_span_ms));
    t.row("graphics queue busy (timestamps)", &|m| fmt_stats(m.graphics_busy_ms));
    t.row("compute queue busy (timestamps)", &|m| fmt_stats(m.compute_busy_ms));
    print_pass_rows(&t);
    t.row("ratio to sync (host median)", &|m| m.frame_ratio_to_sync.map(|x| format!("{x:.3}")).unwrap_or("-".into()));
    t.row("image error vs sync (mean, max)", &|m| {
        m.image_error_vs_sync
            .as_ref()
            .map(|e| format!("{:.2e}, {:.2e}", e.mean_relative, e.max_relative))
            .unwrap_or("-".into())
    });
    t.row("submits per frame", &|m| format!("{:.1}", m.submits_per_frame));
    t.row("frame copies (extra MiB)", &|m| {
        format!("{} ({:.1})", m.frame_copies, m.frame_copies_bytes as f64 / (1024.0 * 1024.0))
    });
    t.row("display latency, frames", &|m| m.latency_frames.to_string());
    if let Some(o) = r.modes.iter().find_map(|m| m.occupancy) {
        outln!("occupied voxels (work list): {}", o.summary());
    }
    if let Some(v) = r.modes.iter().find_map(|m| m.voxel_memory.as_ref()) {
        outln!("{}", v.summary()[0]);
    }
    t.row("host waits: in frame / slot reuse", &|m| format!("{} / {}", m.host_waits.in_frame, m.host_waits.slot_reuse));
    for m in r.modes.iter().filter(|m| m.raster.is_some()) {
        print_raster(&m.mode, m.raster.as_ref().expect("raster"));
    }
    if ctx.info.is_cpu() {
        outln!(
            "note: {} is a CPU implementation; its GPU timestamps can be wrong — compare host wall-clock \
             figures (and --serial-profile for per-pass host times)",
            ctx.info.name
        );
    }
}

/// `--raster-profile`: each pass's times and counts, and the overdraw.
fn print_raster(mode: &str, r: &dvsgi::bench::RasterReport) {
    let covered = 100.0 * r.covered_pixels as f64 / r.pixels.max(1) as f64;
    outln!("raster profile ({mode}): {} pixels, {covered:.1}% covered", r.pixels);
    for (i, p) in r.passes.iter().enumerate() {
        let counts = match (p.counts, r.overdraw(i)) {
            (Some(c), Some(o)) => format!(
                "; {} triangles, {} vertex and {} fragment invocations ({o:.2} per covered pixel)",
                c.primitives, c.vertex_invocations, c.fragment_invocations
            ),
            _ => String::new(),
        };
        outln!("  {}: GPU {} ms, serial host {} ms{counts}", p.name, fmt_stats(p.gpu_ms), fmt_stats(p.serial_host_ms));
    }
}

/// The lines above the table: device, queue note and scene.
fn print_table_heading(r: &Report) {
    outln!("device: {} ({}); queue topology: {}", r.device.name, r.device.driver, r.device.queue_topology);
    if !r.device.separate_queues {
        outln!("note: one queue — the async modes submit both streams to it, so they cannot overlap here");
    }
    let gi = if r.gi_mode == "vct" { format!("vct, voxels {}³", r.voxel_resolution) } else { r.gi_mode.clone() };
    outln!(
        "scene: {}  {}x{}  gi {}  {} scenario  {} frames (+{} warm-up), {} in flight",
        r.scene,
        r.width,
        r.height,
        gi,
        r.scenario,
        r.frames,
        r.warmup,
        r.frames_in_flight
    );
}

/// The table's columns: a label column `w` wide, then one per mode.
struct Table<'a> {
    modes: &'a [ModeReport],
    w: usize,
}

impl<'a> Table<'a> {
    /// The table of `r`'s modes, the label column as wide as the longest label needs.
    fn new(r: &'a Report) -> Table<'a> {
        let longest = r.modes.iter().flat_map(|m| &m.passes).map(|p| p.name.len() + 17).max().unwrap_or(0);
        Table { modes: &r.modes, w: longest.max(34) }
    }

    /// Print the header row: the modes' names.
    fn head(&self) {
        let w = self.w;
        let mut head = format!("{:<w$}", "median ms (min..p95)");
        for m in self.modes {
            head.push_str(&format!(" {:>24}", m.mode));
        }
        outln!("{head}");
    }

    /// Print one row: `label`, then `f` of each mode.
    fn row(&self, label: &str, f: &dyn Fn(&ModeReport) -> String) {
        let w = self.w;
        let mut line = format!("{label:<w$}");
        for m in self.modes {
            line.push_str(&format!(" {:>24}", f(m)));
        }
        outln!("{line}");
    }
}

/// `median (min..p95)`, or `-`.
fn fmt_stats(s: Option<Stats>) -> String {
    match s {
        Some(s) => format!("{:.2} ({:.2}..{:.2})", s.median, s.min, s.p95),
        None => "-".to_string(),
    }
}

/// A row per pass (in first-seen order over the modes) with its GPU time and queue, and one
/// with its serial host time where some mode has it.
fn print_pass_rows(t: &Table) {
    let mut names: Vec<&str> = Vec::new();
    for m in t.modes {
        for p in &m.passes {
            if !names.contains(&p.name.as_str()) {
                names.push(&p.name);
            }
        }
    }
    for n in names {
        let find = |m: &ModeReport| m.passes.iter().find(|p| p.name == n).cloned();
        t.row(&format!("  {n} (GPU)"), &|m| match find(m) {
            Some(p) => format!("{} {}", fmt_stats(p.gpu_ms), if p.queue == "compute" { "C" } else { "G" }),
            None => "-".to_string(),
        });
        if t.modes.iter().any(|m| find(m).is_some_and(|p| p.serial_host_ms.is_some())) {
            t.row(&format!("  {n} (serial, host)"), &|m| fmt_stats(find(m).and_then(|p| p.serial_host_ms)));
        }
    }
}
