//! Per-pixel cone tracing from the G-buffer (compute), at 1/k resolution, and the depth- and
//! normal-aware upsample to full resolution (only when k > 1).

use super::gbuffer::GBuffer;
use crate::gpu::{shaders, Access, Bind, Buffer, Context, GpuResult, Image, ImageDesc, Pipeline, Sampler};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, QueueKind};
use crate::render::sky::SkyGpu;
use crate::render::voxel::VoxelVolumes;
use crate::render::FrameBuffers;
use ash::vk;
use std::sync::Arc;

pub const GI_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
pub const SHADOW_VIS_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

/// The tracer's outputs at one resolution. Missing outputs are bound as 1x1 placeholders that
/// the shaders never touch (specialization constants switch them off).
#[derive(Clone)]
pub struct GiTargets {
    /// rgb: cosine-weighted mean incoming radiance (irradiance / pi); a: AO factor.
    pub diffuse: Arc<Image>,
    /// Specular-cone radiance; only with glossy materials.
    pub specular: Option<Arc<Image>>,
    /// Cone-traced visibility of lights 0..3; only with `gi.shadows = "cone"`.
    pub shadow: Option<Arc<Image>>,
}

/// Stand-ins bound where an output does not exist.
pub struct GiPlaceholders {
    pub color: Arc<Image>,
    pub shadow: Arc<Image>,
}

impl GiPlaceholders {
    pub fn new(ctx: &Arc<Context>) -> GpuResult<GiPlaceholders> {
        let mk = |name: &str, format| {
            Image::new(ctx, name, ImageDesc::d2(format, 1, 1, vk::ImageUsageFlags::STORAGE)).map(Arc::new)
        };
        Ok(GiPlaceholders {
            color: mk("gi placeholder", GI_FORMAT)?,
            shadow: mk("gi shadow placeholder", SHADOW_VIS_FORMAT)?,
        })
    }
}

impl GiTargets {
    pub fn new(
        ctx: &Arc<Context>,
        label: &str,
        width: u32,
        height: u32,
        specular: bool,
        shadow: bool,
    ) -> GpuResult<GiTargets> {
        let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
        let mk = |name: &str, format| {
            Image::new(ctx, &format!("gi {name}{label}"), ImageDesc::d2(format, width, height, usage)).map(Arc::new)
        };
        Ok(GiTargets {
            diffuse: mk("diffuse", GI_FORMAT)?,
            specular: specular.then(|| mk("specular", GI_FORMAT)).transpose()?,
            shadow: shadow.then(|| mk("shadow", SHADOW_VIS_FORMAT)).transpose()?,
        })
    }

    /// Diffuse, specular (or placeholder), shadow (or placeholder).
    pub fn bound<'a>(&'a self, p: &'a GiPlaceholders) -> [&'a Arc<Image>; 3] {
        [&self.diffuse, self.specular.as_ref().unwrap_or(&p.color), self.shadow.as_ref().unwrap_or(&p.shadow)]
    }

    /// Diffuse, specular and shadow as storage images (three bindings, placeholders where
    /// an output does not exist: the shaders never reach them, but they are declared like the
    /// real images so their layout is right), touched with `access`.
    pub fn storage<'a>(&'a self, p: &'a GiPlaceholders, access: Access) -> Binds<'a> {
        let [d, s, sh] = self.bound(p);
        Binds::new().storage_image(d, access).storage_image(s, access).storage_image(sh, access)
    }

    /// Every image, for memory reports.
    pub fn all(&self) -> Vec<&Arc<Image>> {
        [Some(&self.diffuse), self.specular.as_ref(), self.shadow.as_ref()].into_iter().flatten().collect()
    }
}

pub struct GiTracePass {
    pub targets: GiTargets,
    pipeline: Pipeline,
    set: PassSet,
    _sampler: Sampler,
}

