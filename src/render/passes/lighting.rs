//! Deferred direct lighting (compute): G-buffer + lights + shadow maps -> HDR radiance.

use super::gbuffer::GBuffer;
use super::gi_trace::{GiPlaceholders, GiTargets};
use crate::gpu::{shaders, Access, Context, GpuResult, Image, Pipeline, Sampler};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, QueueKind};
use crate::render::sky::SkyGpu;
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
    /// The background.
    pub sky: &'a SkyGpu,
}

pub struct LightingPass {
    pub radiance: Arc<Image>,
    pipeline: Pipeline,
    set: PassSet,
    _samplers: (Sampler, Sampler),
}

impl LightingPass {
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        inputs: LightingInputs,
        output: LightingOutput,
    ) -> GpuResult<Self> {
        let LightingInputs { gbuffer, shadow_atlas, radiance, gi, shadow_visibility, placeholders, sky } = inputs;
        // The indirect light's targets (placeholders without GI) and the traced visibility.
        let targets = match &gi {
            Some(g) => GiTargets { shadow: shadow_visibility.cloned(), ..g.targets.clone() },
            None => {
                GiTargets { diffuse: placeholders.color.clone(), specular: None, shadow: shadow_visibility.cloned() }
            }
        };
        let point = GBuffer::sampler(ctx)?;
        let compare = Sampler::new(ctx, "shadow compare sampler", &shadow_sampler_info())?;
        let (buffer, read, depth) =
            (Access::ComputeShaderReadBuffer, Access::ComputeShaderReadSampled, Access::ComputeShaderReadDepth);
        let set = Binds::new()
            .uniform(&frame.uniforms, buffer)
            .storage(&frame.lights, buffer)
            .storage(&frame.shadow_views, buffer)
            .sampled(&gbuffer.depth, point.raw, depth)
            .sampled(&gbuffer.albedo, point.raw, read)
            .sampled(&gbuffer.normal, point.raw, read)
            .sampled(&gbuffer.specular, point.raw, read)
            .sampled(gbuffer.emission_or_albedo(), point.raw, read)
            .sampled(shadow_atlas, compare.raw, depth)
            .storage_image(radiance, Access::ComputeShaderWrite)
            .overwritten()
            // Without GI the diffuse and specular placeholders are one image (held once).
            .extend(targets.storage(placeholders, Access::ComputeShaderReadStorage))
            .extend(sky.map_bind())
            .build(ctx, "deferred lighting", vk::ShaderStageFlags::COMPUTE)?;
        let rt_specular = gi.as_ref().is_some_and(|g| g.rt_specular);
        let spec = [
            (0, u32::from(gi.is_some())),
            (1, u32::from(targets.specular.is_some() && !rt_specular)),
            (2, u32::from(shadow_visibility.is_some())),
            (3, output as u32),
            (4, u32::from(targets.specular.is_some() && rt_specular)),
            (5, u32::from(gbuffer.emission.is_some())),
        ];
        let pipeline =
            Pipeline::compute(ctx, "deferred lighting", shaders::DEFERRED_LIGHT_COMP, &[set.layout()], 0, &spec)?;
        Ok(LightingPass { radiance: radiance.clone(), pipeline, set, _samplers: (point, compare) })
    }
}

impl Pass for LightingPass {
    fn pipelined_queue(&self) -> QueueKind {
        QueueKind::Compute
    }

    fn name(&self) -> &str {
        "deferred lighting"
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.dispatch_pixels(cmd, &self.radiance);
    }
}
