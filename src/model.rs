//! The schedule model (`bench --model REPORT.json`): what a schedule costs on a device whose
//! per-pass GPU times are known (a bench report from that device), from the submits the
//! scheduler records for the same scene and settings on whatever device runs the command.
//!
//! The simulation replays the recorded frames on two in-order queues. A batch (one submit)
//! starts when its queue has finished the batch before it, when the other queue has reached
//! the timeline value it waits for, and when the host has submitted it; it then takes the
//! sum of its passes' times. The host records a frame as soon as the frame slot it reuses is
//! free (the frame `frames in flight` before it has finished on both queues) and costs no
//! time itself. What it assumes, and where that fails, is in BENCHMARKS.md ("The schedule
//! model"): full-speed concurrency (a pass takes the time it took in the mode whose times
//! are used, whatever runs beside it) and no latency between a signal and a waiting batch.

use crate::bench::{ModeReport, Report, Stats};
use crate::render::graph::QueueKind;
use crate::render::{Mode, SubmitRecord};
use serde::Serialize;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

pub const SCHEMA: &str = "dvsgi-bench-model/1";

/// What can stop the model: a report it cannot use.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    #[error("{}: cannot read the bench report: {source}", path.display())]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{}: not a bench report of schema {} ({reason}); give a file written by bench --json", path.display(), crate::bench::SCHEMA)]
    NotAReport { path: PathBuf, reason: String },
    #[error("{}: the report has no GPU time for any pass; the model needs a report from a device with timestamps", path.display())]
    NoTimes { path: PathBuf },
}

/// Read a bench report (`bench --json`) for the model.
pub fn read_report(path: &Path) -> Result<Report, ModelError> {
    let text = std::fs::read_to_string(path).map_err(|source| ModelError::Read { path: path.into(), source })?;
    let not = |reason: String| ModelError::NotAReport { path: path.into(), reason };
    let report: Report = serde_json::from_str(&text).map_err(|e| not(e.to_string()))?;
    if report.schema != crate::bench::SCHEMA {
        return Err(not(format!("its schema is '{}'", report.schema)));
    }
    if report.modes.is_empty() {
        return Err(not("it has no modes".into()));
    }
    Ok(report)
}

/// The voxel layout the report's frames used (its scenes may say "auto", which another device
/// can resolve otherwise), where it has voxels.
pub fn report_layout(report: &Report) -> Option<String> {
    report.modes.iter().find_map(|m| m.voxel_memory.as_ref()).map(|v| v.layout.clone())
}

/// Whether the report's frames drew the depth prepass (`render.depth_prepass`, which "auto"
/// resolves by the device): a report from before the option has no such pass, so no prepass.
pub fn report_depth_prepass(report: &Report) -> bool {
    let prepass = crate::render::passes::gbuffer::DEPTH_PREPASS;
    report.modes.iter().any(|m| m.passes.iter().any(|p| p.name == prepass))
}

/// The model's answer for one mode.
#[derive(Debug, Clone, Serialize)]
pub struct ModeModel {
    pub mode: String,
    /// The report's mode whose pass times were used (the same mode where it was measured,
    /// else async, else sync, else the first).
    pub times_from: String,
    pub predicted: Prediction,
    /// The report's host median frame time, where it measured this mode.
    pub measured_frame_host_ms: Option<f64>,
    pub measured_graphics_busy_ms: Option<f64>,
    pub measured_compute_busy_ms: Option<f64>,
    /// Predicted over measured host median, minus one.
    pub error: Option<f64>,
    /// Predicted host median over the predicted sync one.
    pub predicted_ratio_to_sync: Option<f64>,
    /// Passes whose count differs between the report's timeline (one measured frame) and the
    /// recorded frame closest to it; empty when some recorded frame has exactly its passes.
    /// Not empty: the recording is not the schedule the report measured.
    pub structure_differences: Vec<String>,
    /// Recorded passes the report has no time for (a version that did not run them): they
    /// count 0 ms.
    pub untimed_passes: Vec<String>,
    pub submits_per_frame: f64,
    /// The busier queue's modelled time: the frame time if each queue's work overlapped the
    /// other's fully, across frames.
    pub overlap_bound_ms: f64,
    /// Waits of a frame's submits for the other queue's work of an earlier frame, as
    /// "frame N QUEUE [passes] waits for frame M [passes]" (in the last recorded frame).
    pub waits_across_frames: Vec<String>,
}

