//! `bench --raster-profile`: what the G-buffer's time is made of. After a frame, the G-buffer is
//! drawn again in three passes, each submitted alone and timed (GPU timestamps, and host time
//! with the pass waited for): the frame's own pass; a depth prepass of the opaque draws (vertex,
//! raster and depth work: no fragment shader, no colour target); and the G-buffer over that
//! depth (each covered pixel shaded once: fragment and attachment work without overdraw). Where
//! the device has pipeline statistics queries, the primitives and the vertex and fragment shader
//! invocations of the frame's pass and of the pass over the prepass are counted: fragment
//! invocations over covered pixels is the overdraw.

use crate::gpu::{Context, GpuResult, VkContext};
use crate::render::binding::PassSet;
use crate::render::graph::{Pass, QueueKind, Use};
use ash::vk;

/// What the pipeline statistics counted over one pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShaderCounts {
    /// Primitives assembled (triangles drawn).
    pub primitives: u64,
    pub vertex_invocations: u64,
    pub fragment_invocations: u64,
}

/// One profiled pass: its samples over the rounds.
#[derive(Debug, Clone)]
pub struct RasterPassSamples {
    pub name: String,
    /// GPU timestamps, ms (empty where the device has none).
    pub gpu_ms: Vec<f64>,
    /// Host wall clock with the pass submitted alone and waited for, ms.
    pub host_ms: Vec<f64>,
    /// The last round's counts (they do not vary), where the device counts.
    pub counts: Option<ShaderCounts>,
}

/// The profile: the G-buffer's pixels, those a surface covers, and the passes.
#[derive(Debug, Clone)]
pub struct RasterSamples {
    pub pixels: u64,
    pub covered_pixels: u64,
    pub passes: Vec<RasterPassSamples>,
}

/// A pass whose draws a pipeline statistics query counts (query `query` of `pool`).
pub struct Counted<'a> {
    pub pass: &'a dyn Pass,
    pub pool: vk::QueryPool,
    pub query: u32,
}

impl Pass for Counted<'_> {
    fn name(&self) -> &str {
        self.pass.name()
    }
    fn sets(&self) -> Vec<&PassSet> {
        self.pass.sets()
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        self.pass.unbound()
    }
    fn queue(&self) -> QueueKind {
        self.pass.queue()
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let d = &ctx.device;
        unsafe {
            d.cmd_reset_query_pool(cmd, self.pool, self.query, 1);
            d.cmd_begin_query(cmd, self.pool, self.query, vk::QueryControlFlags::empty());
        }
        self.pass.record(ctx, cmd);
        unsafe { d.cmd_end_query(cmd, self.pool, self.query) };
    }
}

/// Primitives, vertex and fragment shader invocations: three counters per query, in this order
/// (the order of their bits).
pub const COUNTED: vk::QueryPipelineStatisticFlags = vk::QueryPipelineStatisticFlags::from_raw(
    vk::QueryPipelineStatisticFlags::INPUT_ASSEMBLY_PRIMITIVES.as_raw()
        | vk::QueryPipelineStatisticFlags::VERTEX_SHADER_INVOCATIONS.as_raw()
        | vk::QueryPipelineStatisticFlags::FRAGMENT_SHADER_INVOCATIONS.as_raw(),
);

/// A pool of `queries` pipeline statistics queries, destroyed on drop.
pub struct StatisticsPool<'a> {
    ctx: &'a Context,
    pub pool: vk::QueryPool,
    queries: u32,
}

impl<'a> StatisticsPool<'a> {
    pub fn new(ctx: &'a Context, queries: u32) -> GpuResult<StatisticsPool<'a>> {
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::PIPELINE_STATISTICS)
            .query_count(queries)
            .pipeline_statistics(COUNTED);
        let pool = unsafe { ctx.device.create_query_pool(&info, None) }.vk("vkCreateQueryPool")?;
        Ok(StatisticsPool { ctx, pool, queries })
    }

    /// Every query's counts (the work that wrote them has completed).
    pub fn read(&self) -> GpuResult<Vec<ShaderCounts>> {
        // One element per query: ash takes the query count from the slice's length.
        let mut data = vec![[0u64; 3]; self.queries as usize];
        unsafe {
            self.ctx.device.get_query_pool_results(
                self.pool,
                0,
                &mut data,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .vk("vkGetQueryPoolResults")?;
        Ok(data
            .iter()
            .map(|c| ShaderCounts { primitives: c[0], vertex_invocations: c[1], fragment_invocations: c[2] })
            .collect())
    }
}

impl Drop for StatisticsPool<'_> {
    fn drop(&mut self) {
        unsafe { self.ctx.device.destroy_query_pool(self.pool, None) };
    }
}

/// Pixels whose depth a surface wrote (below the cleared 1.0), from a `D32_SFLOAT` image's bytes.
pub fn covered_pixels(depth: &[u8]) -> u64 {
    bytemuck::pod_collect_to_vec::<u8, f32>(depth).iter().filter(|d| **d < 1.0).count() as u64
}
