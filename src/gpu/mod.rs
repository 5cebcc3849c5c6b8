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

    /// Which build of a shader that traces cones a device runs (glsl/include/cone.glsl,
    /// SAMPLER_LOOP): CPU drivers the one whose sampler loops are kept (`kept`: one copy of the
    /// voxel sampler, which lavapipe compiles in a third of the time), GPUs the unrolled one
    /// (the H200 traced 1.5x slower with kept loops). `DVSGI_CONE_SAMPLERS=kept|unrolled`
    /// chooses either on any device (the tests compare them).
    pub fn cone_variant(
        info: &super::context::DeviceInfo,
        kept: &'static [u8],
        unrolled: &'static [u8],
    ) -> &'static [u8] {
        if cone_loops_unrolled(info) {
            unrolled
        } else {
            kept
        }
    }

    /// Whether `cone_variant` picks the unrolled build on this device (`dvsgi info` says which).
    pub fn cone_loops_unrolled(info: &super::context::DeviceInfo) -> bool {
        match std::env::var("DVSGI_CONE_SAMPLERS").as_deref() {
            Ok("kept") => false,
            Ok("unrolled") => true,
            Ok(other) => {
                static WARNED: std::sync::Once = std::sync::Once::new();
                WARNED.call_once(|| {
                    eprintln!(
                        "warning: DVSGI_CONE_SAMPLERS={other:?} is neither \"kept\" nor \"unrolled\"; the device's \
                         own build runs"
                    )
                });
                !info.is_cpu()
            }
            Err(_) => !info.is_cpu(),
        }
    }

    #[cfg(test)]
    mod tests {
        const OP_IMAGE_SAMPLE_EXPLICIT_LOD: u32 = 88;
        const OP_LOOP_MERGE: u32 = 246;
        const LOOP_CONTROL_UNROLL: u32 = 1;
        const LOOP_CONTROL_DONT_UNROLL: u32 = 2;

        /// Every instruction of a SPIR-V module: (opcode, its words).
        fn instructions(spirv: &[u8]) -> Vec<(u32, Vec<u32>)> {
            // What pipeline.rs hands the driver: checks the magic number and the byte order.
            let words = ash::util::read_spv(&mut std::io::Cursor::new(spirv)).expect("build.rs produced valid SPIR-V");
            let (mut at, mut out) = (5, Vec::new());
            while at < words.len() {
                let (count, opcode) = ((words[at] >> 16) as usize, words[at] & 0xffff);
                assert!(count > 0, "a zero-length instruction at word {at}");
                out.push((opcode, words[at..(at + count).min(words.len())].to_vec()));
                at += count;
            }
            out
        }

        /// How many `OpImageSampleExplicitLod` (textureLod) instructions a SPIR-V module holds.
        fn explicit_lod_samples(spirv: &[u8]) -> usize {
            instructions(spirv).iter().filter(|(op, _)| *op == OP_IMAGE_SAMPLE_EXPLICIT_LOD).count()
        }

        /// How many loops a module asks the driver to unroll and to keep (OpLoopMerge's control).
        fn loop_controls(spirv: &[u8]) -> (usize, usize) {
            let merges: Vec<u32> =
                instructions(spirv).into_iter().filter(|(op, _)| *op == OP_LOOP_MERGE).map(|(_, w)| w[3]).collect();
            let count = |bit: u32| merges.iter().filter(|&&c| c & bit != 0).count();
            (count(LOOP_CONTROL_UNROLL), count(LOOP_CONTROL_DONT_UNROLL))
        }

        /// cone.glsl's SAMPLER_LOOPs (the footprint's parts, the directional levels of the
        /// plain and two-tap samplers) reach the driver kept in the build for CPU drivers and
        /// marked for unrolling in the one for GPUs, in every shader that traces cones.
        #[test]
        fn cone_tracers_are_built_with_kept_and_with_unrolled_sampler_loops() {
            for (name, kept, unrolled) in [
                ("gi_trace", super::GI_TRACE_COMP, super::GI_TRACE_COMP_UNROLLED),
                ("voxel_bounce", super::VOXEL_BOUNCE_COMP, super::VOXEL_BOUNCE_COMP_UNROLLED),
            ] {
                let (k_unroll, k_keep) = loop_controls(kept);
                let (u_unroll, u_keep) = loop_controls(unrolled);
                assert!(k_keep >= 3 && k_unroll == 0, "{name}, kept: {k_unroll} unrolled, {k_keep} kept loops");
                assert!(u_unroll >= 3 && u_keep == 0, "{name}, unrolled: {u_unroll} unrolled, {u_keep} kept loops");
            }
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
