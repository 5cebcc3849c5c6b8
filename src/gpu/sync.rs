//! Barriers derived from declared access types (after vk-sync / kajiya).
//!
//! A pass declares *how* it touches each resource as an [`Access`]; each access maps to one
//! (stage, access mask, image layout) triple in [`Access::info`]. Given the accesses a resource
//! last had and the ones the next pass declares, [`barrier`] works out the one synchronization2
//! barrier needed, or none. No pass writes a barrier by hand.

use ash::vk;

/// How a pass touches a resource. Keep this table the only place that knows stages and layouts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Access {
    /// Not accessed yet / contents may be discarded.
    Nothing,
    // ----- reads -----
    IndexBuffer,
    VertexBuffer,
    /// Uniform or storage buffer read by pre-rasterization (vertex, geometry) and fragment shaders.
    GraphicsShaderReadBuffer,
    /// Uniform or storage buffer read by compute shaders.
    ComputeShaderReadBuffer,
    /// Sampled image read in fragment shaders.
    FragmentShaderReadSampled,
    /// Sampled image read in compute shaders.
    ComputeShaderReadSampled,
    /// Depth image read as a texture in compute shaders.
    ComputeShaderReadDepth,
    /// Storage image/buffer read (no writes) in compute shaders.
    ComputeShaderReadStorage,
    /// Depth attachment tested but not written.
    DepthAttachmentRead,
    TransferRead,
    HostRead,
    /// Arguments of an indirect dispatch (or draw) read from a buffer.
    IndirectCommandRead,
    /// A buffer an acceleration-structure build reads its input from (instances, geometry).
    AccelerationStructureBuildInput,
    /// An acceleration structure (its backing buffer) traced by ray queries in compute shaders.
    ComputeShaderReadAccelerationStructure,
    /// A swapchain image handed to the presentation engine. The presentation engine's reads
    /// are ordered by the semaphore the frame's last submit signals; the stage is every stage,
    /// so that the next frame's first barrier on the image chains with the semaphore that
    /// waits for its acquisition, whatever stage that wait names.
    Present,
    // ----- writes -----
    ColorAttachmentWrite,
    DepthAttachmentWrite,
    /// Storage image/buffer write (or read-write) in compute shaders.
    ComputeShaderWrite,
    /// Storage image/buffer write (or read-write, atomics) in fragment shaders.
    FragmentShaderWrite,
    TransferWrite,
    HostWrite,
    /// An acceleration structure (its backing buffer) or build scratch written by a build.
    AccelerationStructureBuildWrite,
}

/// Stage, access mask and layout of one [`Access`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AccessInfo {
    pub stage: vk::PipelineStageFlags2,
    pub access: vk::AccessFlags2,
    pub layout: vk::ImageLayout,
    pub writes: bool,
}

