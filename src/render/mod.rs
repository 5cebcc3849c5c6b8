//! The renderer: scene upload, per-frame data, and frame submission. What a frame runs is in
//! [`frame`]; how barriers are derived is in [`graph`].

pub mod binding;
pub mod budget;
pub mod cones;
pub mod frame;
pub mod graph;
pub mod lights;
pub mod lpv;
pub mod passes;
pub mod plan;
pub mod raster_profile;
pub mod rays;
mod readbacks;
pub mod relief;
pub mod reuse;
pub mod scene_gpu;
pub mod schedule;
pub mod sky;
pub mod texture;
pub mod voxel;

use crate::gpu::{Buffer, Context, GpuError, GpuResult};
use crate::scene::{Motion, Scene, ToneMap};
use ash::vk;
use bytemuck::{Pod, Zeroable};
use frame::{Carried, FramePasses, FrameState};
use gpu_allocator::MemoryLocation;
use graph::Pass;
use passes::upload::Upload;
use plan::FramePlan;
use scene_gpu::SceneGpu;
pub use schedule::{FrameTiming, HostWaits, Mode, PassTime, Scheduler, SerialTime, SubmitRecord};
use std::sync::Arc;
use std::time::Instant;

/// Mirrors `FrameData` in glsl/include/common.glsl (std140-compatible: vec4/mat4 only).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
pub struct FrameUniforms {
    pub view: [[f32; 4]; 4],
    pub proj: [[f32; 4]; 4],
    pub view_proj: [[f32; 4]; 4],
    pub inv_view_proj: [[f32; 4]; 4],
    pub camera_pos: [f32; 4],
    pub counts: [u32; 4],
    pub shadow: [f32; 4],
    /// x: 16-bit radiance targets hold radiance * x (`lights::radiance_scale`); y = 1/x.
    pub radiance_scale: [f32; 4],
    /// x: voxel updates before this frame's; y: this update's bounce interleave (1: the
    /// bounce gathers for every voxel; see `gi.bounce_interleave`).
    pub voxel: [u32; 4],
    /// x: 1 with `render.exposure = "auto"` (the tone map adds the exposure passes' EV);
    /// y: how far the shown EV moves to this frame's (1: all the way; [`Renderer::ease_exposure`]).
    pub exposure: [f32; 4],
    /// The sky (`sky::SkyParams::params`): x cos, y sin of its turn, z 1 with a sky, w unused.
    pub sky: [f32; 4],
}

/// Per-frame data from the host, shared by the passes. The buffers are device-local and
/// written by the frame's upload pass (`passes::upload`), so frames in flight each see their own.
#[derive(Clone)]
pub struct FrameBuffers {
    pub uniforms: Arc<Buffer>,
    pub lights: Arc<Buffer>,
    pub shadow_views: Arc<Buffer>,
}

impl FrameBuffers {
    /// The buffers for `scene`'s lights and `shadow_views` shadow-map views (every view the
    /// lights have, whether or not the frame draws their maps: the upload writes them all).
    fn new(ctx: &Arc<Context>, scene: &Scene, shadow_views: u32) -> GpuResult<FrameBuffers> {
        let written = |usage| usage | vk::BufferUsageFlags::TRANSFER_DST;
        let buffer = |name: &str, size: usize, usage| {
            Buffer::new(ctx, name, size as u64, written(usage), MemoryLocation::GpuOnly).map(Arc::new)
        };
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        Ok(FrameBuffers {
            uniforms: buffer("frame uniforms", size_of::<FrameUniforms>(), vk::BufferUsageFlags::UNIFORM_BUFFER)?,
            lights: buffer("lights", scene.lights.len().max(1) * size_of::<lights::GpuLight>(), storage)?,
            shadow_views: buffer(
                "shadow views",
                shadow_views.max(1) as usize * size_of::<lights::GpuShadowView>(),
                storage,
            )?,
        })
    }
}

/// The rendered frame read back to the host.
pub struct FrameOutput {
    pub width: u32,
    pub height: u32,
    /// Linear radiance, W/(sr m^2), RGBA f32 row-major, top row first.
    pub radiance: Vec<f32>,
    /// Tone-mapped sRGB, RGBA8.
    pub display: Vec<u8>,
}

impl FrameOutput {
    /// RGB radiance at pixel (x, y).
    pub fn radiance_at(&self, x: u32, y: u32) -> [f32; 3] {
        let i = ((y * self.width + x) * 4) as usize;
        [self.radiance[i], self.radiance[i + 1], self.radiance[i + 2]]
    }
}

