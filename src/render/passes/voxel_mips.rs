//! The six directional (anisotropic) radiance volumes (compute): level 0 from a full-resolution
//! radiance volume, each further level from the one below, by front-to-back integration along
//! each direction (see glsl/aniso_mip.comp). With bricked volumes the levels larger than 64^3
//! are pools written over their resident bricks only (an indirect dispatch per level), each
//! followed by the pass that fills the bricks' aprons (glsl/brick_apron.comp); the coarser
//! levels are dense and built as before.

use crate::gpu::{shaders, Access, Bind, Context, GpuResult, Image, Pipeline};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, QueueKind, Use};
use crate::render::voxel::bricks::brick_list_header;
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
    set: Option<PassSet>,
    /// The apron fill after a pooled level.
    apron: Option<(Pipeline, PassSet)>,
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
        let probe = mip_set(ctx, v, "probe", source(&v.radiance), Level::Dense(0))?;
        let mut steps = Vec::new();
        for (i, &dst) in levels.iter().enumerate() {
            let src = (i > 0).then(|| levels[i - 1]);
            let pool = |l: Option<Level>| match l {
                Some(Level::Pooled(p)) => p as u32,
                _ => 0,
            };
            let name = format!("voxel mips level {i}");
            let spec = [
                (0, u32::from(src.is_none())),
                (1, pool(src)),
                (2, pool(Some(dst))),
                (3, u32::from(v.needs.two_tap)),
                (4, u32::from(v.needs.layers)),
                (5, u32::from(v.needs.sides)),
                (6, u32::from(v.needs.dark_backs)),
                (7, u32::from(v.needs.emission)),
                (8, u32::from(v.needs.closed_backs)),
            ];
            let pipeline = Pipeline::compute(ctx, &name, shaders::ANISO_MIP_COMP, &[probe.layout()], 0, &spec)?;
            let set = src.map(|s| mip_set(ctx, v, &name, level(v, s), dst)).transpose()?;
            let apron = match dst {
                Level::Pooled(p) => Some(apron_step(ctx, v, p)?),
                Level::Dense(_) => None,
            };
            steps.push(Step { dst, pipeline, set, apron });
        }
        Ok(Arc::new(VoxelMips { volumes: v.clone(), steps }))
    }

    /// The sets of the levels above 0 and of the aprons.
    fn sets(&self) -> impl Iterator<Item = &PassSet> {
        self.steps.iter().flat_map(|s| s.set.iter().chain(s.apron.iter().map(|(_, set)| set)))
    }

    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer, level0: &PassSet) {
        let v = &self.volumes;
        for (i, step) in self.steps.iter().enumerate() {
            // Each level reads the one written by the previous dispatch: the dependency comes
            // from the same access table as every other barrier.
            if i > 0 {
                super::memory_barrier(ctx, cmd, &[Access::ComputeShaderWrite], &[Access::ComputeShaderWrite]);
            }
            step.pipeline.bind(cmd, &[step.set.as_ref().unwrap_or(level0).raw()]);
            match step.dst {
                Level::Pooled(p) => {
                    let lists = &v.bricks.as_ref().expect("pooled levels have bricks").lists;
                    step.pipeline.dispatch_indirect(cmd, lists, brick_list_header::range(p));
                    let (apron, set) = step.apron.as_ref().expect("a pooled level has an apron step");
                    super::memory_barrier(ctx, cmd, &[Access::ComputeShaderWrite], &[Access::ComputeShaderWrite]);
                    apron.bind(cmd, &[set.raw()]);
                    apron.dispatch_indirect(cmd, lists, brick_list_header::range(p));
                }
                Level::Dense(l) => step.pipeline.dispatch(cmd, [v.directional[0].level_size(l); 3], [4; 3]),
            }
        }
    }
}

