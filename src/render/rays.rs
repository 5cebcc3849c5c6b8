//! Ray tracing (`gi.specular = "rt"`, `gi.shadows = "rt"`): the scene's acceleration
//! structures (one bottom level per draw, a top level with one instance per draw), the pass that
//! rebuilds the top level when dynamic objects move, the pass that traces the reflections into
//! the cone tracer's specular target (glsl/rt_reflect.comp), and the pass that traces the direct
//! light's shadow rays (glsl/rt_shadow.comp).

use super::passes::gbuffer::GBuffer;
use super::scene_gpu::SceneGpu;
use super::voxel::VoxelVolumes;
use super::FrameBuffers;
use crate::gpu::accel::{self, AccelerationStructure, TopLevel, TriangleMesh, TriangleSource};
use crate::gpu::{shaders, Access, Bind, Buffer, Context, GpuError, GpuResult, Image, ImageDesc, Pipeline, Sampler};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, QueueKind, Use};
use crate::scene::{HitIndirect, Scene};
use ash::vk;
use bytemuck::{Pod, Zeroable};
use std::sync::Arc;

/// Mirrors `RtDraw` in glsl/include/scene.glsl: where a hit's triangle is.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct RtDraw {
    first_index: u32,
    vertex_offset: i32,
    instance: u32,
    pad: u32,
}

/// The refusal of a ray-traced setting (`gi.specular = "rt"`, `gi.shadows = "rt"`) on a
/// device without ray queries: `key` is the setting, `alternative` what to use instead.
pub fn missing_ray_queries(ctx: &Context, key: &str, alternative: &str) -> GpuError {
    GpuError::Limit(format!(
        "{key} = \"rt\" needs ray queries (VK_KHR_ray_query with VK_KHR_acceleration_structure), which {} \
         does not have; use {key} = \"{alternative}\"",
        ctx.info.name
    ))
}

/// The scene's acceleration structures and the draw table hits read.
pub struct SceneRays {
    _bottom: Vec<AccelerationStructure>,
    bottom_addresses: Vec<vk::DeviceAddress>,
    pub top: TopLevel,
    pub draws: Buffer,
    /// Some object moves: the frame rebuilds the top level.
    pub dynamic: bool,
}