/// The model's report (`bench --model REPORT --json OUT`, schema dvsgi-bench-model/1).
#[derive(Debug, Clone, Serialize)]
pub struct ModelReport {
    pub schema: String,
    /// The bench report whose pass times were used, and its device.
    pub report: String,
    pub measured_on: String,
    pub measured_topology: String,
    /// false when the report's timestamps come from a CPU implementation (known to be wrong).
    pub measured_timestamps_trusted: bool,
    /// The device whose scheduler recorded the submits.
    pub recorded_on: String,
    pub recorded_topology: String,
    pub scene: String,
    pub scenario: String,
    /// The image size of the recording (the submits do not depend on it).
    pub recorded_width: u32,
    pub recorded_height: u32,
    pub frames: u32,
    pub warmup: u32,
    pub frames_in_flight: u32,
    pub settings: Vec<String>,
    pub modes: Vec<ModeModel>,
}

/// Model `mode` from `report`'s pass times and the recorded frames.
pub fn model_mode(report: &Report, path: &Path, mode: Mode, rec: &Recording) -> Result<ModeModel, ModelError> {
    let measured = report.modes.iter().find(|m| m.mode == mode.name());
    // A mode the report did not measure (async-pipelined in reports before it) takes the
    // times of async, whose GI already ran on the compute queue, else of sync.
    let named = |m: Mode| report.modes.iter().find(|r| r.mode == m.name());
    let source = measured.or_else(|| named(Mode::Async)).or_else(|| named(Mode::Sync)).unwrap_or(&report.modes[0]);
    let times = PassTimes::of(source);
    if times.by_name.is_empty() {
        return Err(ModelError::NoTimes { path: path.into() });
    }
    let predicted = simulate(rec, &|name, q| times.get(name, q).unwrap_or(0.0));
    let timeline: Vec<String> = source.timeline.iter().map(|p| p.name.clone()).collect();
    let structure_differences = closest_structure(&timeline, rec);
    let median = |s: Option<Stats>| s.map(|s| s.median);
    let measured_frame = measured.map(|m| m.frame_host_ms.median);
    let last = rec.frames.len().saturating_sub(1);
    let across = waits_across_frames(rec).into_iter().filter(|w| w.frame == last).map(|w| w.describe()).collect();
    Ok(ModeModel {
        mode: mode.name().to_string(),
        times_from: source.mode.clone(),
        error: measured_frame.map(|m| predicted.frame_host_ms.median / m - 1.0),
        measured_frame_host_ms: measured_frame,
        measured_graphics_busy_ms: measured.and_then(|m| median(m.graphics_busy_ms)),
        measured_compute_busy_ms: measured.and_then(|m| median(m.compute_busy_ms)),
        predicted_ratio_to_sync: None,
        structure_differences,
        untimed_passes: times.missing(rec),
        overlap_bound_ms: predicted.graphics_busy_ms.median.max(predicted.compute_busy_ms.median),
        waits_across_frames: across,
        submits_per_frame: rec.frames.iter().map(Vec::len).sum::<usize>() as f64 / rec.frames.len().max(1) as f64,
        predicted,
    })
}

/// Each mode's predicted median over the predicted sync one (where sync was modelled).
pub fn add_predicted_ratios(modes: &mut [ModeModel]) {
    let sync = modes.iter().find(|m| m.mode == Mode::Sync.name()).map(|m| m.predicted.frame_host_ms.median);
    for m in modes {
        m.predicted_ratio_to_sync = sync.filter(|s| *s > 0.0).map(|s| m.predicted.frame_host_ms.median / s);
    }
}

/// The submits of consecutive frames, as the scheduler recorded them, and how many frames
/// it kept in flight. The frames before the first one here have finished (bench waits for
/// the warm-up frames before timing).
#[derive(Debug, Clone)]
pub struct Recording {
    pub frames_in_flight: u32,
    pub frames: Vec<Vec<SubmitRecord>>,
}

