//! The renderer: scene upload, per-frame data, and frame submission. What a frame runs is in
//! [`frame`]; how barriers are derived is in [`graph`].

pub mod frame;
pub mod graph;
pub mod lights;
pub mod passes;
pub mod scene_gpu;

use crate::gpu::{Buffer, Context, GpuError, GpuResult, VkContext};
use crate::scene::{Scene, ToneMap};
use ash::vk;
use bytemuck::{Pod, Zeroable};
use frame::FramePasses;
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
    /// Barriers of the last recorded frame, described (for `--verbose` and tests).
    pub last_barriers: Vec<String>,
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
        let passes = FramePasses::new(ctx, &scene_gpu, &frame_buffers, width, height, shadow_views, s.shadow_map_size)?;
        let timer = PassTimer::new(ctx, 16)?;
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
            last_barriers: Vec::new(),
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

    /// Names of the passes a frame runs, in order.
    pub fn pass_names(&self, readback: bool) -> Vec<String> {
        self.passes.list(readback).iter().map(|p| p.name().to_string()).collect()
    }

    /// Write the per-frame data for scene time `t`.
    fn update(&self, t: f32) {
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
        let d = &ctx.device;
        unsafe {
            d.reset_command_buffer(self.cmd, vk::CommandBufferResetFlags::empty()).vk("vkResetCommandBuffer")?;
            d.begin_command_buffer(
                self.cmd,
                &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )
            .vk("vkBeginCommandBuffer")?;
        }
        let passes = self.passes.list(readback);
        self.last_barriers = graph::record_passes(&ctx, self.cmd, &mut self.tracker, Some(&mut self.timer), &passes);
        unsafe {
            d.end_command_buffer(self.cmd).vk("vkEndCommandBuffer")?;
            let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(self.cmd)];
            let submit = vk::SubmitInfo2::default().command_buffer_infos(&cmds);
            {
                let _g = ctx.submit_lock.lock().unwrap_or_else(|p| p.into_inner());
                d.queue_submit2(ctx.graphics_queue.raw, &[submit], self.fence).vk("vkQueueSubmit2")?;
            }
        }
        let waited = ctx.wait_fences(&[self.fence], "the frame");
        unsafe { d.reset_fences(&[self.fence]) }.vk("vkResetFences")?;
        waited?;
        let host_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(FrameStats { host_ms, passes: self.timer.read()? })
    }

    /// The last frame rendered with `readback = true`.
    ///
    /// # Panics
    /// If no frame was rendered with `readback = true`.
    pub fn output(&self) -> FrameOutput {
        let (rb, _) = self.passes.readback.as_ref().expect("render(t, true) before output()");
        let n = (self.width * self.height * 4) as usize;
        let radiance_bytes = rb.radiance_buffer.mapped().expect("host-visible readback");
        let display_bytes = rb.display_buffer.mapped().expect("host-visible readback");
        FrameOutput {
            width: self.width,
            height: self.height,
            radiance: bytemuck::pod_collect_to_vec::<u8, f32>(&radiance_bytes[..n * 4]),
            display: display_bytes[..n].to_vec(),
        }
    }
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
