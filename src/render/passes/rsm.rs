//! Reflective shadow maps (`gi.mode = "rsm"`, Dachsbacher & Stamminger 2005): the scene from
//! each shadowed light's view into flux, normal and position maps (graphics), then one diffuse
//! bounce gathered per traced pixel from those texels (compute, at 1/k resolution like the cone
//! tracer, upsampled by the same pass).

use super::gbuffer::GBuffer;
use super::gi_trace::GiTargets;
use crate::gpu::{
    shaders, Access, Bind, Buffer, Context, GpuResult, GraphicsDesc, Image, ImageDesc, Pipeline, Sampler,
};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, QueueKind, Use};
use crate::render::scene_gpu::SceneGpu;
use crate::render::FrameBuffers;
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// rgb flux (W), a the surface area the texel covers (m², 0 where the texel saw nothing).
pub const FLUX_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
pub const NORMAL_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
pub const POSITION_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

/// One layer per RSM view in each of the map arrays.
pub struct RsmMaps {
    pub flux: Arc<Image>,
    pub normal: Arc<Image>,
    pub position: Arc<Image>,
    pub depth: Arc<Image>,
    /// `[shadow view, light, 0, 0]` per layer (`lights::rsm_views`).
    pub views: Vec<[u32; 4]>,
    /// The same, for the gather (`RsmViews` in rsm_gather.comp).
    pub table: Buffer,
}

impl RsmMaps {
    pub fn new(ctx: &Arc<Context>, size: u32, views: Vec<[u32; 4]>) -> GpuResult<RsmMaps> {
        let layers = views.len() as u32;
        let color =
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_SRC;
        let mk = |name: &str, format, usage| {
            Image::new(ctx, name, ImageDesc::d2_array(format, size, size, layers, usage)).map(Arc::new)
        };
        let table = Buffer::new(
            ctx,
            "rsm views",
            (views.len() * 16) as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
        table.write_pod(&views);
        Ok(RsmMaps {
            flux: mk("rsm flux", FLUX_FORMAT, color)?,
            normal: mk("rsm normal", NORMAL_FORMAT, color)?,
            position: mk("rsm position", POSITION_FORMAT, color)?,
            depth: mk(
                "rsm depth",
                DEPTH_FORMAT,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
            )?,
            views,
            table,
        })
    }

    pub fn colors(&self) -> [&Arc<Image>; 3] {
        [&self.flux, &self.normal, &self.position]
    }

    /// Every image, for memory reports.
    pub fn all(&self) -> Vec<&Arc<Image>> {
        vec![&self.flux, &self.normal, &self.position, &self.depth]
    }
}

/// Renders every RSM view (graphics).
pub struct RsmPass {
    pub maps: Arc<RsmMaps>,
    scene: Arc<SceneGpu>,
    pipeline: Pipeline,
    set: PassSet,
}

impl RsmPass {
    pub fn new(
        ctx: &Arc<Context>,
        scene: &Arc<SceneGpu>,
        frame: &FrameBuffers,
        maps: &Arc<RsmMaps>,
    ) -> GpuResult<Self> {
        let buffer = Access::GraphicsShaderReadBuffer;
        let set = Binds::new()
            .storage(&scene.instances, buffer)
            .storage(&frame.shadow_views, buffer)
            .extend(scene.materials.binds())
            .sampler(scene.materials.sampler.raw)
            .storage(&frame.lights, buffer)
            .build(ctx, "rsm", vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT)?;
        let desc = GraphicsDesc {
            vertex_attributes: &[0, 1, 2],
            vert: shaders::RSM_VERT,
            geom: None,
            frag: Some(shaders::RSM_FRAG),
            color_formats: &[FLUX_FORMAT, NORMAL_FORMAT, POSITION_FORMAT],
            depth_format: Some(DEPTH_FORMAT),
            depth_test: true,
            depth_write: true,
            cull: vk::CullModeFlags::NONE,
            depth_bias: false,
            depth_clamp: true,
            conservative: false,
            spec: &[(0, scene.materials.texture_count())],
        };
        let pipeline = Pipeline::graphics(ctx, "rsm", &desc, &[set.layout()], 16)?;
        Ok(RsmPass { maps: maps.clone(), scene: scene.clone(), pipeline, set })
    }

