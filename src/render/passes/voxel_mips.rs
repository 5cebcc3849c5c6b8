//! The six directional (anisotropic) radiance volumes (compute): level 0 from a full-resolution
//! radiance volume, each further level from the one below, by front-to-back integration along
//! each direction (see glsl/aniso_mip.comp). With bricked volumes the levels larger than 64^3
//! are pools written over their resident bricks only (an indirect dispatch per level), each
//! followed by the pass that fills the bricks' aprons (glsl/brick_apron.comp); the coarser
//! levels are dense and built as before.

use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, Image, Pipeline};
use crate::render::bricks::list_header;
use crate::render::graph::{Pass, QueueKind, Use};
use crate::render::voxel::VoxelVolumes;
use ash::vk;
use std::sync::Arc;

/// Where one level of the chain is stored.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Level {
    /// Pool p (1..): a pooled directional level.
    Pooled(usize),
    /// Level l of the dense directional images.
    Dense(u32),
}

/// One step of the chain: the level written, from the level below (None: the
/// full-resolution volume), with its pipeline and (for the steps above level 0) its set.
struct Step {
    dst: Level,
    pipeline: Pipeline,
    /// None for level 0, whose set names the source volume (one per mip pass).
    set: Option<DescriptorSet>,
    /// The apron fill after a pooled level.
    apron: Option<(Pipeline, DescriptorSet)>,
}

/// What every mip build shares: the pipelines and the sets of levels 1.. .
pub struct VoxelMips {
    volumes: Arc<VoxelVolumes>,
    steps: Vec<Step>,
}

impl VoxelMips {
    pub fn new(ctx: &Arc<Context>, volumes: &Arc<VoxelVolumes>) -> GpuResult<Arc<VoxelMips>> {
        let v = volumes;
        let pooled = v.bricks.as_ref().map_or(0, |b| b.directional.len());
        let dense_levels = v.directional[0].desc.mip_levels;
        let levels: Vec<Level> = (1..=pooled).map(Level::Pooled).chain((0..dense_levels).map(Level::Dense)).collect();
        let probe = mip_set(ctx, v, "probe", &[v.radiance.view; 6], Level::Dense(0))?;
        let mut steps = Vec::new();
        for (i, &dst) in levels.iter().enumerate() {
            let src = (i > 0).then(|| levels[i - 1]);
            let pool = |l: Option<Level>| match l {
                Some(Level::Pooled(p)) => p as u32,
                _ => 0,
            };
            let name = format!("voxel mips level {i}");
            let spec = [(0, u32::from(src.is_none())), (1, pool(src)), (2, pool(Some(dst)))];
            let pipeline = Pipeline::compute(ctx, &name, shaders::ANISO_MIP_COMP, &[probe.layout], 0, &spec)?;
            let set = src.map(|s| mip_set(ctx, v, &name, &level_views(v, s), dst)).transpose()?;
            let apron = match dst {
                Level::Pooled(p) => Some(apron_step(ctx, v, p)?),
                Level::Dense(_) => None,
            };
            steps.push(Step { dst, pipeline, set, apron });
        }
        Ok(Arc::new(VoxelMips { volumes: v.clone(), steps }))
    }

    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer, level0: &DescriptorSet) {
        let v = &self.volumes;
        for (i, step) in self.steps.iter().enumerate() {
            // Each level reads the one written by the previous dispatch: the dependency comes
            // from the same access table as every other barrier.
            if i > 0 {
                super::memory_barrier(ctx, cmd, &[Access::ComputeShaderWrite], &[Access::ComputeShaderWrite]);
            }
            step.pipeline.bind(cmd, &[step.set.as_ref().unwrap_or(level0).set]);
            match step.dst {
                Level::Pooled(p) => {
                    let lists = &v.bricks.as_ref().expect("pooled levels have bricks").lists;
                    step.pipeline.dispatch_indirect(cmd, lists, list_header::range(p));
                    let (apron, set) = step.apron.as_ref().expect("a pooled level has an apron step");
                    super::memory_barrier(ctx, cmd, &[Access::ComputeShaderWrite], &[Access::ComputeShaderWrite]);
                    apron.bind(cmd, &[set.set]);
                    apron.dispatch_indirect(cmd, lists, list_header::range(p));
                }
                Level::Dense(l) => step.pipeline.dispatch(cmd, [v.directional[0].level_size(l); 3], [4; 3]),
            }
        }
    }
}

