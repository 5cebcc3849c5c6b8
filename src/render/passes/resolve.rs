//! Supersampling resolve (`render.supersample = k`): the frame renders at k x k times the
//! output size and this pass box-filters each k x k block of radiance into one output pixel.

use crate::gpu::{shaders, Access, Context, GpuResult, Image, Pipeline};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, QueueKind};
use ash::vk;
use std::sync::Arc;

pub struct ResolvePass {
    pub resolved: Arc<Image>,
    pipeline: Pipeline,
    set: PassSet,
}

impl ResolvePass {
    pub fn new(ctx: &Arc<Context>, samples: &Arc<Image>, resolved: &Arc<Image>, k: u32) -> GpuResult<Self> {
        let set = Binds::new()
            .storage_image(samples, Access::ComputeShaderReadStorage)
            .storage_image(resolved, Access::ComputeShaderWrite)
            .overwritten()
            .build(ctx, "resolve", vk::ShaderStageFlags::COMPUTE)?;
        let pipeline = Pipeline::compute(ctx, "resolve", shaders::RESOLVE_COMP, &[set.layout()], 0, &[(0, k)])?;
        Ok(ResolvePass { resolved: resolved.clone(), pipeline, set })
    }
}

impl Pass for ResolvePass {
    fn pipelined_queue(&self) -> QueueKind {
        QueueKind::Compute
    }

    fn name(&self) -> &str {
        "supersample resolve"
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        self.pipeline.dispatch_pixels(cmd, &self.resolved);
    }
}
