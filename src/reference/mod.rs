//! The reference path tracer: the ground truth the accuracy sweep measures against.
//!
//! Unbiased for dvsgi's scene model (`glsl/pt_trace.comp` lists the rules): the same
//! triangles, materials, textures and light table as the renderer, at one scene time. The
//! scene is flattened to world-space triangles under a host-built BVH ([`bvh`]), and the GPU
//! traces it progressively in compute, in batches of samples per pixel sized to take about
//! `batch_ms` each (a long dispatch would look like a hung device). Each pixel keeps the sum
//! and the sum of squares of its samples, from which [`ReferenceImage`] forms the mean and the
//! variance of that mean.

pub mod bvh;

use crate::gpu::{shaders, Access, Bind, Buffer, Context, GpuResult, Image, ImageDesc, Pipeline};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::Pass;
use crate::render::passes::readback::{HostReadPass, ImageDownload};
use crate::render::scene_gpu::{upload_buffer, MaterialTable};
use crate::render::sky::{SkyGpu, SkyParams};
use crate::render::{lights, Mode, Scheduler};
use crate::scene::{Aabb, Scene};
use ash::vk;
use bvh::Bvh;
use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Vec2, Vec3};
use std::cell::Cell;
use std::sync::Arc;
use std::time::Instant;

/// What to trace.
#[derive(Debug, Clone, Copy)]
pub struct ReferenceOptions {
    /// Samples (paths) per pixel.
    pub spp: u32,
    /// Indirect bounces at most (`None`: until Russian roulette ends the path; 0: direct
    /// light and visible emission only, the renderer's `gi.mode = "none"`).
    pub max_bounces: Option<u32>,
    /// Seed of the per-pixel random sequences (different seeds give independent images).
    pub seed: u32,
    /// Aim for GPU batches of about this many milliseconds.
    pub batch_ms: f64,
    /// Spread each pixel's paths over its area (a box filter: antialiased edges). Off, every
    /// path leaves through the pixel's centre, where the rasterizer samples, so edges alias
    /// exactly as in the renderer's image and the error measures the lighting alone. A scene
    /// with `render.supersample` > 1 is always jittered: its renderer averages over the same
    /// footprint.
    pub jitter: bool,
    /// Which surfaces of a path reflect specularly.
    pub specular: SpecularPaths,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        ReferenceOptions {
            spp: 256,
            max_bounces: None,
            seed: 1,
            batch_ms: 400.0,
            jitter: false,
            specular: SpecularPaths::All,
        }
    }
}

/// Which surfaces of a path have their specular (Blinn-Phong) lobe (`reference --specular`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum SpecularPaths {
    /// Every surface: the ground truth.
    #[default]
    All,
    /// Only the first surface the camera sees; every later one is Lambertian. This is the light
    /// transport voxel cone tracing models (its voxels store diffuse light), so it has no
    /// caustics (light a mirror throws onto a wall) and no reflections of glossy surfaces in
    /// others. The renderer's error against it is its approximation alone; the difference
    /// between the two references is what the model leaves out.
    #[value(name = "first")]
    FirstSurface,
}

impl SpecularPaths {
    pub fn name(self) -> &'static str {
        match self {
            SpecularPaths::All => "all",
            SpecularPaths::FirstSurface => "first",
        }
    }
}

/// Where the variance image of reference `out` goes: `ref.exr` -> `ref.var.exr`.
pub fn variance_path(out: &std::path::Path) -> std::path::PathBuf {
    out.with_extension("var.exr")
}

/// Bounces when unlimited: Russian roulette ends paths long before (the shader's loop bound).
const UNLIMITED_BOUNCES: u32 = 1023;

/// The converged estimate and its uncertainty.
#[derive(Debug, Clone)]
pub struct ReferenceImage {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel traced.
    pub spp: u32,
    /// Linear radiance W/(sr m^2), RGB f32 per pixel, top row first.
    pub mean: Vec<f32>,
    /// Variance of the mean per pixel and channel: s^2 / n with s^2 the unbiased sample variance.
    pub variance: Vec<f32>,
    /// Samples whose radiance was not finite (left out of the mean; should be 0).
    pub rejected: u64,
}