/// What `render` reports about a frame.
#[derive(Debug, Clone)]
pub struct FrameStats {
    pub frame: u64,
    /// Host wall clock of `render`: slot wait, record, submit (and the wait for a read-back frame).
    pub host_ms: f64,
    /// GPU timestamps, present when the frame was waited for (read back); otherwise they
    /// arrive later through [`Renderer::take_timings`].
    pub timing: Option<FrameTiming>,
}

/// How frames are scheduled.
#[derive(Debug, Clone, Copy)]
pub struct RenderOptions {
    pub mode: Mode,
    /// Frames recorded ahead of the GPU (1: the host waits for each frame before the next).
    pub frames_in_flight: u32,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions { mode: Mode::Async, frames_in_flight: 2 }
    }
}

pub struct Renderer {
    pub ctx: Arc<Context>,
    pub scene: Scene,
    scene_gpu: Arc<SceneGpu>,
    /// What frames carry over to the next, shared by every copy of the frame's passes.
    carried: Carried,
    /// The frame's passes: one copy, or with `async-pipelined` one per frame in flight (frame
    /// `i` runs copy `i mod n`), each with its own targets, maps and frame data.
    copies: Vec<FramePasses>,
    /// The copy of the frame being rendered or, between frames, of the next.
    copy: usize,
    /// The copy of the last frame rendered (what a pipelined viewer shows with the next).
    shown: Option<usize>,
    /// The copy of the last frame read back ([`Renderer::output`]).
    read_back: usize,
    frames_in_flight: u32,
    scheduler: Scheduler,
    width: u32,
    height: u32,
    /// Static geometry has been voxelized (by a completed frame).
    static_voxelized: bool,
    /// Frames rendered so far (for the voxel update policy).
    frame_index: u64,
    /// The voxels are updated on the next frame whatever the policy says.
    update_requested: bool,
    /// The next frame redraws what it could reuse (`render::reuse`).
    redraw_requested: bool,
    /// The lights as last written, to relight the voxels when they change.
    last_lights: Vec<u8>,
    /// Whether the next frame relights (lights changed since the last relight).
    lights_changed: bool,
    /// Passes of the last rendered frame, in order.
    last_passes: Vec<String>,
    /// `lights::radiance_scale` of the scene.
    radiance_scale: f32,
    /// The frame uniforms being written (uploaded once the frame's state is known).
    uniforms: FrameUniforms,
    /// Voxel updates (relights) so far: the bounce's interleave phase.
    voxel_updates: u64,
    /// What the ray-traced reflections' history was accumulated under.
    history: ReflectionHistory,
    /// The viewer's easing of automatic exposure: its time constant (s) and when the last
    /// frame was written ([`Renderer::ease_exposure`]).
    exposure_easing: Option<(f32, Option<std::time::Instant>)>,
}

/// The view and scene time the rt reflections' history holds, and how many frames it holds.
#[derive(Default)]
struct ReflectionHistory {
    frames: u32,
    view_proj: [[f32; 4]; 4],
    time: f32,
    started: bool,
}

impl Renderer {
    /// A renderer with the default options (async, two frames in flight).
    pub fn new(ctx: &Arc<Context>, scene: Scene) -> GpuResult<Renderer> {
        Renderer::with_options(ctx, scene, RenderOptions::default())
    }

