//! `dvsgi`: render scenes headless and inspect devices.

use clap::{Parser, Subcommand};
use dvsgi::cli::{check_validation, init_logging, report, CommonArgs};
use dvsgi::gpu::Context;
use dvsgi::outln;
use dvsgi::render::{Mode, RenderOptions, Renderer};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "dvsgi",
    version,
    about = "Deferred Voxel Shading: voxel cone traced global illumination over Vulkan",
    after_help = "Examples:
  dvsgi info                                            devices, queue families, topology
  dvsgi info scenes/cornell-box.toml --preset high      passes, memory and the [gi] settings used
  dvsgi render scenes/cornell-box.toml --out c.png --out c.exr
  dvsgi render scenes/sponza.toml --gi none --width 1280 --height 720 --out s.png
  dvsgi reference scenes/cornell-box.toml --spp 1024 --out ref.exr
  dvsgi compare c.exr ref.exr --scene scenes/cornell-box.toml --json err.json
  dvsgi sweep scenes/cornell-box.toml --grid voxel_resolution=32,64 --out sweep/

Scene files: scenes/FORMAT.md. Speed: bench --help. Accuracy: ACCURACY.md."
)]
struct Cli {
    #[command(flatten)]
    common: CommonArgs,
    #[command(subcommand)]
    command: Command,
}

/// `--width/--height/--time`, shared by the commands that render.
#[derive(clap::Args)]
struct SizeArgs {
    /// Image width (overrides render.width).
    #[arg(long)]
    width: Option<u32>,
    /// Image height (overrides render.height).
    #[arg(long)]
    height: Option<u32>,
    /// Scene time in seconds at which motion is evaluated (overrides render.time; may be
    /// negative).
    #[arg(long, allow_negative_numbers = true)]
    time: Option<f32>,
}

impl SizeArgs {
    /// As scene overrides.
    fn overrides(&self) -> Vec<(String, String)> {
        let mut extra = Vec::new();
        if let Some(w) = self.width {
            extra.push(("render.width".to_string(), w.to_string()));
        }
        if let Some(h) = self.height {
            extra.push(("render.height".to_string(), h.to_string()));
        }
        if let Some(t) = self.time {
            // `{:?}` writes NaN as `NaN`, which is not TOML; the scene layer then names the
            // key and says the value is not finite.
            let v = if t.is_nan() { "nan".to_string() } else { format!("{t:?}") };
            extra.push(("render.time".to_string(), v));
        }
        extra
    }
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
        #[command(flatten)]
        size: SizeArgs,
        /// What to show: final | indirect | ao | voxel-albedo | voxel-normal | voxel-emission |
        /// voxel-radiance | voxel-mip (with --set render.view_lod=.. render.view_direction=..)
        /// (overrides render.view).
        #[arg(long)]
        view: Option<String>,
        /// Global illumination: none | vct | rsm | lpv | rsm+lpv (overrides gi.mode).
        #[arg(long)]
        gi: Option<String>,
        /// Queue schedule: sync | async | async-lagged | async-pipelined (async-lagged needs
        /// earlier frames: see --frames).
        #[arg(long, default_value = "async")]
        schedule: Mode,
        /// Frames to render at the same scene time before writing the last one.
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
        frames: u32,
        /// Print the passes, the submits, the barriers and timings.
        #[arg(long, short)]
        verbose: bool,
    },
    /// Open a window on the scene: fly or orbit the camera, change the technique, its knobs,
    /// the schedule and the preset live, and read each pass's GPU time on both queues.
    /// F12 captures the frame (PNG, EXR), the window and the settings (a scene file that
    /// `dvsgi render` reproduces). Needs a display (X11 or Wayland; or xvfb-run).
    #[command(after_help = "Keys: WASD fly, Q/E down/up, Shift faster, right-drag look (fly), left-drag \
orbit, wheel zoom, R reset camera, P pause time, F12 capture.

Script (--script FILE), one command per line:
  frames N | camera PX PY PZ TX TY TZ | turn YAW PITCH (degrees) | fly F R U SECONDS
  orbit | fly-mode | set KEY=VALUE | gi MODE | view NAME | schedule MODE | preset NAME
  pause | play | capture STEM | resize W H | memory | quit
