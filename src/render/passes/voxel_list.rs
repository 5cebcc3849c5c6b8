//! The work list of occupied voxels (see glsl/include/voxel_list.glsl): the bookkeeping pass
//! that closes it after each voxelization, the indirect dispatches over it, and the zeroing
//! of stale voxels (emptied by the last dynamic clear) in the radiance volumes.
//! The static resolve writes the static voxels in grid order (`VoxelResolvePass`), the dynamic
//! voxelization appends the dynamic ones; the voxel light, the bounce and the dynamic clear
//! dispatch over it, so they cost what the scene's surfaces hold rather than N^3.

use crate::gpu::{shaders, Access, Bind, Buffer, Context, GpuResult, Image, Pipeline};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, Use};
use crate::render::voxel::{work_list_header, VoxelVolumes};
use ash::vk;
use std::sync::Arc;

/// What the bookkeeping pass does (push constant `mode` of glsl/voxel_list.comp).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum ListStep {
    /// After static voxelization: everything so far is static.
    Static = 0,
    /// After dynamic voxelization: the entries past the static ones are dynamic.
    Dynamic = 1,
    /// After the dynamic clear: the dynamic range becomes the stale list.
    Cleared = 2,
}

/// The bookkeeping pipeline and its set (shared by every step).
pub struct ListKeeper {
    pipeline: Pipeline,
    set: PassSet,
}

impl ListKeeper {
    pub fn new(ctx: &Arc<Context>, volumes: &Arc<VoxelVolumes>) -> GpuResult<Arc<ListKeeper>> {
        let set = Binds::new().storage(&volumes.list.buffer, Access::ComputeShaderWrite).build(
            ctx,
            "voxel list",
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let pipeline = Pipeline::compute(ctx, "voxel list", shaders::VOXEL_LIST_COMP, &[set.layout()], 4, &[])?;
        Ok(Arc::new(ListKeeper { pipeline, set }))
    }

    /// Its set (the passes that run a step list it with their own).
    pub fn set(&self) -> &PassSet {
        &self.set
    }

    /// Record one step (a single invocation).
    pub fn record(&self, cmd: vk::CommandBuffer, step: ListStep) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.push(cmd, &(step as u32));
        self.pipeline.dispatch(cmd, [1; 3], [1; 3]);
    }
}

/// Closes the list after a voxelization: counts and indirect arguments of its ranges.
pub struct VoxelListPass {
    keeper: Arc<ListKeeper>,
    step: ListStep,
}

impl VoxelListPass {
    pub fn new(keeper: &Arc<ListKeeper>, step: ListStep) -> Self {
        VoxelListPass { keeper: keeper.clone(), step }
    }
}

impl Pass for VoxelListPass {
    fn name(&self) -> &str {
        match self.step {
            ListStep::Static => "voxel list (static)",
            ListStep::Dynamic => "voxel list (dynamic)",
            ListStep::Cleared => "voxel list (cleared)",
        }
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![self.keeper.set()]
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.keeper.record(cmd, self.step);
    }
}

/// Dispatch `pipeline` (local size 64, glsl/include/voxel_list.glsl) over one range of the list.
pub fn dispatch_list(pipeline: &Pipeline, cmd: vk::CommandBuffer, volumes: &VoxelVolumes, range: u64) {
    pipeline.dispatch_indirect(cmd, &volumes.list.buffer, range);
}

/// The indirect arguments of a pass that dispatches over the list ([`dispatch_list`]).
pub fn list_arguments(volumes: &VoxelVolumes) -> Use<'_> {
    Use::buffer(&volumes.list.buffer, Access::IndirectCommandRead)
}

/// Zeroes one radiance volume at the stale voxels that are still empty (glsl/voxel_stale.comp).
/// Only with dynamic objects: without them no voxel is ever emptied after the first clear.
pub struct StaleZero {
    pipeline: Pipeline,
    set: PassSet,
}

impl StaleZero {
    pub fn new(ctx: &Arc<Context>, volumes: &VoxelVolumes, target: &Arc<Image>) -> GpuResult<Option<StaleZero>> {
        let Some(stale) = &volumes.list.stale else { return Ok(None) };
        let (buffer, read) = (Access::ComputeShaderReadBuffer, Access::ComputeShaderReadStorage);
        let set = Binds::new()
            .storage(&volumes.list.buffer, buffer)
            .storage(stale, buffer)
            .storage_image(&volumes.albedo, read)
            .storage_image(target, Access::ComputeShaderWrite)
            .loaded(Bind::Uniform(&volumes.grid_buffer))
            .extend(volumes.brick_maps(read))
            .build(ctx, &format!("voxel stale ({})", target.name), vk::ShaderStageFlags::COMPUTE)?;
        let pipeline = Pipeline::compute(ctx, "voxel stale", shaders::VOXEL_STALE_COMP, &[set.layout()], 0, &[])?;
        Ok(Some(StaleZero { pipeline, set }))
    }

    /// Its set: the owning pass lists it with its own.
    pub fn set(&self) -> &PassSet {
        &self.set
    }

    /// Zero the stale voxels, then a barrier so the owning pass's own writes to the target
    /// come after (the voxel sets are disjoint, but the target is one resource).
    pub fn record(&self, ctx: &Context, cmd: vk::CommandBuffer, volumes: &VoxelVolumes) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        dispatch_list(&self.pipeline, cmd, volumes, work_list_header::STALE);
        super::memory_barrier(ctx, cmd, &[Access::ComputeShaderWrite], &[Access::ComputeShaderWrite]);
    }
}

/// Bytes of `buffer` from `offset` copied to a host-visible buffer (counts read after a frame).
pub struct BufferDownload {
    source: Arc<Buffer>,
    offset: u64,
    pub buffer: Arc<Buffer>,
}

impl BufferDownload {
    pub fn new(ctx: &Arc<Context>, source: &Arc<Buffer>, offset: u64, size: u64) -> GpuResult<Self> {
        let buffer = Buffer::new(
            ctx,
            &format!("{} readback", source.name),
            size,
            vk::BufferUsageFlags::TRANSFER_DST,
            gpu_allocator::MemoryLocation::GpuToCpu,
        )?;
        Ok(BufferDownload { source: source.clone(), offset, buffer: Arc::new(buffer) })
    }

    pub fn bytes(&self) -> &[u8] {
        &self.buffer.mapped().expect("host-visible readback")[..self.buffer.size as usize]
    }
}

impl Pass for BufferDownload {
    fn name(&self) -> &str {
        "buffer readback"
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        vec![Use::buffer(&self.source, Access::TransferRead), Use::buffer(&self.buffer, Access::TransferWrite)]
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let region = vk::BufferCopy { src_offset: self.offset, dst_offset: 0, size: self.buffer.size };
        unsafe { ctx.device.cmd_copy_buffer(cmd, self.source.raw, self.buffer.raw, &[region]) };
    }
}