impl ReferenceImage {
    /// Mean over pixels of the standard error relative to the pixel's mean luminance (pixels
    /// brighter than 1% of the image's mean), a one-number convergence summary.
    pub fn relative_standard_error(&self) -> f64 {
        let lum = |c: &[f32]| (c[0] as f64 + c[1] as f64 + c[2] as f64) / 3.0;
        let n = (self.width * self.height) as usize;
        let image_mean = (0..n).map(|i| lum(&self.mean[i * 3..i * 3 + 3])).sum::<f64>() / n.max(1) as f64;
        let (mut sum, mut count) = (0.0, 0u64);
        for i in 0..n {
            let m = lum(&self.mean[i * 3..i * 3 + 3]);
            if m > 0.01 * image_mean && m > 0.0 {
                sum += lum(&self.variance[i * 3..i * 3 + 3]).sqrt() / m;
                count += 1;
            }
        }
        if count == 0 {
            0.0
        } else {
            sum / count as f64
        }
    }
}

/// Mirrors `PtParams` in glsl/pt_trace.comp.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
struct PtParams {
    inv_view_proj: [[f32; 4]; 4],
    camera: [f32; 4],
    size: [u32; 4],
    info: [u32; 4],
    /// render::sky::SkyParams.
    sky: [f32; 4],
    sky_size: [u32; 4],
}

/// Mirrors `Tri` in glsl/pt_trace.comp.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
struct GpuTri {
    v0: [f32; 4],
    v1: [f32; 4],
    v2: [f32; 4],
}

/// Mirrors `TriShade` in glsl/pt_trace.comp.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
struct GpuTriShade {
    n0: [f32; 4],
    n1: [f32; 4],
    n2: [f32; 4],
    uv01: [f32; 4],
    uv2: [f32; 4],
}

/// World-space triangles of a scene at time `t`, with shading normals, UVs and material.
pub struct Triangles {
    pub corners: Vec<[Vec3; 3]>,
    normals: Vec<[Vec3; 3]>,
    uvs: Vec<[Vec2; 3]>,
    pub materials: Vec<u32>,
    /// (object, mesh) index of each triangle in the scene.
    pub sources: Vec<[u32; 2]>,
}

impl Triangles {
    pub fn of(scene: &Scene, t: f32) -> Triangles {
        let mut out = Triangles {
            corners: Vec::new(),
            normals: Vec::new(),
            uvs: Vec::new(),
            materials: Vec::new(),
            sources: Vec::new(),
        };
        for (oi, object) in scene.objects.iter().enumerate() {
            let m = object.model_matrix(t);
            let nm = Mat3::from_mat4(m).inverse().transpose();
            for &mi in &object.meshes {
                let mesh = &scene.meshes[mi as usize];
                for tri in mesh.indices.chunks_exact(3) {
                    let idx = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
                    out.corners.push(idx.map(|i| m.transform_point3(mesh.positions[i])));
                    out.normals.push(idx.map(|i| nm * mesh.normals.get(i).copied().unwrap_or(Vec3::ZERO)));
                    out.uvs.push(idx.map(|i| mesh.uvs.get(i).copied().unwrap_or(Vec2::ZERO)));
                    out.materials.push(mesh.material);
                    out.sources.push([oi as u32, mi]);
                }
            }
        }
        out
    }
}

/// The one compute pass: trace `samples` paths per pixel into the accumulators.
struct TracePass {
    accum: Arc<Image>,
    accum_sq: Arc<Image>,
    pipeline: Pipeline,
    set: PassSet,
    size: [u32; 2],
    /// The sample index the next recorded dispatch traces.
    next_sample: Cell<u32>,
}

impl Pass for TracePass {
    fn name(&self) -> &str {
        "path trace"
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    /// One sample per pixel per dispatch: llvmpipe caps the iterations a loop may run in
    /// one invocation (gallivm's loop limiter), so tracing many samples in one invocation
    /// silently cut long paths short (a furnace test lost 0.5% of its energy).
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        let sample = self.next_sample.get();
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.push(cmd, &[sample, 1u32]);
        self.pipeline.dispatch(cmd, [self.size[0], self.size[1], 1], [8, 8, 1]);
        self.next_sample.set(sample + 1);
    }
}

