//! Display transform (compute): radiance * 2^EV (plus the exposure passes' EV where it is
//! "auto") -> tone map -> sRGB 8-bit.

use crate::gpu::{shaders, Access, Bind, Buffer, Context, DescriptorSet, GpuResult, Image, Pipeline};
use crate::render::graph::{Pass, Use};
use crate::render::FrameBuffers;
use ash::vk;
use std::sync::Arc;

pub const DISPLAY_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

pub struct TonemapPass {
    frame: FrameBuffers,
    radiance: Arc<Image>,
    pub display: Arc<Image>,
    exposure: Arc<Buffer>,
    pipeline: Pipeline,
    set: DescriptorSet,
}

impl TonemapPass {
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        radiance: &Arc<Image>,
        display: &Arc<Image>,
        exposure: &Arc<Buffer>,
    ) -> GpuResult<Self> {
        let set = DescriptorSet::new(
            ctx,
            "tonemap",
            vk::ShaderStageFlags::COMPUTE,
            &[
                Bind::Uniform(&frame.uniforms),
                Bind::StorageImage(radiance.view),
                Bind::StorageImage(display.view),
                Bind::Storage(exposure),
            ],
        )?;
        let pipeline = Pipeline::compute(ctx, "tonemap", shaders::TONEMAP_COMP, &[set.layout], 0, &[])?;
        Ok(TonemapPass {
            frame: frame.clone(),
            radiance: radiance.clone(),
            display: display.clone(),
            exposure: exposure.clone(),
            pipeline,
            set,
        })
    }
}

impl Pass for TonemapPass {
    fn name(&self) -> &str {
        "tonemap"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let mut uses = vec![
            Use::image(&self.radiance, Access::ComputeShaderReadStorage),
            Use::overwrite(&self.display, Access::ComputeShaderWrite),
            Use::buffer(&self.exposure, Access::ComputeShaderReadBuffer),
        ];
        uses.extend(self.frame.reads(Access::ComputeShaderReadBuffer));
        uses
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.dispatch_pixels(cmd, &self.display);
    }
}