    pub fn with_options(ctx: &Arc<Context>, mut scene: Scene, options: RenderOptions) -> GpuResult<Renderer> {
        scene.settings.gi.voxel_layout = budget::resolve_layout(&scene, &budget::Limits::of(ctx));
        if options.frames_in_flight == 0 || options.frames_in_flight > 8 {
            return Err(GpuError::Limit(format!("frames in flight must be 1..=8, not {}", options.frames_in_flight)));
        }
        let s = &scene.settings;
        let (width, height) = (s.width, s.height);
        let max2d = ctx.info.limits.max_image_dimension2_d;
        let (iw, ih) = s.internal_size();
        if iw == 0 || ih == 0 || iw > max2d || ih > max2d {
            return Err(GpuError::Limit(format!(
                "image size {iw}x{ih} (with supersampling) is outside 1..={max2d} (this device's maxImageDimension2D)"
            )));
        }
        if s.shadow_map_size > max2d {
            return Err(GpuError::Limit(format!(
                "render.shadow_map_size {} exceeds this device's maxImageDimension2D = {max2d}",
                s.shadow_map_size
            )));
        }
        let plan = FramePlan::of(&scene);
        if scene.sky.is_some() && !sky::lit_by_sky(&scene) {
            log::warn!("{}: {}", scene.path.display(), sky::sky_use(&scene).unwrap_or_default());
        }
        // Refuse what cannot fit before allocating anything (async-pipelined: with a copy of
        // the frame's own resources per frame in flight).
        let copies = if options.mode.per_frame_copies() { options.frames_in_flight } else { 1 };
        budget::Estimate::on_plan(ctx, &scene, &plan).with_copies(copies).check(ctx, &scene)?;
        let scene_gpu = Arc::new(SceneGpu::new(ctx, &scene)?);
        let carried = Carried::new(ctx, (&scene, &plan), &scene_gpu)?;
        let scheduler = Scheduler::new(ctx, options.mode, options.frames_in_flight)?;
        let radiance_scale = lights::radiance_scale(&scene);
        let mut r = Renderer {
            ctx: ctx.clone(),
            scene,
            scene_gpu,
            carried,
            copies: Vec::new(),
            copy: 0,
            shown: None,
            read_back: 0,
            frames_in_flight: options.frames_in_flight,
            scheduler,
            width,
            height,
            static_voxelized: false,
            frame_index: 0,
            update_requested: false,
            redraw_requested: false,
            last_lights: Vec::new(),
            lights_changed: true,
            last_passes: Vec::new(),
            radiance_scale,
            uniforms: FrameUniforms::zeroed(),
            voxel_updates: 0,
            history: ReflectionHistory::default(),
            exposure_easing: None,
        };
        r.make_copies(plan)?;
        Ok(r)
    }

    /// The copies of the frame's passes the mode needs: one per frame in flight for
    /// `async-pipelined`, else one (copies made before stay: a mode switch keeps them).
    fn make_copies(&mut self, plan: FramePlan) -> GpuResult<()> {
        let want = if self.scheduler.mode().per_frame_copies() { self.frames_in_flight as usize } else { 1 };
        if !self.copies.is_empty() && self.copies.len() < want {
            // A switch to async-pipelined: refuse copies that cannot fit, before allocating.
            let estimate = budget::Estimate::on_plan(&self.ctx, &self.scene, &plan);
            estimate.with_copies(want as u32).check(&self.ctx, &self.scene)?;
        }
        while self.copies.len() < want {
            let frame = FrameBuffers::new(&self.ctx, &self.scene, lights::shadow_view_count(&self.scene))?;
            let passes = FramePasses::new(&self.ctx, (&self.scene, &plan), &self.scene_gpu, &frame, &self.carried)?;
            self.copies.push(passes);
        }
        Ok(())
    }

    /// Track a swapchain `image` as in the presentation engine's hands: the first frame that
    /// draws into it then orders its barrier after the acquisition's semaphore wait.
    pub fn adopt_presented(&mut self, image: &crate::gpu::Image) {
        self.scheduler.adopt_presented(image);
    }

    /// The passes of the frame being rendered or, between frames, of the next.
    fn passes(&self) -> &FramePasses {
        &self.copies[self.copy]
    }

    /// The display image (tone-mapped, sRGB-encoded RGBA8 in a UNORM format) that a viewer
    /// presents with the next frame: that frame's own, or in `async-pipelined` the last
    /// frame's (one frame of latency, [`Mode::latency_frames`]; the next frame's tail is still
    /// running on the compute queue when its graphics work is done).
    pub fn display_image(&self) -> &Arc<crate::gpu::Image> {
        let latency = self.scheduler.mode().latency_frames() > 0;
        let copy = self.shown.filter(|_| latency).unwrap_or(self.next_copy());
        &self.copies[copy].tonemap.display
    }

    /// The copy the next frame runs.
    fn next_copy(&self) -> usize {
        (self.frame_index % self.copies.len() as u64) as usize
    }

    /// GPU memory of the frame's extra copies (`async-pipelined`: every copy after the first,
    /// its targets and maps), bytes; 0 with one copy.
    pub fn copies_bytes(&self) -> u64 {
        self.copies[1..].iter().map(FramePasses::own_bytes).sum()
    }

