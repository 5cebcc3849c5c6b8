//! Brick allocation (compute): after the marking run of voxelization, every pending brick of
//! each pool gets a slot and joins the pool's list of resident bricks; then each pool's
//! indirect dispatch over its resident bricks is written (glsl/brick_alloc.comp). Bricks stay
//! resident once allocated: the pools are sized for everything voxelization can touch
//! (render::bricks::capacity), so a moving object only ever adds bricks, without a host wait.

use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, Pipeline};
use crate::render::graph::{Pass, Use};
use crate::render::voxel::VoxelVolumes;
use ash::vk;
use std::sync::Arc;

pub struct BrickAllocPass {
    volumes: Arc<VoxelVolumes>,
    /// One pipeline per pool, then the finalizing one.
    allocate: Vec<Pipeline>,
    finalize: Pipeline,
    set: DescriptorSet,
    name: &'static str,
}

impl BrickAllocPass {
    /// None with dense volumes. `dynamic` names the pass after the voxelization it follows.
    pub fn new(ctx: &Arc<Context>, volumes: &Arc<VoxelVolumes>, dynamic: bool) -> GpuResult<Option<Self>> {
        let Some(bricks) = &volumes.bricks else { return Ok(None) };
        let set = DescriptorSet::new(
            ctx,
            "voxel brick allocation",
            vk::ShaderStageFlags::COMPUTE,
            &[Bind::Uniform(&volumes.grid_buffer), volumes.brick_maps_bind(), Bind::Storage(&bricks.lists)],
        )?;
        let pipeline = |pool: u32, finalize: bool| {
            let name =
                if finalize { "voxel brick lists".to_string() } else { format!("voxel brick allocation {pool}") };
            Pipeline::compute(
                ctx,
                &name,
                shaders::BRICK_ALLOC_COMP,
                &[set.layout],
                0,
                &[(0, pool), (1, u32::from(finalize))],
            )
        };
        let allocate =
            (0..bricks.layout.pools.len() as u32).map(|p| pipeline(p, false)).collect::<GpuResult<Vec<_>>>()?;
        let finalize = pipeline(0, true)?;
        let name = if dynamic { "allocate bricks dynamic" } else { "allocate bricks static" };
        Ok(Some(BrickAllocPass { volumes: volumes.clone(), allocate, finalize, set, name }))
    }
}

impl Pass for BrickAllocPass {
    fn name(&self) -> &str {
        self.name
    }
    fn uses(&self) -> Vec<Use<'_>> {
        let v = &self.volumes;
        let mut uses = v.brick_map_uses(Access::ComputeShaderWrite);
        uses.extend(v.bricks.iter().map(|b| Use::buffer(&b.lists, Access::ComputeShaderWrite)));
        uses
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let b = self.volumes.bricks.as_ref().expect("a brick allocation has bricks");
        for (pipeline, pool) in self.allocate.iter().zip(&b.layout.pools) {
            pipeline.bind(cmd, &[self.set.set]);
            pipeline.dispatch(cmd, [pool.map_side; 3], [4; 3]);
        }
        super::memory_barrier(ctx, cmd, &[Access::ComputeShaderWrite], &[Access::ComputeShaderWrite]);
        self.finalize.bind(cmd, &[self.set.set]);
        self.finalize.dispatch(cmd, [1; 3], [4; 3]);
    }
}
