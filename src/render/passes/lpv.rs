//! Light propagation volumes (`gi.mode = "lpv"`, Kaplanyan & Dachsbacher 2010): the
//! reflective shadow maps' texels injected into a grid of 2-band SH per colour with a geometry
//! volume, propagated `gi.lpv_steps` times, looked up per traced pixel (all compute). The
//! host side and the CPU reference of a step are in `render::lpv`.

use super::gbuffer::GBuffer;
use super::gi_trace::GiTargets;
use super::rsm::RsmMaps;
use crate::gpu::{
    shaders, Access, Bind, Buffer, Context, DescriptorSet, GpuResult, Image, ImageDesc, Pipeline, Sampler,
};
use crate::render::graph::{Pass, QueueKind, Use};
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
    pub accum: Buffer,
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
            accum: Buffer::new(
                ctx,
                "lpv injection sums",
                ACCUM_INTS * 4 * (grid.resolution as u64).pow(3),
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::GpuOnly,
            )?,
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

fn storage<'a>(images: &[Arc<Image>]) -> Vec<Bind<'a>> {
    images.iter().map(|i| Bind::StorageImage(i.view)).collect()
}

/// Injection: every map texel adds its VPL and its blocking lobe to the cells they fall in
/// (fixed-point integer atomics), then the sums become the volumes. Three dispatches: clear
/// the accumulator, add the texels, resolve.
pub struct LpvInjectPass {
    maps: Arc<RsmMaps>,
    vols: Arc<LpvVolumes>,
    queue: QueueKind,
    clear: (Pipeline, DescriptorSet),
    inject: (Pipeline, DescriptorSet),
    resolve: (Pipeline, DescriptorSet),
    _sampler: Sampler,
}

impl LpvInjectPass {
    pub fn new(ctx: &Arc<Context>, maps: &Arc<RsmMaps>, vols: &Arc<LpvVolumes>, queue: QueueKind) -> GpuResult<Self> {
        let sampler = GBuffer::sampler(ctx)?;
        let ro = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let stage = vk::ShaderStageFlags::COMPUTE;
        let step = |name: &str, code: &[u8], binds: &[Bind]| -> GpuResult<(Pipeline, DescriptorSet)> {
            let set = DescriptorSet::new(ctx, name, stage, binds)?;
            Ok((Pipeline::compute(ctx, name, code, &[set.layout], 0, &[])?, set))
        };
        let clear = step(
            "lpv clear",
            shaders::LPV_CLEAR_COMP,
            &[Bind::Uniform(&vols.grid_buffer), Bind::Storage(&vols.accum)],
        )?;
        let mut binds = vec![Bind::Uniform(&vols.grid_buffer)];
        binds.extend(maps.colors().map(|i| Bind::Sampled(i.view, sampler.raw, ro)));
        binds.push(Bind::Storage(&vols.accum));
        let inject = step("lpv inject", shaders::LPV_INJECT_COMP, &binds)?;
        let mut binds = vec![Bind::Uniform(&vols.grid_buffer), Bind::Storage(&vols.accum)];
        binds.extend(storage(&vols.light[0]));
        binds.push(Bind::StorageImage(vols.geometry.view));
        binds.extend(storage(&vols.sum));
        let resolve = step("lpv resolve", shaders::LPV_RESOLVE_COMP, &binds)?;
        Ok(LpvInjectPass { maps: maps.clone(), vols: vols.clone(), queue, clear, inject, resolve, _sampler: sampler })
    }
}

