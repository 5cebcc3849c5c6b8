//! Frame scheduling: which queue each pass runs on, command buffers and submits, the timeline
//! semaphores between the queues, frames in flight, and per-queue timestamps.
//!
//! The frame is one ordered pass list (`frame.rs`); the [`Mode`] decides only where each pass is
//! submitted. Passes are recorded in list order into an open *batch* (one command buffer, one
//! submit) per queue. The [`StateTracker`] says, from the declared uses, which barriers a pass
//! needs on its own queue and which value of the other queue's timeline it must wait for (and
//! which ownership transfers, when the families differ). A pass that needs a value the other
//! queue has not yet waited for starts a new batch, so work before it is not held back; a batch
//! the other queue depends on is submitted at once. Every wait therefore names a value already
//! submitted, which also keeps a single shared queue (lavapipe) free of deadlock.
//!
//! Each queue has one timeline semaphore; every batch signals the next value. The host waits
//! only when it reuses a frame slot (`frames_in_flight` slots), when a frame is read back, or
//! in the serial profile; never between the submits of a frame.

use super::graph::{record_barriers, Pass, QueueKind, StateTracker, Transition};
use crate::gpu::{Context, GpuResult, VkContext};
use ash::vk;
use std::fmt;
use std::str::FromStr;
use std::sync::Arc;
use std::time::Instant;

/// How a frame's passes are placed on the queues.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// Everything on the graphics queue, in dependency order.
    Sync,
    /// Voxel illumination, mips, bounces, cone tracing and upsample on the compute queue.
    Async,
    /// As `Async`, but the cone tracer reads the voxel radiance of the previous frame, so this
    /// frame's voxel illumination overlaps the frame's graphics work after the trace.
    AsyncLagged,
    /// As `Async`, with the frame's tail after the G-buffer (deferred lighting, resolve,
    /// exposure, tone map, read-back copies) on the compute queue too, and one copy per frame
    /// in flight of everything a frame writes for itself (`frame::FramePasses`): the graphics
    /// queue draws frame N+1 while the compute queue lights and traces frame N. A viewer shows
    /// each frame one frame later ([`Mode::latency_frames`]).
    AsyncPipelined,
}

impl Mode {
    pub const ALL: [Mode; 4] = [Mode::Sync, Mode::Async, Mode::AsyncLagged, Mode::AsyncPipelined];
    pub fn name(self) -> &'static str {
        match self {
            Mode::Sync => "sync",
            Mode::Async => "async",
            Mode::AsyncLagged => "async-lagged",
            Mode::AsyncPipelined => "async-pipelined",
        }
    }

    /// Frames between a frame's submission and the one whose display a viewer presents with
    /// it: 1 for `async-pipelined` (frame N is shown while N+1's graphics work runs), else 0.
    pub fn latency_frames(self) -> u32 {
        u32::from(self == Mode::AsyncPipelined)
    }

    /// Whether the mode keeps one copy of the frame's own resources per frame in flight.
    pub fn per_frame_copies(self) -> bool {
        self == Mode::AsyncPipelined
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> Result<Mode, String> {
        Mode::ALL.into_iter().find(|m| m.name() == s).ok_or_else(|| {
            format!("unknown schedule mode '{s}' (expected sync, async, async-lagged or async-pipelined)")
        })
    }
}

/// One submit of a frame, for tests and `--verbose`.
#[derive(Debug, Clone)]
pub struct SubmitRecord {
    pub queue: QueueKind,
    /// The value this batch signals on its queue's timeline.
    pub signal: u64,
    /// The other queue's timeline value it waits for.
    pub wait: Option<u64>,
    pub passes: Vec<String>,
}

/// How often the host waited for the GPU, and why.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct HostWaits {
    /// Before reusing a frame slot whose frame was still in flight.
    pub slot_reuse: u64,
    /// After a frame whose output is read back.
    pub readback: u64,
    /// Between two submits of one frame (only the serial profile does this).
    pub in_frame: u64,
    /// Outside frames (downloads for tests, `wait_idle`).
    pub idle: u64,
}

