//! G-buffer by dynamic rendering: depth, linear albedo, normal + shininess, specular, and
//! emission where some material emits.

use crate::gpu::{shaders, Access, Context, GpuResult, GraphicsDesc, Image, ImageDesc, Pipeline, Sampler};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, Use};
use crate::render::scene_gpu::SceneGpu;
use crate::render::FrameBuffers;
use ash::vk;
use std::sync::Arc;

pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
/// The depth prepass's name in pass lists, timings and reports (`render.depth_prepass`).
pub const DEPTH_PREPASS: &str = "depth prepass";
pub const ALBEDO_FORMAT: vk::Format = vk::Format::R8G8B8A8_SRGB;
pub const NORMAL_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
pub const SPECULAR_FORMAT: vk::Format = vk::Format::R8G8B8A8_SRGB;
pub const EMISSION_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;

/// The G-buffer images.
pub struct GBuffer {
    pub depth: Arc<Image>,
    pub albedo: Arc<Image>,
    pub normal: Arc<Image>,
    pub specular: Arc<Image>,
    /// Only where some material emits (`FramePlan::emission`): a target less to write.
    pub emission: Option<Arc<Image>>,
}

impl GBuffer {
    /// The targets, with an emission target where `emission`.
    pub fn new(ctx: &Arc<Context>, width: u32, height: u32, emission: bool) -> GpuResult<GBuffer> {
        // TRANSFER_SRC: tests and debugging read every target back.
        let color =
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_SRC;
        let mk = |name: &str, format, usage| {
            Image::new(ctx, name, ImageDesc::d2(format, width, height, usage)).map(Arc::new)
        };
        Ok(GBuffer {
            depth: mk(
                "gbuffer depth",
                DEPTH_FORMAT,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
                    | vk::ImageUsageFlags::SAMPLED
                    | vk::ImageUsageFlags::TRANSFER_SRC,
            )?,
            albedo: mk("gbuffer albedo", ALBEDO_FORMAT, color)?,
            normal: mk("gbuffer normal", NORMAL_FORMAT, color)?,
            specular: mk("gbuffer specular", SPECULAR_FORMAT, color)?,
            emission: emission.then(|| mk("gbuffer emission", EMISSION_FORMAT, color)).transpose()?,
        })
    }
    /// Point sampling for compute passes that read the G-buffer texel by texel.
    pub fn sampler(ctx: &Arc<Context>) -> GpuResult<Sampler> {
        Sampler::new(
            ctx,
            "gbuffer sampler",
            &vk::SamplerCreateInfo::default()
                .mag_filter(vk::Filter::NEAREST)
                .min_filter(vk::Filter::NEAREST)
                .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE),
        )
    }
    /// The depth and normal that a per-pixel compute pass reads to place its pixel's surface
    /// (two bindings, point-sampled with `sampler`).
    pub fn surface(&self, sampler: vk::Sampler) -> Binds<'_> {
        Binds::new().sampled(&self.depth, sampler, Access::ComputeShaderReadDepth).sampled(
            &self.normal,
            sampler,
            Access::ComputeShaderReadSampled,
        )
    }

    /// The colour targets, in attachment order.
    pub fn colors(&self) -> Vec<&Arc<Image>> {
        [&self.albedo, &self.normal, &self.specular].into_iter().chain(&self.emission).collect()
    }

    /// The emission target, or (where there is none) the albedo to bind in its place: the
    /// reader's EMISSION specialization constant says which.
    pub fn emission_or_albedo(&self) -> &Arc<Image> {
        self.emission.as_ref().unwrap_or(&self.albedo)
    }
}