/// What the simulation predicts for a recording.
#[derive(Debug, Clone, Serialize)]
pub struct Prediction {
    /// Host wall clock per frame as bench measures it: one frame's start to the next's, the
    /// last to idle.
    pub frame_host_ms: Stats,
    pub frame_host_samples: Vec<f64>,
    /// First batch start to last batch end of each frame, over both queues.
    pub gpu_span_ms: Stats,
    pub graphics_busy_ms: Stats,
    pub compute_busy_ms: Stats,
}

/// Simulate `rec` with each pass taking `time(name, queue)` ms.
pub fn simulate(rec: &Recording, time: &dyn Fn(&str, QueueKind) -> f64) -> Prediction {
    let in_flight = rec.frames_in_flight.max(1) as usize;
    // End time of each timeline value reached in the recording (earlier values: time 0).
    let mut reached: [BTreeMap<u64, f64>; 2] = [BTreeMap::new(), BTreeMap::new()];
    let mut queue_free = [0.0f64; 2];
    let mut host = 0.0f64;
    let (mut starts, mut done, mut spans) = (Vec::new(), Vec::new(), Vec::new());
    let mut busy = [Vec::new(), Vec::new()];
    for (i, frame) in rec.frames.iter().enumerate() {
        if i >= in_flight {
            // The slot this frame reuses is free once that frame has finished.
            host = host.max(done[i - in_flight]);
        }
        starts.push(host);
        let (mut first, mut last) = (f64::INFINITY, host);
        let mut frame_busy = [0.0f64; 2];
        for s in frame {
            let q = s.queue.index();
            let waited = s.wait.map_or(0.0, |w| end_of(&reached[1 - q], w));
            let begin = host.max(queue_free[q]).max(waited);
            let length: f64 = s.passes.iter().map(|p| time(p, s.queue)).sum();
            let end = begin + length;
            queue_free[q] = end;
            reached[q].insert(s.signal, end);
            frame_busy[q] += length;
            first = first.min(begin);
            last = last.max(end);
        }
        done.push(last);
        spans.push(if first.is_finite() { last - first } else { 0.0 });
        for q in 0..2 {
            busy[q].push(frame_busy[q]);
        }
    }
    let idle = queue_free[0].max(queue_free[1]);
    let samples: Vec<f64> = (0..starts.len()).map(|i| starts.get(i + 1).copied().unwrap_or(idle) - starts[i]).collect();
    let stats = |v: &[f64]| Stats::of(v).unwrap_or(Stats { min: 0.0, median: 0.0, p95: 0.0 });
    Prediction {
        frame_host_ms: stats(&samples),
        gpu_span_ms: stats(&spans),
        graphics_busy_ms: stats(&busy[0]),
        compute_busy_ms: stats(&busy[1]),
        frame_host_samples: samples,
    }
}

/// When a queue reached timeline value `v`: the end of the first batch that signals `v` or
/// more; values below the first one recorded were signalled before the recording began (by
/// the warm-up frames) and were reached at time 0.
fn end_of(reached: &BTreeMap<u64, f64>, v: u64) -> f64 {
    match reached.first_key_value() {
        Some((&first, _)) if v >= first => reached.range(v..).next().map_or(0.0, |(_, &t)| t),
        _ => 0.0,
    }
}

/// Each pass's median GPU time in one mode of a report, by name and queue.
#[derive(Debug, Clone, Default)]
pub struct PassTimes {
    by_queue: HashMap<(String, String), f64>,
    by_name: HashMap<String, f64>,
}

impl PassTimes {
    /// The medians of `m` (passes without GPU times are left out).
    pub fn of(m: &ModeReport) -> PassTimes {
        let mut t = PassTimes::default();
        for p in &m.passes {
            if let Some(s) = p.gpu_ms {
                t.by_queue.insert((p.name.clone(), p.queue.clone()), s.median);
                t.by_name.entry(p.name.clone()).or_insert(s.median);
            }
        }
        t
    }

