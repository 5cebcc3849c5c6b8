//! Debug view (`--view voxel-albedo|voxel-normal|voxel-emission`): ray-marches the voxel
//! volume from the camera into the radiance image, in place of the lighting pass.

use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, Image, Pipeline};
use crate::render::graph::{Pass, Use};
use crate::render::voxel::VoxelVolumes;
use crate::render::FrameBuffers;
use crate::scene::View;
use ash::vk;
use std::sync::Arc;

pub struct VoxelViewPass {
    volume: Arc<Image>,
    voxel_radiance: Arc<Image>,
    view: View,
    pub radiance: Arc<Image>,
    pipeline: Pipeline,
    set: DescriptorSet,
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
        let set = DescriptorSet::new(
            ctx,
            "voxel view",
            vk::ShaderStageFlags::COMPUTE,
            &[
                Bind::Uniform(&frame.uniforms),
                Bind::Uniform(&volumes.grid_buffer),
                Bind::StorageImage(volume.view),
                Bind::StorageImage(radiance.view),
                Bind::StorageImage(volumes.radiance.view),
            ],
        )?;
        let pipeline = Pipeline::compute(ctx, "voxel view", shaders::VOXEL_VIEW_COMP, &[set.layout], 0, &[(0, mode)])?;
        Ok(VoxelViewPass {
            volume: volume.clone(),
            voxel_radiance: volumes.radiance.clone(),
            view,
            radiance: radiance.clone(),
            pipeline,
            set,
        })
    }
}

impl VoxelViewPass {
    /// The view shows lit voxels (the voxel lighting must run first).
    pub fn shows_radiance(&self) -> bool {
        self.view == View::VoxelRadiance
    }
}

impl Pass for VoxelViewPass {
    fn name(&self) -> &str {
        "voxel view"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        vec![
            Use::image(&self.volume, Access::ComputeShaderReadStorage),
            Use::image(&self.voxel_radiance, Access::ComputeShaderReadStorage),
            Use::overwrite(&self.radiance, Access::ComputeShaderWrite),
        ]
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        let e = self.radiance.extent2d();
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.dispatch(cmd, [e.width, e.height, 1], [8, 8, 1]);
    }
}