/// The views of level `l` of the six directional volumes.
fn level_views(v: &VoxelVolumes, l: Level) -> Vec<vk::ImageView> {
    match l {
        Level::Pooled(p) => v.bricks.as_ref().expect("bricks").directional[p - 1].iter().map(|i| i.view).collect(),
        Level::Dense(d) => v.directional.iter().map(|i| i.level_views[d as usize]).collect(),
    }
}

/// Source views (six), the destination level, the grid, the brick maps and lists.
fn mip_set(
    ctx: &Arc<Context>,
    v: &VoxelVolumes,
    name: &str,
    src: &[vk::ImageView],
    dst: Level,
) -> GpuResult<DescriptorSet> {
    // Without bricks the shader never reads the brick lists: the voxel list stands in.
    let lists = v.bricks.as_ref().map_or(&*v.list.buffer, |b| &*b.lists);
    DescriptorSet::new(
        ctx,
        name,
        vk::ShaderStageFlags::COMPUTE,
        &[
            Bind::StorageImageArray(src.to_vec()),
            Bind::StorageImageArray(level_views(v, dst)),
            Bind::Uniform(&v.grid_buffer),
            v.brick_maps_bind(),
            Bind::Storage(lists),
        ],
    )
}

/// The apron fill of pool p: pipeline and set.
fn apron_step(ctx: &Arc<Context>, v: &VoxelVolumes, p: usize) -> GpuResult<(Pipeline, DescriptorSet)> {
    let b = v.bricks.as_ref().expect("bricks");
    let name = format!("voxel brick aprons (pool {p})");
    let set = DescriptorSet::new(
        ctx,
        &name,
        vk::ShaderStageFlags::COMPUTE,
        &[
            Bind::StorageImageArray(level_views(v, Level::Pooled(p))),
            Bind::Uniform(&v.grid_buffer),
            v.brick_maps_bind(),
            Bind::Storage(&b.lists),
        ],
    )?;
    let pipeline = Pipeline::compute(ctx, &name, shaders::BRICK_APRON_COMP, &[set.layout], 0, &[(0, p as u32)])?;
    Ok((pipeline, set))
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
        let name = format!("voxel mips ({})", source.name);
        let dst = mips.steps[0].dst;
        Ok(VoxelMipPass {
            level0: mip_set(ctx, volumes, &name, &[source.view; 6], dst)?,
            name,
            mips: mips.clone(),
            source: source.clone(),
        })
    }
}

impl Pass for VoxelMipPass {
    fn name(&self) -> &str {
        &self.name
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let v = &self.mips.volumes;
        let mut uses = vec![Use::image(&self.source, Access::ComputeShaderReadStorage)];
        uses.extend(v.directional.iter().map(|d| Use::overwrite(d, Access::ComputeShaderWrite)));
        if let Some(b) = &v.bricks {
            // Resident bricks are rewritten whole (aprons too); the rest stay empty.
            uses.extend(b.directional.iter().flatten().map(|d| Use::image(d, Access::ComputeShaderWrite)));
            uses.push(Use::buffer(&b.lists, Access::IndirectCommandRead));
            uses.push(Use::buffer(&b.lists, Access::ComputeShaderReadBuffer));
        } else {
            uses.push(Use::buffer(&v.list.buffer, Access::ComputeShaderReadBuffer));
            // bound, unread
        }
        uses.extend(v.brick_map_uses(Access::ComputeShaderReadStorage));
        uses
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        self.mips.record(ctx, cmd, &self.level0);
    }
}
