//! The rewriting rules of the layer, free of any device (unit-tested below).
//!
//! A device with one queue family holding one graphics+compute queue is presented as two
//! families: family 0 is the real one; family 1 (the *virtual* family) is compute+transfer
//! only and is backed by the same real queue. Everything the application says in terms of
//! families is mapped back onto the real family before it reaches the driver.

use ash::vk;

/// Whether a device with these queue families is split: exactly one family, with graphics
/// and compute, and one queue (lavapipe, SwiftShader). Anything else passes through.
pub fn should_split(real: &[vk::QueueFamilyProperties]) -> bool {
    real.len() == 1
        && real[0].queue_flags.contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE)
        && real[0].queue_count == 1
}

/// The index of the virtual compute-only family (one past the real ones).
pub const VIRTUAL_FAMILY: u32 = 1;

/// The families the application sees: the real one, then the compute+transfer-only one
/// (same timestamp bits and granularity, one queue).
pub fn virtual_families(real: vk::QueueFamilyProperties) -> [vk::QueueFamilyProperties; 2] {
    [real, virtual_family(real)]
}

/// The compute-only family made from the real family's properties.
pub fn virtual_family(real: vk::QueueFamilyProperties) -> vk::QueueFamilyProperties {
    let keep = vk::QueueFlags::SPARSE_BINDING | vk::QueueFlags::PROTECTED;
    vk::QueueFamilyProperties {
        queue_flags: vk::QueueFlags::COMPUTE | vk::QueueFlags::TRANSFER | (real.queue_flags & keep),
        queue_count: 1,
        ..real
    }
}

/// A family index as the driver must see it (special values pass unchanged).
pub fn map_family(family: u32) -> u32 {
    if family == VIRTUAL_FAMILY {
        0
    } else {
        family
    }
}

/// One queue-create request as the application made it: family and queue count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct QueueRequest {
    pub family: u32,
    pub count: u32,
}

/// Why a device-creation request cannot be served.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RequestError {
    /// A family index beyond the two advertised.
    NoSuchFamily(u32),
    /// More queues than the (virtual) family advertises.
    TooManyQueues { family: u32, count: u32 },
}

/// Check the application's queue requests against the two advertised families (one queue
/// each). Every queue it gets is then backed by the one real queue (family 0, index 0).
pub fn check_requests(requests: &[QueueRequest]) -> Result<(), RequestError> {
    for r in requests {
        if r.family > VIRTUAL_FAMILY {
            return Err(RequestError::NoSuchFamily(r.family));
        }
        if r.count > 1 {
            return Err(RequestError::TooManyQueues { family: r.family, count: r.count });
        }
    }
    Ok(())
}

/// Sharing as the driver must see it: a CONCURRENT list whose families all map onto one
/// real family is EXCLUSIVE there (the spec requires CONCURRENT lists of distinct families).
pub fn map_sharing(mode: vk::SharingMode, families: &[u32]) -> (vk::SharingMode, Vec<u32>) {
    if mode != vk::SharingMode::CONCURRENT {
        return (mode, Vec::new());
    }
    let mut real: Vec<u32> = Vec::new();
    for f in families.iter().map(|&f| map_family(f)) {
        if !real.contains(&f) {
            real.push(f);
        }
    }
    if real.len() <= 1 {
        (vk::SharingMode::EXCLUSIVE, Vec::new())
    } else {
        (mode, real)
    }
}

/// The family-related fields of a buffer or image memory barrier.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BarrierFields {
    pub src_family: u32,
    pub dst_family: u32,
    pub old_layout: vk::ImageLayout,
    pub new_layout: vk::ImageLayout,
    pub src_stage: vk::PipelineStageFlags2,
    pub src_access: vk::AccessFlags2,
    pub dst_stage: vk::PipelineStageFlags2,
    pub dst_access: vk::AccessFlags2,
}

/// What a barrier is, seen from the command buffer (of family `cmd_family`) that records it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Transfer {
    /// No ownership transfer between the two advertised families.
    None,
    /// The release half (recorded on the source family's queue).
    Release,
    /// The acquire half (recorded on the destination family's queue).
    Acquire,
}