The viewer exits at the end of the script; each script frame advances scene time 1/30 s.")]
    View {
        /// Scene file (TOML; see scenes/FORMAT.md).
        scene: PathBuf,
        #[command(flatten)]
        size: SizeArgs,
        /// Queue schedule to start with: sync | async | async-lagged | async-pipelined (the
        /// window then shows each frame one frame later).
        #[arg(long, default_value = "async")]
        schedule: Mode,
        /// Drive the viewer from a file of commands instead of input (tests, figures).
        #[arg(long)]
        script: Option<PathBuf>,
        /// Window width in pixels.
        #[arg(long, default_value_t = 1280)]
        window_width: u32,
        /// Window height in pixels.
        #[arg(long, default_value_t = 800)]
        window_height: u32,
        /// Present in step with the display (FIFO); by default frames are presented as fast as
        /// they come (mailbox or immediate), so the frame time is the renderer's.
        #[arg(long)]
        vsync: bool,
    },
    /// Compare a rendered image with a reference (both linear-radiance .exr): RMSE and relMSE
    /// on radiance, FLIP and SSIM on the display images (exposure and tone map as given).
    Compare {
        /// The image to judge (.exr).
        test: PathBuf,
        /// The reference (.exr), e.g. from `dvsgi reference`.
        reference: PathBuf,
        /// Write the FLIP error map (magma colours) to this .png.
        #[arg(long)]
        diff: Option<PathBuf>,
        /// Exposure in EV stops of the display transform.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        exposure: f32,
        /// Tone map of the display transform: aces | reinhard | clamp.
        #[arg(long, default_value = "aces")]
        tonemap: String,
        /// Also write the figures as JSON.
        #[arg(long)]
        json: Option<PathBuf>,
        /// The scene both images show (with the same --set/--preset and image size): report
        /// the error per region (object, mesh, material, and mesh × facing).
        #[arg(long)]
        scene: Option<PathBuf>,
        /// The reference's direct light alone (`dvsgi reference --bounces 0`; under a sky, with
        /// `--set sky.type='"none"'`: the renderer's indirect light holds the sky's): also report
        /// the indirect light (reference − this) per region. Needs --scene.
        #[arg(long, requires = "scene")]
        ref_direct: Option<PathBuf>,
        /// The test image's indirect light (`dvsgi render --view indirect`); without it the
        /// test's indirect light is TEST − the reference's direct light.
        #[arg(long, requires = "ref_direct")]
        test_indirect: Option<PathBuf>,
        /// Write a picture of log2(test / reference) per pixel (of the indirect light when
        /// --ref-direct is given): blue too dark, white right, red too bright, saturating at
        /// one stop. Needs --scene.
        #[arg(long, requires = "scene")]
        ratio: Option<PathBuf>,
    },
    /// The speed/accuracy sweep: render a grid of cone-tracing settings, time each, compare it
    /// with the path-traced reference, mark the Pareto-optimal ones and draw the frontier.
    Sweep {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Output directory (created; an existing sweep of the same setup is resumed).
        #[arg(long, short)]
        out: PathBuf,
        /// A knob and its values, e.g. --grid voxel_resolution=32,64,128 (repeatable; knobs:
        /// voxel_resolution, diffuse_cones, diffuse_cone_angle, step, bounces, downsample, ao
        /// (0 or 1), bounce_cones, bounce_interleave, mode (the technique: none, vct, rsm, lpv,
        /// rsm+lpv), rsm_samples, rsm_radius, rsm_size, lpv_resolution, lpv_steps, specular
        /// (off, cone, rt), specular_rays, rt_hit_indirect (cones, voxel), specular_history,
        /// shadows (shadow-map, cone, rt), opacity (blend, layers), voxel_cover (touch, area,
        /// directional), footprint and bounce_footprint (whole, quadrants, shares), attenuation
        /// (normal-weighted, n-dot-l, per-side), plane_backs (lit, dark, closed), cone_filter
        /// (trilinear, two-tap)). Sweeps with other
        /// grids into the same
        /// directory add their rows to one frontier, e.g. the cone-tracing grid, then --grid
        /// mode=rsm ....
        /// Without --grid: the default grid of 216 configurations (ACCURACY.md).
        #[arg(long)]
        grid: Vec<String>,
        /// Reference samples per pixel.
        #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
        spp: u32,
        /// Timed frames per configuration (each scenario), after --warmup.
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=10_000))]
        frames: u32,
        /// Untimed frames before each configuration's timed ones.
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(0..=10_000))]
        warmup: u32,
        /// Queue schedule of the timed frames.
        #[arg(long, default_value = "sync")]
        schedule: Mode,
        #[command(flatten)]
        size: SizeArgs,
    },
    /// Path-trace the ground truth: unbiased, the same scene model as the renderer. Writes
    /// linear radiance to each .exr OUT with the variance of each pixel's mean beside it
    /// (ref.exr -> ref.var.exr), and the display image to each .png OUT.
    Reference {
        /// Scene file (TOML; see scenes/FORMAT.md).
        scene: PathBuf,
        /// Output file(s): .exr (linear radiance, plus .var.exr) or .png (tone-mapped).
        #[arg(long, short, required = true)]
        out: Vec<PathBuf>,
        /// Samples (paths) per pixel.
        #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
        spp: u32,
        /// Indirect bounces at most (default: until Russian roulette ends the path; 0 = direct
        /// light only, like `--gi none`).
        #[arg(long)]
        bounces: Option<u32>,
        /// Seed of the random sequences.
        #[arg(long, default_value_t = 1)]
        seed: u32,
        /// Spread each pixel's paths over its area (antialiased). By default they leave
        /// through the pixel centre, where the rasterizer samples, so error maps against the
        /// renderer show lighting errors, not edge aliasing. Always on for a scene with
        /// `render.supersample` > 1, whose renderer averages over the pixel too.
        #[arg(long)]
        jitter: bool,
        /// Which surfaces reflect specularly: `all` (the ground truth) or `first`, the camera's
        /// first surface only, later ones Lambertian: the transport voxel cone tracing models
        /// (no caustics, no reflections of reflections), to tell its approximation error from
        /// what it leaves out.
        #[arg(long, value_enum, default_value_t = dvsgi::reference::SpecularPaths::All)]
        specular: dvsgi::reference::SpecularPaths,
        #[command(flatten)]
        size: SizeArgs,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    init_logging();
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
        Command::Compare {
            test,
            reference,
            diff,
            exposure,
            tonemap,
            json,
            scene,
            ref_direct,
            test_indirect,
            ratio,
        } => {
            let regions = scene.map(|scene| RegionArgs { scene, ref_direct, test_indirect, ratio });
            compare(&cli.common, &test, &reference, diff.as_deref(), exposure, &tonemap, json.as_deref(), regions)
        }
        Command::Sweep { scene, out, grid, spp, frames, warmup, schedule, size } => {
            let grid =
                if grid.is_empty() { dvsgi::sweep::Grid::default_grid() } else { dvsgi::sweep::Grid::parse(&grid)? };
            let opts =
                dvsgi::sweep::SweepOptions { scene, out, grid, spp, frames, warmup, schedule, size: size.overrides() };
            let results = dvsgi::sweep::run(&cli.common, &opts)?;
            print_sweep(&results);
            outln!("wrote {}/results.csv, results.json and frontier-*.svg", opts.out.display());
            Ok(())
        }
        Command::Reference { scene, out, spp, bounces, seed, jitter, specular, size } => {
            let options = dvsgi::reference::ReferenceOptions {
                spp,
                max_bounces: bounces,
                seed,
                jitter,
                specular,
                ..Default::default()
            };
            reference(&cli.common, &scene, &out, options, size.overrides())
        }
        Command::View { scene, size, schedule, script, window_width, window_height, vsync } => {
            let window = (window_width.max(1), window_height.max(1));
            let opts = dvsgi::view::ViewOptions { scene, schedule, window, vsync, size: size.overrides() };
            dvsgi::view::run(&cli.common, opts, script.as_deref())
        }
        Command::Render { scene, out, size, view, gi, schedule, frames, verbose } => {
            let mut extra = size.overrides();
            if let Some(v) = view {
                extra.push(("render.view".to_string(), format!("{v:?}")));
            }
            if let Some(g) = gi {
                extra.push(("gi.mode".to_string(), format!("{g:?}")));
            }
            render(&cli.common, &scene, &out, &extra, schedule, frames, verbose)
        }
    }
}

