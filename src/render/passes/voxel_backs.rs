//! `gi.plane_backs = "closed"`: after each voxelization, which backs of the one-plane voxels
//! close a solid (glsl/voxel_backs.comp), a bit per directional volume, for the directional
//! volumes' first level to leave out. The static voxels are marked once, after the static
//! voxelization; the dynamic ones after each revoxelization.

use super::voxel_list::{dispatch_list, list_arguments};
use crate::gpu::{shaders, Access, Bind, Context, GpuResult, Pipeline};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, Use};
use crate::render::voxel::{work_list_header, VoxelVolumes};
use ash::vk;
use std::sync::Arc;

pub struct VoxelBacksPass {
    volumes: Arc<VoxelVolumes>,
    set: PassSet,
    pipeline: Pipeline,
    /// Over the list's dynamic range (after a revoxelization), else over every occupied voxel
    /// (after the static voxelization: the static ones).
    dynamic: bool,
}

impl VoxelBacksPass {
    /// None unless the scene's voxels have closed backs (`gi.plane_backs = "closed"`).
    pub fn new(ctx: &Arc<Context>, volumes: &Arc<VoxelVolumes>, dynamic: bool) -> GpuResult<Option<Self>> {
        let v = volumes;
        let Some(backs) = &v.backs else { return Ok(None) };
        let read = Access::ComputeShaderReadStorage;
        let set = Binds::new()
            .storage(&v.list.buffer, Access::ComputeShaderReadBuffer)
            .loaded(Bind::Uniform(&v.grid_buffer))
            .extend(v.brick_maps(read))
            .storage_image(&v.albedo, read)
            .storage_image(&v.normal, read)
            .storage_image(backs, Access::ComputeShaderWrite)
            .build(ctx, "voxel closed backs", vk::ShaderStageFlags::COMPUTE)?;
        let pipeline = Pipeline::compute(
            ctx,
            "voxel closed backs",
            shaders::VOXEL_BACKS_COMP,
            &[set.layout()],
            0,
            &[(0, u32::from(dynamic))],
        )?;
        Ok(Some(VoxelBacksPass { volumes: volumes.clone(), set, pipeline, dynamic }))
    }
}

impl Pass for VoxelBacksPass {
    fn name(&self) -> &str {
        if self.dynamic {
            "voxel closed backs (dynamic)"
        } else {
            "voxel closed backs (static)"
        }
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        vec![list_arguments(&self.volumes)]
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        let range = if self.dynamic { work_list_header::DYNAMIC } else { work_list_header::OCCUPIED };
        dispatch_list(&self.pipeline, cmd, &self.volumes, range);
    }
}
