//! Deferred direct lighting (compute): G-buffer + lights + shadow maps -> HDR radiance.

use super::gbuffer::GBuffer;
use super::gi_trace::{GiPlaceholders, GiTargets};
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

/// What the lighting pass writes: the final image or a GI debug view.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightingOutput {
    Final = 0,
    IndirectOnly = 1,
    AmbientOcclusion = 2,
}

impl LightingOutput {
    /// What `render.view` asks the lighting pass for.
    pub fn of(view: crate::scene::View) -> LightingOutput {
        match view {
            crate::scene::View::Indirect => LightingOutput::IndirectOnly,
            crate::scene::View::Ao => LightingOutput::AmbientOcclusion,
            _ => LightingOutput::Final,
        }
    }
}

/// The indirect light of the composite (cone-traced, or gathered from reflective shadow maps).
pub struct GiInputs<'a> {
    pub targets: &'a GiTargets,
    /// The specular target holds ray-traced reflections (not multiplied by the AO factor).
    pub rt_specular: bool,
}

/// What the lighting pass reads and writes.
pub struct LightingInputs<'a> {
    pub gbuffer: &'a Arc<GBuffer>,
    pub shadow_atlas: &'a Arc<Image>,
    /// Written: the shaded radiance.
    pub radiance: &'a Arc<Image>,
    pub gi: Option<GiInputs<'a>>,
    /// Traced visibility of lights 0..3 (shadow cones or rays), in place of their shadow maps.
    pub shadow_visibility: Option<&'a Arc<Image>>,
    pub placeholders: &'a Arc<GiPlaceholders>,
}

pub struct LightingPass {
    frame: FrameBuffers,
    gbuffer: Arc<GBuffer>,
    shadow_atlas: Arc<Image>,
    /// The indirect light's targets and the traced visibility (placeholders where missing).
    gi: GiTargets,
    placeholders: Arc<GiPlaceholders>,
    pub radiance: Arc<Image>,
    pipeline: Pipeline,
    set: DescriptorSet,
    _samplers: (Sampler, Sampler),
}

impl LightingPass {
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        inputs: LightingInputs,
        output: LightingOutput,
    ) -> GpuResult<Self> {
        let LightingInputs { gbuffer, shadow_atlas, radiance, gi, shadow_visibility, placeholders } = inputs;
        // The indirect light's targets (placeholders without GI) and the traced visibility.
        let targets = match &gi {
            Some(g) => GiTargets { shadow: shadow_visibility.cloned(), ..g.targets.clone() },
            None => {
                GiTargets { diffuse: placeholders.color.clone(), specular: None, shadow: shadow_visibility.cloned() }
            }
        };
        let [gd, gs, gsh] = targets.binds(placeholders);
        let point = GBuffer::sampler(ctx)?;
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
                gd,
                gs,
                gsh,
            ],
        )?;
        let rt_specular = gi.as_ref().is_some_and(|g| g.rt_specular);
        let spec = [
            (0, u32::from(gi.is_some())),
            (1, u32::from(targets.specular.is_some() && !rt_specular)),
            (2, u32::from(shadow_visibility.is_some())),
            (3, output as u32),
            (4, u32::from(targets.specular.is_some() && rt_specular)),
        ];
        let pipeline =
            Pipeline::compute(ctx, "deferred lighting", shaders::DEFERRED_LIGHT_COMP, &[set.layout], 0, &spec)?;
        Ok(LightingPass {
            frame: frame.clone(),
            gbuffer: gbuffer.clone(),
            shadow_atlas: shadow_atlas.clone(),
            gi: targets,
            placeholders: placeholders.clone(),
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
        let mut uses = vec![
            Use::image(&g.depth, Access::ComputeShaderReadDepth),
            Use::image(&g.albedo, Access::ComputeShaderReadSampled),
            Use::image(&g.normal, Access::ComputeShaderReadSampled),
            Use::image(&g.specular, Access::ComputeShaderReadSampled),
            Use::image(&g.emission, Access::ComputeShaderReadSampled),
            Use::image(&self.shadow_atlas, Access::ComputeShaderReadDepth),
            Use::overwrite(&self.radiance, Access::ComputeShaderWrite),
        ];
        let bound = self.gi.bound(&self.placeholders);
        for (i, image) in bound.iter().enumerate() {
            // Without GI the diffuse and specular placeholders are one image: declared once.
            if !bound[..i].iter().any(|b| Arc::ptr_eq(b, image)) {
                uses.push(Use::image(image, Access::ComputeShaderReadStorage));
            }
        }
        uses.extend(self.frame.reads(Access::ComputeShaderReadBuffer));
        uses
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.dispatch_pixels(cmd, &self.radiance);
    }
}
