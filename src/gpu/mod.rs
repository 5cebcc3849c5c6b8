//! The Vulkan layer: context, memory, barriers derived from access types, pipelines.
//! Its one error type is [`GpuError`].

pub mod accel;
pub mod context;
pub mod error;
pub mod memory;
pub mod pipeline;
pub mod sync;

pub use context::{Context, ContextDesc, QueueTopology};
pub use error::{GpuError, GpuResult, VkContext};
pub use memory::{Buffer, Image, ImageDesc, ImageKind, Sampler};
pub use pipeline::{Bind, DescriptorSet, GraphicsDesc, Pipeline};
pub use sync::Access;

/// SPIR-V of every shader in glsl/, compiled by build.rs: `pub const NAME_STAGE: &[u8]`.
pub mod shaders {
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}
