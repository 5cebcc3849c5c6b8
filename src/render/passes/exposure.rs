//! Automatic exposure on the GPU (`render.exposure = "auto"`): glsl/exposure.comp reduces the
//! frame's radiance to the EV that takes its lit pixels' log-average luminance to middle grey,
//! in two passes (per 32 x 32 tile, then the tiles), into a small buffer the tone map reads.
//! The buffer is host-visible, so the viewer can say what "auto" chose
//! ([`ExposurePasses::chosen`]); it keeps the shown EV from frame to frame for the viewer's
//! easing.

use crate::gpu::{shaders, Access, Bind, Buffer, Context, GpuResult, Image, Pipeline};
use crate::render::binding::{Binds, PassSet};
use crate::render::graph::{Pass, QueueKind};
use crate::render::FrameBuffers;
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// Pixels per tile side of the first stage, and invocations per workgroup
/// (glsl/exposure.comp).
const TILE: u32 = 32;
const GROUP: u32 = 64;

/// One stage of the reduction.
pub struct ExposurePass {
    name: &'static str,
    resolve: bool,
    /// Its extent gives the dispatch's size.
    radiance: Arc<Image>,
    pipeline: Pipeline,
    set: PassSet,
}

/// The two stages and the buffer they leave the EV in.
pub struct ExposurePasses {
    pub tiles: ExposurePass,
    pub resolve: ExposurePass,
    /// x the EV shown, y this frame's own, z lit pixels, w frames (glsl/exposure.comp).
    pub state: Arc<Buffer>,
}

impl ExposurePasses {
    /// The state the EV carries in from frame to frame, zeroed (no frame yet).
    pub fn state(ctx: &Arc<Context>) -> GpuResult<Arc<Buffer>> {
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let state = Arc::new(Buffer::new(ctx, "exposure", 16, storage, MemoryLocation::GpuToCpu)?);
        state.write(0, &[0u8; 16]);
        Ok(state)
    }

    /// The stages over `radiance`, leaving the EV in `state` ([`ExposurePasses::state`], shared
    /// by every copy of the frame).
    pub fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        radiance: &Arc<Image>,
        state: &Arc<Buffer>,
    ) -> GpuResult<Self> {
        let e = radiance.extent2d();
        let tiles = (e.width.div_ceil(TILE) * e.height.div_ceil(TILE)) as u64;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let partials = Arc::new(Buffer::new(ctx, "exposure tiles", tiles * 8, storage, MemoryLocation::GpuOnly)?);
        let stage = |name: &'static str, resolve: bool| -> GpuResult<ExposurePass> {
            // The tiles read the radiance into the partial sums; the resolve reduces those
            // into the state. Each leaves the other's binding idle.
            let (buffer, write) = (Access::ComputeShaderReadBuffer, Access::ComputeShaderWrite);
            let binds = Binds::new().uniform(&frame.uniforms, buffer);
            let set = if resolve {
                binds.idle(Bind::StorageImage(radiance.view)).storage(&partials, buffer).storage(state, write)
            } else {
                let read = Access::ComputeShaderReadStorage;
                binds.storage_image(radiance, read).storage(&partials, write).idle(Bind::Storage(state))
            }
            .build(ctx, name, vk::ShaderStageFlags::COMPUTE)?;
            let spec = [(0, u32::from(resolve))];
            let pipeline = Pipeline::compute(ctx, name, shaders::EXPOSURE_COMP, &[set.layout()], 0, &spec)?;
            Ok(ExposurePass { name, resolve, radiance: radiance.clone(), pipeline, set })
        };
        Ok(ExposurePasses {
            tiles: stage("exposure (tiles)", false)?,
            resolve: stage("exposure", true)?,
            state: state.clone(),
        })
    }

    /// The EV "auto" added to `render.exposure` in the last frame that ran these passes (the
    /// one in flight may be writing it: the viewer shows it as it is), or None before any.
    pub fn chosen(&self) -> Option<f32> {
        let bytes = self.state.mapped()?;
        let state: [f32; 4] = bytemuck::pod_read_unaligned(&bytes[..16]);
        (state[3] > 0.0).then_some(state[0])
    }
}

impl Pass for ExposurePass {
    fn pipelined_queue(&self) -> QueueKind {
        QueueKind::Compute
    }

    fn name(&self) -> &str {
        self.name
    }
    fn sets(&self) -> Vec<&PassSet> {
        vec![&self.set]
    }
    fn record(&self, _ctx: &Context, cmd: vk::CommandBuffer) {
        self.pipeline.bind(cmd, &[self.set.raw()]);
        let e = self.radiance.extent2d();
        let tiles = e.width.div_ceil(TILE) * e.height.div_ceil(TILE);
        let groups = if self.resolve { 1 } else { tiles };
        self.pipeline.dispatch(cmd, [groups * GROUP, 1, 1], [GROUP, 1, 1]);
    }
}
