//! `bench`: times frames of a scene. For now (before the GI and async-compute work) it times
//! the direct-lighting frame: host wall clock per frame beside per-pass GPU timestamps.

use clap::Parser;
use dvsgi::cli::{check_validation, report, stats, CommonArgs};
use dvsgi::render::Renderer;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "bench", version, about = "Time dvsgi frames: host wall clock and GPU timestamps")]
struct Args {
    #[command(flatten)]
    common: CommonArgs,
    /// Scene file.
    #[arg(long)]
    scene: PathBuf,
    /// Frames measured (after warm-up).
    #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    frames: u32,
    /// Frames rendered first and not measured.
    #[arg(long, default_value_t = 3)]
    warmup: u32,
    #[arg(long)]
    width: Option<u32>,
    #[arg(long)]
    height: Option<u32>,
    /// Advance scene time by this many seconds per frame (moving objects and lights).
    #[arg(long, default_value_t = 0.0)]
    dt: f32,
    /// Write the results as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            report(&e);
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> dvsgi::Result<()> {
    let mut extra = Vec::new();
    if let Some(w) = args.width {
        extra.push(("render.width".to_string(), w.to_string()));
    }
    if let Some(h) = args.height {
        extra.push(("render.height".to_string(), h.to_string()));
    }
    let scene = args.common.load_scene(&args.scene, &extra)?;
    let ctx = args.common.context()?;
    let t0 = scene.settings.time;
    let mut renderer = Renderer::new(&ctx, scene)?;
    let (w, h) = renderer.size();
    let mut host = Vec::new();
    let mut per_pass: Vec<(String, Vec<f64>)> = Vec::new();
    for i in 0..args.warmup + args.frames {
        let t = t0 + i as f32 * args.dt;
        let s = renderer.render(t, false)?;
        if i < args.warmup {
            continue;
        }
        host.push(s.host_ms);
        for p in s.passes {
            match per_pass.iter_mut().find(|(n, _)| *n == p.name) {
                Some((_, v)) => v.push(p.gpu_ms),
                None => per_pass.push((p.name, vec![p.gpu_ms])),
            }
        }
    }
    check_validation(&ctx)?;
    let (hmin, hmed, hp95) = stats(&host);
    println!("device: {} ({}); queue topology: {}", ctx.info.name, ctx.info.driver_info, ctx.topology.describe());
    println!("scene: {}  {}x{}  frames {} (+{} warm-up)", args.scene.display(), w, h, args.frames, args.warmup);
    println!("{:<22} {:>10} {:>10} {:>10}", "", "min ms", "median ms", "p95 ms");
    println!("{:<22} {:>10.3} {:>10.3} {:>10.3}", "frame (host wall clock)", hmin, hmed, hp95);
    for (name, v) in &per_pass {
        let (a, b, c) = stats(v);
        println!("{:<22} {:>10.3} {:>10.3} {:>10.3}", format!("{name} (GPU)"), a, b, c);
    }
    if ctx.info.is_cpu() {
        println!(
            "note: {} is a CPU implementation; its GPU timestamps can be wrong — trust the host figures",
            ctx.info.name
        );
    }
    if let Some(path) = &args.json {
        let passes: Vec<_> = per_pass
            .iter()
            .map(|(n, v)| {
                let (a, b, c) = stats(v);
                serde_json::json!({"name": n, "gpu_ms": {"min": a, "median": b, "p95": c}})
            })
            .collect();
        let doc = serde_json::json!({
            "schema": "dvsgi-bench/0",
            "device": ctx.info.name,
            "driver": ctx.info.driver_info,
            "queue_topology": ctx.topology.describe(),
            "scene": args.scene.display().to_string(),
            "width": w, "height": h,
            "frames": args.frames, "warmup": args.warmup,
            "frame_host_ms": {"min": hmin, "median": hmed, "p95": hp95, "samples": host},
            "passes": passes,
        });
        let text = serde_json::to_string_pretty(&doc).expect("JSON serialisation");
        let tmp = path.with_extension("json.tmp");
        std::fs::write(&tmp, text)
            .and_then(|_| std::fs::rename(&tmp, path))
            .map_err(|e| dvsgi::Error::Usage(format!("{}: could not write: {e}", path.display())))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