    fn attachment(view: vk::ImageView, layout: vk::ImageLayout) -> vk::RenderingAttachmentInfo<'static> {
        vk::RenderingAttachmentInfo::default()
            .image_view(view)
            .image_layout(layout)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
    }
}

impl Pass for RsmPass {
    fn name(&self) -> &str {
        "reflective shadow maps"
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        let m = &self.maps;
        let mut uses: Vec<Use> =
            m.colors().into_iter().map(|i| Use::overwrite(i, Access::ColorAttachmentWrite)).collect();
        uses.push(Use::overwrite(&m.depth, Access::DepthAttachmentWrite));
        uses
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let m = &self.maps;
        let extent = m.flux.extent2d();
        let d = &ctx.device;
        for (layer, view) in m.views.iter().enumerate() {
            let clear = vk::ClearValue { color: vk::ClearColorValue { float32: [0.0; 4] } };
            let colors = m.colors().map(|i| {
                Self::attachment(i.layer_views[layer], vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL).clear_value(clear)
            });
            let depth = Self::attachment(m.depth.layer_views[layer], vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
                .clear_value(vk::ClearValue { depth_stencil: vk::ClearDepthStencilValue { depth: 1.0, stencil: 0 } });
            let info = vk::RenderingInfo::default()
                .render_area(vk::Rect2D { offset: vk::Offset2D::default(), extent })
                .layer_count(1)
                .color_attachments(&colors)
                .depth_attachment(&depth);
            unsafe {
                d.cmd_begin_rendering(cmd, &info);
                self.pipeline.bind(cmd, &[self.set.raw()]);
                super::set_viewport(ctx, cmd, extent);
                self.pipeline.push(cmd, view);
                self.scene.draw_all(ctx, cmd);
                d.cmd_end_rendering(cmd);
            }
        }
    }
}

/// Gathers each traced pixel's indirect light from the maps (compute).
pub struct RsmGatherPass {
    pub targets: GiTargets,
    pipeline: Pipeline,
    set: PassSet,
    _sampler: Sampler,
}

impl RsmGatherPass {
    /// `gi_params` carries the downsampling factor (`GiParams.counts.y`); `near` > 0 keeps
    /// only texels nearer than that (world units).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        gbuffer: &Arc<GBuffer>,
        maps: &Arc<RsmMaps>,
        gi_params: &Buffer,
        targets: GiTargets,
        gi: &crate::scene::GiSettings,
        near: f32,
    ) -> GpuResult<Self> {
        let sampler = GBuffer::sampler(ctx)?;
        let (buffer, read) = (Access::ComputeShaderReadBuffer, Access::ComputeShaderReadSampled);
        let set = Binds::new()
            .uniform(&frame.uniforms, buffer)
            .loaded(Bind::Uniform(gi_params))
            .storage(&frame.shadow_views, buffer)
            .loaded(Bind::Storage(&maps.table))
            .extend(gbuffer.surface(sampler.raw))
            .sampled(&maps.flux, sampler.raw, read)
            .sampled(&maps.normal, sampler.raw, read)
            .sampled(&maps.position, sampler.raw, read)
            .storage_image(&targets.diffuse, Access::ComputeShaderWrite)
            .overwritten()
            .build(ctx, "rsm gather", vk::ShaderStageFlags::COMPUTE)?;
        let spec =
            [(0, maps.views.len() as u32), (1, gi.rsm_samples), (2, gi.rsm_radius.to_bits()), (3, near.to_bits())];
        let pipeline = Pipeline::compute(ctx, "rsm gather", shaders::RSM_GATHER_COMP, &[set.layout()], 0, &spec)?;
        Ok(RsmGatherPass { targets, pipeline, set, _sampler: sampler })
    }
}

impl Pass for RsmGatherPass {
    fn name(&self) -> &str {
        "rsm gather"
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.dispatch_pixels(cmd, &self.targets.diffuse);
    }
}
