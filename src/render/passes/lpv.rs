//! Light propagation volumes (`gi.mode = "lpv"`, Kaplanyan & Dachsbacher 2010): the
//! reflective shadow maps' texels injected into a grid of 2-band SH per colour with a geometry
//! volume, propagated `gi.lpv_steps` times, looked up per traced pixel (all compute). The
//! host side and the CPU reference of a step are in `render::lpv`.

use super::gbuffer::GBuffer;
use super::gi_trace::GiTargets;
use super::rsm::RsmMaps;
use crate::gpu::{shaders, Access, Bind, Buffer, Context, GpuResult, Image, ImageDesc, Pipeline, Sampler};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, QueueKind};
use crate::render::lpv::GpuLpvGrid;
use crate::render::voxel::VoxelGrid;
use crate::render::FrameBuffers;
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// Intensity SH per colour and the geometry volume: RGBA32F (four coefficients).
pub const LPV_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
/// Ints per cell in the injection's accumulator (lpv_accum.glsl).
const ACCUM_INTS: u64 = 16;

pub struct LpvVolumes {
    pub grid: VoxelGrid,
    pub grid_buffer: Buffer,
    /// Ping-pong light of the propagation steps, red, green, blue.
    pub light: [[Arc<Image>; 3]; 2],
    /// Blocking lobes of the surfaces the maps see.
    pub geometry: Arc<Image>,
    /// The injected light plus every step's: what the lookup reads.
    pub sum: [Arc<Image>; 3],
    /// The injection's fixed-point sums (lpv_accum.glsl).
    pub accum: Arc<Buffer>,
    /// Trilinear, clamped to the edge (surfaces on the grid's boundary keep their cells).
    pub sampler: Sampler,
}

impl LpvVolumes {
    /// `skipped`: leading terms left out of the sum (`GpuLpvGrid::dims.z`); `quanta`: the
    /// injection's fixed-point units (`render::lpv::quanta`).
    pub fn new(
        ctx: &Arc<Context>,
        grid: VoxelGrid,
        occlusion: bool,
        skipped: u32,
        quanta: [f32; 2],
    ) -> GpuResult<LpvVolumes> {
        let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_SRC;
        let mk =
            |name: String| Image::new(ctx, &name, ImageDesc::d3(LPV_FORMAT, grid.resolution, 1, usage)).map(Arc::new);
        let rgb = |what: &str| -> GpuResult<[Arc<Image>; 3]> {
            Ok([mk(format!("lpv {what} r"))?, mk(format!("lpv {what} g"))?, mk(format!("lpv {what} b"))?])
        };
        let edge = vk::SamplerAddressMode::CLAMP_TO_EDGE;
        let sampler = Sampler::new(
            ctx,
            "lpv sampler",
            &vk::SamplerCreateInfo::default()
                .mag_filter(vk::Filter::LINEAR)
                .min_filter(vk::Filter::LINEAR)
                .address_mode_u(edge)
                .address_mode_v(edge)
                .address_mode_w(edge),
        )?;
        Ok(LpvVolumes {
            grid_buffer: Buffer::uniform(ctx, "lpv grid", &GpuLpvGrid::new(&grid, occlusion, skipped, quanta))?,
            accum: Arc::new(Buffer::new(
                ctx,
                "lpv injection sums",
                ACCUM_INTS * 4 * (grid.resolution as u64).pow(3),
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::GpuOnly,
            )?),
            grid,
            light: [rgb("light a")?, rgb("light b")?],
            geometry: mk("lpv geometry".into())?,
            sum: rgb("sum")?,
            sampler,
        })
    }

    /// Every volume, for memory reports.
    pub fn all(&self) -> Vec<&Arc<Image>> {
        self.light.iter().flatten().chain(std::iter::once(&self.geometry)).chain(self.sum.iter()).collect()
    }
}

/// Each image of `images` a storage image of its own binding, touched with `access`.
fn storage(images: &[Arc<Image>], access: Access) -> Binds<'_> {
    images.iter().fold(Binds::new(), |b, i| b.storage_image(i, access))
}

/// Injection: every map texel adds its VPL and its blocking lobe to the cells they fall in
/// (fixed-point integer atomics), then the sums become the volumes. Three dispatches: clear
/// the accumulator, add the texels, resolve.
pub struct LpvInjectPass {
    maps: Arc<RsmMaps>,
    vols: Arc<LpvVolumes>,
    queue: QueueKind,
    clear: (Pipeline, PassSet),
    inject: (Pipeline, PassSet),
    resolve: (Pipeline, PassSet),
    _sampler: Sampler,
}

impl LpvInjectPass {
    pub fn new(ctx: &Arc<Context>, maps: &Arc<RsmMaps>, vols: &Arc<LpvVolumes>, queue: QueueKind) -> GpuResult<Self> {
        let sampler = GBuffer::sampler(ctx)?;
        let step = |name: &str, code: &[u8], binds: Binds| -> GpuResult<(Pipeline, PassSet)> {
            let set = binds.build(ctx, name, vk::ShaderStageFlags::COMPUTE)?;
            Ok((Pipeline::compute(ctx, name, code, &[set.layout()], 0, &[])?, set))
        };
        let grid = || Binds::new().loaded(Bind::Uniform(&vols.grid_buffer));
        let write = Access::ComputeShaderWrite;
        let clear = step("lpv clear", shaders::LPV_CLEAR_COMP, grid().storage(&vols.accum, write))?;
        let maps_read =
            maps.colors().into_iter().fold(grid(), |b, i| b.sampled(i, sampler.raw, Access::ComputeShaderReadSampled));
        let inject = step("lpv inject", shaders::LPV_INJECT_COMP, maps_read.storage(&vols.accum, write))?;
        // The resolve writes every cell of the light, the geometry and the sum.
        let resolved = grid()
            .storage(&vols.accum, write)
            .extend(storage(&vols.light[0], write).overwritten_all())
            .storage_image(&vols.geometry, write)
            .overwritten()
            .extend(storage(&vols.sum, write).overwritten_all());
        let resolve = step("lpv resolve", shaders::LPV_RESOLVE_COMP, resolved)?;
        Ok(LpvInjectPass { maps: maps.clone(), vols: vols.clone(), queue, clear, inject, resolve, _sampler: sampler })
    }
}

