//! Voxel clears: every volume and the work list's header once before static voxelization
//! (transfer), and before each dynamic update only the voxels the last dynamic voxelization
//! filled, the list's dynamic range (compute), which then becomes the stale list.

use super::voxel_list::{list_arguments, ListKeeper, ListStep};
use crate::gpu::{shaders, Access, Bind, Context, GpuResult, Pipeline};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, Use};
use crate::render::voxel::{work_list_header, VoxelVolumes};
use ash::vk;
use std::sync::Arc;

pub struct VoxelClearPass {
    volumes: Arc<VoxelVolumes>,
}

impl VoxelClearPass {
    pub fn new(volumes: &Arc<VoxelVolumes>) -> Self {
        VoxelClearPass { volumes: volumes.clone() }
    }
}

impl Pass for VoxelClearPass {
    fn name(&self) -> &str {
        "voxel clear"
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        let mut uses: Vec<Use> =
            self.volumes.all().into_iter().map(|v| Use::overwrite(v, Access::TransferWrite)).collect();
        uses.push(Use::buffer(&self.volumes.list.buffer, Access::TransferWrite));
        uses.push(Use::buffer(&self.volumes.scan, Access::TransferWrite));
        uses.extend(self.volumes.bricks.iter().map(|b| Use::buffer(&b.lists, Access::TransferWrite)));
        uses
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        for v in self.volumes.all() {
            unsafe {
                ctx.device.cmd_clear_color_image(
                    cmd,
                    v.raw,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &vk::ClearColorValue { uint32: [0; 4] },
                    &[v.desc.full_range()],
                )
            };
        }
        // An empty list: no entries, no groups in any range.
        unsafe { ctx.device.cmd_fill_buffer(cmd, self.volumes.list.buffer.raw, 0, work_list_header::SIZE, 0) };
        // No totals yet (the brick allocation's finalize reads every pool's).
        unsafe { ctx.device.cmd_fill_buffer(cmd, self.volumes.scan.raw, 0, vk::WHOLE_SIZE, 0) };
        // No resident bricks: every map entry is 0 (cleared above), every pool's list empty.
        if let Some(b) = &self.volumes.bricks {
            let header = b.empty_header();
            unsafe { ctx.device.cmd_update_buffer(cmd, b.lists.raw, 0, bytemuck::cast_slice(&header)) };
        }
    }
}

pub struct DynamicClearPass {
    volumes: Arc<VoxelVolumes>,
    pipeline: Pipeline,
    set: PassSet,
    keeper: Arc<ListKeeper>,
}

impl DynamicClearPass {
    pub fn new(ctx: &Arc<Context>, volumes: &Arc<VoxelVolumes>, keeper: &Arc<ListKeeper>) -> GpuResult<Self> {
        let stale = volumes.list.stale.as_ref().expect("a scene with dynamic objects has a stale list");
        let write = Access::ComputeShaderWrite;
        let set = Binds::new()
            .storage_image(&volumes.albedo, write)
            .storage_image(&volumes.normal, write)
            .storage_image(volumes.emission_or_albedo(), write)
            .storage(&volumes.list.buffer, write)
            .storage(stale, write)
            .loaded(Bind::Uniform(&volumes.grid_buffer))
            .extend(volumes.brick_maps(Access::ComputeShaderReadStorage))
            .build(ctx, "voxel clear dynamic", vk::ShaderStageFlags::COMPUTE)?;
        let pipeline = Pipeline::compute(
            ctx,
            "voxel clear dynamic",
            shaders::VOXEL_CLEAR_DYNAMIC_COMP,
            &[set.layout()],
            0,
            &[(2, u32::from(volumes.needs.emission))],
        )?;
        Ok(DynamicClearPass { volumes: volumes.clone(), pipeline, set, keeper: keeper.clone() })
    }
}

impl Pass for DynamicClearPass {
    fn name(&self) -> &str {
        "voxel clear dynamic"
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set, self.keeper.set()]
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        vec![list_arguments(&self.volumes)]
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.dispatch_indirect(cmd, &self.volumes.list.buffer, work_list_header::DYNAMIC);
        // The bookkeeping rewrites the arguments the dispatch read and reads what it wrote.
        let dispatched = [Access::IndirectCommandRead, Access::ComputeShaderWrite];
        super::memory_barrier(ctx, cmd, &dispatched, &[Access::ComputeShaderWrite]);
        self.keeper.record(cmd, ListStep::Cleared);
    }
}
