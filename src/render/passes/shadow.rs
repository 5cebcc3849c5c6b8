//! Shadow maps: depth-only renders of the scene, one per shadow view, into the layers of
//! one depth array. Runs only when the scene has a light that casts shadows, and draws only
//! the views whose inputs changed since they were last drawn (`render::reuse`).
//!
//! A view that changed (its light moved, or a cascade with the camera) is drawn with every
//! caster. Where casters move, a view that stands still keeps its static casters in a cache:
//! they are drawn there once, and each frame in which the casters move copies the cache into
//! the maps and draws the moving casters over it. Depth keeps the nearest fragment whatever
//! the order of the draws, so the maps hold the same bytes as one pass over every caster.

use crate::gpu::{shaders, Access, Context, GpuResult, GraphicsDesc, Image, Pipeline};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, Use};
use crate::render::reuse::ShadowCache;
use crate::render::scene_gpu::{Draw, SceneGpu};
use crate::render::FrameBuffers;
use ash::vk;
use std::cell::RefCell;
use std::sync::Arc;

/// Which casters a shadow pass draws, and from what it starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Casters {
    /// Every caster, over cleared views.
    All,
    /// The casters that never move, over cleared views (into the cache).
    Static,
    /// The moving casters, over what the views hold (the copied cache).
    Moving,
}

impl Casters {
    fn draws(self, d: &Draw) -> bool {
        match self {
            Casters::All => true,
            Casters::Static => !d.moving,
            Casters::Moving => d.moving,
        }
    }
}

pub struct ShadowPass {
    name: &'static str,
    pub target: Arc<Image>,
    casters: Casters,
    scene: Arc<SceneGpu>,
    pipeline: Pipeline,
    set: PassSet,
    /// For alpha-masked draws (only where the scene has some): the depth pipeline plus an
    /// alpha test, which costs the early depth test, so opaque draws keep the plain one.
    masked: Option<(Pipeline, PassSet)>,
    views: u32,
    /// The views this frame draws (set before the frame is recorded; every view at first).
    drawn: RefCell<Vec<u32>>,
}

fn depth_only<'a>(
    target: &Image,
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
        depth_format: Some(target.desc.format),
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
    /// Draws `casters` into the `views` layers of `target`.
    pub fn new(
        ctx: &Arc<Context>,
        scene: &Arc<SceneGpu>,
        frame: &FrameBuffers,
        target: &Arc<Image>,
        views: u32,
        casters: Casters,
    ) -> GpuResult<Self> {
        let buffer = Access::GraphicsShaderReadBuffer;
        let set = Binds::new().storage(&scene.instances, buffer).storage(&frame.shadow_views, buffer).build(
            ctx,
            "shadow",
            vk::ShaderStageFlags::VERTEX,
        )?;
        let pipeline = Pipeline::graphics(
            ctx,
            "shadow",
            &depth_only(target, shaders::SHADOW_VERT, None, &[0], &[]),
            &[set.layout()],
            4,
        )?;
        let masked = if scene.draws.iter().any(|d| d.masked && casters.draws(d)) {
            let set = Binds::new()
                .storage(&scene.instances, buffer)
                .storage(&frame.shadow_views, buffer)
                .extend(scene.materials.binds())
                .sampler(scene.materials.sampler.raw)
                .build(ctx, "shadow (masked)", vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT)?;
            let spec = [(0, scene.materials.texture_count())];
            let desc =
                depth_only(target, shaders::SHADOW_MASKED_VERT, Some(shaders::SHADOW_MASKED_FRAG), &[0, 2], &spec);
            Some((Pipeline::graphics(ctx, "shadow (masked)", &desc, &[set.layout()], 4)?, set))
        } else {
            None
        };
        let name = match casters {
            Casters::All => "shadow maps",
            Casters::Static => "shadow maps (static casters)",
            Casters::Moving => "shadow maps (moving casters)",
        };
        Ok(ShadowPass {
            name,
            target: target.clone(),
            casters,
            scene: scene.clone(),
            pipeline,
            set,
            masked,
            views,
            drawn: RefCell::new((0..views).collect()),
        })
    }

    /// Draw `views` on the next frame (none: the pass does not run).
    pub fn set_views(&self, views: &[u32]) {
        *self.drawn.borrow_mut() = views.to_vec();
    }

    /// Whether the next frame draws any view.
    pub fn draws(&self) -> bool {
        !self.drawn.borrow().is_empty()
    }

    /// One view: cleared (or loaded) and drawn.
    fn record_view(&self, ctx: &Context, cmd: vk::CommandBuffer, view: u32) {
        let extent = self.target.extent2d();
        let d = &ctx.device;
        let load =
            if self.casters == Casters::Moving { vk::AttachmentLoadOp::LOAD } else { vk::AttachmentLoadOp::CLEAR };
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(self.target.layer_views[view as usize])
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(load)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue { depth_stencil: vk::ClearDepthStencilValue { depth: 1.0, stencil: 0 } });
        let info = vk::RenderingInfo::default()
            .render_area(vk::Rect2D { offset: vk::Offset2D::default(), extent })
            .layer_count(1)
            .depth_attachment(&depth);
        let casters = self.casters;
        unsafe {
            d.cmd_begin_rendering(cmd, &info);
            self.pipeline.bind(cmd, &[self.set.raw()]);
            super::set_viewport(ctx, cmd, extent);
            // Constant and slope-scaled bias against acne; the lighting pass adds a
            // normal offset (shadow_normal_bias).
            d.cmd_set_depth_bias(cmd, 1.0, 0.0, 1.5);
            self.pipeline.push(cmd, &view);
            self.scene.draw_where(ctx, cmd, |d| !d.masked && casters.draws(d));
            if let Some((pipeline, set)) = &self.masked {
                pipeline.bind(cmd, &[set.raw()]);
                pipeline.push(cmd, &view);
                self.scene.draw_where(ctx, cmd, |d| d.masked && casters.draws(d));
            }
            d.cmd_end_rendering(cmd);
        }
    }
}