/// GPU time of one pass, placed on the frame's timeline.
#[derive(Debug, Clone, serde::Serialize)]
pub struct PassTime {
    pub name: String,
    pub queue: QueueKind,
    /// Start and end in ms after the frame began on the host (calibrated timestamps) or after
    /// the frame's first timestamp (uncalibrated).
    pub begin_ms: f64,
    pub end_ms: f64,
}

impl PassTime {
    pub fn gpu_ms(&self) -> f64 {
        self.end_ms - self.begin_ms
    }
}

/// Timestamps of one completed frame.
#[derive(Debug, Clone)]
pub struct FrameTiming {
    pub frame: u64,
    pub passes: Vec<PassTime>,
    /// Whether the pass times are on the host clock (VK_EXT_calibrated_timestamps).
    pub calibrated: bool,
}

impl FrameTiming {
    /// First begin to last end over both queues.
    pub fn gpu_span_ms(&self) -> f64 {
        let b = self.passes.iter().map(|p| p.begin_ms).fold(f64::INFINITY, f64::min);
        let e = self.passes.iter().map(|p| p.end_ms).fold(f64::NEG_INFINITY, f64::max);
        if b.is_finite() && e.is_finite() {
            e - b
        } else {
            0.0
        }
    }
}

/// A pass timed on the host in the serial profile.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SerialTime {
    pub name: String,
    pub queue: QueueKind,
    pub host_ms: f64,
}

const MAX_STAMPED_PASSES: u32 = 128;
/// Frame timings kept until [`Scheduler::take_timings`].
const MAX_KEPT_TIMINGS: usize = 1024;

struct Batch {
    cmd: vk::CommandBuffer,
    value: u64,
    wait: Option<u64>,
    passes: Vec<String>,
    /// Binary semaphores its passes wait for (with the stages that wait) and signal.
    binary_waits: Vec<(vk::Semaphore, vk::PipelineStageFlags2)>,
    binary_signals: Vec<vk::Semaphore>,
}

/// One queue's side of the scheduler.
struct Stream {
    kind: QueueKind,
    queue: vk::Queue,
    timeline: vk::Semaphore,
    /// Last value given to a batch.
    value: u64,
    /// Last value submitted.
    submitted: u64,
    /// Highest value of the other queue's timeline that a batch of this queue waits for.
    waited: u64,
    /// Whether the queue family writes valid timestamps.
    timestamps: bool,
    open: Option<Batch>,
}

/// Per frame slot and queue: command buffers and timestamp queries.
struct SlotStream {
    pool: vk::CommandPool,
    cmds: Vec<vk::CommandBuffer>,
    used: usize,
    queries: vk::QueryPool,
    /// Stamped passes: name, first of its two query indices.
    stamps: Vec<(String, u32)>,
    reset_recorded: bool,
}

struct Slot {
    streams: [SlotStream; 2],
    /// Timeline values the slot's frame signalled last, per queue.
    end: [u64; 2],
    /// The frame recorded in this slot whose timestamps are not read yet, with its host start
    /// on CLOCK_MONOTONIC (ns).
    pending: Option<(u64, u64)>,
}

pub struct Scheduler {
    ctx: Arc<Context>,
    mode: Mode,
    tracker: StateTracker,
    streams: [Stream; 2],
    slots: Vec<Slot>,
    slot: usize,
    /// Host CLOCK_MONOTONIC (ns) when the open frame began.
    frame_host_ns: u64,
    frame_index: Option<u64>,
    calibration: Option<ash::ext::calibrated_timestamps::Device>,
    /// Submits of the last frame.
    submits: Vec<SubmitRecord>,
    /// Barriers, waits and transfers of the last frame, described.
    log: Vec<String>,
    completed: Vec<FrameTiming>,
    /// Host-time each pass (submit and wait after each): `--serial-profile`.
    pub serial: bool,
    serial_times: Vec<SerialTime>,
    pub waits: HostWaits,
}

/// CLOCK_MONOTONIC in ns (the host domain of VK_EXT_calibrated_timestamps).
pub fn host_now_ns() -> u64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes the timespec it is given.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

