//! Voxel illumination (compute): direct light (and emission) into the voxel radiance volume.

use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, Image, Pipeline, Sampler};
use crate::render::graph::{Pass, QueueKind, Use};
use crate::render::voxel::VoxelVolumes;
use crate::render::FrameBuffers;
use crate::scene::{GiSettings, VoxelAttenuation, VoxelOcclusion};
use ash::vk;
use std::sync::Arc;

pub struct VoxelLightPass {
    frame: FrameBuffers,
    volumes: Arc<VoxelVolumes>,
    shadow_atlas: Arc<Image>,
    pipeline: Pipeline,
    set: DescriptorSet,
    softness: f32,
    _sampler: Sampler,
}

impl VoxelLightPass {
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        volumes: &Arc<VoxelVolumes>,
        shadow_atlas: &Arc<Image>,
        gi: &GiSettings,
    ) -> GpuResult<Self> {
        let sampler = Sampler::new(ctx, "voxel shadow compare sampler", &super::lighting::shadow_sampler_info())?;
        let set = DescriptorSet::new(
            ctx,
            "voxel light",
            vk::ShaderStageFlags::COMPUTE,
            &[
                Bind::Uniform(&frame.uniforms),
                Bind::Storage(&frame.lights),
                Bind::Storage(&frame.shadow_views),
                Bind::Sampled(shadow_atlas.view, sampler.raw, vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL),
                Bind::Uniform(&volumes.grid_buffer),
                Bind::StorageImage(volumes.albedo.view),
                Bind::StorageImage(volumes.normal.view),
                Bind::StorageImage(volumes.emission_or_albedo().view),
                Bind::StorageImage(volumes.radiance.view),
            ],
        )?;
        let pipeline = Pipeline::compute(
            ctx,
            "voxel light",
            shaders::VOXEL_LIGHT_COMP,
            &[set.layout],
            4,
            &[
                (0, u32::from(volumes.needs.emission)),
                (1, u32::from(gi.attenuation == VoxelAttenuation::NormalWeighted)),
                (2, u32::from(gi.occlusion == VoxelOcclusion::Raymarch)),
            ],
        )?;
        Ok(VoxelLightPass {
            frame: frame.clone(),
            volumes: volumes.clone(),
            shadow_atlas: shadow_atlas.clone(),
            pipeline,
            set,
            softness: gi.voxel_shadow_softness,
            _sampler: sampler,
        })
    }
}

impl Pass for VoxelLightPass {
    fn name(&self) -> &str {
        "voxel light"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let v = &self.volumes;
        let mut uses = vec![
            Use::image(&v.albedo, Access::ComputeShaderReadStorage),
            Use::image(&v.normal, Access::ComputeShaderReadStorage),
            Use::image(&self.shadow_atlas, Access::ComputeShaderReadDepth),
            Use::overwrite(&v.radiance, Access::ComputeShaderWrite),
        ];
        uses.extend(v.emission.as_ref().map(|e| Use::image(e, Access::ComputeShaderReadStorage)));
        uses.extend(self.frame.reads(Access::ComputeShaderReadBuffer));
        uses
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        let n = self.volumes.grid.resolution;
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.push(cmd, &self.softness);
        self.pipeline.dispatch(cmd, [n; 3], [4; 3]);
    }
}
