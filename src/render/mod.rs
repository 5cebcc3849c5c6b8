//! The renderer: scene upload, per-frame data, and frame submission. What a frame runs is in
//! [`frame`]; how barriers are derived is in [`graph`].

pub mod cones;
pub mod frame;
pub mod graph;
pub mod lights;
pub mod passes;
pub mod scene_gpu;
pub mod voxel;

use crate::gpu::{Buffer, Context, GpuError, GpuResult, VkContext};
use crate::scene::{GiMode, Scene, ToneMap, View, VoxelOcclusion};
use ash::vk;
use bytemuck::{Pod, Zeroable};
use frame::{FramePasses, FrameState};
use gpu_allocator::MemoryLocation;
use graph::{PassTime, PassTimer, StateTracker};
use scene_gpu::SceneGpu;
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
}

/// Host-written per-frame data, shared by the passes.
pub struct FrameBuffers {
    pub uniforms: Buffer,
    pub lights: Buffer,
    pub shadow_views: Buffer,
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

/// Timing of one frame: host wall clock around record+submit+wait, and GPU timestamps.
#[derive(Debug, Clone)]
pub struct FrameStats {
    pub host_ms: f64,
    pub passes: Vec<PassTime>,
}

pub struct Renderer {
    pub ctx: Arc<Context>,
    pub scene: Scene,
    scene_gpu: Arc<SceneGpu>,
    frame_buffers: FrameBuffers,
    passes: FramePasses,
    tracker: StateTracker,
    timer: PassTimer,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    width: u32,
    height: u32,
    /// Static geometry has been voxelized (by a completed frame).
    static_voxelized: bool,
    /// Frames rendered so far (for the voxel update policy).
    frame_index: u64,
    /// The voxels are updated on the next frame whatever the policy says.
    update_requested: bool,
    /// The lights as last written, to relight the voxels when they change.
    last_lights: Vec<u8>,
    /// Whether the next frame relights (lights changed since the last relight).
    lights_changed: bool,
    /// Barriers of the last recorded frame, described (for `--verbose` and tests).
    pub last_barriers: Vec<String>,
    /// Passes of the last rendered frame, in order.
    last_passes: Vec<String>,
}

impl Renderer {
    pub fn new(ctx: &Arc<Context>, scene: Scene) -> GpuResult<Renderer> {
        let s = &scene.settings;
        let (width, height) = (s.width, s.height);
        let max2d = ctx.info.limits.max_image_dimension2_d;
        if width == 0 || height == 0 || width > max2d || height > max2d {
            return Err(GpuError::Limit(format!(
                "image size {width}x{height} is outside 1..={max2d} (this device's maxImageDimension2D)"
            )));
        }
        if s.shadow_map_size > max2d {
            return Err(GpuError::Limit(format!(
                "render.shadow_map_size {} exceeds this device's maxImageDimension2D = {max2d}",
                s.shadow_map_size
            )));
        }
        let scene_gpu = Arc::new(SceneGpu::new(ctx, &scene)?);
        let shadow_views = lights::shadow_view_count(&scene);
        let frame_buffers = FrameBuffers {
            uniforms: Buffer::new(
                ctx,
                "frame uniforms",
                std::mem::size_of::<FrameUniforms>() as u64,
                vk::BufferUsageFlags::UNIFORM_BUFFER,
                MemoryLocation::CpuToGpu,
            )?,
            lights: Buffer::new(
                ctx,
                "lights",
                (scene.lights.len().max(1) * std::mem::size_of::<lights::GpuLight>()) as u64,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::CpuToGpu,
            )?,
            shadow_views: Buffer::new(
                ctx,
                "shadow views",
                (shadow_views.max(1) as usize * std::mem::size_of::<lights::GpuShadowView>()) as u64,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::CpuToGpu,
            )?,
        };
        // Shadow maps only where something samples them: direct light (unless cones shadow
        // every shadowed light) or voxel lighting with shadow-map occlusion.
        let voxel_lighting = s.gi.mode == GiMode::Vct || matches!(s.view, View::VoxelRadiance | View::VoxelMip);
        let direct_maps = !frame::cone_shadows(&scene) || scene.lights.len() > 4;
        let voxel_maps = voxel_lighting && s.gi.occlusion == VoxelOcclusion::ShadowMap;
        let map_views = if direct_maps || voxel_maps { shadow_views } else { 0 };
        let passes = FramePasses::new(ctx, &scene, &scene_gpu, &frame_buffers, map_views)?;
        let timer = PassTimer::new(ctx, 128)?;
        let d = &ctx.device;
        let pool = unsafe {
            d.create_command_pool(
                &vk::CommandPoolCreateInfo::default()
                    .queue_family_index(ctx.graphics_queue.family)
                    .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
                None,
            )
        }
        .vk("vkCreateCommandPool")?;
        ctx.name_object(pool, "frame command pool");
        let mut me = Renderer {
            ctx: ctx.clone(),
            scene,
            scene_gpu,
            frame_buffers,
            passes,
            tracker: StateTracker::default(),
            timer,
            pool,
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            width,
            height,
            static_voxelized: false,
            frame_index: 0,
            update_requested: false,
            last_lights: Vec::new(),
            lights_changed: true,
            last_barriers: Vec::new(),
            last_passes: Vec::new(),
        };
        me.cmd = unsafe {
            d.allocate_command_buffers(
                &vk::CommandBufferAllocateInfo::default()
                    .command_pool(pool)
                    .level(vk::CommandBufferLevel::PRIMARY)
                    .command_buffer_count(1),
            )
        }
        .vk("vkAllocateCommandBuffers")?[0];
        ctx.name_object(me.cmd, "frame commands");
        me.fence = unsafe { d.create_fence(&vk::FenceCreateInfo::default(), None) }.vk("vkCreateFence")?;
        ctx.name_object(me.fence, "frame fence");
        Ok(me)
    }

    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Names of the passes the next frame runs, in order.
    pub fn pass_names(&self, readback: bool) -> Vec<String> {
        self.passes.list(self.frame_state(readback)).iter().map(|p| p.name().to_string()).collect()
    }

