//! What the viewer holds on the GPU: the context with its window surface, the swapchain, the
//! one [`Renderer`] (the same as `dvsgi render`'s), the UI's renderer and the sRGB image the UI
//! shows the frame through. Dropped in that order's reverse, after the GPU is idle.

use super::passes::{CopyPass, PresentPass, UiDraw, UiPass};
use super::swapchain::{Acquired, Swapchain};
use super::{UiRenderer, ViewError};
use crate::gpu::{Context, GpuResult, Image, ImageDesc, VkContext};
use crate::render::graph::Pass;
use crate::render::passes::readback::{HostReadPass, ImageDownload};
use crate::render::{FrameStats, Renderer};
use ash::vk;
use std::sync::Arc;

/// The frame as the UI's texture: an sRGB image of the render size, its sampler and descriptor.
pub struct FrameTexture {
    ctx: Arc<Context>,
    pub image: Arc<Image>,
    sampler: vk::Sampler,
    layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    pub id: egui::TextureId,
}

impl FrameTexture {
    pub fn new(ctx: &Arc<Context>, ui: &mut UiRenderer, size: (u32, u32)) -> Result<FrameTexture, ViewError> {
        let usage = vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::SAMPLED;
        let image = Arc::new(Image::new(ctx, "view", ImageDesc::d2(vk::Format::R8G8B8A8_SRGB, size.0, size.1, usage))?);
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE);
        let d = &ctx.device;
        let sampler = unsafe { d.create_sampler(&info, None) }.vk("vkCreateSampler")?;
        let ui_err = |e: egui_ash_renderer::RendererError| ViewError::Ui(e.to_string());
        let layout = egui_ash_renderer::vulkan::create_vulkan_descriptor_set_layout(d).map_err(ui_err)?;
        let pool = egui_ash_renderer::vulkan::create_vulkan_descriptor_pool(d, 1).map_err(ui_err)?;
        let set = egui_ash_renderer::vulkan::create_vulkan_descriptor_set(d, layout, pool, image.view, sampler)
            .map_err(ui_err)?;
        let id = ui.add_user_texture(set);
        Ok(FrameTexture { ctx: ctx.clone(), image, sampler, layout, pool, id })
    }

    /// Forget it in the UI's renderer (before it is dropped).
    pub fn remove_from(&self, ui: &mut UiRenderer) {
        ui.remove_user_texture(self.id);
    }
}

impl Drop for FrameTexture {
    fn drop(&mut self) {
        if self.ctx.has_failed() {
            return;
        }
        let d = &self.ctx.device;
        unsafe {
            d.destroy_descriptor_pool(self.pool, None);
            d.destroy_descriptor_set_layout(self.layout, None);
            d.destroy_sampler(self.sampler, None);
        }
    }
}

/// The UI's renderer, drawing into the swapchain's format with dynamic rendering.
pub fn ui_renderer(ctx: &Context, format: vk::Format, frames_in_flight: usize) -> Result<UiRenderer, ViewError> {
    let mode = egui_ash_renderer::RenderMode::DynamicRendering(egui_ash_renderer::DynamicRendering {
        color_attachment_format: format,
        depth_attachment_format: None,
        stencil_attachment_format: None,
    });
    let srgb = matches!(format, vk::Format::B8G8R8A8_SRGB | vk::Format::R8G8B8A8_SRGB);
    let options =
        egui_ash_renderer::Options { in_flight_frames: frames_in_flight, srgb_framebuffer: srgb, ..Default::default() };
    UiRenderer::with_default_allocator(&ctx.instance, ctx.physical_device, ctx.device.clone(), mode, options)
        .map_err(|e| ViewError::Ui(e.to_string()))
}

/// A command pool on the graphics family, for the UI renderer's texture uploads.
pub struct UploadPool {
    ctx: Arc<Context>,
    pub raw: vk::CommandPool,
}

impl UploadPool {
    pub fn new(ctx: &Arc<Context>) -> GpuResult<UploadPool> {
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.graphics_queue.family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let raw = unsafe { ctx.device.create_command_pool(&info, None) }.vk("vkCreateCommandPool")?;
        Ok(UploadPool { ctx: ctx.clone(), raw })
    }
}

impl Drop for UploadPool {
    fn drop(&mut self) {
        if !self.ctx.has_failed() {
            unsafe { self.ctx.device.destroy_command_pool(self.raw, None) };
        }
    }
}

/// One frame of the viewer: the renderer's frame, then the copy, the UI and the presentation
/// (and, when `capture_window`, a copy of the drawn window read back to the host).
pub struct FrameRequest<'a> {
    pub time: f32,
    pub readback: bool,
    pub capture_window: bool,
    pub draw: UiDraw<'a>,
}

/// Record and submit one frame into the acquired image `a`; the window's pixels (RGBA8 as
/// the swapchain stores them) when asked for.
pub fn render_frame(
    renderer: &mut Renderer,
    texture: &FrameTexture,
    swapchain: &Swapchain,
    a: &Acquired,
    req: FrameRequest,
) -> GpuResult<(FrameStats, Option<Vec<u8>>)> {
    let target = swapchain.images[a.index as usize].clone();
    let ctx = renderer.ctx.clone();
    let copy = CopyPass { display: renderer.display_image().clone(), view: texture.image.clone() };
    let ui = UiPass { target: target.clone(), view: texture.image.clone(), acquired: a.acquired, draw: req.draw };
    let capture = req.capture_window && swapchain.readable;
    let download = if capture { Some(ImageDownload::new(&ctx, &target)?) } else { None };
    let host = download.as_ref().map(|d| HostReadPass { buffers: vec![d.buffer.clone()], tail: false });
    let present = PresentPass { target, rendered: a.rendered };
    let mut passes: Vec<&dyn Pass> = vec![&copy, &ui];
    if let (Some(d), Some(h)) = (&download, &host) {
        passes.push(d);
        passes.push(h);
    }
    passes.push(&present);
    let stats = renderer.render_with(req.time, req.readback || req.capture_window, &passes)?;
    Ok((stats, download.map(|d| d.bytes().to_vec())))
}
