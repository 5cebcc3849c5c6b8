//! Voxelization (graphics queue): dominant-axis projection in a geometry shader, conservative
//! coverage (VK_EXT_conservative_rasterization where present, geometry-shader dilation
//! otherwise) and an exact triangle/voxel test per candidate voxel in the fragment shader,
//! writing running averages of albedo, normal and emission, and appending each newly occupied
//! voxel to the work list. One pass for static geometry (run once, marks the static flags)
//! and one for dynamic geometry (every update).

use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, GraphicsDesc, Pipeline};
use crate::render::graph::{Pass, Use};
use crate::render::scene_gpu::SceneGpu;
use crate::render::voxel::VoxelVolumes;
use crate::render::FrameBuffers;
use ash::vk;
use std::sync::Arc;

/// Pipeline and bindings shared by the static and dynamic voxelization passes.
pub struct Voxelizer {
    pipeline: Pipeline,
    set: DescriptorSet,
    volumes: Arc<VoxelVolumes>,
    scene: Arc<SceneGpu>,
    frame: FrameBuffers,
}

impl Voxelizer {
    pub fn new(
        ctx: &Arc<Context>,
        scene: &Arc<SceneGpu>,
        frame: &FrameBuffers,
        volumes: &Arc<VoxelVolumes>,
    ) -> GpuResult<Arc<Self>> {
        let mut binds = vec![Bind::Uniform(&frame.uniforms), Bind::Storage(&scene.instances)];
        binds.extend(scene.materials.binds());
        binds.extend(volumes.binds());
        binds.push(Bind::Storage(&volumes.list.buffer));
        binds.push(scene.materials.sampler_bind());
        let set = DescriptorSet::new(
            ctx,
            "voxelize",
            vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::GEOMETRY | vk::ShaderStageFlags::FRAGMENT,
            &binds,
        )?;
        let hardware_conservative = ctx.info.optional.conservative_rasterization;
        let pipeline = Pipeline::graphics(
            ctx,
            "voxelize",
            &GraphicsDesc {
                vertex_attributes: &[0, 1, 2],
                vert: shaders::GBUFFER_VERT,
                geom: Some(shaders::VOXELIZE_GEOM),
                frag: Some(shaders::VOXELIZE_FRAG),
                color_formats: &[],
                depth_format: None,
                depth_test: false,
                depth_write: false,
                cull: vk::CullModeFlags::NONE,
                depth_bias: false,
                depth_clamp: false,
                conservative: hardware_conservative,
                spec: &[
                    (0, scene.materials.texture_count()),
                    (1, u32::from(!hardware_conservative)),
                    (2, u32::from(volumes.needs.emission)),
                    (3, u32::from(volumes.needs.dynamic)),
                ],
            },
            &[set.layout],
            4,
        )?;
        Ok(Arc::new(Voxelizer { pipeline, set, volumes: volumes.clone(), scene: scene.clone(), frame: frame.clone() }))
    }
}

pub struct VoxelizePass {
    voxelizer: Arc<Voxelizer>,
    /// Voxelize the dynamic objects (else the static ones, marking the static flags).
    dynamic: bool,
}

impl VoxelizePass {
    pub fn new(voxelizer: &Arc<Voxelizer>, dynamic: bool) -> Self {
        VoxelizePass { voxelizer: voxelizer.clone(), dynamic }
    }
}

impl Pass for VoxelizePass {
    fn name(&self) -> &str {
        if self.dynamic {
            "voxelize dynamic"
        } else {
            "voxelize static"
        }
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let v = &self.voxelizer;
        let mut uses = v.volumes.uses(Access::FragmentShaderWrite, Access::FragmentShaderWrite);
        uses.extend(v.frame.reads(Access::GraphicsShaderReadBuffer));
        uses.push(v.scene.instance_reads());
        // Appends every voxel it gives a first sample to the work list.
        uses.push(Use::buffer(&v.volumes.list.buffer, Access::FragmentShaderWrite));
        uses
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let res = self.voxelizer.volumes.grid.resolution;
        let extent = vk::Extent2D { width: res, height: res };
        let info = vk::RenderingInfo::default()
            .render_area(vk::Rect2D { offset: vk::Offset2D::default(), extent })
            .layer_count(1);
        let v = &self.voxelizer;
        unsafe {
            ctx.device.cmd_begin_rendering(cmd, &info);
            v.pipeline.bind(cmd, &[v.set.set]);
            super::set_viewport(ctx, cmd, extent);
            v.pipeline.push(cmd, &u32::from(!self.dynamic));
            v.scene.draw_where(ctx, cmd, |d| d.dynamic == self.dynamic);
            ctx.device.cmd_end_rendering(cmd);
        }
    }
}
