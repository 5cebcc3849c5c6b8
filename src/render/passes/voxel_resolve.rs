//! The voxelization's sums made averages (glsl/voxel_resolve.comp, glsl/scan.comp). After the
//! static voxelization the work list is built here, in grid order: each 8^3 brick counts its
//! occupied voxels, one workgroup turns the counts into offsets, and each brick writes its
//! voxels at its offset and resolves them; so the list, like the averages, is the same on every
//! run whatever order the fragments came in. After a dynamic voxelization the dynamic voxels
//! (appended by the voxelizer; their order decides nothing) are resolved over the list.

use super::voxel_list::{dispatch_list, list_arguments};
use crate::gpu::{shaders, Access, Bind, Context, GpuResult, Pipeline};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, Use};
use crate::render::voxel::{work_list_header, VoxelVolumes};
use ash::vk;
use std::sync::Arc;

/// The modes of glsl/voxel_resolve.comp.
#[derive(Clone, Copy)]
enum Mode {
    Count = 0,
    Write = 1,
    Resolve = 2,
}

/// glsl/scan.comp over the volumes' scan buffer: one workgroup turns a run of counts into
/// offsets in a fixed order.
pub struct Scan {
    pipeline: Pipeline,
    set: PassSet,
}

impl Scan {
    pub fn new(ctx: &Arc<Context>, volumes: &VoxelVolumes) -> GpuResult<Scan> {
        let set = Binds::new().storage(&volumes.scan, Access::ComputeShaderWrite).build(
            ctx,
            "voxel scan",
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let pipeline = Pipeline::compute(ctx, "voxel scan", shaders::SCAN_COMP, &[set.layout()], 12, &[])?;
        Ok(Scan { pipeline, set })
    }

    /// Its set: the passes that run it list it with their own.
    pub fn set(&self) -> &PassSet {
        &self.set
    }

    /// The `count` words from word `first` made exclusive prefix sums; their total into word
    /// `total_at`.
    pub fn record(&self, cmd: vk::CommandBuffer, first: u32, count: u32, total_at: u32) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.push(cmd, &[first, count, total_at]);
        self.pipeline.dispatch(cmd, [1; 3], [1; 3]);
    }
}

pub struct VoxelResolvePass {
    volumes: Arc<VoxelVolumes>,
    set: PassSet,
    /// Static: count, write; dynamic: resolve.
    pipelines: Vec<Pipeline>,
    /// Static only: the scan that turns the bricks' counts into list offsets.
    scan: Option<Arc<Scan>>,
}

impl VoxelResolvePass {
    /// After the static voxelization: builds the work list with `scan`.
    pub fn after_static(ctx: &Arc<Context>, volumes: &Arc<VoxelVolumes>, scan: &Arc<Scan>) -> GpuResult<Self> {
        VoxelResolvePass::new(ctx, volumes, Some(scan))
    }

    /// After the dynamic voxelization: over the list's dynamic range.
    pub fn after_dynamic(ctx: &Arc<Context>, volumes: &Arc<VoxelVolumes>) -> GpuResult<Self> {
        VoxelResolvePass::new(ctx, volumes, None)
    }

    fn new(ctx: &Arc<Context>, volumes: &Arc<VoxelVolumes>, scan: Option<&Arc<Scan>>) -> GpuResult<Self> {
        let v = volumes;
        let write = Access::ComputeShaderWrite;
        let binds = Binds::new()
            .loaded(Bind::Uniform(&v.grid_buffer))
            .extend(v.sums_bound(write))
            .storage_image(&v.albedo, write)
            .storage_image(&v.normal, write)
            .storage_image(v.emission_or_albedo(), write)
            .storage(&v.list.buffer, write);
        // Only the static steps count into the scan buffer.
        let binds = match scan {
            Some(_) => binds.storage(&v.scan, write),
            None => binds.idle(Bind::Storage(&v.scan)),
        };
        let set = binds
            .extend(v.brick_maps(Access::ComputeShaderReadStorage))
            .storage_image(v.side_normals_or_placeholder(), write)
            .build(ctx, "voxel resolve", vk::ShaderStageFlags::COMPUTE)?;
        let pipeline = |mode: Mode| {
            let spec = [(0, mode as u32), (1, u32::from(v.needs.emission)), (2, u32::from(v.needs.sides))];
            Pipeline::compute(ctx, "voxel resolve", shaders::VOXEL_RESOLVE_COMP, &[set.layout()], 0, &spec)
        };
        let pipelines = match scan {
            Some(_) => vec![pipeline(Mode::Count)?, pipeline(Mode::Write)?],
            None => vec![pipeline(Mode::Resolve)?],
        };
        Ok(VoxelResolvePass { volumes: volumes.clone(), set, pipelines, scan: scan.cloned() })
    }

    /// The static steps: count per brick, the scan over the bricks, write and resolve.
    fn record_static(&self, ctx: &Context, cmd: vk::CommandBuffer, scan: &Scan) {
        let bricks = self.volumes.grid.resolution.div_ceil(8);
        let bricks_total = crate::render::voxel::scan_bricks(self.volumes.grid.resolution) as u32;
        let between = |ctx: &Context| {
            let rw = [Access::ComputeShaderWrite];
            super::memory_barrier(ctx, cmd, &rw, &rw);
        };
        let [count, write] = &self.pipelines[..] else { unreachable!("two static steps") };
        count.bind(cmd, &[self.set.raw()]);
        count.dispatch(cmd, [bricks; 3], [1; 3]);
        between(ctx);
        // The counts after the header; their total into word 0.
        scan.record(cmd, crate::render::voxel::SCAN_VOXELS, bricks_total, 0);
        between(ctx);
        write.bind(cmd, &[self.set.raw()]);
        write.dispatch(cmd, [bricks; 3], [1; 3]);
    }
}

impl Pass for VoxelResolvePass {
    fn name(&self) -> &str {
        if self.scan.is_some() {
            "voxel resolve static"
        } else {
            "voxel resolve dynamic"
        }
    }
    fn sets(&self) -> Vec<&PassSet> {
        std::iter::once(&self.set).chain(self.scan.as_deref().map(Scan::set)).collect()
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        match &self.scan {
            Some(_) => Vec::new(),
            None => vec![list_arguments(&self.volumes)],
        }
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        match &self.scan {
            Some(scan) => self.record_static(ctx, cmd, scan),
            None => {
                self.pipelines[0].bind(cmd, &[self.set.raw()]);
                dispatch_list(&self.pipelines[0], cmd, &self.volumes, work_list_header::DYNAMIC);
            }
        }
    }
}
