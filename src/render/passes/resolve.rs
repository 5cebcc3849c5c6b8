//! Supersampling resolve (`render.supersample = k`): the frame renders at k x k times the
//! output size and this pass box-filters each k x k block of radiance into one output pixel.

use crate::gpu::{shaders, Access, Bind, Context, DescriptorSet, GpuResult, Image, Pipeline};
use crate::render::graph::{Pass, Use};
use ash::vk;
use std::sync::Arc;

pub struct ResolvePass {
    samples: Arc<Image>,
    pub resolved: Arc<Image>,
    pipeline: Pipeline,
    set: DescriptorSet,
}

impl ResolvePass {
    pub fn new(ctx: &Arc<Context>, samples: &Arc<Image>, resolved: &Arc<Image>, k: u32) -> GpuResult<Self> {
        let set = DescriptorSet::new(
            ctx,
            "resolve",
            vk::ShaderStageFlags::COMPUTE,
            &[Bind::StorageImage(samples.view), Bind::StorageImage(resolved.view)],
        )?;
        let pipeline = Pipeline::compute(ctx, "resolve", shaders::RESOLVE_COMP, &[set.layout], 0, &[(0, k)])?;
        Ok(ResolvePass { samples: samples.clone(), resolved: resolved.clone(), pipeline, set })
    }
}

impl Pass for ResolvePass {
    fn name(&self) -> &str {
        "supersample resolve"
    }
    fn uses(&self) -> Vec<Use<'_>> {
        vec![
            Use::image(&self.samples, Access::ComputeShaderReadStorage),
            Use::overwrite(&self.resolved, Access::ComputeShaderWrite),
        ]
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.set]);
        self.pipeline.dispatch_pixels(cmd, &self.resolved);
    }
}
