//! Voxel clears: every volume once before static voxelization (transfer), and before each
//! dynamic update only the voxels not marked static (compute).

use crate::gpu::{shaders, Access, Context, DescriptorSet, GpuResult, Pipeline};
use crate::render::graph::{Pass, Use};
use crate::render::voxel::VoxelVolumes;
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
    fn uses(&self) -> Vec<Use<'_>> {
        self.volumes.all().into_iter().map(|v| Use::overwrite(v, Access::TransferWrite)).collect()
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
    }
}

pub struct DynamicClearPass {
    volumes: Arc<VoxelVolumes>,
    pipeline: Pipeline,
    set: DescriptorSet,
}

impl DynamicClearPass {
    pub fn new(ctx: &Arc<Context>, volumes: &Arc<VoxelVolumes>) -> GpuResult<Self> {
        let set = DescriptorSet::new(ctx, "voxel clear dynamic", vk::ShaderStageFlags::COMPUTE, &volumes.binds())?;
        let pipeline = Pipeline::compute(
            ctx,
            "voxel clear dynamic",
            shaders::VOXEL_CLEAR_DYNAMIC_COMP,
            &[set.layout],
            0,
            &[(2, u32::from(volumes.needs.emission))],
        )?;
        Ok(DynamicClearPass { volumes: volumes.clone(), pipeline, set })
    }
}

impl Pass for DynamicClearPass {
    fn name(&self) -> &str {
        "voxel clear dynamic"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        self.volumes.uses(Access::ComputeShaderWrite, Access::ComputeShaderReadStorage)
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        let n = self.volumes.grid.resolution;
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.dispatch(cmd, [n; 3], [4; 3]);
    }
}