    /// How many copies of the frame's passes exist (1, or the frames in flight).
    pub fn copy_count(&self) -> usize {
        self.copies.len()
    }

    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// What the scene's frame needs (decided once, when the renderer was made).
    pub fn plan(&self) -> &FramePlan {
        &self.passes().plan
    }

    /// Names of the passes the next frame runs, in order.
    pub fn pass_names(&self, readback: bool) -> Vec<String> {
        self.passes().list(self.frame_state(readback)).iter().map(|p| p.name().to_string()).collect()
    }

    fn frame_state(&self, readback: bool) -> FrameState {
        // The update policy: every `update_interval` frames (0: only on request).
        let interval = self.scene.settings.gi.update_interval as u64;
        let due = self.update_requested || (interval > 0 && self.frame_index % interval == 0);
        let gi = &self.scene.settings.gi;
        // The first update has nothing to feed back: it runs enough bounces to converge.
        let feed_back = gi.bounce_feedback && self.static_voxelized;
        let first = gi.bounce_feedback && !self.static_voxelized;
        let bounces = if first { gi.bounces.max(gi.first_update_bounces) } else { gi.bounces };
        FrameState {
            static_voxelized: self.static_voxelized,
            revoxelize: due,
            relight: due || self.lights_changed,
            readback,
            lagged: self.scheduler.mode() == Mode::AsyncLagged,
            raster_first: self.scheduler.mode() == Mode::AsyncPipelined,
            bounces,
            feed_back,
            tail: first && gi.first_update_tail(),
            auto_exposure: self.scene.settings.exposure_auto,
        }
    }

    /// Ease the automatic exposure the window shows towards each frame's with time constant
    /// `seconds` of wall-clock time (eye adaptation), or (None) take each frame's at once, as
    /// files do.
    pub fn ease_exposure(&mut self, seconds: Option<f32>) {
        self.exposure_easing = seconds.filter(|s| *s > 0.0).map(|s| (s, None));
    }

    /// How far the shown EV moves to this frame's: 1 - exp(-dt / tau) since the last frame
    /// where the exposure is eased, otherwise all the way.
    fn exposure_step(&mut self) -> f32 {
        let Some((tau, last)) = &mut self.exposure_easing else { return 1.0 };
        let now = std::time::Instant::now();
        let step = last.map_or(1.0, |l| 1.0 - (-(now - l).as_secs_f32() / *tau).exp());
        *last = Some(now);
        step
    }

    /// The EV `render.exposure = "auto"` adds, as the last frame that ran the exposure passes
    /// left it (the window's, eased), or None before any or without "auto".
    pub fn auto_exposure(&self) -> Option<f32> {
        if !self.scene.settings.exposure_auto {
            return None;
        }
        self.passes().exposure.chosen()
    }

    /// Names of the passes the last rendered frame ran, in order.
    pub fn last_pass_names(&self) -> &[String] {
        &self.last_passes
    }

    /// Update the voxels (revoxelize dynamic objects, relight, bounces) on the next frame,
    /// whatever `gi.update_interval` says.
    pub fn request_voxel_update(&mut self) {
        self.update_requested = true;
    }

    /// Redraw on the next frame everything a frame could reuse (the shadow maps, the reflective
    /// shadow maps and the volume built from them) as if the lights and casters had moved: what
    /// a frame costs when everything changes (`bench --scenario redraw`, the sweep's update
    /// frames).
    pub fn request_redraw(&mut self) {
        self.redraw_requested = true;
    }

    /// GPU memory of the scene's textures with their mip chains.
    pub fn texture_bytes(&self) -> u64 {
        self.scene_gpu.materials.texture_bytes()
    }

    /// GPU memory of the sky's maps and tables (black stand-ins without a sky).
    pub fn sky_bytes(&self) -> u64 {
        self.scene_gpu.sky.bytes()
    }

    /// The voxel volumes, when the scene has them.
    pub fn voxels(&self) -> Option<&voxel::VoxelVolumes> {
        self.passes().voxels.as_ref().map(|v| &*v.volumes)
    }

    /// The voxel volumes and cone-tracing targets this scene created (for `info` and tests;
    /// the first copy's targets).
    pub fn images(&self) -> Vec<Arc<crate::gpu::Image>> {
        self.copies[0].gi_images().into_iter().cloned().collect()
    }