impl Access {
    pub fn info(self) -> AccessInfo {
        use vk::AccessFlags2 as A;
        use vk::ImageLayout as L;
        use vk::PipelineStageFlags2 as S;
        let (stage, access, layout, writes) = match self {
            Access::Nothing => (S::NONE, A::NONE, L::UNDEFINED, false),
            Access::IndexBuffer => (S::INDEX_INPUT, A::INDEX_READ, L::UNDEFINED, false),
            Access::VertexBuffer => (S::VERTEX_ATTRIBUTE_INPUT, A::VERTEX_ATTRIBUTE_READ, L::UNDEFINED, false),
            Access::GraphicsShaderReadBuffer => {
                let stage = S::PRE_RASTERIZATION_SHADERS | S::FRAGMENT_SHADER;
                (stage, A::SHADER_STORAGE_READ | A::UNIFORM_READ, L::UNDEFINED, false)
            }
            Access::ComputeShaderReadBuffer => {
                (S::COMPUTE_SHADER, A::SHADER_STORAGE_READ | A::UNIFORM_READ, L::UNDEFINED, false)
            }
            Access::FragmentShaderReadSampled => {
                (S::FRAGMENT_SHADER, A::SHADER_SAMPLED_READ, L::SHADER_READ_ONLY_OPTIMAL, false)
            }
            Access::ComputeShaderReadSampled => {
                (S::COMPUTE_SHADER, A::SHADER_SAMPLED_READ, L::SHADER_READ_ONLY_OPTIMAL, false)
            }
            Access::ComputeShaderReadDepth => {
                (S::COMPUTE_SHADER, A::SHADER_SAMPLED_READ, L::DEPTH_STENCIL_READ_ONLY_OPTIMAL, false)
            }
            Access::ComputeShaderReadStorage => (S::COMPUTE_SHADER, A::SHADER_STORAGE_READ, L::GENERAL, false),
            Access::DepthAttachmentRead => (
                S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS,
                A::DEPTH_STENCIL_ATTACHMENT_READ,
                L::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
                false,
            ),
            Access::TransferRead => (S::COPY, A::TRANSFER_READ, L::TRANSFER_SRC_OPTIMAL, false),
            Access::HostRead => (S::HOST, A::HOST_READ, L::GENERAL, false),
            Access::IndirectCommandRead => (S::DRAW_INDIRECT, A::INDIRECT_COMMAND_READ, L::UNDEFINED, false),
            // The specification's access types for builds: SHADER_READ for the inputs,
            // ACCELERATION_STRUCTURE_READ | WRITE for the structure and the scratch.
            Access::AccelerationStructureBuildInput => {
                (S::ACCELERATION_STRUCTURE_BUILD_KHR, A::SHADER_READ, L::UNDEFINED, false)
            }
            Access::ComputeShaderReadAccelerationStructure => {
                (S::COMPUTE_SHADER, A::ACCELERATION_STRUCTURE_READ_KHR, L::UNDEFINED, false)
            }
            Access::Present => (S::ALL_COMMANDS, A::NONE, L::PRESENT_SRC_KHR, false),
            Access::ColorAttachmentWrite => (
                S::COLOR_ATTACHMENT_OUTPUT,
                A::COLOR_ATTACHMENT_WRITE | A::COLOR_ATTACHMENT_READ,
                L::COLOR_ATTACHMENT_OPTIMAL,
                true,
            ),
            Access::DepthAttachmentWrite => (
                S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS,
                A::DEPTH_STENCIL_ATTACHMENT_WRITE | A::DEPTH_STENCIL_ATTACHMENT_READ,
                L::DEPTH_ATTACHMENT_OPTIMAL,
                true,
            ),
            Access::ComputeShaderWrite => {
                (S::COMPUTE_SHADER, A::SHADER_STORAGE_WRITE | A::SHADER_STORAGE_READ, L::GENERAL, true)
            }
            Access::FragmentShaderWrite => {
                (S::FRAGMENT_SHADER, A::SHADER_STORAGE_WRITE | A::SHADER_STORAGE_READ, L::GENERAL, true)
            }
            Access::TransferWrite => (S::COPY | S::CLEAR, A::TRANSFER_WRITE, L::TRANSFER_DST_OPTIMAL, true),
            Access::HostWrite => (S::HOST, A::HOST_WRITE, L::GENERAL, true),
            Access::AccelerationStructureBuildWrite => (
                S::ACCELERATION_STRUCTURE_BUILD_KHR,
                A::ACCELERATION_STRUCTURE_WRITE_KHR | A::ACCELERATION_STRUCTURE_READ_KHR,
                L::UNDEFINED,
                true,
            ),
        };
        AccessInfo { stage, access, layout, writes }
    }
}

/// The one barrier between two sets of accesses to the same resource.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Barrier {
    pub src_stage: vk::PipelineStageFlags2,
    pub src_access: vk::AccessFlags2,
    pub dst_stage: vk::PipelineStageFlags2,
    pub dst_access: vk::AccessFlags2,
    pub old_layout: vk::ImageLayout,
    pub new_layout: vk::ImageLayout,
    /// Queue families of an ownership transfer (`QUEUE_FAMILY_IGNORED` when none).
    pub src_family: u32,
    pub dst_family: u32,
}

/// Writes among a set of accesses (for the source side of a barrier).
pub fn write_mask(accesses: &[Access]) -> vk::AccessFlags2 {
    combine(accesses).2
}

