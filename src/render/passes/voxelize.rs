//! Voxelization (graphics queue): dominant-axis projection in a geometry shader, conservative
//! coverage (VK_EXT_conservative_rasterization where present, geometry-shader dilation
//! otherwise) and an exact triangle/voxel test per candidate voxel in the fragment shader,
//! adding samples of albedo, normal and emission to the voxels' integer sums (order-independent;
//! `VoxelResolvePass` makes averages of them) and, for dynamic geometry, appending each newly
//! occupied voxel to the work list. One pass for static geometry (run once, marks the static
//! flags) and one for dynamic geometry (every update).

use crate::gpu::{shaders, Access, Bind, Context, GpuResult, GraphicsDesc, Pipeline};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::Pass;
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
    set: PassSet,
    volumes: Arc<VoxelVolumes>,
    scene: Arc<SceneGpu>,
}

impl Voxelizer {
    pub fn new(
        ctx: &Arc<Context>,
        scene: &Arc<SceneGpu>,
        frame: &FrameBuffers,
        volumes: &Arc<VoxelVolumes>,
    ) -> GpuResult<Arc<Self>> {
        let (buffer, write) = (Access::GraphicsShaderReadBuffer, Access::FragmentShaderWrite);
        // The marking run binds everything the voxelization does.
        let set = Binds::new()
            .uniform(&frame.uniforms, buffer)
            .storage(&scene.instances, buffer)
            .extend(scene.materials.binds())
            .loaded(Bind::Uniform(&volumes.grid_buffer))
            .storage_image(volumes.flags_or_placeholder(), write)
            // Appends every dynamic voxel it gives a first sample to the work list.
            .storage(&volumes.list.buffer, write)
            .sampler(scene.materials.sampler.raw)
            .extend(volumes.brick_maps(write))
            .extend(volumes.sums_bound(write))
            .build(
                ctx,
                "voxelize",
                vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::GEOMETRY | vk::ShaderStageFlags::FRAGMENT,
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
                        (5, u32::from(volumes.needs.sides)),
                    ],
                },
                &[set.layout()],
                4,
            )
        };
        let pipeline = make("voxelize", false)?;
        let mark = volumes.bricks.is_some().then(|| make("voxelize: mark bricks", true)).transpose()?;
        Ok(Arc::new(Voxelizer { pipeline, mark, set, volumes: volumes.clone(), scene: scene.clone() }))
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
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.voxelizer.set]
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
            pipeline.bind(cmd, &[v.set.raw()]);
            super::set_viewport(ctx, cmd, extent);
            pipeline.push(cmd, &u32::from(!self.dynamic));
            v.scene.draw_where(ctx, cmd, |d| d.dynamic == self.dynamic);
            ctx.device.cmd_end_rendering(cmd);
        }
    }
}
