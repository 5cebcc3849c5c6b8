//! The six directional (anisotropic) radiance volumes (compute): level 0 from a full-resolution
//! radiance volume, each further level from the one below, by front-to-back integration along
//! each direction (see glsl/aniso_mip.comp).

use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, Image, Pipeline};
use crate::render::graph::{Pass, QueueKind, Use};
use crate::render::voxel::VoxelVolumes;
use ash::vk;
use std::sync::Arc;

/// What every mip build shares: the pipelines and the sets of levels 1.. .
pub struct VoxelMips {
    directional: Vec<Arc<Image>>,
    from_full: Pipeline,
    from_previous: Pipeline,
    /// Set of level `i + 1`: reads level i, writes level i + 1.
    upper_sets: Vec<DescriptorSet>,
}

impl VoxelMips {
    pub fn new(ctx: &Arc<Context>, volumes: &VoxelVolumes) -> GpuResult<Arc<VoxelMips>> {
        let dir = &volumes.directional;
        let levels = dir[0].desc.mip_levels;
        let upper_sets = (1..levels)
            .map(|l| {
                DescriptorSet::new(
                    ctx,
                    &format!("voxel mips level {l}"),
                    vk::ShaderStageFlags::COMPUTE,
                    &[
                        Bind::StorageImageArray(dir.iter().map(|d| d.level_views[l as usize - 1]).collect()),
                        Bind::StorageImageArray(dir.iter().map(|d| d.level_views[l as usize]).collect()),
                    ],
                )
            })
            .collect::<GpuResult<Vec<_>>>()?;
        // Level 0's set has the same layout; build one to create the pipelines with.
        let probe = level0_set(ctx, volumes, &volumes.radiance)?;
        Ok(Arc::new(VoxelMips {
            from_full: Pipeline::compute(
                ctx,
                "voxel mips level 0",
                shaders::ANISO_MIP_COMP,
                &[probe.layout],
                0,
                &[(0, 1)],
            )?,
            from_previous: Pipeline::compute(
                ctx,
                "voxel mips",
                shaders::ANISO_MIP_COMP,
                &[probe.layout],
                0,
                &[(0, 0)],
            )?,
            directional: dir.clone(),
            upper_sets,
        }))
    }
}

fn level0_set(ctx: &Arc<Context>, volumes: &VoxelVolumes, source: &Image) -> GpuResult<DescriptorSet> {
    DescriptorSet::new(
        ctx,
        &format!("voxel mips from {}", source.name),
        vk::ShaderStageFlags::COMPUTE,
        &[
            Bind::StorageImageArray(vec![source.view; 6]),
            Bind::StorageImageArray(volumes.directional.iter().map(|d| d.level_views[0]).collect()),
        ],
    )
}

/// Builds the whole directional mip chain from one full-resolution radiance volume.
pub struct VoxelMipPass {
    name: String,
    mips: Arc<VoxelMips>,
    source: Arc<Image>,
    level0: DescriptorSet,
}

impl VoxelMipPass {
    pub fn new(
        ctx: &Arc<Context>,
        mips: &Arc<VoxelMips>,
        volumes: &VoxelVolumes,
        source: &Arc<Image>,
    ) -> GpuResult<Self> {
        Ok(VoxelMipPass {
            name: format!("voxel mips ({})", source.name),
            mips: mips.clone(),
            source: source.clone(),
            level0: level0_set(ctx, volumes, source)?,
        })
    }
}

impl Pass for VoxelMipPass {
    fn name(&self) -> &str {
        &self.name
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let mut uses = vec![Use::image(&self.source, Access::ComputeShaderReadStorage)];
        uses.extend(self.mips.directional.iter().map(|d| Use::overwrite(d, Access::ComputeShaderWrite)));
        uses
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let m = &self.mips;
        let size = |level: u32| m.directional[0].level_size(level);
        m.from_full.bind(cmd, &[self.level0.set]);
        m.from_full.dispatch(cmd, [size(0); 3], [4; 3]);
        // Each level reads the one written by the previous dispatch: the dependency comes from
        // the same access table as every other barrier (storage write -> storage write/read).
        for (i, set) in m.upper_sets.iter().enumerate() {
            let level = i as u32 + 1;
            super::memory_barrier(ctx, cmd, &[Access::ComputeShaderWrite], &[Access::ComputeShaderWrite]);
            m.from_previous.bind(cmd, &[set.set]);
            m.from_previous.dispatch(cmd, [size(level); 3], [4; 3]);
        }
    }
}