impl Scheduler {
    pub fn new(ctx: &Arc<Context>, mode: Mode, frames_in_flight: u32) -> GpuResult<Scheduler> {
        let d = &ctx.device;
        let queues = [ctx.graphics_queue, ctx.compute_queue];
        let mut streams = Vec::new();
        for kind in QueueKind::ALL {
            let q = queues[kind.index()];
            let mut ty = vk::SemaphoreTypeCreateInfo::default().semaphore_type(vk::SemaphoreType::TIMELINE);
            let timeline = unsafe { d.create_semaphore(&vk::SemaphoreCreateInfo::default().push_next(&mut ty), None) }
                .vk("vkCreateSemaphore")?;
            ctx.name_object(timeline, &format!("{} timeline", kind.name()));
            let timestamps = ctx.info.families.get(q.family as usize).is_some_and(|f| f.timestamp_valid_bits > 0);
            streams.push(Stream {
                kind,
                queue: q.raw,
                timeline,
                value: 0,
                submitted: 0,
                waited: 0,
                timestamps,
                open: None,
            });
        }
        let streams: [Stream; 2] = streams.try_into().unwrap_or_else(|_| unreachable!());
        let calibration = calibration(ctx);
        let mut me = Scheduler {
            ctx: ctx.clone(),
            mode,
            tracker: StateTracker::new(ctx.distinct_families()),
            streams,
            slots: Vec::new(),
            slot: 0,
            frame_host_ns: 0,
            frame_index: None,
            calibration,
            submits: Vec::new(),
            log: Vec::new(),
            completed: Vec::new(),
            serial: false,
            serial_times: Vec::new(),
            waits: HostWaits::default(),
        };
        for i in 0..frames_in_flight.max(1) {
            let slot = me.new_slot(i)?;
            me.slots.push(slot);
        }
        Ok(me)
    }

    fn new_slot(&self, i: u32) -> GpuResult<Slot> {
        let d = &self.ctx.device;
        let families = [self.ctx.graphics_queue.family, self.ctx.compute_queue.family];
        let mut streams = Vec::new();
        for kind in QueueKind::ALL {
            let pool = unsafe {
                d.create_command_pool(
                    &vk::CommandPoolCreateInfo::default()
                        .queue_family_index(families[kind.index()])
                        .flags(vk::CommandPoolCreateFlags::TRANSIENT),
                    None,
                )
            }
            .vk("vkCreateCommandPool")?;
            self.ctx.name_object(pool, &format!("{} commands, slot {i}", kind.name()));
            let queries = unsafe {
                d.create_query_pool(
                    &vk::QueryPoolCreateInfo::default()
                        .query_type(vk::QueryType::TIMESTAMP)
                        .query_count(2 * MAX_STAMPED_PASSES),
                    None,
                )
            }
            .vk("vkCreateQueryPool")?;
            self.ctx.name_object(queries, &format!("{} timestamps, slot {i}", kind.name()));
            streams.push(SlotStream {
                pool,
                cmds: Vec::new(),
                used: 0,
                queries,
                stamps: Vec::new(),
                reset_recorded: false,
            });
        }
        Ok(Slot { streams: streams.try_into().unwrap_or_else(|_| unreachable!()), end: [0, 0], pending: None })
    }

    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Change the mode between frames (the passes and resources stay the same).
    pub fn set_mode(&mut self, mode: Mode) {
        self.mode = mode;
    }

    /// Track `image` as presented (see [`StateTracker::adopt`]).
    pub fn adopt_presented(&mut self, image: &crate::gpu::Image) {
        let key = super::graph::Res::Image(image).res_key();
        self.tracker.adopt(key, crate::gpu::Access::Present, QueueKind::Graphics);
    }

    /// Submits of the last frame, in submission order.
    pub fn submits(&self) -> &[SubmitRecord] {
        &self.submits
    }

    /// Barriers, waits and ownership transfers of the last frame.
    pub fn log(&self) -> &[String] {
        &self.log
    }

    /// Timings of the frames completed since the last call.
    pub fn take_timings(&mut self) -> Vec<FrameTiming> {
        std::mem::take(&mut self.completed)
    }

    /// The timing of a completed frame not yet taken.
    pub fn timing_of(&self, frame: u64) -> Option<&FrameTiming> {
        self.completed.iter().find(|f| f.frame == frame)
    }

    /// Host times of the passes of the last serial-profile frame.
    pub fn serial_times(&self) -> &[SerialTime] {
        &self.serial_times
    }