/// What a G-buffer pass draws. The frame runs `Full`, or `DepthPrepass` then `OverPrepass`
/// (`render.depth_prepass`); `bench --raster-profile` runs all three, to split the pass's time
/// (`render::raster_profile`). Both ways give the same targets: each pixel holds the last drawn
/// of its nearest fragments (depth test LESS_OR_EQUAL), the masked draws after the opaque ones
/// in both, and every pipeline computes the position alike (`invariant gl_Position`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GBufferVariant {
    /// Every draw into every target, depth tested and written.
    Full,
    /// The opaque draws' depth alone: vertex, raster and depth work, no fragment shader.
    DepthPrepass,
    /// Over the prepass's depth: the opaque draws shaded where they are the nearest (depth
    /// tested, not written: each covered pixel shaded once), then the alpha-masked draws as in
    /// `Full`.
    OverPrepass,
}

pub struct GBufferPass {
    pub gbuffer: Arc<GBuffer>,
    variant: GBufferVariant,
    scene: Arc<SceneGpu>,
    frame: FrameBuffers,
    /// The pipeline of the variant's opaque draws.
    pipeline: Pipeline,
    /// `OverPrepass`: the masked draws' pipeline (depth written).
    masked: Option<Pipeline>,
    set: PassSet,
}

const COLOR_FORMATS: [vk::Format; 4] = [ALBEDO_FORMAT, NORMAL_FORMAT, SPECULAR_FORMAT, EMISSION_FORMAT];

/// The G-buffer's pipeline: every target of `gbuffer`, or (`colors` false) depth only; depth
/// written or not.
fn pipeline(
    ctx: &Arc<Context>,
    (scene, gbuffer): (&SceneGpu, &GBuffer),
    set: &PassSet,
    colors: bool,
    depth_write: bool,
) -> GpuResult<Pipeline> {
    let (frag, formats) = match gbuffer.emission {
        Some(_) => (shaders::GBUFFER_FRAG, &COLOR_FORMATS[..]),
        None => (shaders::GBUFFER_NO_EMISSION_FRAG, &COLOR_FORMATS[..3]),
    };
    Pipeline::graphics(
        ctx,
        "gbuffer",
        &GraphicsDesc {
            vertex_attributes: &[0, 1, 2],
            vert: shaders::GBUFFER_VERT,
            geom: None,
            frag: colors.then_some(frag),
            color_formats: if colors { formats } else { &[] },
            depth_format: Some(DEPTH_FORMAT),
            depth_test: true,
            depth_write,
            cull: vk::CullModeFlags::NONE,
            depth_bias: false,
            depth_clamp: false,
            conservative: false,
            spec: &[(0, scene.materials.texture_count())],
        },
        &[set.layout()],
        0,
    )
}

impl GBufferPass {
    /// The frame's G-buffer pass, and with `prepass` the depth prepass it is drawn over.
    pub fn for_frame(
        ctx: &Arc<Context>,
        scene: &Arc<SceneGpu>,
        frame: &FrameBuffers,
        gbuffer: &Arc<GBuffer>,
        prepass: bool,
    ) -> GpuResult<(GBufferPass, Option<GBufferPass>)> {
        if !prepass {
            return Ok((GBufferPass::variant(ctx, scene, frame, gbuffer, GBufferVariant::Full)?, None));
        }
        let over = GBufferPass::variant(ctx, scene, frame, gbuffer, GBufferVariant::OverPrepass)?;
        Ok((over, Some(GBufferPass::variant(ctx, scene, frame, gbuffer, GBufferVariant::DepthPrepass)?)))
    }

    pub fn variant(
        ctx: &Arc<Context>,
        scene: &Arc<SceneGpu>,
        frame: &FrameBuffers,
        gbuffer: &Arc<GBuffer>,
        variant: GBufferVariant,
    ) -> GpuResult<Self> {
        let buffer = Access::GraphicsShaderReadBuffer;
        let set = Binds::new()
            .uniform(&frame.uniforms, buffer)
            .storage(&scene.instances, buffer)
            .extend(scene.materials.binds())
            .sampler(scene.materials.sampler.raw)
            .build(ctx, "gbuffer", vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT)?;
        let g = (&**scene, &**gbuffer);
        let (pipeline, masked) = match variant {
            GBufferVariant::Full => (pipeline(ctx, g, &set, true, true)?, None),
            GBufferVariant::DepthPrepass => (pipeline(ctx, g, &set, false, true)?, None),
            GBufferVariant::OverPrepass => {
                (pipeline(ctx, g, &set, true, false)?, Some(pipeline(ctx, g, &set, true, true)?))
            }
        };
        Ok(GBufferPass {
            gbuffer: gbuffer.clone(),
            variant,
            scene: scene.clone(),
            frame: frame.clone(),
            pipeline,
            masked,
            set,
        })
    }

