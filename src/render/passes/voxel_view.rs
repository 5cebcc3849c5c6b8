//! Debug view (`--view voxel-albedo|voxel-normal|voxel-emission`): ray-marches the voxel
//! volume from the camera into the radiance image, in place of the lighting pass.

use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, Image, Pipeline};
use crate::render::graph::{Pass, Use};
use crate::render::voxel::VoxelVolumes;
use crate::render::FrameBuffers;
use crate::scene::{View, ViewDirection};
use ash::vk;
use std::sync::Arc;

pub struct VoxelViewPass {
    frame: FrameBuffers,
    volumes: Arc<VoxelVolumes>,
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
                Bind::StorageImage(volumes.final_radiance().view),
                volumes.brick_maps_bind(),
            ],
        )?;
        let pipeline = Pipeline::compute(ctx, "voxel view", shaders::VOXEL_VIEW_COMP, &[set.layout], 0, &[(0, mode)])?;
        Ok(VoxelViewPass {
            frame: frame.clone(),
            volumes: volumes.clone(),
            volume: volume.clone(),
            voxel_radiance: volumes.final_radiance().clone(),
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
        let mut uses = vec![
            Use::image(&self.volume, Access::ComputeShaderReadStorage),
            Use::image(&self.voxel_radiance, Access::ComputeShaderReadStorage),
            Use::overwrite(&self.radiance, Access::ComputeShaderWrite),
        ];
        uses.extend(self.frame.reads(Access::ComputeShaderReadBuffer));
        uses.extend(self.volumes.brick_map_uses(Access::ComputeShaderReadStorage));
        uses
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.dispatch_pixels(cmd, &self.radiance);
    }
}

/// Debug view (`--view voxel-mip`): the radiance volumes as the cone tracer samples them, at a
/// fixed level of detail and direction, composited along each camera ray.
pub struct VoxelMipViewPass {
    frame: FrameBuffers,
    volumes: Arc<VoxelVolumes>,
    lod0: Arc<Image>,
    lod: f32,
    pub radiance: Arc<Image>,
    pipeline: Pipeline,
    set: DescriptorSet,
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
        let ro = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let v = volumes;
        let lod0 = v.final_radiance().clone();
        let [pool_images, pool_sampler] = v.pool_binds();
        let set = DescriptorSet::new(
            ctx,
            "voxel mip view",
            vk::ShaderStageFlags::COMPUTE,
            &[
                Bind::Uniform(&frame.uniforms),
                Bind::Uniform(&v.grid_buffer),
                Bind::Uniform(&v.gi_params),
                Bind::Sampled(lod0.view, v.sampler.raw, ro),
                Bind::SampledArray(v.directional.iter().map(|d| d.view).collect(), v.sampler.raw, ro),
                Bind::StorageImage(radiance.view),
                v.brick_maps_bind(),
                pool_images,
                pool_sampler,
            ],
        )?;
        let dir = match direction {
            ViewDirection::Ray => 0,
            ViewDirection::PosX => 1,
            ViewDirection::NegX => 2,
            ViewDirection::PosY => 3,
            ViewDirection::NegY => 4,
            ViewDirection::PosZ => 5,
            ViewDirection::NegZ => 6,
        };
        let pipeline =
            Pipeline::compute(ctx, "voxel mip view", shaders::VOXEL_MIP_VIEW_COMP, &[set.layout], 4, &[(0, dir)])?;
        Ok(VoxelMipViewPass {
            frame: frame.clone(),
            volumes: volumes.clone(),
            lod0,
            lod,
            radiance: radiance.clone(),
            pipeline,
            set,
        })
    }
}

impl Pass for VoxelMipViewPass {
    fn name(&self) -> &str {
        "voxel mip view"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let mut uses = vec![
            Use::image(&self.lod0, Access::ComputeShaderReadSampled),
            Use::overwrite(&self.radiance, Access::ComputeShaderWrite),
        ];
        uses.extend(self.volumes.directional.iter().map(|d| Use::image(d, Access::ComputeShaderReadSampled)));
        uses.extend(self.volumes.pool_uses());
        uses.extend(self.volumes.brick_map_uses(Access::ComputeShaderReadStorage));
        uses.extend(self.frame.reads(Access::ComputeShaderReadBuffer));
        uses
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        let e = self.radiance.extent2d();
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.push(cmd, &self.lod);
        self.pipeline.dispatch(cmd, [e.width, e.height, 1], [8, 8, 1]);
    }
}