impl TracePass {
    /// The accumulators, descriptor set and pipeline that trace the uploaded scene into an
    /// image of `size` pixels.
    fn new(
        ctx: &Arc<Context>,
        (materials, sky): (&MaterialTable, &SkyGpu),
        uniform: Arc<Buffer>,
        scene: SceneBuffers,
        size: [u32; 2],
    ) -> GpuResult<TracePass> {
        let accum = accumulator(ctx, "reference sum", size)?;
        let accum_sq = accumulator(ctx, "reference sum of squares", size)?;
        let [read, write] = [Access::ComputeShaderReadBuffer, Access::ComputeShaderWrite];
        let ro = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let set = Binds::new()
            .uniform(&uniform, read)
            .storage(&scene.nodes, read)
            .storage(&scene.tris, read)
            .storage(&scene.shades, read)
            .loaded(Bind::Storage(&materials.buffer))
            .storage(&scene.lights, read)
            .loaded(Bind::ImageArray(materials.texture_views(), ro))
            .storage_image(&accum, write)
            .storage_image(&accum_sq, write)
            .sampler(materials.lod_sampler.raw)
            .loaded(Bind::Storage(&sky.sampling))
            .extend(sky.map_bind())
            .build(ctx, "path trace", vk::ShaderStageFlags::COMPUTE)?;
        let pipeline = Pipeline::compute(
            ctx,
            "path trace",
            shaders::PT_TRACE_COMP,
            &[set.layout()],
            8,
            &[(0, materials.texture_count())],
        )?;
        Ok(TracePass { accum, accum_sq, pipeline, set, size, next_sample: Cell::new(0) })
    }
}

/// One RGBA32F accumulator image of `size` pixels, written by the trace and copied out.
fn accumulator(ctx: &Arc<Context>, name: &str, size: [u32; 2]) -> GpuResult<Arc<Image>> {
    let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
    let desc = ImageDesc::d2(vk::Format::R32G32B32A32_SFLOAT, size[0], size[1], usage);
    Ok(Arc::new(Image::new(ctx, name, desc)?))
}

/// Refuse an image size the device cannot hold and a sample count of zero.
fn check_request(ctx: &Context, width: u32, height: u32, options: &ReferenceOptions) -> GpuResult<()> {
    let max2d = ctx.info.limits.max_image_dimension2_d;
    if width == 0 || height == 0 || width > max2d || height > max2d {
        return Err(crate::gpu::GpuError::Limit(format!(
            "image size {width}x{height} is outside 1..={max2d} (this device's maxImageDimension2D)"
        )));
    }
    if options.spp == 0 {
        return Err(crate::gpu::GpuError::Limit("samples per pixel must be at least 1".into()));
    }
    Ok(())
}

/// The triangles in BVH order as the shader reads them: corners (material in `v0.w`) and
/// shading attributes; one zeroed triangle when there are none (no empty buffers).
fn gpu_triangles(tris: &Triangles, bvh: &Bvh) -> (Vec<GpuTri>, Vec<GpuTriShade>) {
    let mut gpu_tris = Vec::with_capacity(tris.corners.len().max(1));
    let mut shades = Vec::with_capacity(tris.corners.len().max(1));
    for &i in &bvh.order {
        let i = i as usize;
        let [a, b, c] = tris.corners[i];
        let v4 = |v: Vec3, w: f32| [v.x, v.y, v.z, w];
        gpu_tris.push(GpuTri { v0: v4(a, f32::from_bits(tris.materials[i])), v1: v4(b, 0.0), v2: v4(c, 0.0) });
        let [n0, n1, n2] = tris.normals[i];
        let [t0, t1, t2] = tris.uvs[i];
        shades.push(GpuTriShade {
            n0: v4(n0, 0.0),
            n1: v4(n1, 0.0),
            n2: v4(n2, 0.0),
            uv01: [t0.x, t0.y, t1.x, t1.y],
            uv2: [t2.x, t2.y, 0.0, 0.0],
        });
    }
    if gpu_tris.is_empty() {
        gpu_tris.push(GpuTri::zeroed());
        shades.push(GpuTriShade::zeroed());
    }
    (gpu_tris, shades)
}

