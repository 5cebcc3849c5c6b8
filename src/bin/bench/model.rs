//! `bench --model REPORT.json`: the report's settings made this run's, the submits recorded
//! for each mode, the simulation (`dvsgi::model`) and its table.

use super::{load_bench_scene, measure_spec, usage, Args, Given, Scenario};
use dvsgi::bench::{self, Report};
use dvsgi::model::{self, ModeModel, ModelReport, Recording};
use std::path::Path;

/// The recording's image size unless --width/--height are given: the submits do not depend
/// on it (tests/bench.rs checks that), and small frames record fast on a CPU device.
const RECORDED_SIZE: (u32, u32) = (96, 54);

pub fn run(mut args: Args, given: &Given, path: &Path) -> dvsgi::Result<()> {
    dvsgi::output::check_targets(&args.json.iter().cloned().collect::<Vec<_>>())?;
    let report = model::read_report(path)?;
    adopt_report(&mut args, given, &report)?;
    let scene = load_bench_scene(&args)?;
    let ctx = args.common.context()?;
    eprintln!("recording the submits on {} ({})", ctx.info.name, ctx.topology.describe());
    let mut modes = Vec::new();
    for &mode in &args.modes {
        let m = measure_spec(&args, mode);
        eprintln!("{mode}: {} frames after {} warm-up, {} in flight", m.frames, m.warmup, m.frames_in_flight);
        let frames = bench::record_submits(&ctx, &scene, &m)?;
        let rec = Recording { frames_in_flight: m.frames_in_flight, frames };
        modes.push(model::model_mode(&report, path, mode, &rec)?);
    }
    dvsgi::cli::check_validation(&ctx)?;
    model::add_predicted_ratios(&mut modes);
    let out = ModelReport {
        schema: model::SCHEMA.to_string(),
        report: path.display().to_string(),
        measured_on: report.device.name.clone(),
        measured_topology: report.device.queue_topology.clone(),
        measured_timestamps_trusted: report.device.timestamps_trusted,
        recorded_on: ctx.info.name.clone(),
        recorded_topology: ctx.topology.describe().to_string(),
        scene: args.scene_path().display().to_string(),
        scenario: format!("{:?}", args.scenario).to_lowercase(),
        recorded_width: scene.settings.width,
        recorded_height: scene.settings.height,
        frames: args.frames,
        warmup: args.warmup,
        frames_in_flight: args.frames_in_flight,
        settings: args.common.settings(),
        modes,
    };
    print_table(&out);
    match &args.json {
        Some(p) => {
            let json = serde_json::to_string_pretty(&out).expect("JSON serialisation").into_bytes();
            dvsgi::cli::write_outputs(&[(p.as_path(), json)])
        }
        None => Ok(()),
    }
}

/// What the command line did not say, the report's: scene, scenario, frames, warm-up, frames
/// in flight, its settings (before any --set given here), and the voxel layout and depth
/// prepass its device used.
fn adopt_report(args: &mut Args, given: &Given, report: &Report) -> dvsgi::Result<()> {
    if args.scene.is_none() {
        args.scene = Some(report.scene.clone().into());
    }
    if !given.has("scenario") {
        args.scenario = match report.scenario.as_str() {
            "static" => Scenario::Static,
            "dynamic" => Scenario::Dynamic,
            "redraw" => Scenario::Redraw,
            other => return Err(usage(format!("the report's scenario '{other}' is not one bench knows"))),
        };
    }
    if !given.has("frames") {
        args.frames = report.frames;
    }
    if !given.has("warmup") {
        args.warmup = report.warmup;
    }
    if !given.has("frames_in_flight") {
        args.frames_in_flight = report.frames_in_flight;
    }
    args.width = args.width.or(Some(RECORDED_SIZE.0));
    args.height = args.height.or(Some(RECORDED_SIZE.1));
    let mut sets = Vec::new();
    for s in &report.settings {
        match s.strip_prefix("preset=") {
            Some(p) if args.common.preset.is_none() => {
                args.common.preset =
                    Some(clap::ValueEnum::from_str(p, true).map_err(|e| usage(format!("the report's {s}: {e}")))?)
            }
            Some(_) => {}
            None => sets.push(s.clone()),
        }
    }
    if let Some(layout) = model::report_layout(report) {
        sets.push(format!("gi.voxel_layout=\"{layout}\""));
    }
    let prepass = if model::report_depth_prepass(report) { "on" } else { "off" };
    sets.push(format!("render.depth_prepass=\"{prepass}\""));
    sets.append(&mut args.common.sets);
    args.common.sets = sets;
    Ok(())
}

