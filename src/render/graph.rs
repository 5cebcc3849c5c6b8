//! Passes declare what they read and write; the recorder derives every barrier from those
//! declarations (see `gpu::sync`) and wraps each pass in a debug label and GPU timestamps.

use crate::gpu::sync::{barrier, Access};
use crate::gpu::{Buffer, Context, GpuResult, Image, VkContext};
use ash::vk;
use ash::vk::Handle;
use std::collections::HashMap;
use std::sync::Arc;

/// A resource a pass touches.
#[derive(Clone, Copy)]
pub enum Res<'a> {
    Image(&'a Image),
    Buffer(&'a Buffer),
}

impl Res<'_> {
    fn key(&self) -> u64 {
        match self {
            Res::Image(i) => i.raw.as_raw(),
            Res::Buffer(b) => b.raw.as_raw(),
        }
    }
    fn name(&self) -> &str {
        match self {
            Res::Image(i) => &i.name,
            Res::Buffer(b) => &b.name,
        }
    }
}

/// One declared use of a resource by a pass.
#[derive(Clone, Copy)]
pub struct Use<'a> {
    pub res: Res<'a>,
    pub access: Access,
    /// The pass overwrites the whole resource: previous contents may be discarded.
    pub discard: bool,
}

impl<'a> Use<'a> {
    /// Access an image, keeping its contents.
    pub fn image(image: &'a Image, access: Access) -> Self {
        Use { res: Res::Image(image), access, discard: false }
    }
    /// Overwrite a whole image: its previous contents are discarded.
    pub fn overwrite(image: &'a Image, access: Access) -> Self {
        Use { res: Res::Image(image), access, discard: true }
    }
    pub fn buffer(buffer: &'a Buffer, access: Access) -> Self {
        Use { res: Res::Buffer(buffer), access, discard: false }
    }
}

/// A unit of GPU work in the frame.
pub trait Pass {
    fn name(&self) -> &str;
    /// Everything this pass reads or writes that another pass may also touch.
    /// (Immutable scene data uploaded at load time is not listed.)
    fn uses(&self) -> Vec<Use<'_>>;
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer);
}

/// The last accesses of every resource seen, carried from pass to pass and frame to frame.
#[derive(Default)]
pub struct StateTracker {
    state: HashMap<u64, Vec<Access>>,
}

/// Barriers collected before one pass.
#[derive(Default)]
pub struct PendingBarriers {
    pub images: Vec<vk::ImageMemoryBarrier2<'static>>,
    pub buffers: Vec<vk::BufferMemoryBarrier2<'static>>,
    /// Human-readable description, for `--verbose` and tests.
    pub log: Vec<String>,
}

impl StateTracker {
    /// Barriers needed before a pass with these uses; updates the tracked state.
    pub fn transition(&mut self, uses: &[Use]) -> PendingBarriers {
        let mut out = PendingBarriers::default();
        // Merge multiple uses of the same resource in one pass.
        let mut merged: Vec<(Res, Vec<Access>, bool)> = Vec::new();
        for u in uses {
            match merged.iter_mut().find(|(r, _, _)| r.key() == u.res.key()) {
                Some((_, accs, discard)) => {
                    accs.push(u.access);
                    *discard &= u.discard;
                }
                None => merged.push((u.res, vec![u.access], u.discard)),
            }
        }
        for (res, next, discard) in merged {
            let prev = self.state.get(&res.key()).cloned().unwrap_or_else(|| vec![Access::Nothing]);
            let is_image = matches!(res, Res::Image(_));
            if let Some(b) = barrier(&prev, &next, is_image, discard) {
                out.log.push(format!(
                    "{}: {:?} -> {:?} ({:?} -> {:?})",
                    res.name(),
                    prev,
                    next,
                    b.old_layout,
                    b.new_layout
                ));
                match res {
                    Res::Image(img) => out.images.push(b.image(img.raw, img.desc.full_range())),
                    Res::Buffer(buf) => out.buffers.push(b.buffer(buf.raw)),
                }
            }
            self.state.insert(res.key(), next);
        }
        out
    }
}