impl Pass for LpvInjectPass {
    fn name(&self) -> &str {
        "lpv inject"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let v = &self.vols;
        let mut uses: Vec<Use> =
            self.maps.colors().into_iter().map(|i| Use::image(i, Access::ComputeShaderReadSampled)).collect();
        let written = v.light[0].iter().chain(std::iter::once(&v.geometry)).chain(v.sum.iter());
        uses.extend(written.map(|i| Use::overwrite(i, Access::ComputeShaderWrite)));
        uses.push(Use::buffer(&v.accum, Access::ComputeShaderWrite));
        uses
    }
    fn queue(&self) -> QueueKind {
        self.queue
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let r = self.vols.grid.resolution;
        let rw = [Access::ComputeShaderWrite];
        let (p, set) = &self.clear;
        p.bind(cmd, &[set.set]);
        p.dispatch(cmd, [r, r, r], [4, 4, 4]);
        super::memory_barrier(ctx, cmd, &rw, &rw);
        let (p, set) = &self.inject;
        let size = self.maps.flux.extent2d();
        p.bind(cmd, &[set.set]);
        p.dispatch(cmd, [size.width, size.height, self.maps.views.len() as u32], [8, 8, 1]);
        super::memory_barrier(ctx, cmd, &rw, &rw);
        let (p, set) = &self.resolve;
        p.bind(cmd, &[set.set]);
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
    sets: [DescriptorSet; 2],
}

impl LpvPropagatePass {
    pub fn new(ctx: &Arc<Context>, vols: &Arc<LpvVolumes>, steps: u32, queue: QueueKind) -> GpuResult<Self> {
        let set = |from: usize| {
            let mut binds = vec![Bind::Uniform(&vols.grid_buffer)];
            binds.extend(storage(&vols.light[from]));
            binds.push(Bind::StorageImage(vols.geometry.view));
            binds.extend(storage(&vols.light[1 - from]));
            binds.extend(storage(&vols.sum));
            DescriptorSet::new(ctx, "lpv propagate", vk::ShaderStageFlags::COMPUTE, &binds)
        };
        let sets = [set(0)?, set(1)?];
        let pipeline = Pipeline::compute(ctx, "lpv propagate", shaders::LPV_PROPAGATE_COMP, &[sets[0].layout], 4, &[])?;
        Ok(LpvPropagatePass { vols: vols.clone(), steps, queue, pipeline, sets })
    }
}

impl Pass for LpvPropagatePass {
    fn name(&self) -> &str {
        "lpv propagate"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let v = &self.vols;
        let mut uses: Vec<Use> =
            v.light.iter().flatten().chain(v.sum.iter()).map(|i| Use::image(i, Access::ComputeShaderWrite)).collect();
        uses.push(Use::image(&v.geometry, Access::ComputeShaderReadStorage));
        uses
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
            self.pipeline.bind(cmd, &[self.sets[(step % 2) as usize].set]);
            self.pipeline.push(cmd, &step);
            self.pipeline.dispatch(cmd, [r, r, r], [4, 4, 4]);
        }
    }
}

/// The per-pixel lookup of the summed light (at 1/k resolution).
pub struct LpvLookupPass {
    frame: FrameBuffers,
    gbuffer: Arc<GBuffer>,
    vols: Arc<LpvVolumes>,
    pub targets: GiTargets,
    queue: QueueKind,
    pipeline: Pipeline,
    set: DescriptorSet,
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
        let ro = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let mut binds = vec![
            Bind::Uniform(&frame.uniforms),
            Bind::Uniform(gi_params),
            Bind::Uniform(&vols.grid_buffer),
            Bind::Sampled(gbuffer.depth.view, sampler.raw, vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL),
            Bind::Sampled(gbuffer.normal.view, sampler.raw, ro),
        ];
        binds.extend(vols.sum.iter().map(|i| Bind::Sampled(i.view, vols.sampler.raw, ro)));
        binds.push(Bind::StorageImage(targets.diffuse.view));
        let set = DescriptorSet::new(ctx, "lpv lookup", vk::ShaderStageFlags::COMPUTE, &binds)?;
        let pipeline = Pipeline::compute(ctx, "lpv lookup", shaders::LPV_LOOKUP_COMP, &[set.layout], 0, &[])?;
        Ok(LpvLookupPass {
            frame: frame.clone(),
            gbuffer: gbuffer.clone(),
            vols: vols.clone(),
            targets,
            queue,
            pipeline,
            set,
            _sampler: sampler,
        })
    }
}

impl Pass for LpvLookupPass {
    fn name(&self) -> &str {
        "lpv lookup"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let mut uses = vec![Use::overwrite(&self.targets.diffuse, Access::ComputeShaderWrite)];
        uses.extend(self.gbuffer.surface_reads());
        uses.extend(self.vols.sum.iter().map(|i| Use::image(i, Access::ComputeShaderReadSampled)));
        uses.extend(self.frame.reads(Access::ComputeShaderReadBuffer));
        uses
    }
    fn queue(&self) -> QueueKind {
        self.queue
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.dispatch_pixels(cmd, &self.targets.diffuse);
    }
}