/// Stages of a set of accesses.
pub fn stage_mask(accesses: &[Access]) -> vk::PipelineStageFlags2 {
    combine(accesses).0
}

/// Every access bit of a set of accesses (for the destination side of a barrier).
pub fn access_mask(accesses: &[Access]) -> vk::AccessFlags2 {
    combine(accesses).1
}

/// Whether any of `accesses` writes.
pub fn writes(accesses: &[Access]) -> bool {
    combine(accesses).3
}

fn combine(accesses: &[Access]) -> (vk::PipelineStageFlags2, vk::AccessFlags2, vk::AccessFlags2, bool) {
    let mut stage = vk::PipelineStageFlags2::NONE;
    let mut all = vk::AccessFlags2::NONE;
    let mut writes = vk::AccessFlags2::NONE;
    let mut any_write = false;
    for a in accesses {
        let i = a.info();
        stage |= i.stage;
        all |= i.access;
        if i.writes {
            writes |= i.access;
            any_write = true;
        }
    }
    (stage, all, writes, any_write)
}

/// The layout a set of accesses needs (they must agree; `GENERAL` if they do not).
pub fn layout_of(accesses: &[Access]) -> vk::ImageLayout {
    let mut layout = vk::ImageLayout::UNDEFINED;
    for a in accesses {
        let l = a.info().layout;
        if l == vk::ImageLayout::UNDEFINED {
            continue;
        }
        if layout == vk::ImageLayout::UNDEFINED {
            layout = l;
        } else if layout != l {
            return vk::ImageLayout::GENERAL;
        }
    }
    layout
}

/// The barrier needed before `next` when the resource was last accessed by `prev`.
///
/// * `is_image`: layouts matter (buffers ignore them).
/// * `discard`: the previous contents are not needed (transition from UNDEFINED).
///
/// Rules: read-after-read in the same layout needs nothing; write-after-read needs only an
/// execution dependency; anything after a write needs the write made available and visible;
/// a layout change is a write and always needs a barrier.
pub fn barrier(prev: &[Access], next: &[Access], is_image: bool, discard: bool) -> Option<Barrier> {
    barrier_from(prev, layout_of(prev), next, is_image, discard)
}

/// [`barrier`] with the image's current layout given explicitly (it may have been changed by
/// another queue since `prev`).
pub fn barrier_from(
    prev: &[Access],
    layout: vk::ImageLayout,
    next: &[Access],
    is_image: bool,
    discard: bool,
) -> Option<Barrier> {
    let (src_stage, _src_all, src_writes, prev_writes) = combine(prev);
    let (dst_stage, dst_all, _dst_writes, next_writes) = combine(next);
    let old_layout = if discard || !is_image { vk::ImageLayout::UNDEFINED } else { layout };
    let new_layout = if is_image { layout_of(next) } else { vk::ImageLayout::UNDEFINED };
    let layout_change = is_image && (old_layout != new_layout || (discard && new_layout != vk::ImageLayout::UNDEFINED));
    let prev_empty = prev.iter().all(|a| *a == Access::Nothing);
    if !prev_writes && !layout_change && (!next_writes || prev_empty) {
        return None; // read after read (or first use without a layout)
    }
    if next.iter().all(|a| *a == Access::Nothing) && !layout_change {
        return None;
    }
    let src_stage = if src_stage.is_empty() { vk::PipelineStageFlags2::NONE } else { src_stage };
    // Write-after-read: an execution dependency suffices unless a layout transition
    // (itself a write) or a previous write must be made visible.
    let dst_access = if prev_writes || layout_change { dst_all } else { vk::AccessFlags2::NONE };
    Some(Barrier {
        src_stage,
        src_access: src_writes,
        dst_stage,
        dst_access,
        old_layout,
        new_layout,
        src_family: vk::QUEUE_FAMILY_IGNORED,
        dst_family: vk::QUEUE_FAMILY_IGNORED,
    })
}