    /// Every image of the frame: the 2D targets (G-buffer, shadow maps, radiance, display),
    /// then the voxel volumes and cone-tracing targets, then the other copies' own images (for
    /// robustness tests).
    pub fn all_images(&self) -> Vec<Arc<crate::gpu::Image>> {
        let first = self.copies[0].targets.all().into_iter().cloned().chain(self.images());
        let others = self.copies[1..].iter().flat_map(|c| c.own_images().into_iter().cloned());
        first.chain(others).collect()
    }

    /// `bench --raster-profile` (`render::raster_profile`): `rounds` times, the frame's G-buffer
    /// pass, a depth prepass of its opaque draws and the G-buffer over that prepass, each
    /// submitted alone and timed. After a frame (the G-buffer reads its uniforms) and after the
    /// frames' timings were taken (this takes its own and drops the rest).
    pub fn raster_profile(&mut self, rounds: u32) -> GpuResult<raster_profile::RasterSamples> {
        use passes::gbuffer::GBufferVariant;
        use raster_profile::{Counted, RasterPassSamples, StatisticsPool};
        let ctx = self.ctx.clone();
        let frame_pass = &self.copies[0].gbuffer;
        let full = &frame_pass.with_variant(&ctx, GBufferVariant::Full)?;
        let prepass = full.with_variant(&ctx, GBufferVariant::DepthPrepass)?;
        let over = full.with_variant(&ctx, GBufferVariant::OverPrepass)?;
        let pool = if ctx.info.optional.pipeline_statistics_query { Some(StatisticsPool::new(&ctx, 2)?) } else { None };
        let counted = |pass, query| pool.as_ref().map(|p| Counted { pass, pool: p.pool, query });
        let (full_counted, over_counted) = (counted(full as &dyn Pass, 0), counted(&over as &dyn Pass, 1));
        let list: [&dyn Pass; 3] = [
            full_counted.as_ref().map_or(full as &dyn Pass, |c| c),
            &prepass,
            over_counted.as_ref().map_or(&over as &dyn Pass, |c| c),
        ];
        let names = ["gbuffer", "gbuffer depth prepass (opaque draws)", "gbuffer over the prepass"];
        let mut out: Vec<RasterPassSamples> = names
            .iter()
            .map(|n| RasterPassSamples { name: n.to_string(), gpu_ms: vec![], host_ms: vec![], counts: None })
            .collect();
        self.scheduler.serial = true;
        for round in 0..rounds as u64 {
            // Frame numbers no frame uses, to find these timings.
            let id = u64::MAX - round;
            self.scheduler.begin(Some(id))?;
            self.scheduler.record(&list)?;
            self.scheduler.end(true)?;
            for (o, s) in out.iter_mut().zip(self.scheduler.serial_times()) {
                o.host_ms.push(s.host_ms);
            }
            let stamps = self.scheduler.timing_of(id).map(|t| t.passes.clone()).unwrap_or_default();
            for (o, p) in out.iter_mut().zip(&stamps) {
                o.gpu_ms.push(p.gpu_ms());
            }
        }
        self.scheduler.serial = false;
        self.scheduler.take_timings();
        if let Some(p) = &pool {
            let counts = p.read()?;
            (out[0].counts, out[2].counts) = (Some(counts[0]), Some(counts[1]));
        }
        let g = full.gbuffer.clone();
        let depth = self.download(&g.depth)?;
        let pixels = g.depth.desc.texel_count();
        Ok(raster_profile::RasterSamples {
            pixels,
            covered_pixels: raster_profile::covered_pixels(&depth),
            passes: out,
        })
    }

    /// The schedule mode of the next frames.
    pub fn mode(&self) -> Mode {
        self.scheduler.mode()
    }

    /// Change the schedule mode between frames (same passes; `async-pipelined` adds a copy of
    /// the frame's own resources per frame in flight the first time it is chosen).
    pub fn set_mode(&mut self, mode: Mode) -> GpuResult<()> {
        self.scheduler.set_mode(mode);
        let plan = self.passes().plan.clone();
        self.make_copies(plan)
    }

    /// Host-time every pass of the following frames (each pass submitted alone and waited
    /// for): for devices whose timestamps cannot be trusted.
    pub fn set_serial_profile(&mut self, on: bool) {
        self.scheduler.serial = on;
    }

    /// The scheduler: submits, waits and timings (for `bench`, `--verbose` and tests).
    pub fn scheduler(&self) -> &Scheduler {
        &self.scheduler
    }