    /// The last value each timeline has been asked to signal.
    pub fn timeline_values(&self) -> [u64; 2] {
        [self.streams[0].submitted, self.streams[1].submitted]
    }

    /// Start a frame (`Some(index)`) or a one-off batch of work (`None`): reuse the next slot,
    /// waiting for its previous frame if that is still in flight.
    pub fn begin(&mut self, frame: Option<u64>) -> GpuResult<()> {
        self.slot = (self.slot + 1) % self.slots.len();
        let end = self.slots[self.slot].end;
        let done = self.reached(end)?;
        if !done {
            if frame.is_some() {
                self.waits.slot_reuse += 1;
            } else {
                self.waits.idle += 1;
            }
            self.wait_values(end, "a frame slot to be free")?;
        }
        self.collect_slot(self.slot)?;
        let d = &self.ctx.device;
        for s in &mut self.slots[self.slot].streams {
            unsafe { d.reset_command_pool(s.pool, vk::CommandPoolResetFlags::empty()) }.vk("vkResetCommandPool")?;
            s.used = 0;
            s.stamps.clear();
            s.reset_recorded = false;
        }
        self.frame_index = frame;
        self.frame_host_ns = host_now_ns();
        self.submits.clear();
        self.log.clear();
        if self.serial {
            self.serial_times.clear();
        }
        Ok(())
    }

    /// Record `passes` in order, submitting batches as the dependencies require.
    pub fn record(&mut self, passes: &[&dyn Pass]) -> GpuResult<()> {
        for pass in passes {
            let started = Instant::now();
            let q = match self.mode {
                Mode::Sync => QueueKind::Graphics,
                Mode::AsyncPipelined => pass.pipelined_queue(),
                _ => pass.queue(),
            };
            self.record_pass(*pass, q)?;
            if self.serial {
                self.flush()?;
                let values = self.timeline_values();
                self.waits.in_frame += 1;
                self.wait_values(values, pass.name())?;
                let host_ms = started.elapsed().as_secs_f64() * 1e3;
                self.serial_times.push(SerialTime { name: pass.name().to_string(), queue: q, host_ms });
            }
        }
        Ok(())
    }

    fn record_pass(&mut self, pass: &dyn Pass, q: QueueKind) -> GpuResult<()> {
        let uses = super::graph::uses(pass);
        let mut t: Transition = self.tracker.plan(&uses, q);
        let (qi, oi) = (q.index(), q.other().index());
        let mut wait = t.wait;
        if !t.releases.is_empty() {
            // The release halves go at the end of the other queue's work; wait for that batch.
            let cmd = self.open_batch(q.other(), None)?;
            record_barriers(&self.ctx, cmd, &t.releases, &uses);
            wait = Some(self.streams[oi].value);
        }
        if let Some(w) = wait {
            // A dependency on the other queue's open batch: submit it now.
            if self.streams[oi].open.as_ref().is_some_and(|b| b.value <= w) {
                self.close(q.other())?;
            }
            // A new dependency starts a new batch so the work already recorded is not held back.
            if w > self.streams[qi].waited && self.streams[qi].open.as_ref().is_some_and(|b| !b.passes.is_empty()) {
                self.close(q)?;
            }
        }
        let cmd = self.open_batch(q, wait)?;
        let value = self.streams[qi].value;
        self.tracker.commit(&mut t, q, value);
        self.log.extend(t.log.iter().map(|l| format!("before {} ({}): {l}", pass.name(), q.name())));
        record_barriers(&self.ctx, cmd, &t.barriers, &uses);
        self.ctx.begin_label(cmd, pass.name());
        let stamp = self.stamp_begin(q, cmd, pass.name());
        pass.record(&self.ctx, cmd);
        if let Some(i) = stamp {
            self.write_stamp(q, cmd, i + 1);
        }
        self.ctx.end_label(cmd);
        if let Some(b) = &mut self.streams[qi].open {
            b.passes.push(pass.name().to_string());
            let sems = pass.semaphores();
            b.binary_waits.extend(sems.wait);
            b.binary_signals.extend(sems.signal);
        }
        Ok(())
    }