fn print_table(r: &ModelReport) {
    println!("schedule model: {}", r.report);
    println!("  pass times measured on {} ({})", r.measured_on, r.measured_topology);
    println!("  submits recorded on {} ({})", r.recorded_on, r.recorded_topology);
    println!(
        "  scene {}, {} scenario, {} frames (+{} warm-up), {} in flight; recorded at {}x{}",
        r.scene, r.scenario, r.frames, r.warmup, r.frames_in_flight, r.recorded_width, r.recorded_height
    );
    if !r.measured_timestamps_trusted {
        println!("warning: the report's timestamps come from a CPU implementation and can be wrong; so is what the model makes of them");
    }
    if !r.settings.is_empty() {
        println!("  settings: {}", r.settings.join(" "));
    }
    let col = |f: &dyn Fn(&ModeModel) -> String| r.modes.iter().map(|m| format!("{:>16}", f(m))).collect::<String>();
    let ms = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2}"));
    println!("{:<44}{}", "ms (host median per frame)", col(&|m| m.mode.clone()));
    println!("{:<44}{}", "measured frame", col(&|m| ms(m.measured_frame_host_ms)));
    println!("{:<44}{}", "modelled frame", col(&|m| format!("{:.2}", m.predicted.frame_host_ms.median)));
    println!("{:<44}{}", "model error", col(&|m| m.error.map_or("-".into(), |e| format!("{:+.1}%", 100.0 * e))));
    println!(
        "{:<44}{}",
        "modelled ratio to sync",
        col(&|m| m.predicted_ratio_to_sync.map_or("-".into(), |x| format!("{x:.3}")))
    );
    let busy = |measured: Option<f64>, modelled: f64| format!("{} / {modelled:.2}", ms(measured));
    println!(
        "{:<44}{}",
        "graphics busy, measured / modelled",
        col(&|m| busy(m.measured_graphics_busy_ms, m.predicted.graphics_busy_ms.median))
    );
    println!(
        "{:<44}{}",
        "compute busy, measured / modelled",
        col(&|m| busy(m.measured_compute_busy_ms, m.predicted.compute_busy_ms.median))
    );
    println!("{:<44}{}", "bound with full overlap across frames", col(&|m| format!("{:.2}", m.overlap_bound_ms)));
    println!("{:<44}{}", "modelled GPU span of a frame", col(&|m| format!("{:.2}", m.predicted.gpu_span_ms.median)));
    println!("{:<44}{}", "pass times from", col(&|m| m.times_from.clone()));
    println!("{:<44}{}", "submits per frame (recorded)", col(&|m| format!("{:.1}", m.submits_per_frame)));
    for m in &r.modes {
        for w in &m.waits_across_frames {
            println!("{}: {w}", m.mode);
        }
    }
    for m in r.modes.iter().filter(|m| !m.untimed_passes.is_empty()) {
        println!("warning: {}: the report has no time for {} (counted as 0 ms)", m.mode, m.untimed_passes.join(", "));
    }
    for m in r.modes.iter().filter(|m| !m.structure_differences.is_empty()) {
        println!(
            "warning: {}: the recorded frame is not the one the report measured ({}); \
             the report is from another version or scenario",
            m.mode,
            m.structure_differences.join("; ")
        );
    }
}
