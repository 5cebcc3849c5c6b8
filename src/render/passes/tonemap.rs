//! Display transform (compute): radiance * 2^EV -> tone map -> sRGB 8-bit.

use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, Image, Pipeline};
use crate::render::graph::{Pass, Use};
use crate::render::FrameBuffers;
use ash::vk;
use std::sync::Arc;

pub const DISPLAY_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

pub struct TonemapPass {
    frame: FrameBuffers,
    radiance: Arc<Image>,
    pub display: Arc<Image>,
    pipeline: Pipeline,
    set: DescriptorSet,
}

impl TonemapPass {
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        radiance: &Arc<Image>,
        display: &Arc<Image>,
    ) -> GpuResult<Self> {
        let set = DescriptorSet::new(
            ctx,
            "tonemap",
            vk::ShaderStageFlags::COMPUTE,
            &[Bind::Uniform(&frame.uniforms), Bind::StorageImage(radiance.view), Bind::StorageImage(display.view)],
        )?;
        let pipeline = Pipeline::compute(ctx, "tonemap", shaders::TONEMAP_COMP, &[set.layout], 0, &[])?;
        Ok(TonemapPass { frame: frame.clone(), radiance: radiance.clone(), display: display.clone(), pipeline, set })
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
        ];
        uses.extend(self.frame.reads(Access::ComputeShaderReadBuffer));
        uses
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.dispatch_pixels(cmd, &self.display);
    }
}