    /// The time of `name` on `queue`, else on the other queue.
    pub fn get(&self, name: &str, queue: QueueKind) -> Option<f64> {
        self.by_queue.get(&(name.to_string(), queue.name().to_string())).or_else(|| self.by_name.get(name)).copied()
    }

    /// The recorded passes this report has no time for, each named once.
    pub fn missing(&self, rec: &Recording) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for p in rec.frames.iter().flatten().flat_map(|s| &s.passes) {
            if !self.by_name.contains_key(p) && !out.contains(p) {
                out.push(p.clone());
            }
        }
        out
    }
}

/// A submit that waits for the other queue's work of an earlier frame.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossFrameWait {
    /// The waiting submit's frame (index in the recording), queue and passes.
    pub frame: usize,
    pub queue: QueueKind,
    pub passes: Vec<String>,
    /// The frame and passes of the submit that signalled the value it waits for.
    pub waited_frame: usize,
    pub waited_passes: Vec<String>,
}

impl CrossFrameWait {
    pub fn describe(&self) -> String {
        let list = |p: &[String]| if p.is_empty() { "a queue transfer".to_string() } else { p.join(", ") };
        format!(
            "frame {} {} [{}] waits for frame {} [{}]",
            self.frame,
            self.queue.name(),
            list(&self.passes),
            self.waited_frame,
            list(&self.waited_passes)
        )
    }
}

/// Every submit of `rec` that waits for a value the other queue signalled in an earlier
/// frame of the recording (waits for values from before it are not seen).
pub fn waits_across_frames(rec: &Recording) -> Vec<CrossFrameWait> {
    let mut signalled: [BTreeMap<u64, (usize, &SubmitRecord)>; 2] = [BTreeMap::new(), BTreeMap::new()];
    let mut out = Vec::new();
    for (i, frame) in rec.frames.iter().enumerate() {
        for s in frame {
            let other = &signalled[s.queue.other().index()];
            if let Some((&_, &(f, by))) = s.wait.and_then(|w| other.range(w..).next()) {
                if f < i {
                    out.push(CrossFrameWait {
                        frame: i,
                        queue: s.queue,
                        passes: s.passes.clone(),
                        waited_frame: f,
                        waited_passes: by.passes.clone(),
                    });
                }
            }
            signalled[s.queue.index()].insert(s.signal, (i, s));
        }
    }
    out
}

/// The differences between `report_frame` and the recorded frame with the fewest (frames of
/// a run can differ: a map drawn in one frame and reused in the next).
pub fn closest_structure(report_frame: &[String], rec: &Recording) -> Vec<String> {
    rec.frames.iter().map(|f| structure_differences(report_frame, f)).min_by_key(Vec::len).unwrap_or_default()
}