    /// Timings of frames completed since the last call (call [`Renderer::wait_idle`] first
    /// to include every frame rendered).
    pub fn take_timings(&mut self) -> Vec<FrameTiming> {
        self.scheduler.take_timings()
    }

    /// Wait for every frame in flight.
    pub fn wait_idle(&mut self) -> GpuResult<()> {
        self.scheduler.wait_idle()
    }

    /// Write the per-frame data for scene time `t`.
    fn update(&mut self, t: f32) -> Written {
        let exposure_step = self.exposure_step();
        let s = &self.scene.settings;
        let cam = &self.scene.camera;
        let view = cam.view();
        let proj = cam.projection(self.width as f32 / self.height as f32);
        let view_proj = proj * view;
        let tonemap = match s.tonemap {
            ToneMap::Aces => 0,
            ToneMap::Reinhard => 1,
            ToneMap::Clamp => 2,
        };
        self.uniforms = FrameUniforms {
            view: view.to_cols_array_2d(),
            proj: proj.to_cols_array_2d(),
            view_proj: view_proj.to_cols_array_2d(),
            inv_view_proj: view_proj.inverse().to_cols_array_2d(),
            camera_pos: [cam.position.x, cam.position.y, cam.position.z, t],
            counts: {
                let (w, h) = self.scene.settings.internal_size();
                [w, h, self.scene.lights.len() as u32, tonemap]
            },
            shadow: [s.shadow_filter_radius, s.shadow_normal_bias, s.shadow_map_size as f32, 2f32.powf(s.exposure)],
            radiance_scale: [self.radiance_scale, 1.0 / self.radiance_scale, 0.0, 0.0],
            voxel: [0; 4],
            exposure: [if s.exposure_auto { 1.0 } else { 0.0 }, exposure_step, 0.0, 0.0],
            sky: self.scene_gpu.sky.params.params,
        };
        let upload = &self.copies[self.copy].upload;
        let bounds = self.scene.world_bounds(t);
        let (lights, views) = lights::build(&self.scene, t, bounds, s.shadow_map_size, s.shadow_filter_radius);
        let bytes: &[u8] = bytemuck::cast_slice(&lights);
        upload.set(Upload::Lights, bytes);
        let lights_moved = bytes != self.last_lights.as_slice();
        if lights_moved {
            self.lights_changed = true;
            self.last_lights = bytes.to_vec();
        }
        upload.set(Upload::ShadowViews, bytemuck::cast_slice(&views));
        let instances = self.scene_gpu.instance_bytes(&self.scene, t);
        upload.set(Upload::Instances, &instances);
        if let Some(r) = self.passes().rays().filter(|r| r.build.is_some()) {
            upload.set(Upload::TopInstances, &r.scene.instance_bytes(&self.scene, &self.scene_gpu, t));
        }
        Written { lights_moved, views, instances }
    }

    /// The frames in the ray-traced reflections' history before this one: one more than last
    /// frame's while the view, the lights and the moving objects stand still (up to
    /// `gi.specular_history - 1`), else 0 (the history starts again).
    fn reflection_history(&mut self, t: f32, lights_moved: bool) -> u32 {
        let moving = t != self.history.time && self.scene.objects.iter().any(|o| o.motion != Motion::None);
        let h = &mut self.history;
        let still = h.started && h.view_proj == self.uniforms.view_proj && !lights_moved && !moving;
        let cap = self.scene.settings.gi.specular_history.max(1);
        h.frames = if still { (h.frames + 1).min(cap - 1) } else { 0 };
        (h.view_proj, h.time, h.started) = (self.uniforms.view_proj, t, true);
        h.frames
    }

    /// Record and submit one frame at scene time `t`. The host waits only to reuse a frame
    /// slot still in flight, or, with `readback`, for this frame (then [`Renderer::output`]).
    pub fn render(&mut self, t: f32, readback: bool) -> GpuResult<FrameStats> {
        self.render_with(t, readback, &[])
    }