/// Level `l` of the six directional volumes as storage views, read and written by the chain:
/// a dense level is rewritten whole; a pooled level's resident bricks are (aprons too), the
/// rest stay empty.
fn level(v: &VoxelVolumes, l: Level) -> Binds<'_> {
    let write = Access::ComputeShaderWrite;
    match l {
        Level::Pooled(p) => Binds::new().storage_images(&v.bricks.as_ref().expect("bricks").directional[p - 1], write),
        Level::Dense(d) => Binds::new()
            .storage_views(v.directional.iter().map(|i| (i, i.level_views[d as usize])), write)
            .overwritten(),
    }
}

/// Level 0's source: one full-resolution radiance volume, bound six times.
fn source(volume: &Arc<Image>) -> Binds<'_> {
    Binds::new().storage_images([volume; 6], Access::ComputeShaderReadStorage)
}

/// The source (six views), the destination level, the grid, the brick maps and lists, the
/// normal volume (read by level 0 with `gi.voxel_cover = "directional"` or `gi.plane_backs =
/// "dark"`), the side factors (read by level 0 with `gi.attenuation = "per-side"`), the
/// emission (the albedo in its place where nothing emits; read by level 0 with `dark`) and the
/// closed backs (read by level 0 with `gi.plane_backs = "closed"`).
fn mip_set<'a>(ctx: &Arc<Context>, v: &'a VoxelVolumes, name: &str, src: Binds<'a>, dst: Level) -> GpuResult<PassSet> {
    // Without bricks the shader never reads the brick lists: the voxel list stands in.
    let lists = v.bricks.as_ref().map_or(&v.list.buffer, |b| &b.lists);
    src.extend(level(v, dst))
        .loaded(Bind::Uniform(&v.grid_buffer))
        .extend(v.brick_maps(Access::ComputeShaderReadStorage))
        .storage(lists, Access::ComputeShaderReadBuffer)
        .storage_image(&v.normal, Access::ComputeShaderReadStorage)
        .storage_image(v.sides_or_placeholder(), Access::ComputeShaderReadStorage)
        .storage_image(v.emission_or_albedo(), Access::ComputeShaderReadStorage)
        .storage_image(v.backs_or_placeholder(), Access::ComputeShaderReadStorage)
        .build(ctx, name, vk::ShaderStageFlags::COMPUTE)
}

/// The apron fill of pool p: pipeline and set.
fn apron_step(ctx: &Arc<Context>, v: &VoxelVolumes, p: usize) -> GpuResult<(Pipeline, PassSet)> {
    let b = v.bricks.as_ref().expect("bricks");
    let name = format!("voxel brick aprons (pool {p})");
    let set = level(v, Level::Pooled(p))
        .loaded(Bind::Uniform(&v.grid_buffer))
        .extend(v.brick_maps(Access::ComputeShaderReadStorage))
        .storage(&b.lists, Access::ComputeShaderReadBuffer)
        .build(ctx, &name, vk::ShaderStageFlags::COMPUTE)?;
    let pipeline = Pipeline::compute(ctx, &name, shaders::BRICK_APRON_COMP, &[set.layout()], 0, &[(0, p as u32)])?;
    Ok((pipeline, set))
}

/// Builds the whole directional mip chain from one full-resolution radiance volume.
pub struct VoxelMipPass {
    name: String,
    mips: Arc<VoxelMips>,
    level0: PassSet,
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
        Ok(VoxelMipPass { level0: mip_set(ctx, volumes, &name, self::source(source), dst)?, name, mips: mips.clone() })
    }
}

impl Pass for VoxelMipPass {
    fn name(&self) -> &str {
        &self.name
    }
    fn sets(&self) -> Vec<&PassSet> {
        std::iter::once(&self.level0).chain(self.mips.sets()).collect()
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        let b = self.mips.volumes.bricks.as_ref();
        b.map(|b| Use::buffer(&b.lists, Access::IndirectCommandRead)).into_iter().collect()
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        self.mips.record(ctx, cmd, &self.level0);
    }
}
