//! Ray-traced shadows of the direct light (`gi.shadows = "rt"`, glsl/rt_shadow.comp): a shadow
//! ray per pixel and light (the first four lights) into a visibility image that the lighting
//! pass reads in place of the shadow maps.

use super::gbuffer::GBuffer;
use super::gi_trace::SHADOW_VIS_FORMAT;
use crate::gpu::{shaders, Access, Context, GpuResult, Image, ImageDesc, Pipeline, Sampler};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, QueueKind};
use crate::render::rays::SceneRays;
use crate::render::scene_gpu::SceneGpu;
use crate::render::FrameBuffers;
use ash::vk;
use std::sync::Arc;

pub struct RtShadowPass {
    /// Visibility (0 or 1) of lights 0..3 in r, g, b, a, at the G-buffer's size.
    pub visibility: Arc<Image>,
    pipeline: Pipeline,
    set: PassSet,
    _sampler: Sampler,
}

impl RtShadowPass {
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        gbuffer: &Arc<GBuffer>,
        scene: &Arc<SceneGpu>,
        rays: &Arc<SceneRays>,
    ) -> GpuResult<RtShadowPass> {
        let e = gbuffer.depth.desc.extent;
        let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
        let desc = ImageDesc::d2(SHADOW_VIS_FORMAT, e.width, e.height, usage);
        let visibility = Arc::new(Image::new(ctx, "rt shadow visibility", desc)?);
        let sampler = GBuffer::sampler(ctx)?;
        let (buffer, read) = (Access::ComputeShaderReadBuffer, Access::ComputeShaderReadSampled);
        let set = Binds::new()
            .uniform(&frame.uniforms, buffer)
            .storage(&frame.lights, buffer)
            .sampled(&gbuffer.depth, sampler.raw, Access::ComputeShaderReadDepth)
            .sampled(&gbuffer.albedo, sampler.raw, read)
            .sampled(&gbuffer.specular, sampler.raw, read)
            .storage_image(&visibility, Access::ComputeShaderWrite)
            .overwritten()
            .extend(rays.binds(scene))
            .build(ctx, "rt shadows", vk::ShaderStageFlags::COMPUTE)?;
        let spec = [(0, scene.materials.texture_count())];
        let pipeline = Pipeline::compute(ctx, "rt shadows", shaders::RT_SHADOW_COMP, &[set.layout()], 0, &spec)?;
        Ok(RtShadowPass { visibility, pipeline, set, _sampler: sampler })
    }
}

impl Pass for RtShadowPass {
    fn name(&self) -> &str {
        "rt shadows"
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.dispatch_pixels(cmd, &self.visibility);
    }
}
