//! Brick residency (compute, glsl/brick_alloc.comp and brick_clear.comp). After the marking run
//! of voxelization, every pending brick of each pool gets a slot and joins the pool's list of
//! resident bricks, and each pool's indirect dispatches are written. Static bricks keep their
//! slots; before each dynamic revoxelization the dynamic bricks are released (they read as
//! empty unless the marking run claims them again), the allocation hands their slots out anew
//! and the slots are emptied, so the resident set follows moving objects without a host wait.
//! The pools are sized for the static bricks plus what the moving objects can touch at once
//! (render::voxel::capacity).

use super::voxel_resolve::Scan;
use crate::gpu::{shaders, Access, Bind, Context, GpuResult, Pipeline};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, Use};
use crate::render::voxel::{ScanLayout, VoxelVolumes, SCAN_POOL_TOTAL};
use ash::vk;
use std::sync::Arc;

/// The modes of glsl/brick_alloc.comp.
#[derive(Clone, Copy)]
enum Mode {
    Allocate = 0,
    Finalize = 1,
    Release = 2,
    Restart = 3,
    Count = 4,
}

/// A brick_alloc.comp pipeline for `pool` in `mode` (`after_static`: the finalize step after
/// the static voxelization, which records the static bricks).
fn alloc_pipeline(
    ctx: &Arc<Context>,
    set: &PassSet,
    pool: u32,
    mode: Mode,
    (after_static, scan_first): (bool, u32),
) -> GpuResult<Pipeline> {
    let name = match mode {
        Mode::Count => format!("voxel brick count {pool}"),
        Mode::Allocate => format!("voxel brick allocation {pool}"),
        Mode::Finalize => "voxel brick lists".to_string(),
        Mode::Release => format!("voxel brick release {pool}"),
        Mode::Restart => "voxel brick restart".to_string(),
    };
    let spec = [(0, pool), (1, mode as u32), (2, u32::from(after_static)), (3, scan_first)];
    Pipeline::compute(ctx, &name, shaders::BRICK_ALLOC_COMP, &[set.layout()], 0, &spec)
}

/// A step of brick_alloc.comp over the maps and lists: one dispatch per pool over its map
/// (`per_pool`), a barrier, then one invocation (`then`). Allocation: count the pending bricks
/// of each block of the map, scan the counts, allocate in grid order, then write the
/// dispatches (`BrickListPass::allocate`); release: release, then restart the lists
/// (`BrickListPass::release`).
pub struct BrickListPass {
    volumes: Arc<VoxelVolumes>,
    per_pool: Vec<Pipeline>,
    then: Pipeline,
    set: PassSet,
    name: &'static str,
    /// Allocation only: the counting before it.
    counting: Option<Counting>,
}

/// Per pool the pipeline counting its pending bricks per block and its run of the scan buffer
/// (first word, blocks); the scan that makes the counts offsets.
type Counting = (Vec<(Pipeline, (u32, u32))>, Arc<Scan>);

impl BrickListPass {
    /// After a marking run: the pending bricks allocated. None with dense volumes. `dynamic`
    /// names the pass after the voxelization it precedes (the static one records the static
    /// bricks). `scan` turns the counts of pending bricks into slots.
    pub fn allocate(
        ctx: &Arc<Context>,
        volumes: &Arc<VoxelVolumes>,
        dynamic: bool,
        scan: &Arc<Scan>,
    ) -> GpuResult<Option<Self>> {
        let name = if dynamic { "allocate bricks dynamic" } else { "allocate bricks static" };
        BrickListPass::new(ctx, volumes, (Mode::Allocate, Mode::Finalize, !dynamic), name, Some(scan))
    }

    /// Before the dynamic objects are marked again: their bricks leave the maps and every
    /// pool's list ends at its static bricks. None with dense volumes.
    pub fn release(ctx: &Arc<Context>, volumes: &Arc<VoxelVolumes>) -> GpuResult<Option<Self>> {
        BrickListPass::new(ctx, volumes, (Mode::Release, Mode::Restart, false), "release bricks dynamic", None)
    }

    fn new(
        ctx: &Arc<Context>,
        volumes: &Arc<VoxelVolumes>,
        (per_pool_mode, then, after_static): (Mode, Mode, bool),
        name: &'static str,
        scan: Option<&Arc<Scan>>,
    ) -> GpuResult<Option<Self>> {
        let Some(bricks) = &volumes.bricks else { return Ok(None) };
        let write = Access::ComputeShaderWrite;
        let set = Binds::new()
            .loaded(Bind::Uniform(&volumes.grid_buffer))
            .extend(volumes.brick_maps(write))
            .storage(&bricks.lists, write)
            .storage(&volumes.scan, write)
            .build(ctx, name, vk::ShaderStageFlags::COMPUTE)?;
        let regions = ScanLayout::new(volumes.grid.resolution, Some(&bricks.layout)).pools;
        let per_pool = (0..regions.len() as u32)
            .map(|p| alloc_pipeline(ctx, &set, p, per_pool_mode, (false, regions[p as usize].0)))
            .collect::<GpuResult<Vec<_>>>()?;
        let then = alloc_pipeline(ctx, &set, 0, then, (after_static, 0))?;
        // The allocation counts and scans first (`Mode::Count`, then scan.comp).
        let counting = scan
            .map(|scan| -> GpuResult<_> {
                let count = (regions.iter().enumerate())
                    .map(|(p, &r)| Ok((alloc_pipeline(ctx, &set, p as u32, Mode::Count, (false, r.0))?, r)))
                    .collect::<GpuResult<Vec<_>>>()?;
                Ok((count, scan.clone()))
            })
            .transpose()?;
        Ok(Some(BrickListPass { volumes: volumes.clone(), per_pool, then, set, name, counting }))
    }
}

