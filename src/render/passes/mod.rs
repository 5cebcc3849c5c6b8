//! One module per pass; each declares what it reads and writes (`Pass::uses`).

pub mod exposure;
pub mod gbuffer;
pub mod gi_trace;
pub mod lighting;
pub mod lpv;
pub mod readback;
pub mod resolve;
pub mod rsm;
pub mod rt_shadow;
pub mod shadow;
pub mod tonemap;
pub mod upload;
pub mod voxel_backs;
pub mod voxel_bounce;
pub mod voxel_bricks;
pub mod voxel_clear;
pub mod voxel_light;
pub mod voxel_list;
pub mod voxel_mips;
pub mod voxel_resolve;
pub mod voxel_view;
pub mod voxelize;

use crate::gpu::sync::{barrier, Access};
use crate::gpu::Context;
use ash::vk;

/// A memory barrier between two commands of one pass (a dispatch whose results the next one
/// reads or rewrites), from the same access table as every barrier between passes.
pub(crate) fn memory_barrier(ctx: &Context, cmd: vk::CommandBuffer, prev: &[Access], next: &[Access]) {
    let b = barrier(prev, next, false, false).expect("a write on one side needs a barrier").memory();
    unsafe { ctx.device.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().memory_barriers(&[b])) };
}

pub(crate) fn set_viewport(ctx: &Context, cmd: vk::CommandBuffer, extent: vk::Extent2D) {
    unsafe {
        ctx.device.cmd_set_viewport(
            cmd,
            0,
            &[vk::Viewport {
                x: 0.0,
                y: 0.0,
                width: extent.width as f32,
                height: extent.height as f32,
                min_depth: 0.0,
                max_depth: 1.0,
            }],
        );
        ctx.device.cmd_set_scissor(cmd, 0, &[vk::Rect2D { offset: vk::Offset2D::default(), extent }]);
    }
}
