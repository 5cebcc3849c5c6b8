//! Display transform (compute): radiance * 2^EV (plus the exposure passes' EV where it is
//! "auto") -> tone map -> sRGB 8-bit.

use crate::gpu::{shaders, Access, Buffer, Context, GpuResult, Image, Pipeline};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, QueueKind};
use crate::render::FrameBuffers;
use ash::vk;
use std::sync::Arc;

pub const DISPLAY_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

pub struct TonemapPass {
    pub display: Arc<Image>,
    pipeline: Pipeline,
    set: PassSet,
}

impl TonemapPass {
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        radiance: &Arc<Image>,
        display: &Arc<Image>,
        exposure: &Arc<Buffer>,
    ) -> GpuResult<Self> {
        let set = Binds::new()
            .uniform(&frame.uniforms, Access::ComputeShaderReadBuffer)
            .storage_image(radiance, Access::ComputeShaderReadStorage)
            .storage_image(display, Access::ComputeShaderWrite)
            .overwritten()
            .storage(exposure, Access::ComputeShaderReadBuffer)
            .build(ctx, "tonemap", vk::ShaderStageFlags::COMPUTE)?;
        let pipeline = Pipeline::compute(ctx, "tonemap", shaders::TONEMAP_COMP, &[set.layout()], 0, &[])?;
        Ok(TonemapPass { display: display.clone(), pipeline, set })
    }
}

impl Pass for TonemapPass {
    fn pipelined_queue(&self) -> QueueKind {
        QueueKind::Compute
    }

    fn name(&self) -> &str {
        "tonemap"
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.dispatch_pixels(cmd, &self.display);
    }
}