/// `dvsgi render`: `frames` frames at the scene's time, the last one written to `out`.
fn render(
    common: &CommonArgs,
    scene: &std::path::Path,
    out: &[PathBuf],
    extra: &[(String, String)],
    schedule: Mode,
    frames: u32,
    verbose: bool,
) -> dvsgi::Result<()> {
    // Fail on unwritable targets before doing any work.
    for o in out {
        dvsgi::output::check_target(o)?;
    }
    dvsgi::output::check_targets(out)?;
    let scene = common.load_scene(scene, extra)?;
    let ctx = common.context()?;
    let t = scene.settings.time;
    let options = RenderOptions { mode: schedule, ..RenderOptions::default() };
    let mut renderer = Renderer::with_options(&ctx, scene, options)?;
    outln!("schedule: {}", schedule_line(&ctx, schedule));
    for _ in 1..frames {
        renderer.render(t, false)?;
    }
    let stats = renderer.render(t, true)?;
    if verbose {
        print_frame(&ctx, &renderer, &stats);
    }
    check_validation(&ctx)?;
    let frame = renderer.output();
    let files = out
        .iter()
        .map(|o| Ok((o.as_path(), dvsgi::output::encode_frame(o, &frame)?)))
        .collect::<dvsgi::Result<Vec<_>>>()?;
    dvsgi::cli::write_outputs(&files)?;
    Ok(())
}

