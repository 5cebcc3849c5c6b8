//! One light bounce in the voxels (compute): diffuse cones from the occupied voxels (the work
//! list's entries, one in `gi.bounce_interleave` static voxels per feedback update) through a
//! radiance volume and its directional mips, the reflected light written to the scratch
//! volume; then the bounced radiance: direct plus that indirect light, per occupied voxel.

use super::voxel_list::{dispatch_list, list_reads, StaleZero};
use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, Image, Pipeline};
use crate::render::graph::{Pass, QueueKind, Use};
use crate::render::voxel::{list_header, VoxelVolumes};
use crate::render::FrameBuffers;
use ash::vk;
use std::sync::Arc;

pub struct VoxelBouncePass {
    name: String,
    frame: FrameBuffers,
    volumes: Arc<VoxelVolumes>,
    source: Arc<Image>,
    target: Arc<Image>,
    pipeline: Pipeline,
    set: DescriptorSet,
}

impl VoxelBouncePass {
    /// The bounce that samples `source` (and the directional volumes built from it) and writes
    /// the indirect light into the scratch volume.
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        volumes: &Arc<VoxelVolumes>,
        source: &Arc<Image>,
    ) -> GpuResult<Self> {
        let target = &volumes.bounced[1];
        let ro = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let v = volumes;
        let name = format!("voxel bounce ({} -> {})", source.name, target.name);
        let [pool_images, pool_sampler] = v.pool_binds();
        let set = DescriptorSet::new(
            ctx,
            &name,
            vk::ShaderStageFlags::COMPUTE,
            &[
                Bind::Uniform(&v.grid_buffer),
                Bind::Uniform(&v.bounce_params),
                Bind::Sampled(source.view, v.sampler.raw, ro),
                Bind::SampledArray(v.directional.iter().map(|d| d.view).collect(), v.sampler.raw, ro),
                Bind::StorageImage(v.albedo.view),
                Bind::StorageImage(v.normal.view),
                Bind::Uniform(&frame.uniforms),
                Bind::StorageImage(target.view),
                Bind::Storage(&v.list.buffer),
                v.brick_maps_bind(),
                pool_images,
                pool_sampler,
            ],
        )?;
        let pipeline = Pipeline::compute(ctx, "voxel bounce", shaders::VOXEL_BOUNCE_COMP, &[set.layout], 0, &[])?;
        Ok(VoxelBouncePass {
            name,
            frame: frame.clone(),
            volumes: volumes.clone(),
            source: source.clone(),
            target: target.clone(),
            pipeline,
            set,
        })
    }
}

impl Pass for VoxelBouncePass {
    fn name(&self) -> &str {
        &self.name
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let v = &self.volumes;
        let mut uses = vec![
            Use::image(&self.source, Access::ComputeShaderReadSampled),
            Use::image(&v.albedo, Access::ComputeShaderReadStorage),
            Use::image(&v.normal, Access::ComputeShaderReadStorage),
            // Voxels that do not gather this update keep their last indirect light.
            Use::image(&self.target, Access::ComputeShaderWrite),
            Use::buffer(&self.frame.uniforms, Access::ComputeShaderReadBuffer),
        ];
        uses.extend(v.directional.iter().map(|d| Use::image(d, Access::ComputeShaderReadSampled)));
        uses.extend(v.pool_uses());
        uses.extend(list_reads(v));
        uses
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.set]);
        dispatch_list(&self.pipeline, cmd, &self.volumes, list_header::OCCUPIED);
    }
}

/// The bounced radiance of every occupied voxel: its direct radiance plus the indirect light
/// in the scratch volume (stale voxels zeroed). The next bounce, the directional mips and the
/// cones read it.
pub struct BounceComposePass {
    volumes: Arc<VoxelVolumes>,
    pipeline: Pipeline,
    set: DescriptorSet,
    stale: Option<StaleZero>,
}

impl BounceComposePass {
    pub fn new(ctx: &Arc<Context>, volumes: &Arc<VoxelVolumes>) -> GpuResult<Self> {
        let v = volumes;
        let set = DescriptorSet::new(
            ctx,
            "voxel bounce compose",
            vk::ShaderStageFlags::COMPUTE,
            &[
                Bind::Storage(&v.list.buffer),
                Bind::StorageImage(v.radiance.view),
                Bind::StorageImage(v.bounced[1].view),
                Bind::StorageImage(v.bounced[0].view),
                Bind::Uniform(&v.grid_buffer),
                v.brick_maps_bind(),
            ],
        )?;
        let pipeline =
            Pipeline::compute(ctx, "voxel bounce compose", shaders::VOXEL_BOUNCE_COMPOSE_COMP, &[set.layout], 0, &[])?;
        let stale = StaleZero::new(ctx, volumes, &volumes.bounced[0])?;
        Ok(BounceComposePass { volumes: volumes.clone(), pipeline, set, stale })
    }
}

impl Pass for BounceComposePass {
    fn name(&self) -> &str {
        "voxel bounce compose"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let v = &self.volumes;
        let mut uses = vec![
            Use::image(&v.radiance, Access::ComputeShaderReadStorage),
            Use::image(&v.bounced[1], Access::ComputeShaderReadStorage),
            Use::image(&v.bounced[0], Access::ComputeShaderWrite),
        ];
        uses.extend(list_reads(v));
        if let Some(stale) = &self.stale {
            uses.push(Use::image(&v.albedo, Access::ComputeShaderReadStorage));
            uses.extend(stale.uses(v));
        }
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
        dispatch_list(&self.pipeline, cmd, &self.volumes, list_header::OCCUPIED);
    }
}
