//! Copies the HDR radiance and the 8-bit display image into host-visible buffers, then
//! makes them visible to the host. Only in frames whose output is read back.

use crate::gpu::{Access, Buffer, Context, GpuResult, Image};
use crate::render::graph::{Pass, Use};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

pub struct ReadbackPass {
    radiance: Arc<Image>,
    display: Arc<Image>,
    pub radiance_buffer: Arc<Buffer>,
    pub display_buffer: Arc<Buffer>,
}

fn bytes_per_pixel(format: vk::Format) -> u64 {
    match format {
        vk::Format::R32G32B32A32_SFLOAT => 16,
        vk::Format::R16G16B16A16_SFLOAT => 8,
        _ => 4,
    }
}

impl ReadbackPass {
    pub fn new(ctx: &Arc<Context>, radiance: &Arc<Image>, display: &Arc<Image>) -> GpuResult<Self> {
        let size = |img: &Image| {
            img.desc.extent.width as u64 * img.desc.extent.height as u64 * bytes_per_pixel(img.desc.format)
        };
        Ok(ReadbackPass {
            radiance_buffer: Arc::new(Buffer::new(
                ctx,
                "radiance readback",
                size(radiance),
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?),
            display_buffer: Arc::new(Buffer::new(
                ctx,
                "display readback",
                size(display),
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?),
            radiance: radiance.clone(),
            display: display.clone(),
        })
    }
}

fn copy(ctx: &Context, cmd: vk::CommandBuffer, img: &Image, buf: &Buffer) {
    let region = vk::BufferImageCopy {
        buffer_offset: 0,
        buffer_row_length: 0,
        buffer_image_height: 0,
        image_subresource: vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        },
        image_offset: vk::Offset3D::default(),
        image_extent: img.desc.extent,
    };
    unsafe {
        ctx.device.cmd_copy_image_to_buffer(cmd, img.raw, vk::ImageLayout::TRANSFER_SRC_OPTIMAL, buf.raw, &[region])
    };
}

impl Pass for ReadbackPass {
    fn name(&self) -> &str {
        "readback"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        vec![
            Use::read_image(&self.radiance, Access::TransferRead),
            Use::read_image(&self.display, Access::TransferRead),
            Use::buffer(&self.radiance_buffer, Access::TransferWrite),
            Use::buffer(&self.display_buffer, Access::TransferWrite),
        ]
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        copy(ctx, cmd, &self.radiance, &self.radiance_buffer);
        copy(ctx, cmd, &self.display, &self.display_buffer);
    }
}

/// Records nothing: declares the host reads so the tracker makes the copies host-visible.
pub struct HostReadPass {
    pub buffers: [Arc<Buffer>; 2],
}

impl HostReadPass {
    pub fn new(readback: &ReadbackPass) -> Self {
        HostReadPass { buffers: [readback.radiance_buffer.clone(), readback.display_buffer.clone()] }
    }
}

impl Pass for HostReadPass {
    fn name(&self) -> &str {
        "host read"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        self.buffers.iter().map(|b| Use::buffer(b, Access::HostRead)).collect()
    }
    fn record(&self, _ctx: &Context, _cmd: vk::CommandBuffer) {}
}