impl Barrier {
    pub fn image(&self, image: vk::Image, range: vk::ImageSubresourceRange) -> vk::ImageMemoryBarrier2<'static> {
        vk::ImageMemoryBarrier2::default()
            .src_stage_mask(self.src_stage)
            .src_access_mask(self.src_access)
            .dst_stage_mask(self.dst_stage)
            .dst_access_mask(self.dst_access)
            .old_layout(self.old_layout)
            .new_layout(self.new_layout)
            .src_queue_family_index(self.src_family)
            .dst_queue_family_index(self.dst_family)
            .image(image)
            .subresource_range(range)
    }
    /// A global memory barrier (no layout change): between dependent dispatches inside one
    /// pass, e.g. the levels of a mip chain.
    pub fn memory(&self) -> vk::MemoryBarrier2<'static> {
        vk::MemoryBarrier2::default()
            .src_stage_mask(self.src_stage)
            .src_access_mask(self.src_access)
            .dst_stage_mask(self.dst_stage)
            .dst_access_mask(self.dst_access)
    }
    pub fn buffer(&self, buffer: vk::Buffer) -> vk::BufferMemoryBarrier2<'static> {
        vk::BufferMemoryBarrier2::default()
            .src_stage_mask(self.src_stage)
            .src_access_mask(self.src_access)
            .dst_stage_mask(self.dst_stage)
            .dst_access_mask(self.dst_access)
            .src_queue_family_index(self.src_family)
            .dst_queue_family_index(self.dst_family)
            .buffer(buffer)
            .offset(0)
            .size(vk::WHOLE_SIZE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vk::AccessFlags2 as A;
    use vk::ImageLayout as L;
    use vk::PipelineStageFlags2 as S;

    #[test]
    fn read_after_read_same_layout_needs_nothing() {
        assert_eq!(
            barrier(&[Access::ComputeShaderReadSampled], &[Access::ComputeShaderReadSampled], true, false),
            None
        );
        assert_eq!(barrier(&[Access::VertexBuffer], &[Access::ComputeShaderReadBuffer], false, false), None);
    }

    #[test]
    fn read_after_write_makes_writes_visible() {
        let b = barrier(&[Access::ColorAttachmentWrite], &[Access::ComputeShaderReadSampled], true, false).unwrap();
        assert_eq!(b.src_stage, S::COLOR_ATTACHMENT_OUTPUT);
        assert_eq!(b.src_access, A::COLOR_ATTACHMENT_WRITE | A::COLOR_ATTACHMENT_READ);
        assert_eq!(b.dst_stage, S::COMPUTE_SHADER);
        assert_eq!(b.dst_access, A::SHADER_SAMPLED_READ);
        assert_eq!(b.old_layout, L::COLOR_ATTACHMENT_OPTIMAL);
        assert_eq!(b.new_layout, L::SHADER_READ_ONLY_OPTIMAL);
    }

    #[test]
    fn indirect_arguments_written_by_a_shader() {
        // A work list's group counts written by a compute shader, then read as the arguments
        // of an indirect dispatch and as a storage buffer by the dispatched shader.
        let next = [Access::IndirectCommandRead, Access::ComputeShaderReadBuffer];
        let b = barrier(&[Access::ComputeShaderWrite], &next, false, false).unwrap();
        assert_eq!(b.src_stage, S::COMPUTE_SHADER);
        assert_eq!(b.dst_stage, S::DRAW_INDIRECT | S::COMPUTE_SHADER);
        assert!(b.dst_access.contains(A::INDIRECT_COMMAND_READ | A::SHADER_STORAGE_READ));
        assert_eq!((b.old_layout, b.new_layout), (L::UNDEFINED, L::UNDEFINED));
        // Rewriting them after the dispatch waits for the argument read (no memory to make
        // visible: reads only).
        let b = barrier(&next, &[Access::ComputeShaderWrite], false, false).unwrap();
        assert_eq!(b.src_stage, S::DRAW_INDIRECT | S::COMPUTE_SHADER);
        assert_eq!((b.src_access, b.dst_access), (A::NONE, A::NONE));
        // Two indirect dispatches over the same arguments need nothing between them.
        assert_eq!(barrier(&next, &next, false, false), None);
    }

    #[test]
    fn write_after_read_same_layout_is_execution_only() {
        let b = barrier(&[Access::ComputeShaderReadStorage], &[Access::ComputeShaderWrite], true, false).unwrap();
        assert_eq!(b.src_access, A::NONE);
        assert_eq!(b.dst_access, A::NONE);
        assert_eq!(b.src_stage, S::COMPUTE_SHADER);
        assert_eq!(b.old_layout, b.new_layout);
    }

    #[test]
    fn write_after_write_is_a_full_dependency() {
        let b = barrier(&[Access::ComputeShaderWrite], &[Access::ComputeShaderWrite], true, false).unwrap();
        assert!(b.src_access.contains(A::SHADER_STORAGE_WRITE));
        assert!(b.dst_access.contains(A::SHADER_STORAGE_WRITE));
        assert_eq!(b.old_layout, L::GENERAL);
        assert_eq!(b.new_layout, L::GENERAL);
    }

    #[test]
    fn first_use_transitions_from_undefined() {
        let b = barrier(&[Access::Nothing], &[Access::DepthAttachmentWrite], true, false).unwrap();
        assert_eq!(b.old_layout, L::UNDEFINED);
        assert_eq!(b.new_layout, L::DEPTH_ATTACHMENT_OPTIMAL);
        assert_eq!(b.src_stage, S::NONE);
        assert_eq!(b.src_access, A::NONE);
        assert!(b.dst_access.contains(A::DEPTH_STENCIL_ATTACHMENT_WRITE));
        // A buffer's first use needs nothing.
        assert_eq!(barrier(&[Access::Nothing], &[Access::ComputeShaderWrite], false, false), None);
    }

    #[test]
    fn discard_drops_old_contents_even_in_same_layout() {
        let b = barrier(&[Access::ComputeShaderWrite], &[Access::ComputeShaderWrite], true, true).unwrap();
        assert_eq!(b.old_layout, L::UNDEFINED);
        assert_eq!(b.new_layout, L::GENERAL);
    }

    #[test]
    fn layout_change_between_reads_is_a_barrier() {
        let b = barrier(&[Access::TransferRead], &[Access::ComputeShaderReadSampled], true, false).unwrap();
        assert_eq!(b.old_layout, L::TRANSFER_SRC_OPTIMAL);
        assert_eq!(b.new_layout, L::SHADER_READ_ONLY_OPTIMAL);
        assert_eq!(b.src_access, A::NONE);
        assert_eq!(b.dst_access, A::SHADER_SAMPLED_READ);
    }

    #[test]
    fn multiple_reads_merge_stages() {
        let b = barrier(
            &[Access::TransferWrite],
            &[Access::FragmentShaderReadSampled, Access::ComputeShaderReadSampled],
            true,
            false,
        )
        .unwrap();
        assert_eq!(b.dst_stage, S::FRAGMENT_SHADER | S::COMPUTE_SHADER);
        assert_eq!(b.new_layout, L::SHADER_READ_ONLY_OPTIMAL);
        assert_eq!(b.src_access, A::TRANSFER_WRITE);
    }

    #[test]
    fn depth_written_then_sampled_as_depth() {
        let b = barrier(&[Access::DepthAttachmentWrite], &[Access::ComputeShaderReadDepth], true, false).unwrap();
        assert_eq!(b.new_layout, L::DEPTH_STENCIL_READ_ONLY_OPTIMAL);
        assert!(b.src_stage.contains(S::LATE_FRAGMENT_TESTS));
    }

    #[test]
    fn host_read_after_transfer_write() {
        let b = barrier(&[Access::TransferWrite], &[Access::HostRead], false, false).unwrap();
        assert_eq!(b.dst_stage, S::HOST);
        assert_eq!(b.dst_access, A::HOST_READ);
        assert_eq!(b.old_layout, L::UNDEFINED);
        assert_eq!(b.new_layout, L::UNDEFINED);
    }

    #[test]
    fn acceleration_structure_builds_order_against_their_inputs_and_rays() {
        let b = barrier(
            &[Access::AccelerationStructureBuildWrite],
            &[Access::ComputeShaderReadAccelerationStructure],
            false,
            false,
        )
        .unwrap();
        assert_eq!(b.src_stage, S::ACCELERATION_STRUCTURE_BUILD_KHR);
        assert!(b.src_access.contains(A::ACCELERATION_STRUCTURE_WRITE_KHR));
        assert_eq!((b.dst_stage, b.dst_access), (S::COMPUTE_SHADER, A::ACCELERATION_STRUCTURE_READ_KHR));
        // Instances uploaded by the frame, then read by the build.
        let b = barrier(&[Access::TransferWrite], &[Access::AccelerationStructureBuildInput], false, false).unwrap();
        assert_eq!((b.dst_stage, b.dst_access), (S::ACCELERATION_STRUCTURE_BUILD_KHR, A::SHADER_READ));
        // A rebuild after the previous frame's rays: an execution dependency only.
        let b = barrier(
            &[Access::ComputeShaderReadAccelerationStructure],
            &[Access::AccelerationStructureBuildWrite],
            false,
            false,
        )
        .unwrap();
        assert_eq!((b.src_stage, b.src_access, b.dst_access), (S::COMPUTE_SHADER, A::NONE, A::NONE));
    }

    #[test]
    fn a_presented_image_is_transitioned_after_its_writes_and_reacquired_without_its_contents() {
        use Access::*;
        // The UI drawn, then handed to the presentation engine: writes made available, layout
        // changed to PRESENT_SRC, nothing after it in the frame waits.
        let b = barrier(&[ColorAttachmentWrite], &[Present], true, false).expect("a layout change");
        assert_eq!(b.src_stage, S::COLOR_ATTACHMENT_OUTPUT);
        assert_eq!(b.src_access, A::COLOR_ATTACHMENT_WRITE | A::COLOR_ATTACHMENT_READ);
        assert_eq!((b.old_layout, b.new_layout), (L::COLOR_ATTACHMENT_OPTIMAL, L::PRESENT_SRC_KHR));
        assert_eq!(b.dst_access, A::NONE);
        // Acquired again next frame and drawn over whole: old contents dropped, and the barrier
        // waits on every stage so it chains with the acquire semaphore's wait.
        let b = barrier(&[Present], &[ColorAttachmentWrite], true, true).expect("a layout change");
        assert_eq!(b.src_stage, S::ALL_COMMANDS);
        assert_eq!(b.src_access, A::NONE);
        assert_eq!((b.old_layout, b.new_layout), (L::UNDEFINED, L::COLOR_ATTACHMENT_OPTIMAL));
    }

    #[test]
    fn every_access_has_consistent_info() {
        use Access::*;
        for a in [
            Nothing,
            IndexBuffer,
            VertexBuffer,
            GraphicsShaderReadBuffer,
            ComputeShaderReadBuffer,
            FragmentShaderReadSampled,
            ComputeShaderReadSampled,
            ComputeShaderReadDepth,
            ComputeShaderReadStorage,
            DepthAttachmentRead,
            TransferRead,
            HostRead,
            IndirectCommandRead,
            AccelerationStructureBuildInput,
            ComputeShaderReadAccelerationStructure,
            Present,
            ColorAttachmentWrite,
            DepthAttachmentWrite,
            ComputeShaderWrite,
            FragmentShaderWrite,
            TransferWrite,
            HostWrite,
            AccelerationStructureBuildWrite,
        ] {
            let i = a.info();
            // A write access always carries a write bit in its mask.
            let write_bits = A::SHADER_STORAGE_WRITE
                | A::COLOR_ATTACHMENT_WRITE
                | A::DEPTH_STENCIL_ATTACHMENT_WRITE
                | A::TRANSFER_WRITE
                | A::HOST_WRITE
                | A::ACCELERATION_STRUCTURE_WRITE_KHR;
            assert_eq!(i.writes, i.access.intersects(write_bits), "{a:?}");
            assert_eq!(a == Nothing, i.stage == S::NONE, "{a:?}");
        }
    }
}