    /// The same G-buffer drawn as `variant`.
    pub fn with_variant(&self, ctx: &Arc<Context>, variant: GBufferVariant) -> GpuResult<GBufferPass> {
        GBufferPass::variant(ctx, &self.scene, &self.frame, &self.gbuffer, variant)
    }

    /// The colour targets this variant writes, cleared.
    fn color_attachments(&self) -> Vec<vk::RenderingAttachmentInfo<'static>> {
        if self.variant == GBufferVariant::DepthPrepass {
            return Vec::new();
        }
        self.gbuffer
            .colors()
            .iter()
            .map(|img| {
                vk::RenderingAttachmentInfo::default()
                    .image_view(img.view)
                    .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                    .load_op(vk::AttachmentLoadOp::CLEAR)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .clear_value(vk::ClearValue { color: vk::ClearColorValue { float32: [0.0; 4] } })
            })
            .collect()
    }
}

impl Pass for GBufferPass {
    fn name(&self) -> &str {
        // The G-buffer is "gbuffer" whether or not a prepass came first (`bench
        // --raster-profile` labels the variants itself).
        match self.variant {
            GBufferVariant::Full | GBufferVariant::OverPrepass => "gbuffer",
            GBufferVariant::DepthPrepass => DEPTH_PREPASS,
        }
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        let g = &self.gbuffer;
        // Over the prepass the depth is kept; the prepass writes no colour.
        let depth = match self.variant {
            GBufferVariant::OverPrepass => Use::image(&g.depth, Access::DepthAttachmentWrite),
            _ => Use::overwrite(&g.depth, Access::DepthAttachmentWrite),
        };
        let mut uses = vec![depth];
        if self.variant != GBufferVariant::DepthPrepass {
            uses.extend(g.colors().into_iter().map(|c| Use::overwrite(c, Access::ColorAttachmentWrite)));
        }
        uses
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let g = &self.gbuffer;
        let extent = g.depth.extent2d();
        let colors = self.color_attachments();
        let load = match self.variant {
            GBufferVariant::OverPrepass => vk::AttachmentLoadOp::LOAD,
            _ => vk::AttachmentLoadOp::CLEAR,
        };
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(g.depth.view)
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(load)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue { depth_stencil: vk::ClearDepthStencilValue { depth: 1.0, stencil: 0 } });
        let info = vk::RenderingInfo::default()
            .render_area(vk::Rect2D { offset: vk::Offset2D::default(), extent })
            .layer_count(1)
            .color_attachments(&colors)
            .depth_attachment(&depth);
        unsafe {
            ctx.device.cmd_begin_rendering(cmd, &info);
            self.pipeline.bind(cmd, &[self.set.raw()]);
            super::set_viewport(ctx, cmd, extent);
            match (self.variant, &self.masked) {
                (GBufferVariant::Full, _) => {
                    self.scene.draw_where(ctx, cmd, |d| !d.masked);
                    self.scene.draw_where(ctx, cmd, |d| d.masked);
                }
                (GBufferVariant::DepthPrepass, _) => self.scene.draw_where(ctx, cmd, |d| !d.masked),
                (GBufferVariant::OverPrepass, masked) => {
                    self.scene.draw_where(ctx, cmd, |d| !d.masked);
                    if let Some(masked) = masked {
                        masked.bind(cmd, &[self.set.raw()]);
                        self.scene.draw_where(ctx, cmd, |d| d.masked);
                    }
                }
            }
            ctx.device.cmd_end_rendering(cmd);
        }
    }
}
