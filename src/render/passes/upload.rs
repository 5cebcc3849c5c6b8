//! The frame's host data (uniforms, lights, shadow views, instance transforms) written into
//! device-local buffers by the frame's own commands (`vkCmdUpdateBuffer` copies the bytes
//! into the command buffer at record time). The data then flows through the frame like any
//! other resource: frames in flight never see the host overwrite data a running frame reads,
//! and the barriers and cross-queue waits come from the declared uses.

use crate::gpu::{Access, Buffer, Context};
use crate::render::graph::{Pass, Use};
use ash::vk;
use std::cell::RefCell;
use std::sync::Arc;

/// vkCmdUpdateBuffer's limit per call.
const MAX_UPDATE: usize = 65536;

pub struct UploadPass {
    targets: Vec<Arc<Buffer>>,
    /// Bytes for each target, set by the renderer before the frame is recorded.
    data: RefCell<Vec<Vec<u8>>>,
}

impl UploadPass {
    pub fn new(targets: Vec<Arc<Buffer>>) -> UploadPass {
        let n = targets.len();
        UploadPass { targets, data: RefCell::new(vec![Vec::new(); n]) }
    }

    /// Bytes for target `i` this frame (a multiple of 4, at most the buffer's size).
    pub fn set(&self, i: usize, bytes: &[u8]) {
        assert!(
            bytes.len() % 4 == 0 && bytes.len() as u64 <= self.targets[i].size,
            "upload to {}",
            self.targets[i].name
        );
        let mut data = self.data.borrow_mut();
        data[i].clear();
        data[i].extend_from_slice(bytes);
    }
}

impl Pass for UploadPass {
    fn name(&self) -> &str {
        "frame data upload"
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        self.targets.iter().map(|b| Use::buffer(b, Access::TransferWrite)).collect()
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        for (buffer, bytes) in self.targets.iter().zip(self.data.borrow().iter()) {
            for (i, chunk) in bytes.chunks(MAX_UPDATE).enumerate() {
                unsafe { ctx.device.cmd_update_buffer(cmd, buffer.raw, (i * MAX_UPDATE) as u64, chunk) };
            }
        }
    }
}