impl SceneBuffers {
    /// Upload the BVH, the triangles and the scene's light table at the scene's time (`bounds`:
    /// the world bounds then).
    fn upload(ctx: &Arc<Context>, scene: &Scene, tris: &Triangles, bvh: &Bvh, bounds: Aabb) -> GpuResult<SceneBuffers> {
        let s = &scene.settings;
        let (gpu_tris, shades) = gpu_triangles(tris, bvh);
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let nodes = Arc::new(upload_buffer(ctx, "reference bvh", bytemuck::cast_slice(&bvh.nodes), storage)?);
        let tris = Arc::new(upload_buffer(ctx, "reference triangles", bytemuck::cast_slice(&gpu_tris), storage)?);
        let shades = Arc::new(upload_buffer(ctx, "reference shading", bytemuck::cast_slice(&shades), storage)?);
        let (mut gpu_lights, _) = lights::build(scene, s.time, bounds, s.shadow_map_size, s.shadow_filter_radius);
        let light_count = gpu_lights.len() as u32;
        if gpu_lights.is_empty() {
            gpu_lights.push(lights::GpuLight::default());
        }
        let lights = Arc::new(upload_buffer(ctx, "reference lights", bytemuck::cast_slice(&gpu_lights), storage)?);
        Ok(SceneBuffers { nodes, tris, shades, lights, light_count })
    }
}

/// The trace's parameters: the camera's inverse view-projection, the ray offset (scaled to
/// the scene's `bounds`), the image size, lights, bounce limit, seed, jitter, triangle count
/// and which surfaces reflect specularly.
fn trace_params(
    scene: &Scene,
    options: &ReferenceOptions,
    (bounds, sky): (Aabb, SkyParams),
    light_count: u32,
    triangle_count: u32,
) -> PtParams {
    let s = &scene.settings;
    let (width, height) = (s.width, s.height);
    let cam = &scene.camera;
    let view_proj = cam.projection(width as f32 / height as f32) * cam.view();
    let extent = if bounds.is_empty() { 1.0 } else { bounds.extent().max_element().max(1e-6) };
    PtParams {
        inv_view_proj: view_proj.inverse().to_cols_array_2d(),
        camera: [0.0, 0.0, 0.0, 1e-5 * extent],
        size: [width, height, light_count, options.max_bounces.unwrap_or(UNLIMITED_BOUNCES).min(UNLIMITED_BOUNCES)],
        info: [
            options.seed,
            (options.jitter || s.supersample > 1) as u32,
            triangle_count,
            (options.specular == SpecularPaths::FirstSurface) as u32,
        ],
        sky: sky.params,
        sky_size: sky.size,
    }
}

/// A progressive path tracer for one scene.
pub struct PathTracer {
    ctx: Arc<Context>,
    pass: TracePass,
    // Keep the material table, the textures and the sky the descriptor set points at alive.
    _materials: MaterialTable,
    _sky: SkyGpu,
    scheduler: Scheduler,
    options: ReferenceOptions,
    done: u32,
    /// Host milliseconds per sample per pixel, from the last batch.
    ms_per_sample: Option<f64>,
    pub triangle_count: usize,
    pub bvh_nodes: usize,
    pub bvh_depth: usize,
}

/// The scene data the trace shader reads, uploaded to storage buffers.
struct SceneBuffers {
    /// The BVH nodes.
    nodes: Arc<Buffer>,
    /// Triangle corners in BVH order (`GpuTri`).
    tris: Arc<Buffer>,
    /// Triangle normals and UVs in BVH order (`GpuTriShade`).
    shades: Arc<Buffer>,
    /// The light table (one unused light when the scene has none).
    lights: Arc<Buffer>,
    /// Lights in the scene (the table's length without the padding).
    light_count: u32,
}