impl PendingBarriers {
    pub fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        if self.images.is_empty() && self.buffers.is_empty() {
            return;
        }
        let dep =
            vk::DependencyInfo::default().image_memory_barriers(&self.images).buffer_memory_barriers(&self.buffers);
        unsafe { ctx.device.cmd_pipeline_barrier2(cmd, &dep) };
    }
}

/// GPU timestamps around each pass.
pub struct PassTimer {
    ctx: Arc<Context>,
    pool: vk::QueryPool,
    capacity: u32,
    names: Vec<String>,
    valid: bool,
}

/// One pass's GPU time.
#[derive(Debug, Clone)]
pub struct PassTime {
    pub name: String,
    pub gpu_ms: f64,
}

impl PassTimer {
    pub fn new(ctx: &Arc<Context>, max_passes: u32) -> GpuResult<PassTimer> {
        let capacity = max_passes * 2;
        let pool = unsafe {
            ctx.device.create_query_pool(
                &vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(capacity),
                None,
            )
        }
        .vk("vkCreateQueryPool")?;
        ctx.name_object(pool, "pass timestamps");
        let valid = ctx
            .info
            .families
            .get(ctx.graphics_queue.family as usize)
            .map(|f| f.timestamp_valid_bits > 0)
            .unwrap_or(false);
        Ok(PassTimer { ctx: ctx.clone(), pool, capacity, names: Vec::new(), valid })
    }

    fn begin_frame(&mut self, cmd: vk::CommandBuffer) {
        self.names.clear();
        unsafe { self.ctx.device.cmd_reset_query_pool(cmd, self.pool, 0, self.capacity) };
    }

    fn stamp(&mut self, cmd: vk::CommandBuffer, index: u32) {
        if index < self.capacity {
            unsafe {
                self.ctx.device.cmd_write_timestamp2(cmd, vk::PipelineStageFlags2::ALL_COMMANDS, self.pool, index)
            };
        }
    }

    /// Read the timestamps of the last recorded frame (call after its fence signalled).
    pub fn read(&self) -> GpuResult<Vec<PassTime>> {
        let n = (self.names.len() as u32 * 2).min(self.capacity);
        if n == 0 || !self.valid {
            return Ok(Vec::new());
        }
        let mut data = vec![[0u64; 2]; n as usize];
        unsafe {
            self.ctx.device.get_query_pool_results(
                self.pool,
                0,
                &mut data,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WITH_AVAILABILITY,
            )
        }
        .vk("vkGetQueryPoolResults")?;
        let period = self.ctx.info.timestamp_period_ns as f64;
        Ok(self
            .names
            .iter()
            .enumerate()
            .filter_map(|(i, name)| {
                let (b, e) = (data[2 * i], data[2 * i + 1]);
                (b[1] != 0 && e[1] != 0)
                    .then(|| PassTime { name: name.clone(), gpu_ms: e[0].saturating_sub(b[0]) as f64 * period * 1e-6 })
            })
            .collect())
    }
}

impl Drop for PassTimer {
    fn drop(&mut self) {
        unsafe { self.ctx.device.destroy_query_pool(self.pool, None) };
    }
}

/// Record `passes` in order into `cmd`: barriers from declarations, a debug label and
/// timestamps around each. Returns the barrier log.
pub fn record_passes(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    tracker: &mut StateTracker,
    mut timer: Option<&mut PassTimer>,
    passes: &[&dyn Pass],
) -> Vec<String> {
    let mut log = Vec::new();
    if let Some(t) = timer.as_deref_mut() {
        t.begin_frame(cmd);
    }
    for pass in passes {
        let uses = pass.uses();
        let barriers = tracker.transition(&uses);
        barriers.record(ctx, cmd);
        log.extend(barriers.log.iter().map(|l| format!("before {}: {l}", pass.name())));
        ctx.begin_label(cmd, pass.name());
        let slot = timer.as_deref_mut().map(|t| {
            let i = t.names.len() as u32;
            t.names.push(pass.name().to_string());
            t.stamp(cmd, 2 * i);
            i
        });
        pass.record(ctx, cmd);
        if let (Some(t), Some(i)) = (timer.as_deref_mut(), slot) {
            t.stamp(cmd, 2 * i + 1);
        }
        ctx.end_label(cmd);
    }
    log
}
