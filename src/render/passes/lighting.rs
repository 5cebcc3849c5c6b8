//! Deferred direct lighting (compute): G-buffer + lights + shadow maps -> HDR radiance.

use super::gbuffer::GBuffer;
use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, Image, Pipeline, Sampler};
use crate::render::graph::{Pass, Use};
use crate::render::FrameBuffers;
use ash::vk;
use std::sync::Arc;

/// Hardware depth comparison with bilinear filtering; outside the map counts as lit.
pub fn shadow_sampler_info() -> vk::SamplerCreateInfo<'static> {
    vk::SamplerCreateInfo::default()
        .mag_filter(vk::Filter::LINEAR)
        .min_filter(vk::Filter::LINEAR)
        .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_BORDER)
        .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_BORDER)
        .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_BORDER)
        .border_color(vk::BorderColor::FLOAT_OPAQUE_WHITE)
        .compare_enable(true)
        .compare_op(vk::CompareOp::LESS_OR_EQUAL)
}

pub struct LightingPass {
    gbuffer: Arc<GBuffer>,
    shadow_atlas: Arc<Image>,
    pub radiance: Arc<Image>,
    pipeline: Pipeline,
    set: DescriptorSet,
    _samplers: (Sampler, Sampler),
}

impl LightingPass {
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        gbuffer: &Arc<GBuffer>,
        shadow_atlas: &Arc<Image>,
        radiance: &Arc<Image>,
    ) -> GpuResult<Self> {
        let point = Sampler::new(
            ctx,
            "gbuffer sampler",
            &vk::SamplerCreateInfo::default()
                .mag_filter(vk::Filter::NEAREST)
                .min_filter(vk::Filter::NEAREST)
                .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE),
        )?;
        let compare = Sampler::new(ctx, "shadow compare sampler", &shadow_sampler_info())?;
        let ro = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let depth_ro = vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL;
        let set = DescriptorSet::new(
            ctx,
            "deferred lighting",
            vk::ShaderStageFlags::COMPUTE,
            &[
                Bind::Uniform(&frame.uniforms),
                Bind::Storage(&frame.lights),
                Bind::Storage(&frame.shadow_views),
                Bind::Sampled(gbuffer.depth.view, point.raw, depth_ro),
                Bind::Sampled(gbuffer.albedo.view, point.raw, ro),
                Bind::Sampled(gbuffer.normal.view, point.raw, ro),
                Bind::Sampled(gbuffer.specular.view, point.raw, ro),
                Bind::Sampled(gbuffer.emission.view, point.raw, ro),
                Bind::Sampled(shadow_atlas.view, compare.raw, depth_ro),
                Bind::StorageImage(radiance.view),
            ],
        )?;
        let pipeline =
            Pipeline::compute(ctx, "deferred lighting", shaders::DEFERRED_LIGHT_COMP, &[set.layout], 0, &[])?;
        Ok(LightingPass {
            gbuffer: gbuffer.clone(),
            shadow_atlas: shadow_atlas.clone(),
            radiance: radiance.clone(),
            pipeline,
            set,
            _samplers: (point, compare),
        })
    }
}

impl Pass for LightingPass {
    fn name(&self) -> &str {
        "deferred lighting"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let g = &self.gbuffer;
        vec![
            Use::image(&g.depth, Access::ComputeShaderReadDepth),
            Use::image(&g.albedo, Access::ComputeShaderReadSampled),
            Use::image(&g.normal, Access::ComputeShaderReadSampled),
            Use::image(&g.specular, Access::ComputeShaderReadSampled),
            Use::image(&g.emission, Access::ComputeShaderReadSampled),
            Use::image(&self.shadow_atlas, Access::ComputeShaderReadDepth),
            Use::overwrite(&self.radiance, Access::ComputeShaderWrite),
        ]
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        let e = self.radiance.extent2d();
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.dispatch(cmd, [e.width, e.height, 1], [8, 8, 1]);
    }
}