    /// The open batch of `q` (opened if needed), with `wait` added to its waits.
    fn open_batch(&mut self, q: QueueKind, wait: Option<u64>) -> GpuResult<vk::CommandBuffer> {
        let qi = q.index();
        if self.streams[qi].open.is_none() {
            let cmd = self.command_buffer(q)?;
            let s = &mut self.streams[qi];
            s.value += 1;
            s.open = Some(Batch {
                cmd,
                value: s.value,
                wait: None,
                passes: Vec::new(),
                binary_waits: Vec::new(),
                binary_signals: Vec::new(),
            });
        }
        let s = &mut self.streams[qi];
        let b = s.open.as_mut().expect("open batch");
        if let Some(w) = wait {
            b.wait = b.wait.max(Some(w));
            s.waited = s.waited.max(w);
        }
        Ok(b.cmd)
    }

    fn command_buffer(&mut self, q: QueueKind) -> GpuResult<vk::CommandBuffer> {
        let d = &self.ctx.device;
        let ss = &mut self.slots[self.slot].streams[q.index()];
        if ss.used == ss.cmds.len() {
            let cmd = unsafe {
                d.allocate_command_buffers(
                    &vk::CommandBufferAllocateInfo::default()
                        .command_pool(ss.pool)
                        .level(vk::CommandBufferLevel::PRIMARY)
                        .command_buffer_count(1),
                )
            }
            .vk("vkAllocateCommandBuffers")?[0];
            self.ctx.name_object(cmd, &format!("{} commands {}, slot {}", q.name(), ss.cmds.len(), self.slot));
            ss.cmds.push(cmd);
        }
        let cmd = ss.cmds[ss.used];
        ss.used += 1;
        unsafe {
            d.begin_command_buffer(
                cmd,
                &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )
        }
        .vk("vkBeginCommandBuffer")?;
        Ok(cmd)
    }

    fn stamp_begin(&mut self, q: QueueKind, cmd: vk::CommandBuffer, name: &str) -> Option<u32> {
        if !self.streams[q.index()].timestamps || self.frame_index.is_none() {
            return None;
        }
        let ss = &mut self.slots[self.slot].streams[q.index()];
        if ss.stamps.len() as u32 >= MAX_STAMPED_PASSES {
            return None;
        }
        if !ss.reset_recorded {
            unsafe { self.ctx.device.cmd_reset_query_pool(cmd, ss.queries, 0, 2 * MAX_STAMPED_PASSES) };
            ss.reset_recorded = true;
        }
        let i = 2 * ss.stamps.len() as u32;
        ss.stamps.push((name.to_string(), i));
        self.write_stamp(q, cmd, i);
        Some(i)
    }

    fn write_stamp(&self, q: QueueKind, cmd: vk::CommandBuffer, index: u32) {
        let pool = self.slots[self.slot].streams[q.index()].queries;
        unsafe { self.ctx.device.cmd_write_timestamp2(cmd, vk::PipelineStageFlags2::ALL_COMMANDS, pool, index) };
    }