impl SceneRays {
    /// Builds every structure for the scene at time `t` (waits for the builds).
    pub fn new(ctx: &Arc<Context>, scene: &Scene, gpu: &SceneGpu, t: f32) -> GpuResult<SceneRays> {
        let source = TriangleSource {
            vertices: accel::buffer_address(ctx, &gpu.vertices),
            vertex_stride: std::mem::size_of::<super::scene_gpu::Vertex>() as u64,
            indices: accel::buffer_address(ctx, &gpu.indices),
        };
        let meshes: Vec<TriangleMesh> = gpu
            .draws
            .iter()
            .map(|d| TriangleMesh {
                first_index: d.first_index,
                index_count: d.index_count,
                vertex_offset: d.vertex_offset as u32,
                max_index: d.max_index,
                opaque: !d.masked,
            })
            .collect();
        let bottom = accel::build_bottom_levels(ctx, source, &meshes)?;
        let table: Vec<RtDraw> = gpu
            .draws
            .iter()
            .map(|d| RtDraw {
                first_index: d.first_index,
                vertex_offset: d.vertex_offset,
                instance: d.instance,
                pad: 0,
            })
            .collect();
        let draws = super::scene_gpu::upload_buffer(
            ctx,
            "ray draw table",
            bytemuck::cast_slice(&table),
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        let top = TopLevel::new(ctx, "scene top level", gpu.draws.len() as u32)?;
        let rays = SceneRays {
            bottom_addresses: bottom.iter().map(|b| b.address).collect(),
            _bottom: bottom,
            top,
            draws,
            dynamic: gpu.draws.iter().any(|d| d.dynamic),
        };
        rays.build_now(ctx, &rays.instance_bytes(scene, gpu, t))?;
        Ok(rays)
    }

    /// The top level's instance records for time `t`, one per draw.
    pub fn instance_bytes(&self, scene: &Scene, gpu: &SceneGpu, t: f32) -> Vec<u8> {
        let records: Vec<_> = gpu
            .draws
            .iter()
            .zip(&self.bottom_addresses)
            .enumerate()
            .map(|(i, (d, &blas))| {
                let model = scene.objects[d.object].model_matrix(t).to_cols_array_2d();
                accel::instance_record(model, i as u32, blas)
            })
            .collect();
        accel::instance_bytes(&records)
    }

    /// The bindings a ray-query shader declares in a row (glsl/include/ray_query.glsl): the top
    /// level (rebuilt when objects move), the vertices, indices, draw table and instances (their
    /// hits' transforms, uploaded every frame), the materials, the textures and their
    /// explicit-level sampler.
    pub fn binds<'a>(&'a self, scene: &'a SceneGpu) -> Binds<'a> {
        Binds::new()
            .acceleration_structure(self.top.structure.raw, &self.top.structure.buffer)
            .loaded(Bind::Storage(&scene.vertices))
            .loaded(Bind::Storage(&scene.indices))
            .loaded(Bind::Storage(&self.draws))
            .storage(&scene.instances, Access::ComputeShaderReadBuffer)
            .extend(scene.materials.binds())
            .sampler(scene.materials.lod_sampler.raw)
    }

    /// Uploads the instances and builds the top level at load time.
    fn build_now(&self, ctx: &Arc<Context>, instances: &[u8]) -> GpuResult<()> {
        ctx.one_shot("build scene top level", |cmd| unsafe {
            for (i, chunk) in instances.chunks(65536).enumerate() {
                ctx.device.cmd_update_buffer(cmd, self.top.instances.raw, (i * 65536) as u64, chunk);
            }
            let barrier = [vk::MemoryBarrier2::default()
                .src_stage_mask(vk::PipelineStageFlags2::COPY)
                .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
                .dst_stage_mask(vk::PipelineStageFlags2::ACCELERATION_STRUCTURE_BUILD_KHR)
                .dst_access_mask(vk::AccessFlags2::SHADER_READ)];
            ctx.device.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().memory_barriers(&barrier));
            self.top.record_build(ctx, cmd);
        })
    }
}

/// Rebuilds the top level from the instances the frame uploaded (scenes with dynamic objects).
pub struct TopLevelBuildPass {
    rays: Arc<SceneRays>,
}

impl TopLevelBuildPass {
    pub fn new(rays: &Arc<SceneRays>) -> TopLevelBuildPass {
        TopLevelBuildPass { rays: rays.clone() }
    }
}

impl Pass for TopLevelBuildPass {
    fn name(&self) -> &str {
        "top-level build"
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        let top = &self.rays.top;
        vec![
            Use::buffer(&top.instances, Access::AccelerationStructureBuildInput),
            Use::buffer(&top.structure.buffer, Access::AccelerationStructureBuildWrite),
            Use::buffer(&top.scratch.buffer, Access::AccelerationStructureBuildWrite),
        ]
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        self.rays.top.record_build(ctx, cmd);
    }
}

/// Traces the reflections of glossy and mirror pixels into the specular target (1/k).
pub struct RtReflectPass {
    pub target: Arc<Image>,
    pipeline: Pipeline,
    set: PassSet,
    _sampler: Sampler,
}

