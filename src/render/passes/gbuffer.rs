//! G-buffer by dynamic rendering: depth, linear albedo, normal + shininess, specular, emission.

use crate::gpu::{
    shaders, Access, Bind, Context, DescriptorSet, GpuResult, GraphicsDesc, Image, ImageDesc, Pipeline, Sampler,
};
use crate::render::graph::{Pass, Use};
use crate::render::scene_gpu::SceneGpu;
use crate::render::FrameBuffers;
use ash::vk;
use std::sync::Arc;

pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
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
    pub emission: Arc<Image>,
}

impl GBuffer {
    pub fn new(ctx: &Arc<Context>, width: u32, height: u32) -> GpuResult<GBuffer> {
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
            emission: mk("gbuffer emission", EMISSION_FORMAT, color)?,
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
    /// The depth and normal that a per-pixel compute pass reads to place its pixel's surface.
    pub fn surface_reads(&self) -> [Use<'_>; 2] {
        [
            Use::image(&self.depth, Access::ComputeShaderReadDepth),
            Use::image(&self.normal, Access::ComputeShaderReadSampled),
        ]
    }

    pub fn colors(&self) -> [&Arc<Image>; 4] {
        [&self.albedo, &self.normal, &self.specular, &self.emission]
    }
}

pub struct GBufferPass {
    pub gbuffer: Arc<GBuffer>,
    scene: Arc<SceneGpu>,
    frame: FrameBuffers,
    pipeline: Pipeline,
    set: DescriptorSet,
}

impl GBufferPass {
    pub fn new(
        ctx: &Arc<Context>,
        scene: &Arc<SceneGpu>,
        frame: &FrameBuffers,
        gbuffer: &Arc<GBuffer>,
    ) -> GpuResult<Self> {
        let [materials, textures] = scene.materials.binds();
        let set = DescriptorSet::new(
            ctx,
            "gbuffer",
            vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
            &[
                Bind::Uniform(&frame.uniforms),
                Bind::Storage(&scene.instances),
                materials,
                textures,
                scene.materials.sampler_bind(),
            ],
        )?;
        let pipeline = Pipeline::graphics(
            ctx,
            "gbuffer",
            &GraphicsDesc {
                vertex_attributes: &[0, 1, 2],
                vert: shaders::GBUFFER_VERT,
                geom: None,
                frag: Some(shaders::GBUFFER_FRAG),
                color_formats: &[ALBEDO_FORMAT, NORMAL_FORMAT, SPECULAR_FORMAT, EMISSION_FORMAT],
                depth_format: Some(DEPTH_FORMAT),
                depth_test: true,
                depth_write: true,
                cull: vk::CullModeFlags::NONE,
                depth_bias: false,
                depth_clamp: false,
                conservative: false,
                spec: &[(0, scene.materials.texture_count())],
            },
            &[set.layout],
            0,
        )?;
        Ok(GBufferPass { gbuffer: gbuffer.clone(), scene: scene.clone(), frame: frame.clone(), pipeline, set })
    }
}

impl Pass for GBufferPass {
    fn name(&self) -> &str {
        "gbuffer"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let g = &self.gbuffer;
        let mut uses = vec![
            Use::overwrite(&g.depth, Access::DepthAttachmentWrite),
            Use::overwrite(&g.albedo, Access::ColorAttachmentWrite),
            Use::overwrite(&g.normal, Access::ColorAttachmentWrite),
            Use::overwrite(&g.specular, Access::ColorAttachmentWrite),
            Use::overwrite(&g.emission, Access::ColorAttachmentWrite),
            self.scene.instance_reads(),
        ];
        uses.extend(self.frame.reads(Access::GraphicsShaderReadBuffer));
        uses
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let g = &self.gbuffer;
        let extent = g.depth.extent2d();
        let colors: Vec<_> = g
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
            .collect();
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(g.depth.view)
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue { depth_stencil: vk::ClearDepthStencilValue { depth: 1.0, stencil: 0 } });
        let info = vk::RenderingInfo::default()
            .render_area(vk::Rect2D { offset: vk::Offset2D::default(), extent })
            .layer_count(1)
            .color_attachments(&colors)
            .depth_attachment(&depth);
        unsafe {
            ctx.device.cmd_begin_rendering(cmd, &info);
            self.pipeline.bind(cmd, &[self.set.set]);
            super::set_viewport(ctx, cmd, extent);
            self.scene.draw_all(ctx, cmd);
            ctx.device.cmd_end_rendering(cmd);
        }
    }
}