impl GiTracePass {
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        gbuffer: &Arc<GBuffer>,
        volumes: &Arc<VoxelVolumes>,
        targets: GiTargets,
        placeholders: &Arc<GiPlaceholders>,
        sky: &SkyGpu,
    ) -> GpuResult<Self> {
        let sampler = GBuffer::sampler(ctx)?;
        let v = volumes;
        let lod0 = v.final_radiance().clone();
        let (buffer, read) = (Access::ComputeShaderReadBuffer, Access::ComputeShaderReadSampled);
        let set = Binds::new()
            .uniform(&frame.uniforms, buffer)
            .storage(&frame.lights, buffer)
            .loaded(Bind::Uniform(&v.grid_buffer))
            .loaded(Bind::Uniform(&v.gi_params))
            .extend(gbuffer.surface(sampler.raw))
            .sampled(&gbuffer.specular, sampler.raw, read)
            .extend(v.cone_volumes(&lod0))
            .extend(targets.storage(placeholders, Access::ComputeShaderWrite))
            .extend(v.brick_maps(Access::ComputeShaderReadStorage))
            .extend(v.pools())
            .extend(sky.cones_bind())
            .build(ctx, "gi trace", vk::ShaderStageFlags::COMPUTE)?;
        let pipeline = Pipeline::compute(
            ctx,
            "gi trace",
            shaders::cone_variant(&ctx.info, shaders::GI_TRACE_COMP, shaders::GI_TRACE_COMP_UNROLLED),
            &[set.layout()],
            0,
            &[
                (0, u32::from(targets.specular.is_some())),
                (1, u32::from(targets.shadow.is_some())),
                (2, v.diffuse_rays),
            ],
        )?;
        Ok(GiTracePass { targets, pipeline, set, _sampler: sampler })
    }
}

impl Pass for GiTracePass {
    fn name(&self) -> &str {
        "cone trace"
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

pub struct GiUpsamplePass {
    pub targets: GiTargets,
    pipeline: Pipeline,
    set: PassSet,
    _sampler: Sampler,
}

impl GiUpsamplePass {
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        gbuffer: &Arc<GBuffer>,
        gi_params: &Buffer,
        low: &GiTargets,
        targets: GiTargets,
        placeholders: &Arc<GiPlaceholders>,
    ) -> GpuResult<Self> {
        let sampler = GBuffer::sampler(ctx)?;
        let set = Binds::new()
            .uniform(&frame.uniforms, Access::ComputeShaderReadBuffer)
            .loaded(Bind::Uniform(gi_params))
            .extend(gbuffer.surface(sampler.raw))
            .extend(low.storage(placeholders, Access::ComputeShaderReadStorage))
            .extend(targets.storage(placeholders, Access::ComputeShaderWrite))
            .build(ctx, "gi upsample", vk::ShaderStageFlags::COMPUTE)?;
        let pipeline = Pipeline::compute(
            ctx,
            "gi upsample",
            shaders::GI_UPSAMPLE_COMP,
            &[set.layout()],
            0,
            &[(0, u32::from(targets.specular.is_some())), (1, u32::from(targets.shadow.is_some()))],
        )?;
        Ok(GiUpsamplePass { targets, pipeline, set, _sampler: sampler })
    }
}

impl Pass for GiUpsamplePass {
    fn name(&self) -> &str {
        "gi upsample"
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

/// `rsm+lpv`: the sum of two reduced-resolution diffuse results (the RSM gather's near field
/// and the volume's far field), the input of the upsample and the lighting pass.
pub struct GiAddPass {
    pub targets: GiTargets,
    pipeline: Pipeline,
    set: PassSet,
}

impl GiAddPass {
    pub fn new(ctx: &Arc<Context>, a: &GiTargets, b: &GiTargets, targets: GiTargets) -> GpuResult<Self> {
        let read = Access::ComputeShaderReadStorage;
        let set = Binds::new()
            .storage_image(&a.diffuse, read)
            .storage_image(&b.diffuse, read)
            .storage_image(&targets.diffuse, Access::ComputeShaderWrite)
            .overwritten()
            .build(ctx, "gi add", vk::ShaderStageFlags::COMPUTE)?;
        let pipeline = Pipeline::compute(ctx, "gi add", shaders::GI_ADD_COMP, &[set.layout()], 0, &[])?;
        Ok(GiAddPass { targets, pipeline, set })
    }
}

impl Pass for GiAddPass {
    fn name(&self) -> &str {
        "gi add"
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