/// How a recorded frame's passes differ from the frame a report shows (its timeline): each
/// pass whose count differs, as "NAME: report N, recorded M". Empty when they agree.
pub fn structure_differences(report_frame: &[String], recorded: &[SubmitRecord]) -> Vec<String> {
    let count = |names: &mut dyn Iterator<Item = &String>| {
        let mut c: BTreeMap<String, usize> = BTreeMap::new();
        for n in names {
            *c.entry(n.clone()).or_default() += 1;
        }
        c
    };
    let reported = count(&mut report_frame.iter());
    let recorded = count(&mut recorded.iter().flat_map(|s| &s.passes));
    let mut names: Vec<&String> = reported.keys().chain(recorded.keys()).collect();
    names.sort();
    names.dedup();
    names
        .into_iter()
        .filter_map(|n| {
            let (a, b) = (reported.get(n).copied().unwrap_or(0), recorded.get(n).copied().unwrap_or(0));
            (a != b).then(|| format!("{n}: report {a}, recorded {b}"))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn submit(queue: QueueKind, signal: u64, wait: Option<u64>, passes: &[&str]) -> SubmitRecord {
        SubmitRecord { queue, signal, wait, passes: passes.iter().map(|p| p.to_string()).collect() }
    }

    fn times(name: &str, _: QueueKind) -> f64 {
        match name {
            "shadow" => 1.0,
            "gbuffer" => 3.0,
            "voxel light" => 0.5,
            "cone trace" => 5.0,
            "lighting" => 0.1,
            _ => 0.0,
        }
    }

    const G: QueueKind = QueueKind::Graphics;
    const C: QueueKind = QueueKind::Compute;

    /// Sync: one submit per frame on one queue; the frame is the sum of its passes.
    #[test]
    fn one_queue_costs_the_sum_of_its_passes() {
        let frames = (0..10u64).map(|i| vec![submit(G, i + 1, None, &["shadow", "gbuffer", "cone trace"])]).collect();
        let p = simulate(&Recording { frames_in_flight: 2, frames }, &times);
        assert!((p.frame_host_ms.median - 9.0).abs() < 1e-9, "{p:?}");
        assert_eq!(p.graphics_busy_ms.median, 9.0);
        assert_eq!(p.compute_busy_ms.median, 0.0);
        // The first frames' starts come at once (two slots), later ones one frame apart.
        assert_eq!(&p.frame_host_samples[..3], &[0.0, 9.0, 9.0]);
        // The last frame ends when the GPU is idle: it waited for the one before it.
        assert!((p.frame_host_samples.iter().sum::<f64>() - 90.0).abs() < 1e-9);
    }

    /// Async: the cone trace waits for the G-buffer on the other queue, and the lighting for
    /// the trace; the next frame's graphics work queues behind that lighting.
    #[test]
    fn a_chain_across_queues_costs_its_longest_path() {
        let frames = (0..10u64)
            .map(|i| {
                let (g, c) = (2 * i, i);
                vec![
                    submit(G, g + 1, None, &["shadow", "gbuffer"]),
                    submit(C, c + 1, Some(g + 1), &["cone trace"]),
                    submit(G, g + 2, Some(c + 1), &["lighting"]),
                ]
            })
            .collect();
        let p = simulate(&Recording { frames_in_flight: 2, frames }, &times);
        assert!((p.frame_host_ms.median - 9.1).abs() < 1e-9, "{p:?}");
        assert!((p.gpu_span_ms.median - 9.1).abs() < 1e-9);
        assert!((p.graphics_busy_ms.median - 4.1).abs() < 1e-9);
        assert_eq!(p.compute_busy_ms.median, 5.0);
    }

    /// A graphics queue that waits only for data of the frame before: frames overlap, and the
    /// frame time is the busier queue's.
    #[test]
    fn pipelined_frames_cost_the_busier_queue() {
        let frames = (0..20u64)
            .map(|i| {
                // Graphics of frame i needs compute's frame i - 2 (a copy per frame in flight).
                let wait = (i >= 2).then(|| i - 1);
                vec![submit(G, i + 1, wait, &["shadow", "gbuffer"]), submit(C, i + 1, Some(i + 1), &["cone trace"])]
            })
            .collect();
        let p = simulate(&Recording { frames_in_flight: 2, frames }, &times);
        assert!((p.frame_host_ms.median - 5.0).abs() < 1e-9, "{p:?}");
        // A frame starts when the frame two before it has finished its trace, and its own
        // trace follows the one of the frame before: two frames' traces.
        assert!((p.gpu_span_ms.median - 10.0).abs() < 1e-9);
    }

    /// A recording that begins after warm-up frames: a wait for a value they signalled is
    /// met at once, not by the first recorded batch that signals more.
    #[test]
    fn values_from_before_the_recording_are_reached_at_once() {
        let frames = (0..4u64)
            .map(|i| {
                // Compute values 1..=3 belong to warm-up frames; graphics of frame i waits for
                // compute's value i + 2 (two frames before), the first recorded one is 4.
                vec![
                    submit(G, i + 4, Some(i + 2), &["shadow", "gbuffer"]),
                    submit(C, i + 4, Some(i + 4), &["cone trace"]),
                ]
            })
            .collect();
        let p = simulate(&Recording { frames_in_flight: 2, frames }, &times);
        // Frame 1's graphics work follows frame 0's at once (4..8), its trace frame 0's
        // (9..14); frames 2 and 3 start when frames 0 and 1 are done (9, 14) and end at 19, 24.
        // Were value 3 reached only with the first recorded one (4, at 9), frame 1 would end at 18.
        assert_eq!(p.frame_host_samples, [0.0, 9.0, 5.0, 10.0], "{p:?}");
    }

    /// One frame in flight: the host waits for each frame, so nothing overlaps.
    #[test]
    fn one_frame_in_flight_serialises_frames() {
        let frames = (0..10u64)
            .map(|i| vec![submit(G, i + 1, None, &["gbuffer"]), submit(C, i + 1, None, &["cone trace"])])
            .collect();
        let p = simulate(&Recording { frames_in_flight: 1, frames }, &times);
        assert!((p.frame_host_ms.median - 5.0).abs() < 1e-9, "{p:?}");
        let two = (0..10u64)
            .map(|i| vec![submit(G, i + 1, None, &["gbuffer"]), submit(C, i + 1, None, &["cone trace"])])
            .collect();
        let p2 = simulate(&Recording { frames_in_flight: 2, frames: two }, &times);
        assert!((p2.frame_host_ms.median - 5.0).abs() < 1e-9);
        // With a wait on the other queue's previous frame and one slot, frames cannot overlap.
        let chained = (0..10u64)
            .map(|i| vec![submit(G, i + 1, None, &["gbuffer"]), submit(C, i + 1, Some(i + 1), &["cone trace"])])
            .collect();
        let p3 = simulate(&Recording { frames_in_flight: 1, frames: chained }, &times);
        assert!((p3.frame_host_ms.median - 8.0).abs() < 1e-9, "{p3:?}");
    }

    #[test]
    fn waits_across_frames_name_both_ends() {
        let frames = (0..3u64)
            .map(|i| {
                let wait = (i >= 1).then_some(i);
                vec![submit(G, i + 1, wait, &["gbuffer"]), submit(C, i + 1, Some(i + 1), &["cone trace"])]
            })
            .collect();
        let w = waits_across_frames(&Recording { frames_in_flight: 2, frames });
        assert_eq!(w.len(), 2);
        assert_eq!(w[1].describe(), "frame 2 graphics [gbuffer] waits for frame 1 [cone trace]");
        // Waits inside a frame are not listed.
        let same = vec![vec![submit(G, 1, None, &["gbuffer"]), submit(C, 1, Some(1), &["cone trace"])]];
        assert!(waits_across_frames(&Recording { frames_in_flight: 2, frames: same }).is_empty());
    }

    #[test]
    fn structure_differences_name_each_count() {
        let recorded = vec![submit(G, 1, None, &["gbuffer", "lighting"]), submit(C, 1, None, &["cone trace"])];
        let report: Vec<String> =
            ["shadow", "gbuffer", "cone trace", "lighting"].iter().map(|s| s.to_string()).collect();
        assert_eq!(structure_differences(&report, &recorded), vec!["shadow: report 1, recorded 0".to_string()]);
        assert!(structure_differences(&report[1..], &recorded).is_empty());
        // The report's frame may be any of the run's: the closest recorded one is compared.
        let first = vec![submit(G, 1, None, &["shadow", "gbuffer", "lighting"]), submit(C, 1, None, &["cone trace"])];
        let rec = Recording { frames_in_flight: 2, frames: vec![first, recorded.clone()] };
        assert!(closest_structure(&report, &rec).is_empty());
        assert_eq!(closest_structure(&report[1..], &rec), Vec::<String>::new());
        let other = Recording { frames_in_flight: 2, frames: vec![recorded] };
        assert_eq!(closest_structure(&report, &other).len(), 1);
    }

    #[test]
    fn missing_pass_times_are_named_once() {
        let t = PassTimes { by_name: [("gbuffer".to_string(), 1.0)].into(), ..Default::default() };
        let rec = Recording {
            frames_in_flight: 2,
            frames: vec![vec![submit(G, 1, None, &["gbuffer", "tonemap"])], vec![submit(G, 2, None, &["tonemap"])]],
        };
        assert_eq!(t.missing(&rec), vec!["tonemap".to_string()]);
        assert_eq!(t.get("gbuffer", C), Some(1.0));
    }
}