/// Classify a barrier's families (virtual indices) against the recording command buffer's.
pub fn classify(src: u32, dst: u32, cmd_family: Option<u32>) -> Transfer {
    let advertised = |f: u32| f <= VIRTUAL_FAMILY;
    if src == dst || !advertised(src) || !advertised(dst) {
        return Transfer::None;
    }
    match cmd_family {
        Some(c) if c == src => Transfer::Release,
        Some(c) if c == dst => Transfer::Acquire,
        _ => Transfer::None,
    }
}

/// The barrier as the driver must see it. Both families are one real family, so a transfer
/// between them is no transfer at all: the release becomes a plain barrier that performs
/// the layout transition and makes its writes available to everything after it (the
/// semaphore signal that follows it included); the acquire becomes a plain barrier without a
/// second transition (old layout = new layout). The checks happen above, in the validation
/// layer, which sees the barrier exactly as the application recorded it.
pub fn map_barrier(b: BarrierFields, cmd_family: Option<u32>) -> BarrierFields {
    let ignored = vk::QUEUE_FAMILY_IGNORED;
    match classify(b.src_family, b.dst_family, cmd_family) {
        Transfer::Release => BarrierFields {
            src_family: ignored,
            dst_family: ignored,
            dst_stage: vk::PipelineStageFlags2::ALL_COMMANDS,
            dst_access: vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE,
            ..b
        },
        Transfer::Acquire => BarrierFields {
            src_family: ignored,
            dst_family: ignored,
            old_layout: b.new_layout,
            src_access: vk::AccessFlags2::NONE,
            ..b
        },
        Transfer::None => {
            let (s, d) = (map_family(b.src_family), map_family(b.dst_family));
            if s == d {
                // Same real family (or both ignored): no transfer.
                BarrierFields { src_family: ignored, dst_family: ignored, ..b }
            } else {
                BarrierFields { src_family: s, dst_family: d, ..b }
            }
        }
    }
}

/// In which order the one real queue runs work that the two virtual queues leave unordered.
///
/// On a GPU the two queues run concurrently: any order the application's semaphores allow
/// can happen. `Submission` runs everything in submission order (which hides a missing
/// semaphore wait); the other two hold one queue's batches back for as long as the
/// application's own synchronization allows, so that a missing wait runs the consumer
/// before its producer and shows up as a wrong result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order {
    Submission,
    /// Hold the graphics family's batches back: compute work runs as early as it may.
    ComputeFirst,
    /// Hold the compute family's batches back: graphics work runs as early as it may.
    GraphicsFirst,
}

impl Order {
    /// From `DVSGI_SPLIT_QUEUES_ORDER` (unset: submission order).
    pub fn parse(v: Option<&str>) -> Result<Order, String> {
        match v.map(str::trim) {
            None | Some("") | Some("submission") => Ok(Order::Submission),
            Some("compute-first") => Ok(Order::ComputeFirst),
            Some("graphics-first") => Ok(Order::GraphicsFirst),
            Some(o) => Err(format!("DVSGI_SPLIT_QUEUES_ORDER={o:?}: use submission, compute-first or graphics-first")),
        }
    }
    /// The virtual family whose batches are held back, if any.
    pub fn held_family(self) -> Option<u32> {
        match self {
            Order::Submission => None,
            Order::ComputeFirst => Some(0),
            Order::GraphicsFirst => Some(VIRTUAL_FAMILY),
        }
    }
}

