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

/// The frame's host data, one field per buffer: the buffers (`Uploads<Arc<Buffer>>`) or the
/// bytes a frame writes into them (`Uploads<Vec<u8>>`).
#[derive(Clone, Default)]
pub struct Uploads<T> {
    /// `FrameUniforms`.
    pub uniforms: T,
    /// `GpuLight` per light.
    pub lights: T,
    /// `GpuShadowView` per shadow-map view.
    pub shadow_views: T,
    /// The scene's instance table (its transforms at the frame's time).
    pub instances: T,
    /// The top level's instance records, where rays are traced among moving objects.
    pub top_instances: Option<T>,
}

/// One buffer of [`Uploads`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Upload {
    Uniforms,
    Lights,
    ShadowViews,
    Instances,
    TopInstances,
}

impl<T> Uploads<T> {
    fn get(&self, which: Upload) -> Option<&T> {
        match which {
            Upload::Uniforms => Some(&self.uniforms),
            Upload::Lights => Some(&self.lights),
            Upload::ShadowViews => Some(&self.shadow_views),
            Upload::Instances => Some(&self.instances),
            Upload::TopInstances => self.top_instances.as_ref(),
        }
    }

    fn get_mut(&mut self, which: Upload) -> Option<&mut T> {
        match which {
            Upload::Uniforms => Some(&mut self.uniforms),
            Upload::Lights => Some(&mut self.lights),
            Upload::ShadowViews => Some(&mut self.shadow_views),
            Upload::Instances => Some(&mut self.instances),
            Upload::TopInstances => self.top_instances.as_mut(),
        }
    }

    fn iter(&self) -> impl Iterator<Item = &T> {
        [&self.uniforms, &self.lights, &self.shadow_views, &self.instances].into_iter().chain(&self.top_instances)
    }
}

pub struct UploadPass {
    buffers: Uploads<Arc<Buffer>>,
    /// The bytes of each buffer, set by the renderer before the frame is recorded.
    data: RefCell<Uploads<Vec<u8>>>,
}

impl UploadPass {
    pub fn new(buffers: Uploads<Arc<Buffer>>) -> UploadPass {
        let data = Uploads { top_instances: buffers.top_instances.as_ref().map(|_| Vec::new()), ..Uploads::default() };
        UploadPass { buffers, data: RefCell::new(data) }
    }

    /// This frame's bytes for the buffer `which` (a multiple of 4, at most the buffer's size).
    pub fn set(&self, which: Upload, bytes: &[u8]) {
        let buffer = self.buffers.get(which).unwrap_or_else(|| panic!("the frame has no {which:?} buffer"));
        assert!(bytes.len() % 4 == 0 && bytes.len() as u64 <= buffer.size, "upload to {}", buffer.name);
        let mut data = self.data.borrow_mut();
        let target = data.get_mut(which).expect("bytes for every buffer");
        target.clear();
        target.extend_from_slice(bytes);
    }
}

impl Pass for UploadPass {
    fn name(&self) -> &str {
        "frame data upload"
    }
    fn unbound(&self) -> Vec<Use<'_>> {
        self.buffers.iter().map(|b| Use::buffer(b, Access::TransferWrite)).collect()
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        for (buffer, bytes) in self.buffers.iter().zip(self.data.borrow().iter()) {
            for (i, chunk) in bytes.chunks(MAX_UPDATE).enumerate() {
                unsafe { ctx.device.cmd_update_buffer(cmd, buffer.raw, (i * MAX_UPDATE) as u64, chunk) };
            }
        }
    }
}
