//! The `bench` report: what it measures, its JSON form (schema `dvsgi-bench/1`, documented in
//! BENCHMARKS.md and `docs/bench-schema.json`) and the timeline picture.

use crate::gpu::Context;
use crate::render::graph::QueueKind;
use crate::render::{FrameTiming, HostWaits, Mode, PassTime, RenderOptions, Renderer, SubmitRecord};
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::sync::Arc;
use std::time::Instant;

pub const SCHEMA: &str = "dvsgi-bench/1";

/// min / median / p95 of a set of samples (ms unless said otherwise).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Stats {
    pub min: f64,
    pub median: f64,
    pub p95: f64,
}

impl Stats {
    /// `None` for no samples.
    pub fn of(samples: &[f64]) -> Option<Stats> {
        if samples.is_empty() {
            return None;
        }
        let mut v = samples.to_vec();
        v.sort_by(|a, b| a.total_cmp(b));
        let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
        Some(Stats { min: v[0], median: q(0.5), p95: q(0.95) })
    }
}

fn vct() -> String {
    "vct".to_owned()
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Report {
    pub schema: String,
    pub device: DeviceReport,
    pub scene: String,
    /// "static" or "dynamic".
    pub scenario: String,
    pub width: u32,
    pub height: u32,
    /// `gi.mode` ("vct" in reports from before it was recorded).
    #[serde(default = "vct")]
    pub gi_mode: String,
    pub voxel_resolution: u32,
    pub frames: u32,
    pub warmup: u32,
    pub frames_in_flight: u32,
    /// The `--set` overrides, as given.
    pub settings: Vec<String>,
    pub modes: Vec<ModeReport>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeviceReport {
    pub name: String,
    pub driver: String,
    /// Vulkan device type, e.g. "CPU" or "DISCRETE_GPU".
    pub device_type: String,
    pub queue_topology: String,
    /// Whether graphics and compute work go to two different queues.
    pub separate_queues: bool,
    /// Pass times are on the host clock through VK_EXT_calibrated_timestamps.
    pub timestamps_calibrated: bool,
    /// false on CPU implementations, whose timestamps are known to be wrong.
    pub timestamps_trusted: bool,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModeReport {
    /// "sync", "async", "async-lagged" or "async-pipelined".
    pub mode: String,
    /// Frames between a frame's submission and the frame whose display a viewer presents
    /// with it (`Mode::latency_frames`: 1 for async-pipelined).
    #[serde(default)]
    pub latency_frames: u32,
    /// Copies of the frame's own targets and maps (async-pipelined: one per frame in flight).
    #[serde(default = "one")]
    pub frame_copies: u32,
    /// GPU memory of the copies after the first, bytes.
    #[serde(default)]
    pub frame_copies_bytes: u64,
    /// Host wall clock per frame in steady state: the interval between the starts of
    /// consecutive frames (the last one ends when the GPU is idle).
    pub frame_host_ms: Stats,
    pub frame_host_samples: Vec<f64>,
    /// Host wall clock from the first measured frame's start until the GPU finished the last,
    /// divided by the frame count (includes draining the frames in flight at the end).
    pub frame_host_mean_ms: f64,
    /// GPU timestamps: first pass begin to last pass end, over both queues.
    pub gpu_span_ms: Option<Stats>,
    /// GPU timestamps: sum of the pass times per queue.
    pub graphics_busy_ms: Option<Stats>,
    pub compute_busy_ms: Option<Stats>,
    pub passes: Vec<PassReport>,
    pub host_waits: WaitReport,
    pub submits_per_frame: f64,
    /// Median host frame time divided by sync's (absent for sync or when sync did not run).
    pub frame_ratio_to_sync: Option<f64>,
    /// This mode's image against sync's at the same scene times (absent for sync).
    pub image_error_vs_sync: Option<ImageError>,
    /// One representative frame (median GPU span), for the timeline picture.
    pub timeline: Vec<TimelinePass>,
    /// The voxel work list after the mode's last frame (absent without voxels).
    #[serde(default)]
    pub occupancy: Option<crate::render::voxel::Occupancy>,
    /// The voxel layout and what its volumes take after the mode's last frame (absent
    /// without voxels).
    #[serde(default)]
    pub voxel_memory: Option<crate::render::voxel::bricks::VoxelMemory>,
    /// `--raster-profile`: what the G-buffer's time is made of (absent without it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub raster: Option<RasterReport>,
}

/// One copy of the frame (reports written before `frame_copies` existed).
fn one() -> u32 {
    1
}

/// `--raster-profile` (`render::raster_profile`): the G-buffer, a depth prepass of its opaque
/// draws and the G-buffer over that prepass, each submitted alone, three times.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RasterReport {
    /// The G-buffer's pixels, and those a surface covers.
    pub pixels: u64,
    pub covered_pixels: u64,
    pub passes: Vec<RasterPassReport>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RasterPassReport {
    pub name: String,
    pub gpu_ms: Option<Stats>,
    pub serial_host_ms: Option<Stats>,
    /// Primitives and shader invocations (where the device has pipeline statistics queries).
    pub counts: Option<crate::render::raster_profile::ShaderCounts>,
}

impl RasterReport {
    fn of(s: crate::render::raster_profile::RasterSamples) -> RasterReport {
        let passes = s
            .passes
            .into_iter()
            .map(|p| RasterPassReport {
                name: p.name,
                gpu_ms: Stats::of(&p.gpu_ms),
                serial_host_ms: Stats::of(&p.host_ms),
                counts: p.counts,
            })
            .collect();
        RasterReport { pixels: s.pixels, covered_pixels: s.covered_pixels, passes }
    }

    /// Fragment shader invocations of pass `i` per covered pixel.
    pub fn overdraw(&self, i: usize) -> Option<f64> {
        let c = self.passes.get(i)?.counts?;
        (self.covered_pixels > 0).then(|| c.fragment_invocations as f64 / self.covered_pixels as f64)
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PassReport {
    pub name: String,
    /// "graphics" or "compute": the queue it ran on in this mode.
    pub queue: String,
    pub gpu_ms: Option<Stats>,
    /// `--serial-profile`: host wall clock with the pass submitted alone and waited for.
    pub serial_host_ms: Option<Stats>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaitReport {
    pub slot_reuse: u64,
    pub readback: u64,
    pub in_frame: u64,
    pub idle: u64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageError {
    pub frames: u32,
    /// Mean over frames of sum|a - b| / sum|sync| over the RGB radiance.
    pub mean_relative: f64,
    pub max_relative: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimelinePass {
    pub name: String,
    pub queue: String,
    pub begin_ms: f64,
    pub end_ms: f64,
}

/// Per-pass statistics over frames, in first-seen order.
pub fn pass_stats(frames: &[FrameTiming]) -> Vec<(String, QueueKind, Vec<f64>)> {
    let mut out: Vec<(String, QueueKind, Vec<f64>)> = Vec::new();
    for f in frames {
        for p in &f.passes {
            match out.iter_mut().find(|(n, q, _)| *n == p.name && *q == p.queue) {
                Some((_, _, v)) => v.push(p.gpu_ms()),
                None => out.push((p.name.clone(), p.queue, vec![p.gpu_ms()])),
            }
        }
    }
    out
}

/// Sum of pass times on one queue.
pub fn busy_ms(f: &FrameTiming, q: QueueKind) -> f64 {
    f.passes.iter().filter(|p| p.queue == q).map(PassTime::gpu_ms).fold(0.0, |a, b| a + b)
}

/// The frame with the median GPU span.
pub fn representative(frames: &[FrameTiming]) -> Option<&FrameTiming> {
    let mut v: Vec<&FrameTiming> = frames.iter().filter(|f| !f.passes.is_empty()).collect();
    v.sort_by(|a, b| a.gpu_span_ms().total_cmp(&b.gpu_span_ms()));
    v.get(v.len() / 2).copied()
}

/// Relative image difference over RGB radiance: sum|a - b| / sum|a|.
pub fn relative_error(reference: &[f32], other: &[f32]) -> f64 {
    let (mut diff, mut total) = (0.0f64, 0.0f64);
    for (i, (a, b)) in reference.iter().zip(other).enumerate() {
        if i % 4 == 3 {
            continue;
        }
        diff += (*a as f64 - *b as f64).abs();
        total += (*a as f64).abs();
    }
    if total > 0.0 {
        diff / total
    } else {
        diff
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// Timeline picture layout: left edge of the time axis, its width, the height of a lane and
/// the top of the first lane (px).
const LEFT: f64 = 150.0;
const WIDTH: f64 = 900.0;
const LANE: f64 = 26.0;
const TOP: f64 = 58.0;

/// The timeline picture: per mode, one lane per queue and one bar per pass of the mode's
/// representative frame, on a shared time axis, so overlap shows at a glance.
pub fn timeline_svg(report: &Report) -> String {
    let lanes = report.modes.len() * QueueKind::ALL.len();
    // Common origin and scale: each mode's frame starts at its first pass.
    let longest = report.modes.iter().map(timeline_span).filter(|(b, e)| e > b).map(|(b, e)| e - b).fold(0.0, f64::max);
    let scale = if longest > 0.0 { WIDTH / longest } else { 1.0 };
    let height = TOP + lanes as f64 * LANE + report.modes.len() as f64 * 10.0 + 60.0;
    let mut svg = String::new();
    write_timeline_heading(&mut svg, report, height);
    let mut y = TOP;
    for (i, m) in report.modes.iter().enumerate() {
        if i > 0 {
            y += 10.0;
        }
        y = write_mode_lanes(&mut svg, m, y, scale);
    }
    write_time_axis(&mut svg, y, longest, scale);
    svg.push_str("</svg>\n");
    svg
}

/// First pass begin and last pass end of a mode's representative frame, ms.
fn timeline_span(m: &ModeReport) -> (f64, f64) {
    let b = m.timeline.iter().map(|p| p.begin_ms).fold(f64::INFINITY, f64::min);
    let e = m.timeline.iter().map(|p| p.end_ms).fold(f64::NEG_INFINITY, f64::max);
    (b, e)
}

/// The picture's opening tag, background, title and device caveats.
fn write_timeline_heading(svg: &mut String, report: &Report, height: f64) {
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{height}" font-family="sans-serif" font-size="11">"#,
        LEFT + WIDTH + 40.0
    );
    let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let d = &report.device;
    let _ = writeln!(
        svg,
        r#"<text x="10" y="18" font-size="13" font-weight="bold">dvsgi bench: {} ({}x{}, {} scenario)</text>"#,
        escape(&report.scene),
        report.width,
        report.height,
        escape(&report.scenario)
    );
    let mut caveat = format!("{} — {}", d.name, d.queue_topology);
    if !d.timestamps_trusted {
        caveat.push_str(" — CPU device: GPU timestamps are not trustworthy");
    }
    if !d.timestamps_calibrated {
        caveat.push_str(" — uncalibrated timestamps");
    }
    let _ = writeln!(svg, r#"<text x="10" y="34">{}</text>"#, escape(&caveat));
    let _ = writeln!(
        svg,
        r##"<text x="10" y="48" fill="#555">one representative frame per mode (median GPU span); bars from GPU timestamps</text>"##
    );
}

/// One mode's lanes (one per queue) starting at height `y`, with a bar per pass; returns the
/// height below them.
fn write_mode_lanes(svg: &mut String, m: &ModeReport, mut y: f64, scale: f64) -> f64 {
    let (origin, _) = timeline_span(m);
    for q in QueueKind::ALL {
        let _ = writeln!(svg, r#"<text x="10" y="{}">{} · {}</text>"#, y + LANE * 0.65, escape(&m.mode), q.name());
        let _ = writeln!(
            svg,
            r##"<rect x="{LEFT}" y="{y}" width="{WIDTH}" height="{}" fill="#f4f4f4" stroke="#ddd"/>"##,
            LANE - 4.0
        );
        for (k, p) in m.timeline.iter().filter(|p| p.queue == q.name()).enumerate() {
            write_pass_bar(svg, p, q, k, y, origin, scale);
        }
        y += LANE;
    }
    y
}

/// The bar of pass `p`, the `k`-th on queue `q`, in the lane at height `y` of a frame that
/// starts at `origin` ms (its name written inside when it fits).
fn write_pass_bar(svg: &mut String, p: &TimelinePass, q: QueueKind, k: usize, y: f64, origin: f64, scale: f64) {
    let x = LEFT + (p.begin_ms - origin) * scale;
    let w = ((p.end_ms - p.begin_ms) * scale).max(1.0);
    let fill = match (q, k % 2) {
        (QueueKind::Graphics, 0) => "#4c78a8",
        (QueueKind::Graphics, _) => "#72a0cf",
        (QueueKind::Compute, 0) => "#e45756",
        (QueueKind::Compute, _) => "#f08a5d",
    };
    let _ = writeln!(
        svg,
        r#"<rect x="{x:.2}" y="{}" width="{w:.2}" height="{}" fill="{fill}"><title>{} ({}): {:.3} ms</title></rect>"#,
        y + 1.0,
        LANE - 6.0,
        escape(&p.name),
        q.name(),
        p.end_ms - p.begin_ms
    );
    if w > 40.0 {
        let _ = writeln!(
            svg,
            r#"<text x="{:.2}" y="{}" fill="white" font-size="10">{}</text>"#,
            x + 3.0,
            y + LANE * 0.6,
            escape(&p.name)
        );
    }
}

/// The time axis at height `y`: ticks at a round step up to `longest` ms, and its label.
fn write_time_axis(svg: &mut String, y: f64, longest: f64, scale: f64) {
    let _ = writeln!(svg, r#"<line x1="{LEFT}" y1="{y}" x2="{}" y2="{y}" stroke="black"/>"#, LEFT + WIDTH);
    let step = nice_step(longest / 8.0);
    let decimals = if step > 0.0 { (-step.log10().floor()).max(0.0) as usize } else { 0 };
    let mut t = 0.0;
    while step > 0.0 && t <= longest + 1e-9 {
        let x = LEFT + t * scale;
        let _ = writeln!(svg, r#"<line x1="{x:.2}" y1="{y}" x2="{x:.2}" y2="{}" stroke="black"/>"#, y + 4.0);
        let _ = writeln!(svg, r#"<text x="{x:.2}" y="{}" text-anchor="middle">{t:.decimals$}</text>"#, y + 16.0);
        t += step;
    }
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="{}" text-anchor="middle">ms from the frame's first pass</text>"#,
        LEFT + WIDTH / 2.0,
        y + 32.0
    );
}

/// 1, 2 or 5 times a power of ten, at least `raw`.
fn nice_step(raw: f64) -> f64 {
    if raw <= 0.0 || !raw.is_finite() {
        return 0.0;
    }
    let p = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * p).find(|s| *s >= raw).unwrap_or(10.0 * p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_of_samples() {
        let s = Stats::of(&[5.0, 1.0, 3.0, 2.0, 4.0]).unwrap();
        assert_eq!((s.min, s.median), (1.0, 3.0));
        assert_eq!(s.p95, 5.0);
        assert!(Stats::of(&[]).is_none());
    }

    #[test]
    fn nice_steps() {
        assert_eq!(nice_step(0.3), 0.5);
        assert_eq!(nice_step(1.0), 1.0);
        assert_eq!(nice_step(13.0), 20.0);
        assert_eq!(nice_step(0.0), 0.0);
    }

    #[test]
    fn relative_error_ignores_alpha() {
        let a = [1.0, 1.0, 1.0, 0.0, 1.0, 1.0, 1.0, 5.0];
        let b = [1.0, 1.0, 1.5, 9.0, 1.0, 1.0, 1.0, 0.0];
        assert!((relative_error(&a, &b) - 0.5 / 6.0).abs() < 1e-12);
        assert_eq!(relative_error(&a, &a), 0.0);
    }
}

/// How [`measure`] times one schedule mode (the `bench` binary's and the sweep's timing).
#[derive(Debug, Clone, Copy)]
pub struct Measure {
    pub mode: Mode,
    /// Timed frames, after `warmup` untimed ones.
    pub frames: u32,
    pub warmup: u32,
    pub frames_in_flight: u32,
    /// Afterwards, submit every pass alone for three frames and host-time it.
    pub serial_profile: bool,
    /// Afterwards, split the G-buffer's time (`Renderer::raster_profile`, three rounds).
    pub raster_profile: bool,
    /// The dynamic scenario: every frame updates the voxels (revoxelize, relight, bounces)
    /// and scene time advances by this many seconds per frame. `None`: a static scene, where
    /// frames after the first reuse the lit voxels.
    pub dynamic_dt: Option<f32>,
    /// Every frame updates the voxels and redraws what it could reuse (shadow maps, reflective
    /// shadow maps and the volume built from them), as if everything had changed
    /// (`Renderer::request_redraw`).
    pub redraw: bool,
}

impl Measure {
    /// Scene time of frame `i`.
    pub fn time_of(&self, scene: &Scene, i: u32) -> f32 {
        match self.dynamic_dt {
            None => scene.settings.time,
            Some(dt) => scene.settings.time + i as f32 * dt,
        }
    }
}

/// Render `warmup + frames` frames with a new renderer and report the host wall clock per
/// frame (start to next start, the last to idle), the GPU timestamps, the host waits and
/// optionally the serial profile. The flag says whether every timestamp was calibrated.
pub fn measure(ctx: &Arc<Context>, scene: &Scene, m: &Measure) -> crate::Result<(ModeReport, bool)> {
    let options = RenderOptions { mode: m.mode, frames_in_flight: m.frames_in_flight };
    let mut r = Renderer::with_options(ctx, scene.clone(), options)?;
    measure_renderer(&mut r, scene, m)
}

/// [`measure`] with a renderer already made (its later frames continue from its state).
pub fn measure_renderer(r: &mut Renderer, scene: &Scene, m: &Measure) -> crate::Result<(ModeReport, bool)> {
    let frames = render_timed_frames(r, scene, m, false)?;
    let host = frames.host_ms(m);
    let waits = waits_since(r.scheduler().waits, frames.waits_before);
    let timings: Vec<_> = r.take_timings().into_iter().filter(|f| f.frame >= m.warmup as u64).collect();
    let calibrated = timings.iter().all(|f| f.calibrated);
    let serial = if m.serial_profile { serial_profile(r, scene, m)? } else { Vec::new() };
    let raster = if m.raster_profile { Some(RasterReport::of(r.raster_profile(3)?)) } else { None };
    let passes = pass_reports(&timings, &serial);
    let with_stamps: Vec<_> = timings.iter().filter(|f| !f.passes.is_empty()).collect();
    let span: Vec<f64> = with_stamps.iter().map(|f| f.gpu_span_ms()).collect();
    let busy = |q| with_stamps.iter().map(|f| busy_ms(f, q)).collect::<Vec<_>>();
    let report = ModeReport {
        mode: m.mode.name().to_string(),
        latency_frames: m.mode.latency_frames(),
        frame_copies: r.copy_count() as u32,
        frame_copies_bytes: r.copies_bytes(),
        frame_host_ms: Stats::of(&host).expect("at least one frame"),
        frame_host_mean_ms: frames.mean_ms(m),
        frame_host_samples: host,
        gpu_span_ms: Stats::of(&span),
        graphics_busy_ms: Stats::of(&busy(QueueKind::Graphics)),
        compute_busy_ms: Stats::of(&busy(QueueKind::Compute)),
        passes,
        host_waits: waits,
        submits_per_frame: frames.submits as f64 / m.frames as f64,
        frame_ratio_to_sync: None,
        image_error_vs_sync: None,
        timeline: timeline_of(&timings),
        // Read after the measured frames (a readback of its own, never inside a frame).
        occupancy: r.voxel_list()?.map(|l| l.occupancy()),
        voxel_memory: r.voxel_memory()?,
        raster,
    };
    Ok((report, calibrated))
}

/// The submits of each timed frame of `m` on a new renderer, as the scheduler handed them to
/// the queues: the schedule model's recording (`crate::model`).
pub fn record_submits(ctx: &Arc<Context>, scene: &Scene, m: &Measure) -> crate::Result<Vec<Vec<SubmitRecord>>> {
    let options = RenderOptions { mode: m.mode, frames_in_flight: m.frames_in_flight };
    let mut r = Renderer::with_options(ctx, scene.clone(), options)?;
    Ok(render_timed_frames(&mut r, scene, m, true)?.recorded)
}

/// When the frames of [`render_timed_frames`] started and ended, what they submitted and the
/// host waits before the first timed one.
struct TimedFrames {
    /// Host start of every frame, warm-up included.
    starts: Vec<Instant>,
    /// When the GPU was idle after the last.
    end: Instant,
    /// Submits of the timed frames.
    submits: usize,
    /// With `record`: the submits of each timed frame (copied only when asked, as the copy
    /// falls inside the timed host interval).
    recorded: Vec<Vec<SubmitRecord>>,
    waits_before: HostWaits,
}

impl TimedFrames {
    /// Host wall clock of each timed frame, ms: start to next start, the last to idle.
    fn host_ms(&self, m: &Measure) -> Vec<f64> {
        (m.warmup as usize..self.starts.len())
            .map(|i| {
                let next = self.starts.get(i + 1).copied().unwrap_or(self.end);
                (next - self.starts[i]).as_secs_f64() * 1e3
            })
            .collect()
    }

    /// First timed frame's start to idle after the last, per timed frame, ms.
    fn mean_ms(&self, m: &Measure) -> f64 {
        (self.end - self.starts[m.warmup as usize]).as_secs_f64() * 1e3 / m.frames as f64
    }
}

/// Render the `warmup + frames` frames of `m`, then wait until the GPU is idle.
fn render_timed_frames(r: &mut Renderer, scene: &Scene, m: &Measure, record: bool) -> crate::Result<TimedFrames> {
    let total = m.warmup + m.frames;
    let mut starts = Vec::with_capacity(total as usize);
    let (mut submits, mut recorded) = (0usize, Vec::new());
    let mut waits_before = r.scheduler().waits;
    for i in 0..total {
        if i == m.warmup {
            // The warm-up frames finish before the first timed one starts: with frames in
            // flight, the first timed frame would otherwise wait for them (the first frame of
            // a renderer does the most work: static voxelization and, with bounce feedback,
            // `gi.first_update_bounces`).
            r.wait_idle()?;
            waits_before = r.scheduler().waits;
        }
        starts.push(render_frame(r, scene, m, i)?);
        if i >= m.warmup {
            submits += r.scheduler().submits().len();
            if record {
                recorded.push(r.scheduler().submits().to_vec());
            }
        }
    }
    r.wait_idle()?;
    Ok(TimedFrames { starts, end: Instant::now(), submits, recorded, waits_before })
}

/// Render frame `i` of `m` (asking for a voxel update in the dynamic scenario); returns when
/// it started on the host.
fn render_frame(r: &mut Renderer, scene: &Scene, m: &Measure, i: u32) -> crate::Result<Instant> {
    if m.dynamic_dt.is_some() || m.redraw {
        r.request_voxel_update();
    }
    if m.redraw {
        r.request_redraw();
    }
    let start = Instant::now();
    r.render(m.time_of(scene, i), false)?;
    Ok(start)
}

/// The host waits counted since `before`.
fn waits_since(now: HostWaits, before: HostWaits) -> WaitReport {
    WaitReport {
        slot_reuse: now.slot_reuse - before.slot_reuse,
        readback: now.readback - before.readback,
        in_frame: now.in_frame - before.in_frame,
        idle: now.idle - before.idle,
    }
}

/// `--serial-profile`: three more frames with every pass submitted alone and waited for; the
/// host times of each pass, in first-seen order.
fn serial_profile(r: &mut Renderer, scene: &Scene, m: &Measure) -> crate::Result<Vec<(String, Vec<f64>)>> {
    let total = m.warmup + m.frames;
    let mut serial: Vec<(String, Vec<f64>)> = Vec::new();
    r.set_serial_profile(true);
    for i in 0..3 {
        render_frame(r, scene, m, total + i)?;
        for s in r.scheduler().serial_times() {
            match serial.iter_mut().find(|(n, _)| *n == s.name) {
                Some((_, v)) => v.push(s.host_ms),
                None => serial.push((s.name.clone(), vec![s.host_ms])),
            }
        }
    }
    r.set_serial_profile(false);
    r.wait_idle()?;
    Ok(serial)
}

/// Per-pass statistics: GPU timestamps (with the serial host times beside them), or the serial
/// host times alone where the device has no timestamps.
fn pass_reports(timings: &[FrameTiming], serial: &[(String, Vec<f64>)]) -> Vec<PassReport> {
    if timings.iter().all(|f| f.passes.is_empty()) {
        // No timestamps on this device: list the passes with their host times only.
        return serial
            .iter()
            .map(|(n, s)| PassReport {
                name: n.clone(),
                queue: String::new(),
                gpu_ms: None,
                serial_host_ms: Stats::of(s),
            })
            .collect();
    }
    pass_stats(timings)
        .into_iter()
        .map(|(name, q, v)| PassReport {
            serial_host_ms: serial.iter().find(|(n, _)| *n == name).and_then(|(_, s)| Stats::of(s)),
            name,
            queue: q.name().to_string(),
            gpu_ms: Stats::of(&v),
        })
        .collect()
}

/// The passes of the representative frame, for the timeline picture (none without timestamps).
fn timeline_of(timings: &[FrameTiming]) -> Vec<TimelinePass> {
    representative(timings)
        .map(|f| {
            f.passes
                .iter()
                .map(|p| TimelinePass {
                    name: p.name.clone(),
                    queue: p.queue.name().to_string(),
                    begin_ms: p.begin_ms,
                    end_ms: p.end_ms,
                })
                .collect()
        })
        .unwrap_or_default()
}