impl Pass for ShadowPass {
    fn name(&self) -> &str {
        self.name
    }
    fn sets(&self) -> Vec<&PassSet> {
        std::iter::once(&self.set).chain(self.masked.as_ref().map(|(_, set)| set)).collect()
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        // Views that are not drawn keep what they hold; the moving casters draw over the copy.
        let whole = self.casters != Casters::Moving && self.drawn.borrow().len() as u32 == self.views;
        let target = Use { discard: whole, ..Use::image(&self.target, Access::DepthAttachmentWrite) };
        vec![target]
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        for &view in self.drawn.borrow().iter() {
            self.record_view(ctx, cmd, view);
        }
    }
}

/// The cached maps of the static casters copied into the shadow maps, view by view, for the
/// moving casters to be drawn over.
pub struct ShadowCopyPass {
    pub cache: Arc<Image>,
    pub maps: Arc<Image>,
    views: u32,
    /// The views this frame copies (set before the frame is recorded; every view at first).
    copied: RefCell<Vec<u32>>,
}

impl ShadowCopyPass {
    pub fn new(cache: &Arc<Image>, maps: &Arc<Image>, views: u32) -> ShadowCopyPass {
        ShadowCopyPass { cache: cache.clone(), maps: maps.clone(), views, copied: RefCell::new((0..views).collect()) }
    }

    /// Copy `views` on the next frame.
    pub fn set_views(&self, views: &[u32]) {
        *self.copied.borrow_mut() = views.to_vec();
    }
}

impl Pass for ShadowCopyPass {
    fn name(&self) -> &str {
        "shadow map copy"
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        let whole = self.copied.borrow().len() as u32 == self.views;
        let maps = Use { discard: whole, ..Use::image(&self.maps, Access::TransferWrite) };
        vec![Use::image(&self.cache, Access::TransferRead), maps]
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let layer = |view: u32| vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::DEPTH,
            mip_level: 0,
            base_array_layer: view,
            layer_count: 1,
        };
        let extent = vk::Extent3D { depth: 1, ..self.maps.desc.extent };
        let regions: Vec<vk::ImageCopy> = self
            .copied
            .borrow()
            .iter()
            .map(|&v| vk::ImageCopy {
                src_subresource: layer(v),
                dst_subresource: layer(v),
                extent,
                ..Default::default()
            })
            .collect();
        unsafe {
            ctx.device.cmd_copy_image(
                cmd,
                self.cache.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                self.maps.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &regions,
            )
        };
    }
}

/// With moving casters: the static casters' maps cached, copied into the maps, and the moving
/// casters drawn over the copy.
pub struct CachedCasters {
    /// The static casters' maps of the views that stand still while the casters move.
    pub cache: Arc<Image>,
    pub statics: ShadowPass,
    pub copy: ShadowCopyPass,
    pub moving: ShadowPass,
}