impl Pass for LpvInjectPass {
    fn name(&self) -> &str {
        "lpv inject"
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.clear.1, &self.inject.1, &self.resolve.1]
    }
    fn queue(&self) -> QueueKind {
        self.queue
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let r = self.vols.grid.resolution;
        let rw = [Access::ComputeShaderWrite];
        let (p, set) = &self.clear;
        p.bind(cmd, &[set.raw()]);
        p.dispatch(cmd, [r, r, r], [4, 4, 4]);
        super::memory_barrier(ctx, cmd, &rw, &rw);
        let (p, set) = &self.inject;
        let size = self.maps.flux.extent2d();
        p.bind(cmd, &[set.raw()]);
        p.dispatch(cmd, [size.width, size.height, self.maps.views.len() as u32], [8, 8, 1]);
        super::memory_barrier(ctx, cmd, &rw, &rw);
        let (p, set) = &self.resolve;
        p.bind(cmd, &[set.raw()]);
        p.dispatch(cmd, [r, r, r], [4, 4, 4]);
    }
}

/// The propagation steps, ping-ponging between the two light volumes (one dispatch each).
pub struct LpvPropagatePass {
    vols: Arc<LpvVolumes>,
    steps: u32,
    queue: QueueKind,
    pipeline: Pipeline,
    /// a -> b and b -> a.
    sets: [PassSet; 2],
}

impl LpvPropagatePass {
    pub fn new(ctx: &Arc<Context>, vols: &Arc<LpvVolumes>, steps: u32, queue: QueueKind) -> GpuResult<Self> {
        // Each step reads one light volume, writes the other and adds to the sum.
        let write = Access::ComputeShaderWrite;
        let set = |from: usize| {
            Binds::new()
                .loaded(Bind::Uniform(&vols.grid_buffer))
                .extend(storage(&vols.light[from], write))
                .storage_image(&vols.geometry, Access::ComputeShaderReadStorage)
                .extend(storage(&vols.light[1 - from], write))
                .extend(storage(&vols.sum, write))
                .build(ctx, "lpv propagate", vk::ShaderStageFlags::COMPUTE)
        };
        let sets = [set(0)?, set(1)?];
        let pipeline =
            Pipeline::compute(ctx, "lpv propagate", shaders::LPV_PROPAGATE_COMP, &[sets[0].layout()], 4, &[])?;
        Ok(LpvPropagatePass { vols: vols.clone(), steps, queue, pipeline, sets })
    }
}

impl Pass for LpvPropagatePass {
    fn name(&self) -> &str {
        "lpv propagate"
    }
    fn sets(&self) -> Vec<&PassSet> {
        self.sets.iter().collect()
    }
    fn queue(&self) -> QueueKind {
        self.queue
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let r = self.vols.grid.resolution;
        for step in 0..self.steps {
            if step > 0 {
                // This step reads the last one's light and adds to the sum it wrote.
                let rw = [Access::ComputeShaderWrite];
                super::memory_barrier(ctx, cmd, &rw, &rw);
            }
            self.pipeline.bind(cmd, &[self.sets[(step % 2) as usize].raw()]);
            self.pipeline.push(cmd, &step);
            self.pipeline.dispatch(cmd, [r, r, r], [4, 4, 4]);
        }
    }
}

/// The per-pixel lookup of the summed light (at 1/k resolution).
pub struct LpvLookupPass {
    pub targets: GiTargets,
    queue: QueueKind,
    pipeline: Pipeline,
    set: PassSet,
    _sampler: Sampler,
}

impl LpvLookupPass {
    /// `gi_params` carries the downsampling factor (`GiParams.counts.y`).
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        gbuffer: &Arc<GBuffer>,
        vols: &Arc<LpvVolumes>,
        gi_params: &Buffer,
        targets: GiTargets,
        queue: QueueKind,
    ) -> GpuResult<Self> {
        let sampler = GBuffer::sampler(ctx)?;
        let read = Access::ComputeShaderReadSampled;
        let set = Binds::new()
            .uniform(&frame.uniforms, Access::ComputeShaderReadBuffer)
            .loaded(Bind::Uniform(gi_params))
            .loaded(Bind::Uniform(&vols.grid_buffer))
            .extend(gbuffer.surface(sampler.raw))
            .extend(vols.sum.iter().fold(Binds::new(), |b, i| b.sampled(i, vols.sampler.raw, read)))
            .storage_image(&targets.diffuse, Access::ComputeShaderWrite)
            .overwritten()
            .build(ctx, "lpv lookup", vk::ShaderStageFlags::COMPUTE)?;
        let pipeline = Pipeline::compute(ctx, "lpv lookup", shaders::LPV_LOOKUP_COMP, &[set.layout()], 0, &[])?;
        Ok(LpvLookupPass { targets, queue, pipeline, set, _sampler: sampler })
    }
}

impl Pass for LpvLookupPass {
    fn name(&self) -> &str {
        "lpv lookup"
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn queue(&self) -> QueueKind {
        self.queue
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.dispatch_pixels(cmd, &self.targets.diffuse);
    }
}
