//! One light bounce in the voxels (compute): diffuse cones from every occupied voxel through
//! the current radiance and its directional mips, added to the direct radiance.

use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, Image, Pipeline};
use crate::render::graph::{Pass, QueueKind, Use};
use crate::render::voxel::VoxelVolumes;
use ash::vk;
use std::sync::Arc;

pub struct VoxelBouncePass {
    name: String,
    volumes: Arc<VoxelVolumes>,
    source: Arc<Image>,
    target: Arc<Image>,
    pipeline: Pipeline,
    set: DescriptorSet,
}

impl VoxelBouncePass {
    /// The bounce that samples `source` (and the directional volumes built from it) and writes
    /// `target`.
    pub fn new(
        ctx: &Arc<Context>,
        volumes: &Arc<VoxelVolumes>,
        source: &Arc<Image>,
        target: &Arc<Image>,
    ) -> GpuResult<Self> {
        let ro = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let v = volumes;
        let name = format!("voxel bounce ({} -> {})", source.name, target.name);
        let set = DescriptorSet::new(
            ctx,
            &name,
            vk::ShaderStageFlags::COMPUTE,
            &[
                Bind::Uniform(&v.grid_buffer),
                Bind::Uniform(&v.gi_params),
                Bind::Sampled(source.view, v.sampler.raw, ro),
                Bind::SampledArray(v.directional.iter().map(|d| d.view).collect(), v.sampler.raw, ro),
                Bind::StorageImage(v.albedo.view),
                Bind::StorageImage(v.normal.view),
                Bind::Sampled(v.radiance.view, v.sampler.raw, ro),
                Bind::StorageImage(target.view),
            ],
        )?;
        let pipeline = Pipeline::compute(ctx, "voxel bounce", shaders::VOXEL_BOUNCE_COMP, &[set.layout], 0, &[])?;
        Ok(VoxelBouncePass {
            name,
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
            Use::image(&v.radiance, Access::ComputeShaderReadSampled),
            Use::image(&v.albedo, Access::ComputeShaderReadStorage),
            Use::image(&v.normal, Access::ComputeShaderReadStorage),
            Use::overwrite(&self.target, Access::ComputeShaderWrite),
        ];
        uses.extend(v.directional.iter().map(|d| Use::image(d, Access::ComputeShaderReadSampled)));
        uses
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        let n = self.volumes.grid.resolution;
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.dispatch(cmd, [n; 3], [4; 3]);
    }
}