    /// End and submit the open batch of `q`: wait for the other timeline if needed, signal
    /// this queue's next value.
    fn close(&mut self, q: QueueKind) -> GpuResult<()> {
        let qi = q.index();
        let Some(batch) = self.streams[qi].open.take() else { return Ok(()) };
        let d = &self.ctx.device;
        unsafe { d.end_command_buffer(batch.cmd) }.vk("vkEndCommandBuffer")?;
        let other = &self.streams[q.other().index()];
        let mut waits: Vec<vk::SemaphoreSubmitInfo> = batch
            .wait
            .map(|w| {
                debug_assert!(w <= other.submitted, "a wait names a value not yet submitted");
                vk::SemaphoreSubmitInfo::default()
                    .semaphore(other.timeline)
                    .value(w)
                    .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
            })
            .into_iter()
            .collect();
        let s = &self.streams[qi];
        let mut signals = vec![vk::SemaphoreSubmitInfo::default()
            .semaphore(s.timeline)
            .value(batch.value)
            .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)];
        for &(semaphore, stage) in &batch.binary_waits {
            waits.push(vk::SemaphoreSubmitInfo::default().semaphore(semaphore).stage_mask(stage));
        }
        for &semaphore in &batch.binary_signals {
            let all = vk::PipelineStageFlags2::ALL_COMMANDS;
            signals.push(vk::SemaphoreSubmitInfo::default().semaphore(semaphore).stage_mask(all));
        }
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(batch.cmd)];
        let submit = vk::SubmitInfo2::default()
            .wait_semaphore_infos(&waits)
            .command_buffer_infos(&cmds)
            .signal_semaphore_infos(&signals);
        {
            let _g = self.ctx.submit_lock.lock().unwrap_or_else(|p| p.into_inner());
            unsafe { d.queue_submit2(s.queue, &[submit], vk::Fence::null()) }.vk("vkQueueSubmit2")?;
        }
        let kind = s.kind;
        // The record is read back from what vkQueueSubmit2 was handed, not from the plan.
        let wait = handed_wait(&submit, other.timeline);
        self.streams[qi].submitted = batch.value;
        self.slots[self.slot].end[qi] = batch.value;
        self.submits.push(SubmitRecord { queue: kind, signal: batch.value, wait, passes: batch.passes });
        Ok(())
    }

    /// Submit the open batch of `q`, if any: what is recorded next starts a new one (where a
    /// later frame waits for what came before, not for what follows).
    pub fn end_batch(&mut self, q: QueueKind) -> GpuResult<()> {
        self.close(q)
    }

    /// Submit every open batch.
    fn flush(&mut self) -> GpuResult<()> {
        for q in QueueKind::ALL {
            self.close(q)?;
        }
        Ok(())
    }

    /// Submit the rest of the frame; with `wait`, wait for it (counted as a readback wait).
    pub fn end(&mut self, wait: bool) -> GpuResult<()> {
        self.flush()?;
        if let Some(frame) = self.frame_index {
            self.slots[self.slot].pending = Some((frame, self.frame_host_ns));
        }
        if wait {
            if self.frame_index.is_some() {
                self.waits.readback += 1;
            } else {
                self.waits.idle += 1;
            }
            let end = self.timeline_values();
            self.wait_values(end, "the frame")?;
            self.collect_slot(self.slot)?;
        }
        self.frame_index = None;
        Ok(())
    }

    /// Wait for all submitted work and collect the timings of every finished frame.
    pub fn wait_idle(&mut self) -> GpuResult<()> {
        let end = self.timeline_values();
        if !self.reached(end)? {
            self.waits.idle += 1;
            self.wait_values(end, "the frames in flight")?;
        }
        for i in 0..self.slots.len() {
            // Oldest first.
            let slot = (self.slot + 1 + i) % self.slots.len();
            self.collect_slot(slot)?;
        }
        Ok(())
    }

    fn reached(&self, values: [u64; 2]) -> GpuResult<bool> {
        for (s, v) in self.streams.iter().zip(values) {
            if v > 0
                && unsafe { self.ctx.device.get_semaphore_counter_value(s.timeline) }
                    .vk("vkGetSemaphoreCounterValue")?
                    < v
            {
                return Ok(false);
            }
        }
        Ok(true)
    }

    fn wait_values(&self, values: [u64; 2], what: &str) -> GpuResult<()> {
        let (sems, vals): (Vec<_>, Vec<_>) =
            self.streams.iter().zip(values).filter(|(_, v)| *v > 0).map(|(s, v)| (s.timeline, v)).unzip();
        if sems.is_empty() {
            return Ok(());
        }
        let info = vk::SemaphoreWaitInfo::default().semaphores(&sems).values(&vals);
        let r = unsafe { self.ctx.device.wait_semaphores(&info, self.ctx.gpu_timeout().as_nanos() as u64) };
        self.ctx.wait_result(r, "vkWaitSemaphores", what)
    }

    /// Read the timestamps of the finished frame in `slot`, if it has one not read yet.
    fn collect_slot(&mut self, slot: usize) -> GpuResult<()> {
        let Some((frame, host_ns)) = self.slots[slot].pending.take() else { return Ok(()) };
        let period = self.ctx.info.timestamp_period_ns as f64;
        // Device ticks -> host ns (CLOCK_MONOTONIC), when the device can say.
        let offset = self.calibration.as_ref().and_then(|c| {
            let infos = [
                vk::CalibratedTimestampInfoEXT::default().time_domain(vk::TimeDomainEXT::DEVICE),
                vk::CalibratedTimestampInfoEXT::default().time_domain(vk::TimeDomainEXT::CLOCK_MONOTONIC),
            ];
            unsafe { c.get_calibrated_timestamps(&infos) }.ok().map(|(t, _)| (t[0], t[1]))
        });
        let mut raw = Vec::new();
        for q in QueueKind::ALL {
            let ss = &self.slots[slot].streams[q.index()];
            if ss.stamps.is_empty() {
                continue;
            }
            let mut data = vec![[0u64; 2]; 2 * ss.stamps.len()];
            unsafe {
                self.ctx.device.get_query_pool_results(
                    ss.queries,
                    0,
                    &mut data,
                    vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WITH_AVAILABILITY,
                )
            }
            .vk("vkGetQueryPoolResults")?;
            for (name, i) in &ss.stamps {
                let (b, e) = (data[*i as usize], data[*i as usize + 1]);
                if b[1] != 0 && e[1] != 0 {
                    raw.push((name.clone(), q, b[0], e[0].max(b[0])));
                }
            }
        }
        let to_ms: Box<dyn Fn(u64) -> f64> = match offset {
            Some((dev, host)) => Box::new(move |tick: u64| {
                let ns = host as f64 + (tick as f64 - dev as f64) * period;
                (ns - host_ns as f64) * 1e-6
            }),
            None => {
                let first = raw.iter().map(|r| r.2).min().unwrap_or(0);
                Box::new(move |tick: u64| (tick - first) as f64 * period * 1e-6)
            }
        };
        let mut passes: Vec<PassTime> = raw
            .into_iter()
            .map(|(name, queue, b, e)| PassTime { name, queue, begin_ms: to_ms(b), end_ms: to_ms(e) })
            .collect();
        passes.sort_by(|a, b| a.begin_ms.total_cmp(&b.begin_ms));
        // Keep a bounded history for callers that never take the timings.
        if self.completed.len() >= MAX_KEPT_TIMINGS {
            self.completed.remove(0);
        }
        self.completed.push(FrameTiming { frame, passes, calibrated: offset.is_some() });
        Ok(())
    }
}

