//! Copies images into host-visible buffers and makes them visible to the host: the frame's
//! HDR radiance and 8-bit display image (only in frames whose output is read back), and any
//! other image on demand (volumes in tests and debugging).

use crate::gpu::{Access, Buffer, Context, GpuResult, Image};
use crate::render::graph::{Pass, QueueKind, Use};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

pub fn bytes_per_texel(format: vk::Format) -> u64 {
    match format {
        vk::Format::R32G32B32A32_SFLOAT | vk::Format::R32G32B32A32_UINT => 16,
        vk::Format::R16G16B16A16_SFLOAT => 8,
        vk::Format::R8_UINT | vk::Format::R8_UNORM => 1,
        _ => 4,
    }
}

/// Copy of one image (one mip level, every layer and depth slice, layer after layer) into a new
/// host-visible buffer.
pub struct ImageDownload {
    image: Arc<Image>,
    level: u32,
    extent: vk::Extent3D,
    pub buffer: Arc<Buffer>,
    name: String,
    /// Part of the frame's tail: on the compute queue in `async-pipelined`.
    tail: bool,
}

impl ImageDownload {
    /// Mip level 0.
    pub fn new(ctx: &Arc<Context>, image: &Arc<Image>) -> GpuResult<Self> {
        Self::level(ctx, image, 0)
    }

    pub fn level(ctx: &Arc<Context>, image: &Arc<Image>, level: u32) -> GpuResult<Self> {
        let full = image.desc.extent;
        let shrink = |v: u32| (v >> level).max(1);
        let e = vk::Extent3D { width: shrink(full.width), height: shrink(full.height), depth: shrink(full.depth) };
        let texels = e.width as u64 * e.height as u64 * e.depth as u64 * image.desc.layers as u64;
        let size = texels * bytes_per_texel(image.desc.format);
        Ok(ImageDownload {
            buffer: Arc::new(Buffer::new(
                ctx,
                &format!("{} readback", image.name),
                size,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?),
            image: image.clone(),
            level,
            extent: e,
            name: format!("readback {} level {level}", image.name),
            tail: false,
        })
    }

    /// The bytes of the last completed copy.
    pub fn bytes(&self) -> &[u8] {
        let e = self.extent;
        let texels = e.width as usize * e.height as usize * e.depth as usize * self.image.desc.layers as usize;
        let n = texels * bytes_per_texel(self.image.desc.format) as usize;
        &self.buffer.mapped().expect("host-visible readback")[..n]
    }
}

impl Pass for ImageDownload {
    fn name(&self) -> &str {
        &self.name
    }
    fn pipelined_queue(&self) -> QueueKind {
        if self.tail {
            QueueKind::Compute
        } else {
            self.queue()
        }
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        vec![Use::image(&self.image, Access::TransferRead), Use::buffer(&self.buffer, Access::TransferWrite)]
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        unsafe {
            ctx.device.cmd_copy_image_to_buffer(
                cmd,
                self.image.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                self.buffer.raw,
                &[vk::BufferImageCopy {
                    image_subresource: vk::ImageSubresourceLayers {
                        mip_level: self.level,
                        layer_count: self.image.desc.layers,
                        ..self.image.copy_region().image_subresource
                    },
                    image_extent: self.extent,
                    ..self.image.copy_region()
                }],
            )
        };
    }
}

/// Records nothing: declares the host reads so the tracker makes the copies host-visible.
pub struct HostReadPass {
    pub buffers: Vec<Arc<Buffer>>,
    /// Part of the frame's tail: on the compute queue in `async-pipelined`.
    pub tail: bool,
}

impl Pass for HostReadPass {
    fn name(&self) -> &str {
        "host read"
    }
    fn pipelined_queue(&self) -> QueueKind {
        if self.tail {
            QueueKind::Compute
        } else {
            self.queue()
        }
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        self.buffers.iter().map(|b| Use::buffer(b, Access::HostRead)).collect()
    }
    fn record(&self, _ctx: &Context, _cmd: vk::CommandBuffer) {}
}

/// The frame's outputs: radiance and display image.
pub struct ReadbackPasses {
    pub radiance: ImageDownload,
    pub display: ImageDownload,
    pub host: HostReadPass,
}

impl ReadbackPasses {
    pub fn new(ctx: &Arc<Context>, radiance: &Arc<Image>, display: &Arc<Image>) -> GpuResult<Self> {
        let radiance = ImageDownload { tail: true, ..ImageDownload::new(ctx, radiance)? };
        let display = ImageDownload { tail: true, ..ImageDownload::new(ctx, display)? };
        let host = HostReadPass { buffers: vec![radiance.buffer.clone(), display.buffer.clone()], tail: true };
        Ok(ReadbackPasses { radiance, display, host })
    }
}