impl PathTracer {
    pub fn new(ctx: &Arc<Context>, scene: &Scene, options: ReferenceOptions) -> GpuResult<PathTracer> {
        let s = &scene.settings;
        let (width, height) = (s.width, s.height);
        check_request(ctx, width, height, &options)?;
        let tris = Triangles::of(scene, s.time);
        let bvh = Bvh::build(&tris.corners);
        let bounds = scene.world_bounds(s.time);
        let buffers = SceneBuffers::upload(ctx, scene, &tris, &bvh, bounds)?;
        let materials = MaterialTable::new(ctx, scene)?;
        let sky = SkyGpu::new(ctx, scene.sky.as_ref())?;
        let params =
            trace_params(scene, &options, (bounds, sky.params), buffers.light_count, tris.corners.len() as u32);
        let uniform = Arc::new(Buffer::uniform(ctx, "reference parameters", &params)?);
        let pass = TracePass::new(ctx, (&materials, &sky), uniform, buffers, [width, height])?;
        Ok(PathTracer {
            ctx: ctx.clone(),
            pass,
            _materials: materials,
            _sky: sky,
            scheduler: Scheduler::new(ctx, Mode::Sync, 1)?,
            options,
            done: 0,
            ms_per_sample: None,
            triangle_count: tris.corners.len(),
            bvh_nodes: bvh.nodes.len(),
            bvh_depth: bvh.depth(),
        })
    }

    /// Samples per pixel traced so far.
    pub fn samples_done(&self) -> u32 {
        self.done
    }

    /// Trace the next batch (sized from the last one's time) and wait for it; returns the
    /// samples per pixel traced in it (0 once `spp` is reached).
    pub fn step(&mut self) -> GpuResult<u32> {
        let left = self.options.spp - self.done;
        if left == 0 {
            return Ok(0);
        }
        let n = match self.ms_per_sample {
            None => 1,
            Some(ms) => ((self.options.batch_ms / ms.max(1e-3)).floor() as u32).clamp(1, 256),
        }
        .min(left);
        self.pass.next_sample.set(self.done);
        let dispatches: Vec<&dyn Pass> = vec![&self.pass; n as usize];
        let start = Instant::now();
        self.scheduler.begin(None)?;
        self.scheduler.record(&dispatches)?;
        self.scheduler.end(true)?;
        self.ms_per_sample = Some(start.elapsed().as_secs_f64() * 1e3 / n as f64);
        self.done += n;
        Ok(n)
    }

    /// Trace every remaining sample, calling `progress(done, total)` after each batch.
    pub fn run(&mut self, mut progress: impl FnMut(u32, u32)) -> GpuResult<()> {
        while self.step()? > 0 {
            progress(self.done, self.options.spp);
        }
        Ok(())
    }

    /// The estimate from the samples traced so far (waits for a copy).
    pub fn image(&mut self) -> GpuResult<ReferenceImage> {
        let sum = ImageDownload::new(&self.ctx, &self.pass.accum)?;
        let sum_sq = ImageDownload::new(&self.ctx, &self.pass.accum_sq)?;
        let host = HostReadPass { buffers: vec![sum.buffer.clone(), sum_sq.buffer.clone()], tail: false };
        self.scheduler.begin(None)?;
        self.scheduler.record(&[&sum, &sum_sq, &host])?;
        self.scheduler.end(true)?;
        let a: Vec<f32> = bytemuck::pod_collect_to_vec(sum.bytes());
        let b: Vec<f32> = bytemuck::pod_collect_to_vec(sum_sq.bytes());
        let [width, height] = self.pass.size;
        let mut mean = Vec::with_capacity(a.len() / 4 * 3);
        let mut variance = Vec::with_capacity(a.len() / 4 * 3);
        let mut rejected = 0u64;
        for (pa, pb) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
            let n = pa[3] as f64;
            rejected += pb[3] as u64;
            for c in 0..3 {
                let (s, s2) = (pa[c] as f64, pb[c] as f64);
                let m = if n > 0.0 { s / n } else { 0.0 };
                // Unbiased sample variance, divided by n for the variance of the mean.
                let var = if n > 1.0 { ((s2 - s * m) / (n - 1.0)).max(0.0) / n } else { 0.0 };
                mean.push(m as f32);
                variance.push(var as f32);
            }
        }
        Ok(ReferenceImage { width, height, spp: self.done, mean, variance, rejected })
    }
}