/// `render --verbose`: the passes, the submits, the barriers and the timings of the frame.
fn print_frame(ctx: &Context, renderer: &Renderer, stats: &dvsgi::render::FrameStats) {
    outln!("device: {} ({})", ctx.info.name, ctx.info.driver_info);
    outln!("passes: {}", renderer.last_pass_names().join(" -> "));
    let sched = renderer.scheduler();
    for s in sched.submits() {
        let wait = s.wait.map(|w| format!(", waits for {} {w}", s.queue.other().name())).unwrap_or_default();
        outln!("  submit {} {}{wait}: {}", s.queue.name(), s.signal, s.passes.join(", "));
    }
    for b in sched.log() {
        outln!("  {b}");
    }
    outln!("frame: {:.2} ms host wall clock (record + submit + wait)", stats.host_ms);
    if let Some(timing) = &stats.timing {
        for p in &timing.passes {
            outln!("  {:<22} {:<8} {:>8.3} ms GPU timestamps", p.name, p.queue.name(), p.gpu_ms());
        }
    }
}

/// `compare --scene`: where the regions come from and what else to report.
struct RegionArgs {
    scene: PathBuf,
    ref_direct: Option<PathBuf>,
    test_indirect: Option<PathBuf>,
    ratio: Option<PathBuf>,
}

/// What `compare --json` writes: the whole-image figures, and the regions when asked for.
#[derive(serde::Serialize)]
struct CompareJson {
    #[serde(flatten)]
    comparison: dvsgi::metrics::Comparison,
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    regions: Option<dvsgi::regions::RegionReport>,
}

#[allow(clippy::too_many_arguments)]
fn compare(
    common: &CommonArgs,
    test: &std::path::Path,
    reference: &std::path::Path,
    diff: Option<&std::path::Path>,
    exposure: f32,
    tonemap: &str,
    json: Option<&std::path::Path>,
    regions: Option<RegionArgs>,
) -> dvsgi::Result<()> {
    use dvsgi::metrics::{compare_named, flip_error_map, LinearImage};
    let tonemap: dvsgi::scene::ToneMap = serde_json::from_value(serde_json::Value::String(tonemap.to_string()))
        .map_err(|_| dvsgi::Error::Usage(format!("--tonemap {tonemap}: use aces, reinhard or clamp")))?;
    if !exposure.is_finite() {
        return Err(dvsgi::Error::Usage(format!("--exposure {exposure} is not a finite number")));
    }
    if regions.is_none() && (!common.sets.is_empty() || common.preset.is_some() || !common.asset_paths.is_empty()) {
        // Without a scene they would change nothing: refuse rather than ignore.
        return Err(dvsgi::Error::Usage(
            "compare: --set, --preset and --asset-path apply to the scene of --scene (the regions); \
             without --scene there is no scene to apply them to"
                .into(),
        ));
    }
    let ratio = regions.as_ref().and_then(|r| r.ratio.as_deref());
    let outs: Vec<PathBuf> = diff.iter().chain(json.iter()).chain(ratio.iter()).map(|p| p.to_path_buf()).collect();
    dvsgi::output::check_targets(&outs)?;
    for picture in diff.iter().chain(ratio.iter()) {
        if dvsgi::output::format_of(picture)? != dvsgi::output::Format::Png {
            return Err(dvsgi::Error::Usage(format!("{}: this is a picture; give a .png name", picture.display())));
        }
    }
    let (t, r) = (LinearImage::read_exr(test)?, LinearImage::read_exr(reference)?);
    let name = |p: &std::path::Path| p.display().to_string();
    let c = compare_named(&t, &name(test), &r, &name(reference), exposure, tonemap)?;
    print_comparison(test, reference, &c);
    let (region_report, ratio_png) = match &regions {
        Some(args) => {
            let (report, png) = compare_regions(common, &t, &r, reference, args)?;
            (Some(report), png)
        }
        None => (None, None),
    };
    // Every output or none.
    let mut files: Vec<(&std::path::Path, Vec<u8>)> = Vec::new();
    if let Some(d) = diff {
        files.push((d, dvsgi::output::encode_png(d, &flip_error_map(&t, &r, exposure, tonemap)?)?));
    }
    if let Some(j) = json {
        let text = serde_json::to_string_pretty(&CompareJson { comparison: c, regions: region_report }).expect("JSON");
        files.push((j, text.into_bytes()));
    }
    if let (Some(p), Some(png)) = (ratio, ratio_png) {
        files.push((p, png));
    }
    dvsgi::cli::write_outputs(&files)
}

fn print_comparison(test: &std::path::Path, reference: &std::path::Path, c: &dvsgi::metrics::Comparison) {
    outln!("{} against {} ({} pixels)", test.display(), reference.display(), c.pixels);
    outln!("  RMSE   {:.6} (linear radiance)", c.rmse);
    outln!("  relMSE {:.6} (linear radiance, epsilon {})", c.relmse, dvsgi::metrics::RELMSE_EPSILON);
    let row = |name: &str, s: &dvsgi::metrics::Summary| {
        outln!(
            "  {name:<6} mean {:.4}  p50 {:.4}  p90 {:.4}  p95 {:.4}  p99 {:.4}  max {:.4}",
            s.mean,
            s.p50,
            s.p90,
            s.p95,
            s.p99,
            s.max
        )
    };
    outln!(
        "  mean radiance {:.6} against {:.6} (ratio {:.4})",
        c.test_mean,
        c.reference_mean,
        c.test_mean / c.reference_mean
    );
    row("FLIP", &c.flip);
    row("SSIM", &c.ssim);
    outln!(
        "  outliers {:.4} against {:.4} (lit pixels > 50% off their 3x3 median: salt-and-pepper noise)",
        c.test_outliers,
        c.reference_outliers
    );
    outln!("  (FLIP: 0 = identical, lower is better; SSIM: 1 = identical, higher is better)");
}

