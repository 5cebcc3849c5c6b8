//! Per-pixel cone tracing from the G-buffer (compute), at 1/k resolution, and the depth- and
//! normal-aware upsample to full resolution (only when k > 1).

use super::gbuffer::GBuffer;
use crate::gpu::{
    shaders, Access, Bind, Buffer, Context, DescriptorSet, GpuResult, Image, ImageDesc, Pipeline, Sampler,
};
use crate::render::graph::{Pass, QueueKind, Use};
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

    pub fn binds(&self, p: &GiPlaceholders) -> [Bind<'static>; 3] {
        self.bound(p).map(|i| Bind::StorageImage(i.view))
    }

    /// Uses of everything bound, placeholders included (they are declared like the real
    /// images so their layout is right, although the shaders never reach them).
    pub fn uses<'a>(&'a self, p: &'a GiPlaceholders, access: Access) -> Vec<Use<'a>> {
        self.bound(p).into_iter().map(|i| Use::image(i, access)).collect()
    }

    /// Every image, for memory reports.
    pub fn all(&self) -> Vec<&Arc<Image>> {
        [Some(&self.diffuse), self.specular.as_ref(), self.shadow.as_ref()].into_iter().flatten().collect()
    }
}

pub struct GiTracePass {
    frame: FrameBuffers,
    gbuffer: Arc<GBuffer>,
    volumes: Arc<VoxelVolumes>,
    /// The full-resolution radiance volume sampled below lod 1.
    lod0: Arc<Image>,
    pub targets: GiTargets,
    placeholders: Arc<GiPlaceholders>,
    pipeline: Pipeline,
    set: DescriptorSet,
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
    ) -> GpuResult<Self> {
        let sampler = GBuffer::sampler(ctx)?;
        let ro = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let v = volumes;
        let lod0 = v.final_radiance().clone();
        let [d, s, sh] = targets.binds(placeholders);
        let [pool_images, pool_sampler] = v.pool_binds();
        let set = DescriptorSet::new(
            ctx,
            "gi trace",
            vk::ShaderStageFlags::COMPUTE,
            &[
                Bind::Uniform(&frame.uniforms),
                Bind::Storage(&frame.lights),
                Bind::Uniform(&v.grid_buffer),
                Bind::Uniform(&v.gi_params),
                Bind::Sampled(gbuffer.depth.view, sampler.raw, vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL),
                Bind::Sampled(gbuffer.normal.view, sampler.raw, ro),
                Bind::Sampled(gbuffer.specular.view, sampler.raw, ro),
                Bind::Sampled(lod0.view, v.sampler.raw, ro),
                Bind::SampledArray(v.directional.iter().map(|d| d.view).collect(), v.sampler.raw, ro),
                d,
                s,
                sh,
                v.brick_maps_bind(),
                pool_images,
                pool_sampler,
            ],
        )?;
        let pipeline = Pipeline::compute(
            ctx,
            "gi trace",
            shaders::GI_TRACE_COMP,
            &[set.layout],
            0,
            &[
                (0, u32::from(targets.specular.is_some())),
                (1, u32::from(targets.shadow.is_some())),
                (2, v.diffuse_rays),
            ],
        )?;
        Ok(GiTracePass {
            frame: frame.clone(),
            gbuffer: gbuffer.clone(),
            volumes: volumes.clone(),
            lod0,
            targets,
            placeholders: placeholders.clone(),
            pipeline,
            set,
            _sampler: sampler,
        })
    }
}

impl Pass for GiTracePass {
    fn name(&self) -> &str {
        "cone trace"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let mut uses = self.gbuffer.surface_reads().to_vec();
        uses.push(Use::image(&self.gbuffer.specular, Access::ComputeShaderReadSampled));
        uses.extend(self.volumes.cone_reads(&self.lod0));
        uses.extend(self.targets.uses(&self.placeholders, Access::ComputeShaderWrite));
        uses.extend(self.frame.reads(Access::ComputeShaderReadBuffer));
        uses
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.dispatch_pixels(cmd, &self.targets.diffuse);
    }
}

pub struct GiUpsamplePass {
    frame: FrameBuffers,
    gbuffer: Arc<GBuffer>,
    low: GiTargets,
    pub targets: GiTargets,
    placeholders: Arc<GiPlaceholders>,
    pipeline: Pipeline,
    set: DescriptorSet,
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
        let ro = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let [ld, ls, lsh] = low.binds(placeholders);
        let [d, s, sh] = targets.binds(placeholders);
        let set = DescriptorSet::new(
            ctx,
            "gi upsample",
            vk::ShaderStageFlags::COMPUTE,
            &[
                Bind::Uniform(&frame.uniforms),
                Bind::Uniform(gi_params),
                Bind::Sampled(gbuffer.depth.view, sampler.raw, vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL),
                Bind::Sampled(gbuffer.normal.view, sampler.raw, ro),
                ld,
                ls,
                lsh,
                d,
                s,
                sh,
            ],
        )?;
        let pipeline = Pipeline::compute(
            ctx,
            "gi upsample",
            shaders::GI_UPSAMPLE_COMP,
            &[set.layout],
            0,
            &[(0, u32::from(targets.specular.is_some())), (1, u32::from(targets.shadow.is_some()))],
        )?;
        Ok(GiUpsamplePass {
            frame: frame.clone(),
            gbuffer: gbuffer.clone(),
            low: low.clone(),
            targets,
            placeholders: placeholders.clone(),
            pipeline,
            set,
            _sampler: sampler,
        })
    }
}

impl Pass for GiUpsamplePass {
    fn name(&self) -> &str {
        "gi upsample"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let mut uses = self.gbuffer.surface_reads().to_vec();
        uses.extend(self.low.uses(&self.placeholders, Access::ComputeShaderReadStorage));
        uses.extend(self.targets.uses(&self.placeholders, Access::ComputeShaderWrite));
        uses.extend(self.frame.reads(Access::ComputeShaderReadBuffer));
        uses
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.dispatch_pixels(cmd, &self.targets.diffuse);
    }
}

/// `rsm+lpv`: the sum of two reduced-resolution diffuse results (the RSM gather's near field
/// and the volume's far field), the input of the upsample and the lighting pass.
pub struct GiAddPass {
    parts: [Arc<Image>; 2],
    pub targets: GiTargets,
    pipeline: Pipeline,
    set: DescriptorSet,
}

impl GiAddPass {
    pub fn new(ctx: &Arc<Context>, a: &GiTargets, b: &GiTargets, targets: GiTargets) -> GpuResult<Self> {
        let set = DescriptorSet::new(
            ctx,
            "gi add",
            vk::ShaderStageFlags::COMPUTE,
            &[
                Bind::StorageImage(a.diffuse.view),
                Bind::StorageImage(b.diffuse.view),
                Bind::StorageImage(targets.diffuse.view),
            ],
        )?;
        let pipeline = Pipeline::compute(ctx, "gi add", shaders::GI_ADD_COMP, &[set.layout], 0, &[])?;
        Ok(GiAddPass { parts: [a.diffuse.clone(), b.diffuse.clone()], targets, pipeline, set })
    }
}

impl Pass for GiAddPass {
    fn name(&self) -> &str {
        "gi add"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let mut uses: Vec<Use> = self.parts.iter().map(|i| Use::image(i, Access::ComputeShaderReadStorage)).collect();
        uses.push(Use::overwrite(&self.targets.diffuse, Access::ComputeShaderWrite));
        uses
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.dispatch_pixels(cmd, &self.targets.diffuse);
    }
}
