//! Voxelization (graphics queue): dominant-axis projection in a geometry shader, conservative
//! coverage (VK_EXT_conservative_rasterization where present, geometry-shader dilation
//! otherwise) and an exact triangle/voxel test per candidate voxel in the fragment shader,
//! adding samples of albedo, normal and emission to the voxels' integer sums (order-independent;
//! `VoxelResolvePass` makes averages of them) and, for dynamic geometry, appending each newly
//! occupied voxel to the work list. One pass for static geometry (run once, marks the static
//! flags) and one for dynamic geometry (every update).

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
    /// With bricked volumes: the same shader marking the bricks the voxels need.
    mark: Option<Pipeline>,
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
        binds.push(volumes.brick_maps_bind());
        binds.push(volumes.sums_bind());
        let set = DescriptorSet::new(
            ctx,
            "voxelize",
            vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::GEOMETRY | vk::ShaderStageFlags::FRAGMENT,
            &binds,
        )?;
        let hardware_conservative = ctx.info.optional.conservative_rasterization;
        let make = |name: &str, mark: bool| {
            Pipeline::graphics(
                ctx,
                name,
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
                        (4, u32::from(mark)),
                    ],
                },
                &[set.layout],
                4,
            )
        };
        let pipeline = make("voxelize", false)?;
        let mark = volumes.bricks.is_some().then(|| make("voxelize: mark bricks", true)).transpose()?;
        Ok(Arc::new(Voxelizer {
            pipeline,
            mark,
            set,
            volumes: volumes.clone(),
            scene: scene.clone(),
            frame: frame.clone(),
        }))
    }
}

pub struct VoxelizePass {
    voxelizer: Arc<Voxelizer>,
    /// Voxelize the dynamic objects (else the static ones, marking the static flags).
    dynamic: bool,
    /// Only mark the bricks the voxels need (bricked volumes, before the allocation).
    mark: bool,
}

impl VoxelizePass {
    pub fn new(voxelizer: &Arc<Voxelizer>, dynamic: bool) -> Self {
        VoxelizePass { voxelizer: voxelizer.clone(), dynamic, mark: false }
    }

    /// The brick-marking run over the same geometry; None with dense volumes.
    pub fn marking(voxelizer: &Arc<Voxelizer>, dynamic: bool) -> Option<Self> {
        voxelizer.mark.is_some().then(|| VoxelizePass { voxelizer: voxelizer.clone(), dynamic, mark: true })
    }
}

impl Pass for VoxelizePass {
    fn name(&self) -> &str {
        match (self.dynamic, self.mark) {
            (true, false) => "voxelize dynamic",
            (false, false) => "voxelize static",
            (true, true) => "mark bricks dynamic",
            (false, true) => "mark bricks static",
        }
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let v = &self.voxelizer;
        // The marking run binds (and so declares) everything the voxelization does.
        let mut uses = v.volumes.brick_map_uses(Access::FragmentShaderWrite);
        uses.extend(v.volumes.uses(Access::FragmentShaderWrite, Access::FragmentShaderWrite));
        uses.extend(v.frame.reads(Access::GraphicsShaderReadBuffer));
        uses.push(v.scene.instance_reads());
        // Appends every dynamic voxel it gives a first sample to the work list.
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
            let pipeline = if self.mark { v.mark.as_ref().unwrap_or(&v.pipeline) } else { &v.pipeline };
            pipeline.bind(cmd, &[v.set.set]);
            super::set_viewport(ctx, cmd, extent);
            pipeline.push(cmd, &u32::from(!self.dynamic));
            v.scene.draw_where(ctx, cmd, |d| d.dynamic == self.dynamic);
            ctx.device.cmd_end_rendering(cmd);
        }
    }
}