/// The per-region part of `compare` (the two images already read and of one size): label the
/// pixels from the scene, report, and draw the ratio picture (encoded, when asked for).
fn compare_regions(
    common: &CommonArgs,
    t: &dvsgi::metrics::LinearImage,
    r: &dvsgi::metrics::LinearImage,
    reference: &std::path::Path,
    args: &RegionArgs,
) -> dvsgi::Result<(dvsgi::regions::RegionReport, Option<Vec<u8>>)> {
    use dvsgi::metrics::LinearImage;
    use dvsgi::regions::{indirect_pair, ratio_picture, region_stats, Pair, RegionMap, RegionReport};
    // Further images must have the test image's size.
    let read = |p: &std::path::Path, what: &str| -> dvsgi::Result<LinearImage> {
        let img = LinearImage::read_exr(p)?;
        if (img.width, img.height) != (t.width, t.height) {
            return Err(dvsgi::Error::Usage(format!(
                "{}: {what} is {}x{} but the test image is {}x{}",
                p.display(),
                img.width,
                img.height,
                t.width,
                t.height
            )));
        }
        Ok(img)
    };
    let var_path = dvsgi::reference::variance_path(reference);
    let var = if var_path.is_file() { Some(read(&var_path, "the reference's variance")?) } else { None };
    let size =
        vec![("render.width".to_string(), t.width.to_string()), ("render.height".to_string(), t.height.to_string())];
    let scene = common.load_scene(&args.scene, &size)?;
    let map = RegionMap::trace(&scene, t.width, t.height);
    let regions = region_stats(&map, &Pair { test: t, reference: r, reference_variance: var.as_ref() });
    print_regions("regions (test / reference mean radiance)", &regions);
    let indirect = match &args.ref_direct {
        Some(rd) => {
            if scene.sky.is_some() {
                eprintln!("{}", sky_split_note("--ref-direct"));
            }
            let rd = read(rd, "the reference's direct light")?;
            let ti = args.test_indirect.as_deref().map(|p| read(p, "the test's indirect light")).transpose()?;
            let (ti, ri) = indirect_pair(t, r, &rd, ti.as_ref());
            let stats = region_stats(&map, &Pair { test: &ti, reference: &ri, reference_variance: var.as_ref() });
            print_regions("indirect light by region (test / reference)", &stats);
            Some((stats, ti, ri))
        }
        None => None,
    };
    // Of the indirect light when it is known.
    let (pt, pr) = indirect.as_ref().map(|(_, ti, ri)| (ti, ri)).unwrap_or((t, r));
    let png =
        args.ratio.as_deref().map(|p| dvsgi::output::encode_png(p, &ratio_picture(&map, pt, pr, 1.0))).transpose()?;
    let indirect = indirect.map(|(stats, _, _)| stats);
    Ok((RegionReport { regions, indirect }, png))
}

/// The renderer's indirect light (`render --view indirect`) holds the sky's light, which its
/// cones gather, while `reference --bounces 0` counts the sky's light as direct: under a sky,
/// the indirect light of `compare --ref-direct` is the renderer's only when the direct light
/// was rendered without the sky (ACCURACY.md, "Sponza under a sky"). `compare` notes it; so
/// does `reference --bounces 0`, where such an image is made.
fn sky_split_note(what: &str) -> String {
    format!(
        "note: the scene has a sky, whose light the renderer counts as indirect (its cones gather it): {what} \
         should hold the lights' direct light alone, `dvsgi reference SCENE --bounces 0 --set sky.type='\"none\"'`; \
         with the sky in it, the reference's indirect light lacks the sky's direct light and the ratios come out too high"
    )
}

fn print_regions(title: &str, stats: &[dvsgi::regions::RegionStats]) {
    outln!("{title}:");
    outln!(
        "  {:<9} {:<34} {:>7} {:>8} {:>8} {:>9} {:>9}",
        "grouping",
        "region",
        "pixels",
        "ratio",
        "±noise",
        "relMSE",
        "RMSE"
    );
    for s in stats {
        let noise = s.ratio_noise.map(|n| format!("{n:.4}")).unwrap_or_else(|| "-".into());
        outln!(
            "  {:<9} {:<34} {:>7} {:>8.4} {:>8} {:>9.5} {:>9.5}{}",
            format!("{:?}", s.grouping).to_lowercase(),
            s.name,
            s.pixels,
            s.ratio,
            noise,
            s.relmse,
            s.rmse,
            if s.small { "  (few pixels)" } else { "" }
        );
    }
}

