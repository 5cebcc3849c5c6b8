//! Ray-traced shadows of the direct light (`gi.shadows = "rt"`, glsl/rt_shadow.comp): a shadow
//! ray per pixel and light (the first four lights) into a visibility image that the lighting
//! pass reads in place of the shadow maps.

use super::gbuffer::GBuffer;
use super::gi_trace::SHADOW_VIS_FORMAT;
use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, Image, ImageDesc, Pipeline, Sampler};
use crate::render::graph::{Pass, QueueKind, Use};
use crate::render::rays::SceneRays;
use crate::render::scene_gpu::SceneGpu;
use crate::render::FrameBuffers;
use ash::vk;
use std::sync::Arc;

pub struct RtShadowPass {
    frame: FrameBuffers,
    gbuffer: Arc<GBuffer>,
    rays: Arc<SceneRays>,
    scene: Arc<SceneGpu>,
    /// Visibility (0 or 1) of lights 0..3 in r, g, b, a, at the G-buffer's size.
    pub visibility: Arc<Image>,
    pipeline: Pipeline,
    set: DescriptorSet,
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
        let ro = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let binds: Vec<Bind> = [
            Bind::Uniform(&frame.uniforms),
            Bind::Storage(&frame.lights),
            Bind::Sampled(gbuffer.depth.view, sampler.raw, vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL),
            Bind::Sampled(gbuffer.albedo.view, sampler.raw, ro),
            Bind::Sampled(gbuffer.specular.view, sampler.raw, ro),
            Bind::StorageImage(visibility.view),
        ]
        .into_iter()
        .chain(rays.binds(scene))
        .collect();
        let set = DescriptorSet::new(ctx, "rt shadows", vk::ShaderStageFlags::COMPUTE, &binds)?;
        let spec = [(0, scene.materials.texture_count())];
        let pipeline = Pipeline::compute(ctx, "rt shadows", shaders::RT_SHADOW_COMP, &[set.layout], 0, &spec)?;
        Ok(RtShadowPass {
            frame: frame.clone(),
            gbuffer: gbuffer.clone(),
            rays: rays.clone(),
            scene: scene.clone(),
            visibility,
            pipeline,
            set,
            _sampler: sampler,
        })
    }
}

impl Pass for RtShadowPass {
    fn name(&self) -> &str {
        "rt shadows"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let g = &self.gbuffer;
        let mut uses = vec![
            Use::image(&g.depth, Access::ComputeShaderReadDepth),
            Use::image(&g.albedo, Access::ComputeShaderReadSampled),
            Use::image(&g.specular, Access::ComputeShaderReadSampled),
            Use::overwrite(&self.visibility, Access::ComputeShaderWrite),
        ];
        uses.extend(self.rays.reads(&self.scene));
        uses.extend(self.frame.reads(Access::ComputeShaderReadBuffer));
        uses
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.dispatch_pixels(cmd, &self.visibility);
    }
}