/// The value of `timeline` that a submit waits for, as handed to `vkQueueSubmit2` (the
/// scheduler waits on nothing else but the binary semaphores passes ask for, which carry no
/// value).
fn handed_wait(submit: &vk::SubmitInfo2, timeline: vk::Semaphore) -> Option<u64> {
    let n = submit.wait_semaphore_info_count as usize;
    if n == 0 || submit.p_wait_semaphore_infos.is_null() {
        return None;
    }
    // SAFETY: the pointer and count come from the slice the submit info was built from.
    let waits = unsafe { std::slice::from_raw_parts(submit.p_wait_semaphore_infos, n) };
    debug_assert!(
        waits.iter().all(|w| w.semaphore == timeline || w.value == 0),
        "a timeline wait on another semaphore"
    );
    waits.iter().filter(|w| w.semaphore == timeline).map(|w| w.value).max()
}

/// The calibrated-timestamps loader, when the device and host domains can be calibrated.
fn calibration(ctx: &Context) -> Option<ash::ext::calibrated_timestamps::Device> {
    if !ctx.info.optional.calibrated_timestamps {
        return None;
    }
    let inst = ash::ext::calibrated_timestamps::Instance::new(&ctx.entry, &ctx.instance);
    let domains = unsafe { inst.get_physical_device_calibrateable_time_domains(ctx.physical_device) }.ok()?;
    (domains.contains(&vk::TimeDomainEXT::DEVICE) && domains.contains(&vk::TimeDomainEXT::CLOCK_MONOTONIC))
        .then(|| ash::ext::calibrated_timestamps::Device::new(&ctx.instance, &ctx.device))
}

impl Drop for Scheduler {
    fn drop(&mut self) {
        // Bounded wait for this scheduler's own work; after a timeout or a lost device, leak.
        if self.ctx.has_failed() || self.wait_values(self.timeline_values(), "the frames in flight").is_err() {
            return;
        }
        let d = &self.ctx.device;
        unsafe {
            for slot in &self.slots {
                for s in &slot.streams {
                    d.destroy_command_pool(s.pool, None);
                    d.destroy_query_pool(s.queries, None);
                }
            }
            for s in &self.streams {
                d.destroy_semaphore(s.timeline, None);
            }
        }
    }
}