fn print_sweep(results: &dvsgi::sweep::Results) {
    use dvsgi::sweep::value_text;
    outln!("each knob, one step up, averaged over rows that differ only in it:");
    outln!("  {:<20} {:>26} {:>6} {:>10} {:>11} {:>11}", "knob", "step", "pairs", "d ms", "d FLIP", "d RMSE");
    for e in &results.knob_effects {
        outln!(
            "  {:<20} {:>26} {:>6} {:>+10.1} {:>+11.5} {:>+11.5}",
            e.knob.key(),
            format!("{} -> {}", value_text(e.knob, e.from), value_text(e.knob, e.to)),
            e.pairs,
            e.delta_ms,
            e.delta_flip,
            e.delta_rmse
        );
    }
    outln!("{} configurations; Pareto-optimal for mean FLIP against frame time:", results.rows.len());
    outln!(
        "  {:<28} {:>10} {:>10} {:>9} {:>9} {:>7}",
        "configuration",
        "frame ms",
        "static ms",
        "RMSE",
        "FLIP",
        "SSIM"
    );
    let mut front: Vec<_> = results.rows.iter().filter(|r| r.front_flip).collect();
    front.sort_by(|a, b| a.frame_ms.total_cmp(&b.frame_ms));
    for r in front {
        outln!(
            "  {:<28} {:>10.1} {:>10.1} {:>9.5} {:>9.4} {:>7.4}",
            r.label,
            r.frame_ms,
            r.static_frame_ms,
            r.rmse,
            r.flip_mean,
            r.ssim_mean
        );
    }
}

/// What `reference` writes into one file.
enum RefOutput {
    /// Linear radiance, the mean of the samples (EXR).
    Mean,
    /// The variance of that mean, beside each EXR (`X.var.exr`).
    Variance,
    /// The display image (PNG).
    Display,
}

fn reference(
    common: &CommonArgs,
    scene: &std::path::Path,
    outs: &[PathBuf],
    options: dvsgi::reference::ReferenceOptions,
    extra: Vec<(String, String)>,
) -> dvsgi::Result<()> {
    // Every file this writes (an EXR's variance beside it), distinct and writable, up front.
    let mut targets: Vec<(PathBuf, RefOutput)> = Vec::new();
    for o in outs {
        if dvsgi::output::check_target(o)? == dvsgi::output::Format::Exr {
            targets.push((o.clone(), RefOutput::Mean));
            targets.push((dvsgi::reference::variance_path(o), RefOutput::Variance));
        } else {
            targets.push((o.clone(), RefOutput::Display));
        }
    }
    dvsgi::output::check_targets(&targets.iter().map(|(p, _)| p.clone()).collect::<Vec<_>>())?;
    let scene = common.load_scene(scene, &extra)?;
    if options.max_bounces == Some(0) && scene.sky.is_some() {
        eprintln!("{}", sky_split_note("an image for `compare --ref-direct`"));
    }
    let ctx = common.context()?;
    let start = std::time::Instant::now();
    let mut tracer = dvsgi::reference::PathTracer::new(&ctx, &scene, options)?;
    outln!(
        "reference: {} triangles, BVH {} nodes (depth {}), {}x{}, {} spp, bounces {}, specular at {} surfaces, device {}",
        tracer.triangle_count,
        tracer.bvh_nodes,
        tracer.bvh_depth,
        scene.settings.width,
        scene.settings.height,
        options.spp,
        options.max_bounces.map(|b| b.to_string()).unwrap_or_else(|| "unlimited (Russian roulette)".into()),
        options.specular.name(),
        ctx.info.name
    );
    let bar = indicatif::ProgressBar::new(options.spp as u64).with_style(
        indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} spp, eta {eta}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    tracer.run(|done, _| bar.set_position(done as u64))?;
    bar.finish_and_clear();
    let image = tracer.image()?;
    check_validation(&ctx)?;
    let secs = start.elapsed().as_secs_f64();
    let paths = image.spp as f64 * (image.width * image.height) as f64;
    outln!(
        "traced {} spp in {secs:.1} s ({:.2} M paths/s, host wall clock); mean relative standard error {:.4}",
        image.spp,
        paths / secs / 1e6,
        image.relative_standard_error()
    );
    if image.rejected > 0 {
        eprintln!("warning: {} samples had non-finite radiance and were left out", image.rejected);
    }
    // Every file or none.
    let (w, h) = (image.width, image.height);
    let linear = dvsgi::metrics::LinearImage { width: w, height: h, rgb: image.mean.clone() };
    let s = &scene.settings;
    let files = targets
        .iter()
        .map(|(p, what)| {
            let bytes = match what {
                RefOutput::Mean => dvsgi::output::encode_exr(p, w, h, &image.mean)?,
                RefOutput::Variance => dvsgi::output::encode_exr(p, w, h, &image.variance)?,
                RefOutput::Display => {
                    let ev = dvsgi::metrics::display_exposure(s, &linear);
                    dvsgi::output::encode_display_png(p, &linear, ev, s.tonemap)?
                }
            };
            Ok((p.as_path(), bytes))
        })
        .collect::<dvsgi::Result<Vec<_>>>()?;
    dvsgi::cli::write_outputs(&files)
}

