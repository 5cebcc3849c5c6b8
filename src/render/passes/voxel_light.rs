//! Voxel illumination (compute): direct light (and emission) into the voxel radiance volume,
//! at the occupied voxels of the work list (and zeroes at the stale ones, see voxel_list).

use super::voxel_list::{dispatch_list, list_reads, StaleZero};
use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, Image, Pipeline, Sampler};
use crate::render::graph::{Pass, QueueKind, Use};
use crate::render::voxel::{list_header, VoxelVolumes};
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
    stale: Option<StaleZero>,
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
                Bind::Storage(&volumes.list.buffer),
                volumes.brick_maps_bind(),
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
            stale: StaleZero::new(ctx, volumes, &volumes.radiance)?,
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
            // Only occupied (and stale) voxels are written: the rest keep their zero.
            Use::image(&v.radiance, Access::ComputeShaderWrite),
        ];
        uses.extend(v.emission.as_ref().map(|e| Use::image(e, Access::ComputeShaderReadStorage)));
        uses.extend(self.frame.reads(Access::ComputeShaderReadBuffer));
        uses.extend(list_reads(v));
        uses.extend(self.stale.iter().flat_map(|s| s.uses(v)));
        uses
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        if let Some(stale) = &self.stale {
            stale.record(ctx, cmd, &self.volumes);
        }
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.push(cmd, &self.softness);
        dispatch_list(&self.pipeline, cmd, &self.volumes, list_header::OCCUPIED);
    }
}
