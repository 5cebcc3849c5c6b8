//! The soak: a dynamic scene (moving objects and light) rendered for many frames by one renderer
//! per schedule mode, every frame revoxelizing, relighting and re-bouncing. At intervals it
//! samples the process's resident memory, gpu-allocator's report and the validation counts, and
//! re-renders one fixed scene time to check that the image does not drift: whatever ran before,
//! the same time must give the same picture. `soak` (src/bin/soak.rs) runs it;
//! tests/soak.rs runs a short one; docs/ROBUSTNESS.md has the long runs.

use crate::gpu::Context;
use crate::render::{FrameOutput, Mode, RenderOptions, Renderer};
use crate::scene::Scene;
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

#[derive(Debug, Clone)]
pub struct SoakOptions {
    /// Frames per mode (the fixed-time check frames come on top).
    pub frames: u32,
    /// Sample every this many frames (and after the last).
    pub sample_every: u32,
    /// Scene time step per frame (s).
    pub dt: f32,
    pub frames_in_flight: u32,
}

/// One sample of a mode's run.
#[derive(Debug, Clone, Serialize)]
pub struct Sample {
    /// Frames rendered so far.
    pub frame: u32,
    /// Resident set size of the process (bytes; 0 where /proc is not available).
    pub rss_bytes: u64,
    /// gpu-allocator: bytes in live allocations.
    pub gpu_allocated_bytes: u64,
    /// gpu-allocator: bytes in device-memory blocks (what the driver holds for us).
    pub gpu_block_bytes: u64,
    pub gpu_allocations: usize,
    pub gpu_blocks: usize,
    /// Mean host wall-clock ms per frame since the previous sample.
    pub host_ms: f64,
    /// Largest per-pixel difference of the fixed-time image from the first one, relative to
    /// the first one's peak radiance.
    pub drift: f32,
    /// Validation errors + warnings so far.
    pub validation_messages: u32,
}

#[derive(Debug, Clone, Serialize)]
pub struct ModeSoak {
    pub mode: String,
    pub samples: Vec<Sample>,
    pub seconds: f64,
}

impl ModeSoak {
    /// Growth of a figure from the first sample after warm-up (the second) to the last.
    pub fn growth(&self, f: impl Fn(&Sample) -> u64) -> i64 {
        match (self.samples.get(1), self.samples.last()) {
            (Some(a), Some(b)) => f(b) as i64 - f(a) as i64,
            _ => 0,
        }
    }

    pub fn max_drift(&self) -> f32 {
        self.samples.iter().map(|s| s.drift).fold(0.0, f32::max)
    }
}

/// Resident set size of this process (Linux /proc/self/statm; 0 elsewhere).
pub fn rss_bytes() -> u64 {
    let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) }.max(0) as u64;
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1).and_then(|v| v.parse::<u64>().ok()))
        .map(|pages| pages * page)
        .unwrap_or(0)
}

/// With bounce feedback, the fixed-time image is rendered until what is left to converge is
/// estimated below this (relative to the peak), or for `MAX_SETTLE_FRAMES` interleave cycles.
const SETTLED: f32 = 1e-5;
const MAX_SETTLE_FRAMES: u32 = 32;

/// Largest per-pixel RGB difference relative to `reference`'s peak.
fn drift(reference: &FrameOutput, image: &FrameOutput) -> f32 {
    let peak = reference.radiance.iter().fold(0.0f32, |m, v| m.max(v.abs())).max(1e-30);
    let d = reference
        .radiance
        .chunks_exact(4)
        .zip(image.radiance.chunks_exact(4))
        .flat_map(|(a, b)| (0..3).map(move |i| (a[i] - b[i]).abs()))
        .fold(0.0f32, f32::max);
    d / peak
}

/// Soak one mode. `on_sample` sees each sample as it is taken (progress output).
pub fn soak_mode(
    ctx: &Arc<Context>,
    scene: &Scene,
    mode: Mode,
    o: &SoakOptions,
    mut on_sample: impl FnMut(&Sample),
) -> crate::Result<ModeSoak> {
    let t0 = scene.settings.time;
    let options = RenderOptions { mode, frames_in_flight: o.frames_in_flight };
    let mut r = Renderer::with_options(ctx, scene.clone(), options)?;
    // The fixed-time image: twice in a row, so async-lagged's one frame of lag has passed;
    // with bounce feedback (each update gathers the previous one's bounced light, so what ran
    // before shows until it converges) until it has converged: the changes between frames
    // shrink geometrically, by r, so what is left is about d r / (1 - r) after a change d.
    // With `gi.bounce_interleave` N each update gathers for a different 1/N of the voxels, so
    // the changes are compared a whole cycle (N frames) apart.
    let gi = &scene.settings.gi;
    let cycle = if gi.bounce_feedback { gi.bounce_interleave.max(1) as usize } else { 1 };
    let settle = if gi.bounce_feedback { MAX_SETTLE_FRAMES * cycle as u32 } else { 2 };
    let fixed = |r: &mut Renderer| -> crate::Result<FrameOutput> {
        let mut last: std::collections::VecDeque<FrameOutput> = std::collections::VecDeque::new();
        let mut last_change = f32::INFINITY;
        for _ in 0..settle {
            r.request_voxel_update();
            r.render(t0, true)?;
            let out = r.output();
            if last.len() == cycle {
                let change = drift(&last[0], &out);
                let rate = (change / last_change).min(0.99);
                if last_change.is_finite() && change * rate / (1.0 - rate) <= SETTLED {
                    return Ok(out);
                }
                last_change = change;
                last.pop_front();
            }
            last.push_back(out);
        }
        Ok(r.output())
    };
    let reference = fixed(&mut r)?;
    let start = Instant::now();
    let mut samples = Vec::new();
    let mut since = Instant::now();
    let mut since_frame = 0;
    let every = o.sample_every.max(1);
    for i in 0..=o.frames {
        if i % every == 0 || i == o.frames {
            let host_ms =
                if i > since_frame { since.elapsed().as_secs_f64() * 1e3 / (i - since_frame) as f64 } else { 0.0 };
            let image = fixed(&mut r)?;
            r.wait_idle()?;
            let report = ctx.allocator().generate_report();
            let v = ctx.validation();
            let s = Sample {
                frame: i,
                rss_bytes: rss_bytes(),
                gpu_allocated_bytes: report.total_allocated_bytes,
                gpu_block_bytes: report.total_capacity_bytes,
                gpu_allocations: report.allocations.len(),
                gpu_blocks: report.blocks.len(),
                host_ms,
                drift: drift(&reference, &image),
                validation_messages: v.errors() + v.warnings(),
            };
            on_sample(&s);
            samples.push(s);
            since = Instant::now();
            since_frame = i;
        }
        if i == o.frames {
            break;
        }
        r.request_voxel_update();
        r.render(t0 + (i + 1) as f32 * o.dt, false)?;
    }
    r.wait_idle()?;
    Ok(ModeSoak { mode: mode.name().to_string(), samples, seconds: start.elapsed().as_secs_f64() })
}
