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

    #[cfg(test)]
    mod tests {
        const OP_IMAGE_SAMPLE_EXPLICIT_LOD: u32 = 88;

        /// How many `OpImageSampleExplicitLod` (textureLod) instructions a SPIR-V module holds.
        fn explicit_lod_samples(spirv: &[u8]) -> usize {
            // What pipeline.rs hands the driver: checks the magic number and the byte order.
            let words = ash::util::read_spv(&mut std::io::Cursor::new(spirv)).expect("build.rs produced valid SPIR-V");
            let (mut at, mut n) = (5, 0);
            while at < words.len() {
                let (count, opcode) = ((words[at] >> 16) as usize, words[at] & 0xffff);
                assert!(count > 0, "a zero-length instruction at word {at}");
                n += usize::from(opcode == OP_IMAGE_SAMPLE_EXPLICIT_LOD);
                at += count;
            }
            n
        }

        /// GLSL inlines every call: each call site of the voxel sampler is a copy of it (its
        /// lookups) in the compiled shader, and a CPU driver compiles every copy on a machine's
        /// first frame. Five copies per cone step, each with four of the directional level
        /// sampler, took a cold lavapipe render of the Cornell box (16x16, no bounce) from 13 s
        /// to 37 s and the test suite from 36 to 71 minutes (BENCHMARKS.md, "What the cone
        /// tracer costs to compile").
        /// `voxel_bounce` traces cones at one place: one copy of the sampler, 78 lookups (306
        /// before); `gi_trace` at three (diffuse, specular, shadow cones): 232 (916 before).
        #[test]
        fn each_cone_call_site_holds_one_copy_of_the_voxel_sampler() {
            let bounce = explicit_lod_samples(super::VOXEL_BOUNCE_COMP);
            let trace = explicit_lod_samples(super::GI_TRACE_COMP);
            assert!((40..=96).contains(&bounce), "voxel_bounce: {bounce} texture lookups");
            assert!(trace <= 3 * 96, "gi_trace: {trace} texture lookups");
        }
    }
}