impl RtReflectPass {
    /// Everything the reflections read: the G-buffer, the voxels (for the light at the hits),
    /// the scene's geometry and materials, and its acceleration structures.
    /// The history (`history`, made by [`RtReflectPass::history`]) is shared by every copy of
    /// the frame: it carries from frame to frame.
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        gbuffer: &Arc<GBuffer>,
        volumes: &Arc<VoxelVolumes>,
        (scene, rays): (&Arc<SceneGpu>, &Arc<SceneRays>),
        (target, history): (&Arc<Image>, &Arc<Image>),
        (specular_rays, hit): (u32, HitIndirect),
    ) -> GpuResult<RtReflectPass> {
        let sampler = GBuffer::sampler(ctx)?;
        let lod0 = volumes.final_radiance().clone();
        debug_assert_eq!(history.desc.extent, target.desc.extent, "the history is the size of the target");
        let images = RtImages { target, history, lod0: &lod0 };
        let set = Self::binds(frame, gbuffer, volumes, scene, rays, images, &sampler).build(
            ctx,
            "rt reflections",
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let cones = u32::from(hit == HitIndirect::Cones);
        let spec = [(0, scene.materials.texture_count()), (1, specular_rays), (2, cones)];
        let pipeline = Pipeline::compute(
            ctx,
            "rt reflections",
            shaders::cone_variant(&ctx.info, shaders::RT_REFLECT_COMP, shaders::RT_REFLECT_COMP_UNROLLED),
            &[set.layout()],
            0,
            &spec,
        )?;
        Ok(RtReflectPass { target: target.clone(), pipeline, set, _sampler: sampler })
    }

    /// The reflections' history for a target of `width` x `height`: what they average over
    /// the frames the view and the scene stood still.
    pub fn history(ctx: &Arc<Context>, (width, height): (u32, u32)) -> GpuResult<Arc<Image>> {
        let desc = ImageDesc::d2(vk::Format::R32G32B32A32_SFLOAT, width, height, vk::ImageUsageFlags::STORAGE);
        Ok(Arc::new(Image::new(ctx, "rt reflection history", desc)?))
    }

    /// The bindings of glsl/rt_reflect.comp, in order: the G-buffer, the voxels (for the light
    /// at the hits), the target, the scene's rays, then the direct radiance the hits read and
    /// the history (the reflections averaged over the frames the view and the scene stood still),
    /// then the sky's cone map (for the cones at the hits) and its radiance map (for misses).
    #[allow(clippy::too_many_arguments)]
    fn binds<'a>(
        frame: &'a FrameBuffers,
        gbuffer: &'a GBuffer,
        v: &'a VoxelVolumes,
        scene: &'a SceneGpu,
        rays: &'a SceneRays,
        images: RtImages<'a>,
        sampler: &'a Sampler,
    ) -> Binds<'a> {
        let RtImages { target, history, lod0 } = images;
        let (buffer, read) = (Access::ComputeShaderReadBuffer, Access::ComputeShaderReadSampled);
        let write = Access::ComputeShaderWrite;
        Binds::new()
            .uniform(&frame.uniforms, buffer)
            .storage(&frame.lights, buffer)
            .loaded(Bind::Uniform(&v.grid_buffer))
            .loaded(Bind::Uniform(&v.gi_params))
            .sampled(&gbuffer.depth, sampler.raw, Access::ComputeShaderReadDepth)
            .sampled(&gbuffer.albedo, sampler.raw, read)
            .sampled(&gbuffer.normal, sampler.raw, read)
            .sampled(&gbuffer.specular, sampler.raw, read)
            .extend(v.cone_volumes(lod0))
            .extend(v.brick_maps(Access::ComputeShaderReadStorage))
            .extend(v.pools())
            .storage_image(target, write)
            .overwritten()
            .extend(rays.binds(scene))
            .sampled(&v.radiance, v.sampler.raw, read)
            .storage_image(history, write)
            .extend(scene.sky.cones_bind())
            .extend(scene.sky.map_bind())
    }
}

/// The images the reflections write (the specular target and the history) and the radiance
/// volume whose level 0 the hits read.
struct RtImages<'a> {
    target: &'a Arc<Image>,
    history: &'a Arc<Image>,
    lod0: &'a Arc<Image>,
}

impl Pass for RtReflectPass {
    fn name(&self) -> &str {
        "rt reflections"
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn queue(&self) -> QueueKind {
        QueueKind::Compute
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.dispatch_pixels(cmd, &self.target);
    }
}