/// The shadow maps' passes and what the maps hold (`reuse::ShadowCache`).
pub struct ShadowMaps {
    /// Every caster, into the views that changed.
    pub all: ShadowPass,
    pub cached: Option<CachedCasters>,
    held: RefCell<ShadowCache>,
    /// Per draw (a row of the instance table): the caster moves.
    moving_rows: Vec<bool>,
}

/// The static casters' maps, one cache for every copy of the frame's maps (`frame::Carried`):
/// drawn and copied on the graphics queue only, so sharing it ties no copy to the compute
/// work of another, and a view that comes to stand still is cached once, as in `sync`.
pub struct StaticCasterCache {
    pub image: Arc<Image>,
    pub held: crate::render::reuse::CacheHeld,
}

impl StaticCasterCache {
    /// Where some caster moves: a cache like the shadow maps `desc` describes.
    pub fn new(ctx: &Arc<Context>, scene: &SceneGpu, desc: crate::gpu::ImageDesc) -> GpuResult<Option<Self>> {
        if !scene.draws.iter().any(|d| d.moving) {
            return Ok(None);
        }
        let image = Arc::new(Image::new(ctx, "shadow maps (static casters)", desc)?);
        Ok(Some(StaticCasterCache { image, held: Default::default() }))
    }
}

impl ShadowMaps {
    /// The passes that draw the `views` layers of `maps`; where casters move, those that draw
    /// the static ones into `cache` and copy it into the maps.
    pub fn new(
        ctx: &Arc<Context>,
        (scene, frame): (&Arc<SceneGpu>, &FrameBuffers),
        maps: &Arc<Image>,
        views: u32,
        cache: Option<&StaticCasterCache>,
    ) -> GpuResult<ShadowMaps> {
        let cached = match cache {
            Some(c) => {
                let c = CachedCasters {
                    statics: ShadowPass::new(ctx, scene, frame, &c.image, views, Casters::Static)?,
                    copy: ShadowCopyPass::new(&c.image, maps, views),
                    moving: ShadowPass::new(ctx, scene, frame, maps, views, Casters::Moving)?,
                    cache: c.image.clone(),
                };
                // The first frame draws every view from scratch.
                c.set_views(&[], &[]);
                Some(c)
            }
            None => None,
        };
        let all = ShadowPass::new(ctx, scene, frame, maps, views, Casters::All)?;
        let moving_rows = scene.draws.iter().map(|d| d.moving).collect();
        let held = RefCell::new(cache.map(|c| ShadowCache::sharing(&c.held)).unwrap_or_default());
        Ok(ShadowMaps { all, cached, held, moving_rows })
    }

    /// Plan the next frame's draws for its `views` and `instances` (the instance table).
    pub fn plan(&self, views: &[crate::render::lights::GpuShadowView], instances: &[u8]) {
        // The instance table has one row per draw, in draw order.
        let row = instances.len() / self.moving_rows.len().max(1);
        let (mut statics, mut moving) = (Vec::new(), Vec::new());
        for (bytes, &moves) in instances.chunks(row.max(1)).zip(&self.moving_rows) {
            if moves { &mut moving } else { &mut statics }.extend_from_slice(bytes);
        }
        let draws = self.held.borrow_mut().plan(views, &statics, &moving);
        self.all.set_views(&draws.all);
        if let Some(c) = &self.cached {
            c.set_views(&draws.statics, &draws.moving);
        }
    }

    /// Forget what the maps and the cache hold: the next plan draws every view.
    pub fn forget(&self) {
        self.held.borrow_mut().forget();
    }

    /// After a frame is recorded: the next one draws what its plan says, else nothing.
    pub fn recorded(&self) {
        self.all.set_views(&[]);
        if let Some(c) = &self.cached {
            c.set_views(&[], &[]);
        }
    }

    /// The passes the next frame runs (none when every view is as drawn).
    pub fn push<'a>(&'a self, passes: &mut Vec<&'a dyn Pass>) {
        if self.all.draws() {
            passes.push(&self.all);
        }
        if let Some(c) = &self.cached {
            if c.statics.draws() {
                passes.push(&c.statics);
            }
            if c.moving.draws() {
                passes.push(&c.copy);
                passes.push(&c.moving);
            }
        }
    }
}

impl CachedCasters {
    fn set_views(&self, statics: &[u32], moving: &[u32]) {
        self.statics.set_views(statics);
        self.copy.set_views(moving);
        self.moving.set_views(moving);
    }
}
