//! One light bounce in the voxels (compute): diffuse cones from every occupied voxel through
//! a radiance volume and its directional mips, added to the direct radiance and written to the
//! scratch volume; then a copy of the scratch volume into the bounced radiance (transfer).

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
    /// the scratch volume.
    pub fn new(ctx: &Arc<Context>, volumes: &Arc<VoxelVolumes>, source: &Arc<Image>) -> GpuResult<Self> {
        let target = &volumes.bounced[1];
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

/// Copies the bounce's scratch volume into the bounced radiance, which the next bounce, the
/// directional mips and the cones read.
pub struct BounceCopyPass {
    scratch: Arc<Image>,
    bounced: Arc<Image>,
}

impl BounceCopyPass {
    pub fn new(volumes: &VoxelVolumes) -> Self {
        BounceCopyPass { bounced: volumes.bounced[0].clone(), scratch: volumes.bounced[1].clone() }
    }
}

impl Pass for BounceCopyPass {
    fn name(&self) -> &str {
        "voxel bounce copy"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        vec![Use::image(&self.scratch, Access::TransferRead), Use::overwrite(&self.bounced, Access::TransferWrite)]
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let layers = vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        };
        let region =
            vk::ImageCopy::default().src_subresource(layers).dst_subresource(layers).extent(self.scratch.desc.extent);
        unsafe {
            ctx.device.cmd_copy_image(
                cmd,
                self.scratch.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                self.bounced.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            )
        };
    }
}