impl Pass for BrickListPass {
    fn name(&self) -> &str {
        self.name
    }
    fn sets(&self) -> Vec<&PassSet> {
        std::iter::once(&self.set).chain(self.counting.as_ref().map(|(_, scan)| scan.set())).collect()
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let b = self.volumes.bricks.as_ref().expect("a brick list pass has bricks");
        let rw = [Access::ComputeShaderWrite];
        if let Some((count, scan)) = &self.counting {
            // Pending bricks per block of each map, then their offsets, then the slots.
            for (pipeline, (_, blocks)) in count {
                pipeline.bind(cmd, &[self.set.raw()]);
                pipeline.dispatch(cmd, [*blocks, 1, 1], [1; 3]);
            }
            super::memory_barrier(ctx, cmd, &rw, &rw);
            for (p, (_, (first, blocks))) in count.iter().enumerate() {
                scan.record(cmd, *first, *blocks, SCAN_POOL_TOTAL + p as u32);
            }
            super::memory_barrier(ctx, cmd, &rw, &rw);
            for (pipeline, (_, (_, blocks))) in self.per_pool.iter().zip(count) {
                pipeline.bind(cmd, &[self.set.raw()]);
                pipeline.dispatch(cmd, [*blocks, 1, 1], [1; 3]);
            }
        } else {
            for (pipeline, pool) in self.per_pool.iter().zip(&b.layout.pools) {
                pipeline.bind(cmd, &[self.set.raw()]);
                pipeline.dispatch(cmd, [pool.map_side; 3], [4; 3]);
            }
        }
        super::memory_barrier(ctx, cmd, &rw, &rw);
        self.then.bind(cmd, &[self.set.raw()]);
        self.then.dispatch(cmd, [1; 3], [4; 3]);
    }
}

/// After the dynamic allocation: the dynamic bricks' slots emptied in every volume of their
/// pool (a slot may last have held another brick), before the dynamic voxelization fills them.
pub struct BrickClearPass {
    volumes: Arc<VoxelVolumes>,
    /// Per pool: the pipeline and its set (pool 0 binds the full-resolution volumes, pool p
    /// the six directional volumes of its level).
    clears: Vec<(Pipeline, PassSet)>,
}

impl BrickClearPass {
    /// None with dense volumes.
    pub fn new(ctx: &Arc<Context>, volumes: &Arc<VoxelVolumes>) -> GpuResult<Option<Self>> {
        let Some(bricks) = &volumes.bricks else { return Ok(None) };
        let v = volumes;
        let write = Access::ComputeShaderWrite;
        let words = [&v.albedo, &v.normal, v.emission_or_albedo()];
        // The sampled radiance volumes (9^3 per slot): the radiance, then the bounced radiance
        // where it exists; the bounce's scratch (8^3 per slot) where it exists.
        let radiance = [&v.radiance, v.bounced.first().unwrap_or(&v.radiance)];
        let scratch = v.bounced.get(1);
        let clears = (0..bricks.layout.pools.len())
            .map(|p| {
                let faces = (0..6).map(|f| p.checked_sub(1).map_or(&v.pool_placeholder, |l| &bricks.directional[l][f]));
                let set = Binds::new()
                    .loaded(Bind::Uniform(&v.grid_buffer))
                    .extend(v.brick_maps(Access::ComputeShaderReadStorage))
                    .storage(&bricks.lists, Access::ComputeShaderReadBuffer)
                    .storage_images(words, write)
                    .storage_images(radiance, write)
                    .storage_images(faces, write)
                    .storage_image(scratch.unwrap_or(&v.pool_placeholder), write)
                    .build(ctx, "voxel brick clear", vk::ShaderStageFlags::COMPUTE)?;
                let name = format!("voxel brick clear {p}");
                let constants = [(0, p as u32), (1, u32::from(scratch.is_some()))];
                let pipeline =
                    Pipeline::compute(ctx, &name, shaders::BRICK_CLEAR_COMP, &[set.layout()], 0, &constants)?;
                Ok((pipeline, set))
            })
            .collect::<GpuResult<Vec<_>>>()?;
        Ok(Some(BrickClearPass { volumes: volumes.clone(), clears }))
    }
}

impl Pass for BrickClearPass {
    fn name(&self) -> &str {
        "clear bricks dynamic"
    }
    fn sets(&self) -> Vec<&PassSet> {
        self.clears.iter().map(|(_, set)| set).collect()
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        let b = self.volumes.bricks.as_ref().expect("bricks");
        vec![Use::buffer(&b.lists, Access::IndirectCommandRead)]
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        let lists = &self.volumes.bricks.as_ref().expect("bricks").lists;
        for (p, (pipeline, set)) in self.clears.iter().enumerate() {
            pipeline.bind(cmd, &[set.raw()]);
            pipeline.dispatch_indirect(cmd, lists, crate::render::voxel::bricks::brick_list_header::dynamic_range(p));
        }
    }
}
