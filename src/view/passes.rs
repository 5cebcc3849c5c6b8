//! The three passes the viewer adds after the frame's own: copy the display image into the
//! UI's sRGB image, draw the UI (which shows that image) into the swapchain image, and hand
//! the swapchain image to the presentation engine. Their barriers come from their declared
//! uses, like every pass's.

use crate::gpu::{Access, Context, Image};
use crate::render::graph::{BinarySemaphores, Pass, Use};
use ash::vk;
use std::cell::RefCell;
use std::sync::Arc;

/// The display image (sRGB-encoded bytes in a UNORM format) copied into an `R8G8B8A8_SRGB`
/// image of the same size, which the UI samples: sampling it decodes to linear, and the UI's
/// sRGB target encodes again.
pub struct CopyPass {
    pub display: Arc<Image>,
    pub view: Arc<Image>,
}

impl Pass for CopyPass {
    fn name(&self) -> &str {
        "view copy"
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        vec![Use::image(&self.display, Access::TransferRead), Use::overwrite(&self.view, Access::TransferWrite)]
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let e = self.display.desc.extent;
        let layers = vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        };
        let region =
            vk::ImageCopy { src_subresource: layers, dst_subresource: layers, extent: e, ..Default::default() };
        unsafe {
            ctx.device.cmd_copy_image(
                cmd,
                self.display.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                self.view.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            )
        };
    }
}

/// What the UI pass draws: egui's triangles for this frame.
pub struct UiDraw<'a> {
    pub renderer: &'a RefCell<super::UiRenderer>,
    pub primitives: &'a [egui::ClippedPrimitive],
    pub pixels_per_point: f32,
    /// Where recording failed (a pass cannot return an error): said after the frame.
    pub error: &'a RefCell<Option<String>>,
}

/// The UI (with the frame as one of its images) drawn over a cleared swapchain image. Its
/// submit waits for the image's acquisition before drawing.
pub struct UiPass<'a> {
    pub target: Arc<Image>,
    pub view: Arc<Image>,
    pub acquired: vk::Semaphore,
    pub draw: UiDraw<'a>,
}

impl Pass for UiPass<'_> {
    fn name(&self) -> &str {
        "ui"
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        vec![
            Use::image(&self.view, Access::FragmentShaderReadSampled),
            Use::overwrite(&self.target, Access::ColorAttachmentWrite),
        ]
    }
    fn semaphores(&self) -> BinarySemaphores {
        BinarySemaphores { wait: Some((self.acquired, vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT)), signal: None }
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let e = self.target.desc.extent;
        let extent = vk::Extent2D { width: e.width, height: e.height };
        let clear = vk::ClearValue { color: vk::ClearColorValue { float32: [0.02, 0.02, 0.025, 1.0] } };
        let attachment = [vk::RenderingAttachmentInfo::default()
            .image_view(self.target.view)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(clear)];
        let info = vk::RenderingInfo::default()
            .render_area(vk::Rect2D { offset: vk::Offset2D::default(), extent })
            .layer_count(1)
            .color_attachments(&attachment);
        unsafe { ctx.device.cmd_begin_rendering(cmd, &info) };
        let d = &self.draw;
        if let Err(e) = d.renderer.borrow_mut().cmd_draw(cmd, extent, d.pixels_per_point, d.primitives) {
            *d.error.borrow_mut() = Some(e.to_string());
        }
        unsafe { ctx.device.cmd_end_rendering(cmd) };
    }
}

/// Records nothing: moves the swapchain image to the presentation layout, and its submit
/// signals the semaphore the presentation waits for.
pub struct PresentPass {
    pub target: Arc<Image>,
    pub rendered: vk::Semaphore,
}

impl Pass for PresentPass {
    fn name(&self) -> &str {
        "present"
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        vec![Use::image(&self.target, Access::Present)]
    }
    fn semaphores(&self) -> BinarySemaphores {
        BinarySemaphores { wait: None, signal: Some(self.rendered) }
    }
    fn record(&self, _ctx: &Context, _cmd: vk::CommandBuffer) {}
}