fn info(common: &CommonArgs, scene: Option<PathBuf>) -> dvsgi::Result<()> {
    let scene = scene.map(|s| common.load_scene(&s, &[])).transpose()?;
    outln!("Vulkan devices:");
    for c in Context::list_devices()? {
        outln!(
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
    print_device(&ctx);
    if let Some(scene) = scene {
        print_scene(common, &ctx, scene)?;
    }
    check_validation(&ctx)?;
    Ok(())
}

/// The chosen device: type, driver, queues, features and limits.
fn print_device(ctx: &Context) {
    let i = &ctx.info;
    outln!("chosen device: [{}] {}", i.index, i.name);
    outln!("  type: {:?}", i.device_type);
    outln!("  driver: {} ({})", i.driver_name, i.driver_info);
    outln!("  Vulkan: {}", i.api_version_string());
    outln!("  queue families:");
    for f in &i.families {
        outln!("    [{}] {:?} x{} (timestamp bits {})", f.index, f.flags, f.count, f.timestamp_valid_bits);
    }
    outln!("  graphics queue: family {} index {}", ctx.graphics_queue.family, ctx.graphics_queue.index);
    outln!("  compute queue: family {} index {}", ctx.compute_queue.family, ctx.compute_queue.index);
    outln!("  queue topology: {}", ctx.topology.describe());
    outln!("  required features: timelineSemaphore synchronization2 dynamicRendering maintenance4 (enabled)");
    let o = &i.optional;
    let yn = |b: bool| if b { "yes" } else { "no" };
    outln!(
        "  optional: geometryShader {} fragmentStoresAndAtomics {} depthClamp {} samplerAnisotropy {} \
         conservativeRasterization {} calibratedTimestamps {} shaderImageFloat32Atomics {} \
         pipelineStatisticsQuery {}",
        yn(o.geometry_shader),
        yn(o.fragment_stores_and_atomics),
        yn(o.depth_clamp),
        yn(o.sampler_anisotropy),
        yn(o.conservative_rasterization),
        yn(o.calibrated_timestamps),
        yn(o.shader_image_float32_atomics),
        yn(o.pipeline_statistics_query)
    );
    outln!(
        "  ray queries (VK_KHR_ray_query + VK_KHR_acceleration_structure, for gi.specular = \"rt\"): {}",
        yn(o.ray_query)
    );
    outln!(
        "  timestamp period: {} ns; maxImageDimension2D {}, maxImageDimension3D {}, maxSamplerAnisotropy {}",
        i.timestamp_period_ns,
        i.limits.max_image_dimension2_d,
        i.limits.max_image_dimension3_d,
        i.limits.max_sampler_anisotropy
    );
    // No "voxel" or "cone trace" here: tests/cli.rs reads those words as passes that run.
    outln!(
        "  GI sampler loops: {} (DVSGI_CONE_SAMPLERS=kept|unrolled chooses)",
        if dvsgi::gpu::shaders::cone_loops_unrolled(i) {
            "unrolled (the GPU build)"
        } else {
            "kept (the CPU driver build: one copy of the sampler to compile)"
        }
    );
    outln!("  validation: {}", if ctx.validation_enabled { "on" } else { "off" });
}

/// A scene on the device: its size, the [gi] settings that apply, the passes of its first
/// frame, the memory of every image and volume, and what its voxels hold.
fn print_scene(common: &CommonArgs, ctx: &std::sync::Arc<Context>, scene: dvsgi::scene::Scene) -> dvsgi::Result<()> {
    outln!(
        "scene {}: {} objects, {} meshes, {} triangles, {} materials, {} lights",
        scene.path.display(),
        scene.objects.len(),
        scene.meshes.len(),
        scene.triangle_count(),
        scene.materials.len(),
        scene.lights.len()
    );
    // The [gi] table as it applies: the file's, then --preset, then every --set.
    let settings = common.settings();
    let from = if settings.is_empty() { String::new() } else { format!(" (with {})", settings.join(" ")) };
    outln!("  [gi]{from}:");
    match gi_table(&scene.settings.gi) {
        Ok(t) => t.lines().for_each(|l| outln!("    {l}")),
        Err(e) => outln!("    (cannot show: {e})"),
    }
    if let Some(sky) = dvsgi::render::sky::sky_use(&scene) {
        outln!("  {sky}");
    }
    let mut scene = scene;
    let layout = dvsgi::render::budget::resolve_layout(&scene, &dvsgi::render::budget::Limits::of(ctx));
    if scene.settings.gi.voxel_layout != layout && scene.settings.gi.mode == dvsgi::scene::GiMode::Vct {
        let name = if layout == dvsgi::scene::VoxelLayout::Dense { "dense" } else { "bricks" };
        outln!("  gi.voxel_layout \"auto\" on this device: {name} (docs/SPARSE.md)");
    }
    scene.settings.gi.voxel_layout = layout;
    let estimate = dvsgi::render::budget::Estimate::on(ctx, &scene);
    outln!(
        "  GPU memory estimated before allocating: {:.2} MiB (device-local heap {:.0} MiB)",
        estimate.total() as f64 / (1024.0 * 1024.0),
        ctx.info.device_local_heap as f64 / (1024.0 * 1024.0)
    );
    outln!(
        "  async-pipelined adds a copy of the frame's targets and maps per frame in flight beyond the first: \
         {:.2} MiB each",
        estimate.frame_copy as f64 / (1024.0 * 1024.0)
    );
    let before = ctx.allocated_bytes();
    let time = scene.settings.time;
    let textures = scene.textures.len();
    let has_sky = scene.sky.is_some();
    let mut renderer = Renderer::new(ctx, scene)?;
    outln!("  frame plan: {}", renderer.plan().summary().join("; "));
    outln!("  passes (first frame): {}", renderer.pass_names(false).join(" -> "));
    for img in renderer.images() {
        let kind = if img.desc.kind == dvsgi::gpu::ImageKind::D3 { "volume" } else { "image" };
        outln!("  {kind} {}: {:.2} MiB", img.name, img.bytes as f64 / (1024.0 * 1024.0));
    }
    if let Some(v) = renderer.voxels() {
        outln!("  buffer voxel work lists: {:.2} MiB", v.list.bytes() as f64 / (1024.0 * 1024.0));
        outln!("  buffer voxel scan: {:.2} MiB", v.scan.size as f64 / (1024.0 * 1024.0));
        if let Some(t) = &v.bounce_tail {
            outln!("  buffer voxel bounce tail: {:.2} MiB", t.buffer.size as f64 / (1024.0 * 1024.0));
        }
    }
    outln!(
        "  textures: {} with mip chains, {:.2} MiB (anisotropic filtering {}x)",
        textures,
        renderer.texture_bytes() as f64 / (1024.0 * 1024.0),
        dvsgi::render::scene_gpu::max_anisotropy(ctx)
    );
    if has_sky {
        outln!("  sky maps and sampling tables: {:.2} MiB", renderer.sky_bytes() as f64 / (1024.0 * 1024.0));
    }
    outln!(
        "  GPU memory allocated for the scene and frame: {:.2} MiB",
        (ctx.allocated_bytes() - before) as f64 / (1024.0 * 1024.0)
    );
    occupancy(&mut renderer, time)?;
    Ok(())
}

/// Voxelize (one frame at the scene time) and print what the grid holds: occupied voxels and
/// bricks, the layout's resident bricks per pool, and its memory against the dense layout's.
fn occupancy(renderer: &mut Renderer, time: f32) -> dvsgi::Result<()> {
    if renderer.voxels().is_none() {
        return Ok(());
    }
    renderer.render(time, false)?;
    let Some(list) = renderer.voxel_list()? else { return Ok(()) };
    let o = list.occupancy();
    outln!("  occupied voxels (first frame): {}", o.summary());
    if let Some(memory) = renderer.voxel_memory()? {
        for line in memory.summary() {
            outln!("  {line}");
        }
    }
    Ok(())
}

/// The schedule and where its compute work really runs (every output says so).
fn schedule_line(ctx: &Context, mode: Mode) -> String {
    match mode {
        Mode::Sync => "sync (everything on the graphics queue)".to_string(),
        Mode::AsyncPipelined => format!(
            "{mode}, {}; one copy of the frame's targets per frame in flight, shown one frame later",
            ctx.topology.describe()
        ),
        _ => format!("{mode}, {}", ctx.topology.describe()),
    }
}

/// The `[gi]` table as TOML in the struct's order, its f32 values written as the shortest
/// decimals that read back to them (1.42, not the f64 widening 1.4199999570846558).
fn gi_table(gi: &dvsgi::scene::GiSettings) -> Result<String, toml::ser::Error> {
    let shortest = |line: &str| -> Option<String> {
        let (key, value) = line.split_once(" = ")?;
        if !value.contains('.') {
            return None;
        }
        let f = value.parse::<f64>().ok()? as f32;
        let text = f.to_string();
        Some(format!("{key} = {text}{}", if text.contains(['.', 'e', 'N', 'i']) { "" } else { ".0" }))
    };
    let text = toml::to_string(gi)?;
    Ok(text.lines().map(|l| shortest(l).unwrap_or_else(|| l.to_owned()) + "\n").collect())
}
