//! Debug view (`--view voxel-albedo|voxel-normal|voxel-emission`): ray-marches the voxel
//! volume from the camera into the radiance image, in place of the lighting pass.

use crate::gpu::{shaders, Access, Bind, Context, GpuResult, Image, Pipeline};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, QueueKind};
use crate::render::voxel::VoxelVolumes;
use crate::render::FrameBuffers;
use crate::scene::{View, ViewDirection};
use ash::vk;
use std::sync::Arc;

pub struct VoxelViewPass {
    view: View,
    pub radiance: Arc<Image>,
    pipeline: Pipeline,
    set: PassSet,
}

impl VoxelViewPass {
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        volumes: &Arc<VoxelVolumes>,
        view: View,
        radiance: &Arc<Image>,
    ) -> GpuResult<Self> {
        let (volume, mode) = match view {
            View::VoxelNormal => (&volumes.normal, 1),
            View::VoxelRadiance => (&volumes.albedo, 4),
            View::VoxelEmission => (volumes.emission_or_albedo(), 2),
            _ => (&volumes.albedo, 0),
        };
        // Without emissive materials there is no emission volume: show black, not albedo.
        let mode = if view == View::VoxelEmission && volumes.emission.is_none() { 3 } else { mode };
        let read = Access::ComputeShaderReadStorage;
        let set = Binds::new()
            .uniform(&frame.uniforms, Access::ComputeShaderReadBuffer)
            .loaded(Bind::Uniform(&volumes.grid_buffer))
            .storage_image(volume, read)
            .storage_image(radiance, Access::ComputeShaderWrite)
            .overwritten()
            .storage_image(volumes.final_radiance(), read)
            .extend(volumes.brick_maps(read))
            .build(ctx, "voxel view", vk::ShaderStageFlags::COMPUTE)?;
        let pipeline =
            Pipeline::compute(ctx, "voxel view", shaders::VOXEL_VIEW_COMP, &[set.layout()], 0, &[(0, mode)])?;
        Ok(VoxelViewPass { view, radiance: radiance.clone(), pipeline, set })
    }
}

impl VoxelViewPass {
    /// The view shows lit voxels (the voxel lighting must run first).
    pub fn shows_radiance(&self) -> bool {
        self.view == View::VoxelRadiance
    }
}

impl Pass for VoxelViewPass {
    fn pipelined_queue(&self) -> QueueKind {
        QueueKind::Compute
    }

    fn name(&self) -> &str {
        "voxel view"
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.dispatch_pixels(cmd, &self.radiance);
    }
}

/// Debug view (`--view voxel-mip`): the radiance volumes as the cone tracer samples them, at a
/// fixed level of detail and direction, composited along each camera ray.
pub struct VoxelMipViewPass {
    lod: f32,
    pub radiance: Arc<Image>,
    pipeline: Pipeline,
    set: PassSet,
}

impl VoxelMipViewPass {
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        volumes: &Arc<VoxelVolumes>,
        lod: f32,
        direction: ViewDirection,
        radiance: &Arc<Image>,
    ) -> GpuResult<Self> {
        let v = volumes;
        let set = Binds::new()
            .uniform(&frame.uniforms, Access::ComputeShaderReadBuffer)
            .loaded(Bind::Uniform(&v.grid_buffer))
            .loaded(Bind::Uniform(&v.gi_params))
            .extend(v.cone_volumes(v.final_radiance()))
            .storage_image(radiance, Access::ComputeShaderWrite)
            .overwritten()
            .extend(v.brick_maps(Access::ComputeShaderReadStorage))
            .extend(v.pools())
            .build(ctx, "voxel mip view", vk::ShaderStageFlags::COMPUTE)?;
        let dir = match direction {
            ViewDirection::Ray => 0,
            ViewDirection::PosX => 1,
            ViewDirection::NegX => 2,
            ViewDirection::PosY => 3,
            ViewDirection::NegY => 4,
            ViewDirection::PosZ => 5,
            ViewDirection::NegZ => 6,
        };
        let mip_view =
            shaders::cone_variant(&ctx.info, shaders::VOXEL_MIP_VIEW_COMP, shaders::VOXEL_MIP_VIEW_COMP_UNROLLED);
        let pipeline = Pipeline::compute(ctx, "voxel mip view", mip_view, &[set.layout()], 4, &[(0, dir)])?;
        Ok(VoxelMipViewPass { lod, radiance: radiance.clone(), pipeline, set })
    }
}

impl Pass for VoxelMipViewPass {
    fn pipelined_queue(&self) -> QueueKind {
        QueueKind::Compute
    }

    fn name(&self) -> &str {
        "voxel mip view"
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        let e = self.radiance.extent2d();
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.push(cmd, &self.lod);
        self.pipeline.dispatch(cmd, [e.width, e.height, 1], [8, 8, 1]);
    }
}
