//! Voxel illumination (compute): direct light (and emission) into the voxel radiance volume,
//! at the occupied voxels of the work list (and zeroes at the stale ones, see voxel_list).

use super::voxel_list::{dispatch_list, list_arguments, StaleZero};
use crate::gpu::{shaders, Access, Bind, Context, GpuResult, Image, Pipeline, Sampler};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, QueueKind, Use};
use crate::render::voxel::{work_list_header, VoxelVolumes};
use crate::render::FrameBuffers;
use crate::scene::{GiSettings, VoxelAttenuation, VoxelOcclusion};
use ash::vk;
use std::sync::Arc;

pub struct VoxelLightPass {
    volumes: Arc<VoxelVolumes>,
    pipeline: Pipeline,
    set: PassSet,
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
        let (read, write) = (Access::ComputeShaderReadStorage, Access::ComputeShaderWrite);
        let buffer = Access::ComputeShaderReadBuffer;
        let set = Binds::new()
            .uniform(&frame.uniforms, buffer)
            .storage(&frame.lights, buffer)
            .storage(&frame.shadow_views, buffer)
            .sampled(shadow_atlas, sampler.raw, Access::ComputeShaderReadDepth)
            .loaded(Bind::Uniform(&volumes.grid_buffer))
            .storage_image(&volumes.albedo, read)
            .storage_image(&volumes.normal, read)
            .storage_image(volumes.emission_or_albedo(), read)
            // Only occupied (and stale) voxels are written: the rest keep their zero.
            .storage_image(&volumes.radiance, write)
            .storage(&volumes.list.buffer, buffer)
            .extend(volumes.brick_maps(read))
            // gi.attenuation = "per-side": each occupied voxel's side factors (else a placeholder).
            .storage_image(volumes.sides_or_placeholder(), write)
            // ... from the normals seen from each side (the resolve's).
            .storage_image(volumes.side_normals_or_placeholder(), read)
            .build(ctx, "voxel light", vk::ShaderStageFlags::COMPUTE)?;
        let pipeline = Pipeline::compute(
            ctx,
            "voxel light",
            shaders::VOXEL_LIGHT_COMP,
            &[set.layout()],
            4,
            &[
                (0, u32::from(volumes.needs.emission)),
                (1, u32::from(gi.attenuation == VoxelAttenuation::NormalWeighted)),
                (2, u32::from(gi.occlusion == VoxelOcclusion::Raymarch)),
                (3, u32::from(volumes.needs.sides)),
            ],
        )?;
        Ok(VoxelLightPass {
            volumes: volumes.clone(),
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
    fn sets(&self) -> Vec<&PassSet> {
        std::iter::once(&self.set).chain(self.stale.as_ref().map(StaleZero::set)).collect()
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        vec![list_arguments(&self.volumes)]
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        if let Some(stale) = &self.stale {
            stale.record(ctx, cmd, &self.volumes);
        }
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.push(cmd, &self.softness);
        dispatch_list(&self.pipeline, cmd, &self.volumes, work_list_header::OCCUPIED);
    }
}