/// How many of the held batches (oldest first, each with the (semaphore, value) pairs it
/// signals) must run before a batch with these waits: through the first signaller of each
/// wait, whichever is latest. A timeline signal of `v >= w` satisfies a wait for `w`.
pub fn flush_through(held_signals: &[Vec<(u64, u64)>], waits: &[(u64, u64)]) -> usize {
    waits
        .iter()
        .filter_map(|(ws, wv)| held_signals.iter().position(|sig| sig.iter().any(|(s, v)| s == ws && v >= wv)))
        .max()
        .map_or(0, |i| i + 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use vk::AccessFlags2 as A;
    use vk::ImageLayout as L;
    use vk::PipelineStageFlags2 as S;

    fn lavapipe() -> vk::QueueFamilyProperties {
        vk::QueueFamilyProperties {
            queue_flags: vk::QueueFlags::GRAPHICS
                | vk::QueueFlags::COMPUTE
                | vk::QueueFlags::TRANSFER
                | vk::QueueFlags::SPARSE_BINDING,
            queue_count: 1,
            timestamp_valid_bits: 64,
            min_image_transfer_granularity: vk::Extent3D { width: 1, height: 1, depth: 1 },
        }
    }

    #[test]
    fn splits_only_a_single_queue_graphics_compute_device() {
        assert!(should_split(&[lavapipe()]));
        let two_queues = vk::QueueFamilyProperties { queue_count: 2, ..lavapipe() };
        assert!(!should_split(&[two_queues]));
        let compute_only = vk::QueueFamilyProperties { queue_flags: vk::QueueFlags::COMPUTE, ..lavapipe() };
        assert!(!should_split(&[compute_only]));
        assert!(!should_split(&[lavapipe(), lavapipe()]), "a real multi-family GPU passes through");
        assert!(!should_split(&[]));
    }

    #[test]
    fn the_virtual_family_is_compute_only_with_valid_timestamps() {
        let [g, c] = virtual_families(lavapipe());
        assert_eq!((g.queue_flags, g.queue_count), (lavapipe().queue_flags, 1));
        assert!(c.queue_flags.contains(vk::QueueFlags::COMPUTE | vk::QueueFlags::TRANSFER));
        assert!(!c.queue_flags.contains(vk::QueueFlags::GRAPHICS));
        assert!(c.queue_flags.contains(vk::QueueFlags::SPARSE_BINDING), "kept from the real family");
        assert_eq!(c.queue_count, 1);
        assert_eq!(c.timestamp_valid_bits, 64);
        assert_eq!(c.min_image_transfer_granularity, g.min_image_transfer_granularity);
    }

    #[test]
    fn families_map_onto_the_real_one_and_special_values_pass() {
        assert_eq!(map_family(0), 0);
        assert_eq!(map_family(1), 0);
        assert_eq!(map_family(vk::QUEUE_FAMILY_IGNORED), vk::QUEUE_FAMILY_IGNORED);
        assert_eq!(map_family(vk::QUEUE_FAMILY_EXTERNAL), vk::QUEUE_FAMILY_EXTERNAL);
        assert_eq!(map_family(vk::QUEUE_FAMILY_FOREIGN_EXT), vk::QUEUE_FAMILY_FOREIGN_EXT);
    }

    #[test]
    fn queue_requests_are_checked_against_the_advertised_families() {
        let ok = [QueueRequest { family: 0, count: 1 }, QueueRequest { family: 1, count: 1 }];
        assert_eq!(check_requests(&ok), Ok(()));
        assert_eq!(check_requests(&[QueueRequest { family: 2, count: 1 }]), Err(RequestError::NoSuchFamily(2)));
        assert_eq!(
            check_requests(&[QueueRequest { family: 1, count: 2 }]),
            Err(RequestError::TooManyQueues { family: 1, count: 2 })
        );
    }

    #[test]
    fn concurrent_sharing_between_the_two_families_is_exclusive_below() {
        assert_eq!(map_sharing(vk::SharingMode::CONCURRENT, &[0, 1]), (vk::SharingMode::EXCLUSIVE, vec![]));
        assert_eq!(map_sharing(vk::SharingMode::EXCLUSIVE, &[]), (vk::SharingMode::EXCLUSIVE, vec![]));
        // A family the layer does not own stays distinct.
        assert_eq!(map_sharing(vk::SharingMode::CONCURRENT, &[1, 2]), (vk::SharingMode::CONCURRENT, vec![0, 2]));
    }

    fn transfer(old: L, new: L) -> BarrierFields {
        BarrierFields {
            src_family: 1,
            dst_family: 0,
            old_layout: old,
            new_layout: new,
            src_stage: S::COMPUTE_SHADER,
            src_access: A::SHADER_STORAGE_WRITE,
            dst_stage: S::FRAGMENT_SHADER,
            dst_access: A::SHADER_SAMPLED_READ,
        }
    }

    #[test]
    fn a_transfer_is_classified_by_the_recording_family() {
        assert_eq!(classify(1, 0, Some(1)), Transfer::Release);
        assert_eq!(classify(1, 0, Some(0)), Transfer::Acquire);
        assert_eq!(classify(0, 0, Some(0)), Transfer::None);
        let ignored = vk::QUEUE_FAMILY_IGNORED;
        assert_eq!(classify(ignored, ignored, Some(0)), Transfer::None);
        assert_eq!(classify(1, vk::QUEUE_FAMILY_EXTERNAL, Some(1)), Transfer::None);
        assert_eq!(classify(1, 0, None), Transfer::None);
    }

    #[test]
    fn the_release_transitions_once_and_the_acquire_does_not_again() {
        let b = transfer(L::GENERAL, L::SHADER_READ_ONLY_OPTIMAL);
        let release = map_barrier(b, Some(1));
        assert_eq!((release.src_family, release.dst_family), (vk::QUEUE_FAMILY_IGNORED, vk::QUEUE_FAMILY_IGNORED));
        assert_eq!((release.old_layout, release.new_layout), (L::GENERAL, L::SHADER_READ_ONLY_OPTIMAL));
        assert_eq!(release.src_access, A::SHADER_STORAGE_WRITE, "the writes are made available");
        assert_eq!(release.dst_stage, S::ALL_COMMANDS, "ordered before the semaphore signal");
        let acquire = map_barrier(b, Some(0));
        assert_eq!((acquire.src_family, acquire.dst_family), (vk::QUEUE_FAMILY_IGNORED, vk::QUEUE_FAMILY_IGNORED));
        assert_eq!(acquire.old_layout, L::SHADER_READ_ONLY_OPTIMAL, "no second transition");
        assert_eq!(acquire.new_layout, L::SHADER_READ_ONLY_OPTIMAL);
        assert_eq!((acquire.dst_stage, acquire.dst_access), (S::FRAGMENT_SHADER, A::SHADER_SAMPLED_READ));
    }

    #[test]
    fn plain_barriers_only_lose_their_family_indices() {
        let mut b = transfer(L::UNDEFINED, L::GENERAL);
        b.src_family = 1;
        b.dst_family = 1;
        let m = map_barrier(b, Some(1));
        assert_eq!((m.src_family, m.dst_family), (vk::QUEUE_FAMILY_IGNORED, vk::QUEUE_FAMILY_IGNORED));
        assert_eq!(BarrierFields { src_family: 1, dst_family: 1, ..m }, b);
        // External transfers keep the real family on the layer's side.
        b.dst_family = vk::QUEUE_FAMILY_EXTERNAL;
        let m = map_barrier(b, Some(1));
        assert_eq!((m.src_family, m.dst_family), (0, vk::QUEUE_FAMILY_EXTERNAL));
    }

    #[test]
    fn orders_parse_and_name_the_held_family() {
        assert_eq!(Order::parse(None), Ok(Order::Submission));
        assert_eq!(Order::parse(Some("compute-first")).unwrap().held_family(), Some(0));
        assert_eq!(Order::parse(Some("graphics-first")).unwrap().held_family(), Some(VIRTUAL_FAMILY));
        assert_eq!(Order::Submission.held_family(), None);
        assert!(Order::parse(Some("random")).unwrap_err().contains("compute-first"));
    }

    #[test]
    fn a_wait_releases_the_held_batches_through_its_signaller() {
        let held = vec![vec![(7, 1)], vec![(7, 2)], vec![(7, 3)]];
        assert_eq!(flush_through(&held, &[]), 0, "no wait: run ahead of everything held");
        assert_eq!(flush_through(&held, &[(7, 2)]), 2, "value 2 needs the first two, in order");
        assert_eq!(flush_through(&held, &[(7, 3)]), 3);
        assert_eq!(flush_through(&held, &[(8, 1)]), 0, "another semaphore");
        assert_eq!(flush_through(&held, &[(7, 1), (9, 4)]), 1, "the first signaller of each wait, no further");
        assert_eq!(flush_through(&held, &[(9, 4), (7, 3)]), 3);
        assert_eq!(flush_through(&held, &[(7, 9)]), 0, "not signalled by anything held");
    }
}
