//! `dvsgi`: render scenes headless and inspect devices.

use clap::{Parser, Subcommand};
use dvsgi::cli::{check_validation, report, CommonArgs};
use dvsgi::gpu::Context;
use dvsgi::render::{Mode, RenderOptions, Renderer};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "dvsgi", version, about = "Deferred Voxel Shading: voxel cone traced global illumination over Vulkan")]
struct Cli {
    #[command(flatten)]
    common: CommonArgs,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List Vulkan devices and describe the chosen one (queues, features); with a scene,
    /// also the passes a frame runs and the GPU memory it uses.
    Info {
        /// Scene file to describe.
        scene: Option<PathBuf>,
    },
    /// Render a scene to PNG (tone-mapped sRGB) and/or EXR (linear radiance).
    Render {
        /// Scene file (TOML; see scenes/FORMAT.md).
        scene: PathBuf,
        /// Output file(s): .png or .exr (repeatable).
        #[arg(long, short, required = true)]
        out: Vec<PathBuf>,
        /// Image width (overrides render.width).
        #[arg(long)]
        width: Option<u32>,
        /// Image height (overrides render.height).
        #[arg(long)]
        height: Option<u32>,
        /// Scene time in seconds at which motion is evaluated (overrides render.time).
        #[arg(long)]
        time: Option<f32>,
        /// What to show: final | indirect | ao | voxel-albedo | voxel-normal | voxel-emission |
        /// voxel-radiance | voxel-mip (with --set render.view_lod=.. render.view_direction=..)
        /// (overrides render.view).
        #[arg(long)]
        view: Option<String>,
        /// Global illumination: none | vct (overrides gi.mode).
        #[arg(long)]
        gi: Option<String>,
        /// Queue schedule: sync | async | async-lagged (async-lagged needs earlier frames:
        /// see --frames).
        #[arg(long, default_value = "async")]
        schedule: Mode,
        /// Frames to render at the same scene time before writing the last one.
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
        frames: u32,
        /// Print the passes, the submits, the barriers and timings.
        #[arg(long, short)]
        verbose: bool,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            report(&e);
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> dvsgi::Result<()> {
    match cli.command {
        Command::Info { scene } => info(&cli.common, scene),
        Command::Render { scene, out, width, height, time, view, gi, schedule, frames, verbose } => {
            // Fail on unwritable targets before doing any work.
            for o in &out {
                dvsgi::output::check_target(o)?;
            }
            let mut extra = Vec::new();
            if let Some(w) = width {
                extra.push(("render.width".to_string(), w.to_string()));
            }
            if let Some(h) = height {
                extra.push(("render.height".to_string(), h.to_string()));
            }
            if let Some(t) = time {
                extra.push(("render.time".to_string(), format!("{t:?}")));
            }
            if let Some(v) = view {
                extra.push(("render.view".to_string(), format!("{v:?}")));
            }
            if let Some(g) = gi {
                extra.push(("gi.mode".to_string(), format!("{g:?}")));
            }
            let scene = cli.common.load_scene(&scene, &extra)?;
            let ctx = cli.common.context()?;
            let t = scene.settings.time;
            let options = RenderOptions { mode: schedule, ..RenderOptions::default() };
            let mut renderer = Renderer::with_options(&ctx, scene, options)?;
            println!("schedule: {}", schedule_line(&ctx, schedule));
            for _ in 1..frames {
                renderer.render(t, false)?;
            }
            let stats = renderer.render(t, true)?;
            if verbose {
                println!("device: {} ({})", ctx.info.name, ctx.info.driver_info);
                println!("passes: {}", renderer.last_pass_names().join(" -> "));
                let sched = renderer.scheduler();
                for s in sched.submits() {
                    let wait =
                        s.wait.map(|w| format!(", waits for {} {w}", s.queue.other().name())).unwrap_or_default();
                    println!("  submit {} {}{wait}: {}", s.queue.name(), s.signal, s.passes.join(", "));
                }
                for b in sched.log() {
                    println!("  {b}");
                }
                println!("frame: {:.2} ms host wall clock (record + submit + wait)", stats.host_ms);
                if let Some(timing) = &stats.timing {
                    for p in &timing.passes {
                        println!("  {:<22} {:<8} {:>8.3} ms GPU timestamps", p.name, p.queue.name(), p.gpu_ms());
                    }
                }
            }
            check_validation(&ctx)?;
            let frame = renderer.output();
            for o in &out {
                dvsgi::output::write_frame(o, &frame)?;
                println!("wrote {}", o.display());
            }
            Ok(())
        }
    }
}

fn info(common: &CommonArgs, scene: Option<PathBuf>) -> dvsgi::Result<()> {
    let scene = scene.map(|s| common.load_scene(&s, &[])).transpose()?;
    println!("Vulkan devices:");
    for c in Context::list_devices()? {
        println!(
            "  [{}] {} ({:?}, Vulkan {}.{}){}",
            c.index,
            c.name,
            c.device_type,
            ash::vk::api_version_major(c.api_version),
            ash::vk::api_version_minor(c.api_version),
            c.unusable.map(|u| format!(" — unusable: {u}")).unwrap_or_default()
        );
    }
    let ctx = common.context()?;
    let i = &ctx.info;
    println!("chosen device: [{}] {}", i.index, i.name);
    println!("  type: {:?}", i.device_type);
    println!("  driver: {} ({})", i.driver_name, i.driver_info);
    println!("  Vulkan: {}", i.api_version_string());
    println!("  queue families:");
    for f in &i.families {
        println!("    [{}] {:?} x{} (timestamp bits {})", f.index, f.flags, f.count, f.timestamp_valid_bits);
    }
    println!("  graphics queue: family {} index {}", ctx.graphics_queue.family, ctx.graphics_queue.index);
    println!("  compute queue: family {} index {}", ctx.compute_queue.family, ctx.compute_queue.index);
    println!("  queue topology: {}", ctx.topology.describe());
    println!("  required features: timelineSemaphore synchronization2 dynamicRendering maintenance4 (enabled)");
    let o = &i.optional;
    let yn = |b: bool| if b { "yes" } else { "no" };
    println!(
        "  optional: geometryShader {} fragmentStoresAndAtomics {} depthClamp {} conservativeRasterization {} \
         calibratedTimestamps {} shaderImageFloat32Atomics {}",
        yn(o.geometry_shader),
        yn(o.fragment_stores_and_atomics),
        yn(o.depth_clamp),
        yn(o.conservative_rasterization),
        yn(o.calibrated_timestamps),
        yn(o.shader_image_float32_atomics)
    );
    println!(
        "  timestamp period: {} ns; maxImageDimension2D {}, maxImageDimension3D {}",
        i.timestamp_period_ns, i.limits.max_image_dimension2_d, i.limits.max_image_dimension3_d
    );
    println!("  validation: {}", if ctx.validation_enabled { "on" } else { "off" });
    if let Some(scene) = scene {
        println!(
            "scene {}: {} objects, {} meshes, {} triangles, {} materials, {} lights",
            scene.path.display(),
            scene.objects.len(),
            scene.meshes.len(),
            scene.triangle_count(),
            scene.materials.len(),
            scene.lights.len()
        );
        let before = ctx.allocated_bytes();
        let renderer = Renderer::new(&ctx, scene)?;
        println!("  passes (first frame): {}", renderer.pass_names(false).join(" -> "));
        for img in renderer.images() {
            let kind = if img.desc.kind == dvsgi::gpu::ImageKind::D3 { "volume" } else { "image" };
            println!("  {kind} {}: {:.2} MiB", img.name, img.bytes as f64 / (1024.0 * 1024.0));
        }
        println!(
            "  GPU memory allocated for the scene and frame: {:.2} MiB",
            (ctx.allocated_bytes() - before) as f64 / (1024.0 * 1024.0)
        );
    }
    check_validation(&ctx)?;
    Ok(())
}

/// The schedule and where its compute work really runs (every output says so).
fn schedule_line(ctx: &Context, mode: Mode) -> String {
    match mode {
        Mode::Sync => "sync (everything on the graphics queue)".to_string(),
        _ => format!("{mode}, {}", ctx.topology.describe()),
    }
}
