//! One light bounce in the voxels (compute): diffuse cones from the occupied voxels (the work
//! list's entries, one in `gi.bounce_interleave` static voxels per feedback update) through a
//! radiance volume and its directional mips, the reflected light written to the scratch
//! volume; then the bounced radiance: direct plus that indirect light, per occupied voxel;
//! and in the first update, the geometric tail of the bounces it does not run (`gi.bounce_tail`).

use super::voxel_list::{dispatch_list, list_arguments, StaleZero};
use crate::gpu::{shaders, Access, Bind, Context, GpuResult, Image, Pipeline};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, QueueKind, Use};
use crate::render::sky::SkyGpu;
use crate::render::voxel::{work_list_header, TailBuffer, VoxelVolumes};
use crate::render::FrameBuffers;
use ash::vk;
use std::sync::Arc;

pub struct VoxelBouncePass {
    name: String,
    volumes: Arc<VoxelVolumes>,
    pipeline: Pipeline,
    set: PassSet,
}

impl VoxelBouncePass {
    /// The bounce that samples `source` (and the directional volumes built from it) and writes
    /// the indirect light into the scratch volume.
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        volumes: &Arc<VoxelVolumes>,
        source: &Arc<Image>,
        sky: &SkyGpu,
    ) -> GpuResult<Self> {
        let target = &volumes.bounced[1];
        let v = volumes;
        let name = format!("voxel bounce ({} -> {})", source.name, target.name);
        let (read, buffer) = (Access::ComputeShaderReadStorage, Access::ComputeShaderReadBuffer);
        let set = Binds::new()
            .loaded(Bind::Uniform(&v.grid_buffer))
            .loaded(Bind::Uniform(&v.bounce_params))
            .extend(v.cone_volumes(source))
            .storage_image(&v.albedo, read)
            .storage_image(&v.normal, read)
            .uniform(&frame.uniforms, buffer)
            // Voxels that do not gather this update keep their last indirect light.
            .storage_image(target, Access::ComputeShaderWrite)
            .storage(&v.list.buffer, buffer)
            .extend(v.brick_maps(read))
            .extend(v.pools())
            .extend(sky.cones_bind())
            .build(ctx, &name, vk::ShaderStageFlags::COMPUTE)?;
        let spirv = shaders::cone_variant(&ctx.info, shaders::VOXEL_BOUNCE_COMP, shaders::VOXEL_BOUNCE_COMP_UNROLLED);
        let pipeline = Pipeline::compute(ctx, "voxel bounce", spirv, &[set.layout()], 0, &[])?;
        Ok(VoxelBouncePass { name, volumes: volumes.clone(), pipeline, set })
    }
}

impl Pass for VoxelBouncePass {
    fn name(&self) -> &str {
        &self.name
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        vec![list_arguments(&self.volumes)]
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        dispatch_list(&self.pipeline, cmd, &self.volumes, work_list_header::OCCUPIED);
    }
}

/// What a compose step does for the first update's bounce tail (`gi.bounce_tail`;
/// glsl/voxel_bounce_compose.comp): nothing, record what its bounce added (per workgroup, for
/// the ratio), or add the geometric tail of the bounces not run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TailStep {
    None = 0,
    RecordFirst = 1,
    RecordSecond = 2,
    Extrapolate = 3,
}

/// The bounced radiance of every occupied voxel: its direct radiance plus the indirect light
/// in the scratch volume (stale voxels zeroed). The next bounce, the directional mips and the
/// cones read it. `step` says what it does for the bounce tail.
pub struct BounceComposePass {
    name: &'static str,
    volumes: Arc<VoxelVolumes>,
    pipeline: Pipeline,
    set: PassSet,
    stale: Option<StaleZero>,
    push: [u32; 2],
}

impl BounceComposePass {
    pub fn new(ctx: &Arc<Context>, volumes: &Arc<VoxelVolumes>, tail: &TailBuffer, step: TailStep) -> GpuResult<Self> {
        let v = volumes;
        let read = Access::ComputeShaderReadStorage;
        let name = match step {
            TailStep::None => "voxel bounce compose",
            TailStep::RecordFirst => "voxel bounce compose (tail: first record)",
            TailStep::RecordSecond => "voxel bounce compose (tail: second record)",
            TailStep::Extrapolate => "voxel bounce compose (tail: extrapolated)",
        };
        // Every step writes the bounced radiance (the tail's steps read what the last bounce
        // left there first); the extrapolation also writes the scratch; the records write the
        // tail buffer, which the extrapolation reads and the plain step leaves alone.
        let (write, buffer) = (Access::ComputeShaderWrite, Access::ComputeShaderReadBuffer);
        let scratch = if step == TailStep::Extrapolate { write } else { read };
        let records = if matches!(step, TailStep::RecordFirst | TailStep::RecordSecond) { write } else { buffer };
        let set = Binds::new()
            .storage(&v.list.buffer, buffer)
            .storage_image(&v.radiance, read)
            .storage_image(&v.bounced[1], scratch)
            .storage_image(&v.bounced[0], write)
            .loaded(Bind::Uniform(&v.grid_buffer))
            .extend(v.brick_maps(read))
            .storage(&tail.buffer, records)
            .build(ctx, name, vk::ShaderStageFlags::COMPUTE)?;
        let pipeline = Pipeline::compute(ctx, name, shaders::VOXEL_BOUNCE_COMPOSE_COMP, &[set.layout()], 8, &[])?;
        let stale = StaleZero::new(ctx, volumes, &volumes.bounced[0])?;
        Ok(BounceComposePass { name, volumes: volumes.clone(), pipeline, set, stale, push: [step as u32, tail.groups] })
    }
}

impl Pass for BounceComposePass {
    fn name(&self) -> &str {
        self.name
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
        self.pipeline.push(cmd, &self.push);
        dispatch_list(&self.pipeline, cmd, &self.volumes, work_list_header::OCCUPIED);
    }
}

/// The bounce tail's gain (glsl/voxel_bounce_tail.comp): the ratio of the two records' sums
/// over every voxel, per channel, and r / (1 - r), summed by one workgroup in a fixed order.
pub struct BounceTailPass {
    pipeline: Pipeline,
    set: PassSet,
    groups: u32,
}

impl BounceTailPass {
    pub fn new(ctx: &Arc<Context>, volumes: &VoxelVolumes, tail: &TailBuffer) -> GpuResult<Self> {
        let set = Binds::new()
            .storage(&volumes.list.buffer, Access::ComputeShaderReadBuffer)
            .storage(&tail.buffer, Access::ComputeShaderWrite)
            .build(ctx, "voxel bounce tail", vk::ShaderStageFlags::COMPUTE)?;
        let pipeline =
            Pipeline::compute(ctx, "voxel bounce tail", shaders::VOXEL_BOUNCE_TAIL_COMP, &[set.layout()], 4, &[])?;
        Ok(BounceTailPass { pipeline, set, groups: tail.groups })
    }
}

impl Pass for BounceTailPass {
    fn name(&self) -> &str {
        "voxel bounce tail"
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.push(cmd, &self.groups);
        self.pipeline.dispatch(cmd, [1, 1, 1], [1, 1, 1]);
    }
}