    fn frame_state(&self, readback: bool) -> FrameState {
        // The update policy: every `update_interval` frames (0: only on request).
        let interval = self.scene.settings.gi.update_interval as u64;
        let due = self.update_requested || (interval > 0 && self.frame_index % interval == 0);
        FrameState {
            static_voxelized: self.static_voxelized,
            revoxelize: due,
            relight: due || self.lights_changed,
            readback,
        }
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

    /// The voxel volumes, when the scene has them.
    pub fn voxels(&self) -> Option<&voxel::VoxelVolumes> {
        self.passes.voxels.as_ref().map(|v| &*v.volumes)
    }

    /// The voxel volumes and cone-tracing targets this scene created (for `info` and tests).
    pub fn images(&self) -> Vec<Arc<crate::gpu::Image>> {
        self.passes.gi_images().into_iter().cloned().collect()
    }

    /// Copy an image of this renderer to the host (waits; for tests and debugging).
    pub fn download(&mut self, image: &Arc<crate::gpu::Image>) -> GpuResult<Vec<u8>> {
        self.download_level(image, 0)
    }

    /// Copy one mip level of an image to the host (waits; for tests and debugging).
    pub fn download_level(&mut self, image: &Arc<crate::gpu::Image>, level: u32) -> GpuResult<Vec<u8>> {
        let ctx = self.ctx.clone();
        let copy = passes::readback::ImageDownload::level(&ctx, image, level)?;
        let host = passes::readback::HostReadPass { buffers: vec![copy.buffer.clone()] };
        self.last_barriers =
            submit(&self.ctx, self.cmd, self.fence, &mut self.tracker, &mut self.timer, &[&copy, &host])?;
        Ok(copy.bytes().to_vec())
    }

    /// Write the per-frame data for scene time `t`.
    fn update(&mut self, t: f32) {
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
        let u = FrameUniforms {
            view: view.to_cols_array_2d(),
            proj: proj.to_cols_array_2d(),
            view_proj: view_proj.to_cols_array_2d(),
            inv_view_proj: view_proj.inverse().to_cols_array_2d(),
            camera_pos: [cam.position.x, cam.position.y, cam.position.z, t],
            counts: [self.width, self.height, self.scene.lights.len() as u32, tonemap],
            shadow: [s.shadow_filter_radius, s.shadow_normal_bias, s.shadow_map_size as f32, 2f32.powf(s.exposure)],
        };
        self.frame_buffers.uniforms.write_pod(&[u]);
        let bounds = self.scene.world_bounds(t);
        let (lights, views) = lights::build(&self.scene, t, bounds, s.shadow_map_size, s.shadow_filter_radius);
        if !lights.is_empty() {
            self.frame_buffers.lights.write_pod(&lights);
        }
        let bytes: &[u8] = bytemuck::cast_slice(&lights);
        if bytes != self.last_lights.as_slice() {
            self.lights_changed = true;
            self.last_lights = bytes.to_vec();
        }
        if !views.is_empty() {
            self.frame_buffers.shadow_views.write_pod(&views);
        }
        self.scene_gpu.update(&self.scene, t);
    }

    /// Render one frame at scene time `t`, wait for it (with a timeout), and return its timing.
    pub fn render(&mut self, t: f32, readback: bool) -> GpuResult<FrameStats> {
        let start = Instant::now();
        let ctx = self.ctx.clone();
        if readback {
            self.passes.ensure_readback(&ctx)?;
        }
        self.update(t);
        let state = self.frame_state(readback);
        let list = self.passes.list(state);
        self.last_passes = list.iter().map(|p| p.name().to_string()).collect();
        self.last_barriers = submit(&ctx, self.cmd, self.fence, &mut self.tracker, &mut self.timer, &list)?;
        if self.passes.voxels.is_some() {
            self.static_voxelized = true;
        }
        if state.relight {
            self.lights_changed = false;
        }
        self.update_requested = false;
        self.frame_index += 1;
        let host_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(FrameStats { host_ms, passes: self.timer.read()? })
    }

    /// The last frame rendered with `readback = true`.
    ///
    /// # Panics
    /// If no frame was rendered with `readback = true`.
    pub fn output(&self) -> FrameOutput {
        let rb = self.passes.readback.as_ref().expect("render(t, true) before output()");
        FrameOutput {
            width: self.width,
            height: self.height,
            radiance: bytemuck::pod_collect_to_vec::<u8, f32>(rb.radiance.bytes()),
            display: rb.display.bytes().to_vec(),
        }
    }
}

/// Record `passes` into `cmd`, submit to the graphics queue and wait for `fence` (with the
/// timeout). Returns the barrier log.
fn submit(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    tracker: &mut StateTracker,
    timer: &mut PassTimer,
    passes: &[&dyn graph::Pass],
) -> GpuResult<Vec<String>> {
    let d = &ctx.device;
    unsafe {
        d.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty()).vk("vkResetCommandBuffer")?;
        d.begin_command_buffer(
            cmd,
            &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
        )
        .vk("vkBeginCommandBuffer")?;
    }
    let log = graph::record_passes(ctx, cmd, tracker, Some(timer), passes);
    unsafe {
        d.end_command_buffer(cmd).vk("vkEndCommandBuffer")?;
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(cmd)];
        let submit = vk::SubmitInfo2::default().command_buffer_infos(&cmds);
        let _g = ctx.submit_lock.lock().unwrap_or_else(|p| p.into_inner());
        d.queue_submit2(ctx.graphics_queue.raw, &[submit], fence).vk("vkQueueSubmit2")?;
    }
    let waited = ctx.wait_fences(&[fence], "the frame");
    unsafe { d.reset_fences(&[fence]) }.vk("vkResetFences")?;
    waited.map(|_| log)
}

impl Drop for Renderer {
    fn drop(&mut self) {
        unsafe {
            let _ = self.ctx.device.device_wait_idle();
            self.ctx.device.destroy_fence(self.fence, None);
            self.ctx.device.destroy_command_pool(self.pool, None);
        }
    }
}
