//! Shadow maps: depth-only renders of the scene, one per shadow view, into the layers of
//! one depth array. Runs only when the scene has a light that casts shadows.

use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, GraphicsDesc, Image, Pipeline};
use crate::render::graph::{Pass, Use};
use crate::render::scene_gpu::SceneGpu;
use crate::render::FrameBuffers;
use ash::vk;
use std::sync::Arc;

pub struct ShadowPass {
    pub atlas: Arc<Image>,
    scene: Arc<SceneGpu>,
    frame: FrameBuffers,
    pipeline: Pipeline,
    set: DescriptorSet,
    /// For alpha-masked draws (only where the scene has some): the depth pipeline plus an
    /// alpha test, which costs the early depth test, so opaque draws keep the plain one.
    masked: Option<(Pipeline, DescriptorSet)>,
    views: u32,
}

fn depth_only<'a>(
    atlas: &Image,
    vert: &'a [u8],
    frag: Option<&'a [u8]>,
    attributes: &'a [u32],
    spec: &'a [(u32, u32)],
) -> GraphicsDesc<'a> {
    GraphicsDesc {
        vertex_attributes: attributes,
        vert,
        geom: None,
        frag,
        color_formats: &[],
        depth_format: Some(atlas.desc.format),
        depth_test: true,
        depth_write: true,
        cull: vk::CullModeFlags::NONE,
        depth_bias: true,
        depth_clamp: true,
        conservative: false,
        spec,
    }
}

impl ShadowPass {
    pub fn new(
        ctx: &Arc<Context>,
        scene: &Arc<SceneGpu>,
        frame: &FrameBuffers,
        atlas: &Arc<Image>,
        views: u32,
    ) -> GpuResult<Self> {
        let set = DescriptorSet::new(
            ctx,
            "shadow",
            vk::ShaderStageFlags::VERTEX,
            &[Bind::Storage(&scene.instances), Bind::Storage(&frame.shadow_views)],
        )?;
        let pipeline = Pipeline::graphics(
            ctx,
            "shadow",
            &depth_only(atlas, shaders::SHADOW_VERT, None, &[0], &[]),
            &[set.layout],
            4,
        )?;
        let masked = if scene.draws.iter().any(|d| d.masked) {
            let [materials, textures] = scene.materials.binds();
            let set = DescriptorSet::new(
                ctx,
                "shadow (masked)",
                vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
                &[
                    Bind::Storage(&scene.instances),
                    Bind::Storage(&frame.shadow_views),
                    materials,
                    textures,
                    scene.materials.sampler_bind(),
                ],
            )?;
            let spec = [(0, scene.materials.texture_count())];
            let desc =
                depth_only(atlas, shaders::SHADOW_MASKED_VERT, Some(shaders::SHADOW_MASKED_FRAG), &[0, 2], &spec);
            Some((Pipeline::graphics(ctx, "shadow (masked)", &desc, &[set.layout], 4)?, set))
        } else {
            None
        };
        Ok(ShadowPass {
            atlas: atlas.clone(),
            scene: scene.clone(),
            frame: frame.clone(),
            pipeline,
            set,
            masked,
            views,
        })
    }
}

impl Pass for ShadowPass {
    fn name(&self) -> &str {
        "shadow maps"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let mut uses = vec![Use::overwrite(&self.atlas, Access::DepthAttachmentWrite), self.scene.instance_reads()];
        uses.extend(self.frame.reads(Access::GraphicsShaderReadBuffer));
        uses
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let extent = self.atlas.extent2d();
        let d = &ctx.device;
        for view in 0..self.views {
            let depth = vk::RenderingAttachmentInfo::default()
                .image_view(self.atlas.layer_views[view as usize])
                .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue { depth_stencil: vk::ClearDepthStencilValue { depth: 1.0, stencil: 0 } });
            let info = vk::RenderingInfo::default()
                .render_area(vk::Rect2D { offset: vk::Offset2D::default(), extent })
                .layer_count(1)
                .depth_attachment(&depth);
            unsafe {
                d.cmd_begin_rendering(cmd, &info);
                self.pipeline.bind(cmd, &[self.set.set]);
                super::set_viewport(ctx, cmd, extent);
                // Constant and slope-scaled bias against acne; the lighting pass adds a
                // normal offset (shadow_normal_bias).
                d.cmd_set_depth_bias(cmd, 1.0, 0.0, 1.5);
                self.pipeline.push(cmd, &view);
                self.scene.draw_where(ctx, cmd, |d| !d.masked);
                if let Some((pipeline, set)) = &self.masked {
                    pipeline.bind(cmd, &[set.set]);
                    pipeline.push(cmd, &view);
                    self.scene.draw_where(ctx, cmd, |d| d.masked);
                }
                d.cmd_end_rendering(cmd);
            }
        }
    }
}