    /// [`Renderer::render`] with `extra` passes recorded after the frame's own (a viewer's
    /// presentation and UI): their barriers come from their declared uses like any pass's.
    pub fn render_with(&mut self, t: f32, readback: bool, extra: &[&dyn Pass]) -> GpuResult<FrameStats> {
        let start = Instant::now();
        let ctx = self.ctx.clone();
        self.copy = self.next_copy();
        if readback {
            self.copies[self.copy].ensure_readback(&ctx)?;
            self.read_back = self.copy;
        }
        let frame = self.frame_index;
        self.scheduler.begin(Some(frame))?;
        let written = self.update(t);
        let history = self.reflection_history(t, written.lights_moved);
        let state = self.frame_state(readback);
        if std::mem::take(&mut self.redraw_requested) {
            self.copies.iter().for_each(FramePasses::forget_reuse);
        }
        if let (true, Some(shadow)) = (self.passes().samples_shadow_maps(state), &self.passes().shadow) {
            shadow.plan(&written.views, &written.instances);
        }
        if let Some(r) = &self.passes().rsm {
            r.plan(&written.views, &self.last_lights, &written.instances);
        }
        // The update counter and interleave of the bounce (uniforms written last: whether the
        // voxels relight depends on the lights just written).
        let interleave = if state.feed_back { self.scene.settings.gi.bounce_interleave } else { 1 };
        self.uniforms.voxel = [self.voxel_updates as u32, interleave, history, frame as u32];
        self.passes().upload.set(Upload::Uniforms, bytemuck::bytes_of(&self.uniforms));
        if state.relight {
            self.voxel_updates += 1;
        }
        let (mut list, split) = self.copies[self.copy].list_split(state);
        list.extend_from_slice(extra);
        self.last_passes = list.iter().map(|p| p.name().to_string()).collect();
        let (head, rest) = list.split_at(split.unwrap_or(0));
        self.scheduler.record(head)?;
        if split.is_some() {
            self.scheduler.end_batch(graph::QueueKind::Compute)?;
        }
        self.scheduler.record(rest)?;
        drop(list);
        if let Some(shadow) = &self.passes().shadow {
            shadow.recorded();
        }
        if let Some(r) = &self.passes().rsm {
            r.recorded();
        }
        self.scheduler.end(readback)?;
        if self.passes().voxels.is_some() {
            self.static_voxelized = true;
        }
        if state.relight {
            self.lights_changed = false;
        }
        self.update_requested = false;
        self.shown = Some(self.copy);
        self.frame_index += 1;
        self.copy = self.next_copy();
        let timing = if readback { self.scheduler.timing_of(frame).cloned() } else { None };
        Ok(FrameStats { frame, host_ms: start.elapsed().as_secs_f64() * 1e3, timing })
    }

    /// The last frame rendered with `readback = true`.
    ///
    /// # Panics
    /// If no frame was rendered with `readback = true`.
    pub fn output(&self) -> FrameOutput {
        let rb = self.copies[self.read_back].readback.as_ref().expect("render(t, true) before output()");
        FrameOutput {
            width: self.width,
            height: self.height,
            radiance: bytemuck::pod_collect_to_vec::<u8, f32>(rb.radiance.bytes()),
            display: rb.display.bytes().to_vec(),
        }
    }
}

/// What [`Renderer::update`] wrote for a frame.
struct Written {
    /// The lights differ from the last frame's.
    lights_moved: bool,
    views: Vec<lights::GpuShadowView>,
    /// The instance table.
    instances: Vec<u8>,
}

impl Drop for Renderer {
    fn drop(&mut self) {
        // Frames in flight still use the passes' resources, which drop before the scheduler.
        // The wait is bounded; after a timeout or a lost device the resources are leaked
        // (`Context::has_failed`) rather than freed under the GPU.
        if !self.ctx.has_failed() {
            let _ = self.scheduler.wait_idle();
        }
    }
}

/// A scene without geometry in the box [0, 2]^3 with the given lights (unit tests).
#[cfg(test)]
pub(crate) fn test_scene(lights: Vec<crate::scene::LightKind>) -> Scene {
    use crate::scene::{Aabb, Camera, Light, Motion, RenderSettings};
    use glam::Vec3;
    Scene {
        sky: None,
        path: std::path::PathBuf::from("test"),
        name: "test".into(),
        meshes: vec![],
        objects: vec![],
        materials: vec![],
        textures: vec![],
        camera: Camera { position: Vec3::Z, target: Vec3::ZERO, up: Vec3::Y, fov_y_deg: 45.0, near: 0.1, far: 10.0 },
        lights: lights
            .into_iter()
            .map(|kind| Light { name: "l".into(), kind, cast_shadows: false, motion: Motion::None })
            .collect(),
        settings: RenderSettings::default(),
        bounds: Some(Aabb { min: Vec3::ZERO, max: Vec3::splat(2.0) }),
    }
}
