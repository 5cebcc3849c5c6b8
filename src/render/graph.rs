//! Passes declare what they read and write; the recorder derives every barrier from those
//! declarations (see `gpu::sync`) and wraps each pass in a debug label and GPU timestamps.

use super::binding::PassSet;
pub use super::binding::{Res, Use};
use crate::gpu::sync::{access_mask, barrier_from, layout_of, stage_mask, write_mask, writes, Access, Barrier};
use crate::gpu::Context;
use ash::vk;
use std::collections::HashMap;

/// A unit of GPU work in the frame.
pub trait Pass {
    fn name(&self) -> &str;
    /// The descriptor sets the pass binds: what they hold, with its access, is what its shaders
    /// read and write (see `render::binding`).
    fn sets(&self) -> Vec<&PassSet> {
        Vec::new()
    }
    /// What the pass touches outside its sets, that another pass may also touch: attachments,
    /// copies, indirect arguments, host reads. Never again an access one of its sets declares.
    fn unbound(&self) -> Vec<Use<'_>> {
        Vec::new()
    }
    /// The queue this work belongs to in the async modes (graphics unless overridden).
    fn queue(&self) -> QueueKind {
        QueueKind::Graphics
    }
    /// The queue in `async-pipelined`: as [`Pass::queue`], but the compute and transfer work of
    /// the frame's tail (deferred lighting, resolve, exposure, tone map, read-back copies)
    /// joins the GI on the compute queue, so the graphics queue never waits for a frame's GI.
    fn pipelined_queue(&self) -> QueueKind {
        self.queue()
    }
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer);
    /// Binary semaphores the submit holding this pass must wait for or signal (a viewer's
    /// swapchain image: acquired before it is drawn, handed to the presentation engine after).
    fn semaphores(&self) -> BinarySemaphores {
        BinarySemaphores::default()
    }
}

/// Everything `pass` reads or writes that another pass may also touch: what its sets hold,
/// then its unbound uses. (Data written once at load time is bound untracked.)
pub fn uses(pass: &dyn Pass) -> Vec<Use<'_>> {
    let mut uses: Vec<Use> = pass.sets().into_iter().flat_map(PassSet::uses).collect();
    let bound = uses.len();
    uses.extend(pass.unbound());
    debug_assert!(
        uses[bound..].iter().all(|u| uses[..bound].iter().all(|b| (b.res.key(), b.access) != (u.res.key(), u.access))),
        "{}: an access its sets declare is declared again as an unbound use",
        pass.name()
    );
    uses
}

/// What [`Pass::semaphores`] asks of its submit: wait for `wait` before the stages it names,
/// signal `signal` when the submit's work is done.
#[derive(Debug, Clone, Copy, Default)]
pub struct BinarySemaphores {
    pub wait: Option<(vk::Semaphore, vk::PipelineStageFlags2)>,
    pub signal: Option<vk::Semaphore>,
}

/// The queue a pass's work belongs to. In `sync` mode every pass runs on the graphics queue;
/// in the async modes compute passes run on the compute queue (see `render::schedule`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum QueueKind {
    Graphics,
    Compute,
}

impl QueueKind {
    pub const ALL: [QueueKind; 2] = [QueueKind::Graphics, QueueKind::Compute];
    pub fn index(self) -> usize {
        self as usize
    }
    pub fn other(self) -> QueueKind {
        match self {
            QueueKind::Graphics => QueueKind::Compute,
            QueueKind::Compute => QueueKind::Graphics,
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            QueueKind::Graphics => "graphics",
            QueueKind::Compute => "compute",
        }
    }
}

/// A tracked resource: its identity and whether it is an image (layouts, ownership).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ResKey {
    pub id: u64,
    pub is_image: bool,
    /// An image both families share at once (`Image::concurrent`): no ownership transfers.
    pub concurrent: bool,
}

impl Res<'_> {
    pub fn res_key(&self) -> ResKey {
        let concurrent = matches!(self, Res::Image(i) if i.concurrent);
        ResKey { id: self.key(), is_image: matches!(self, Res::Image(_)), concurrent }
    }
}

/// What the tracker knows of one resource across both queues.
#[derive(Debug, Clone, PartialEq)]
struct ResState {
    /// Current image layout (`UNDEFINED` before the first use).
    layout: vk::ImageLayout,
    /// The queue whose family owns the image (meaningful when the families differ).
    owner: Option<QueueKind>,
    /// The queue of the last write (a layout transition counts as a write).
    writer: Option<QueueKind>,
    /// Per queue: the last write there (or the accesses that performed the last layout
    /// transition there), still to be made visible to reads in other stages.
    write: [Vec<Access>; 2],
    /// Per queue: reads since that write, already made visible.
    reads: [Vec<Access>; 2],
    /// Per queue: timeline value of the batch with the latest access there.
    val: [u64; 2],
}

impl Default for ResState {
    fn default() -> Self {
        ResState {
            layout: vk::ImageLayout::UNDEFINED,
            owner: None,
            writer: None,
            write: [vec![], vec![]],
            reads: [vec![], vec![]],
            val: [0, 0],
        }
    }
}

impl ResState {
    fn touched(&self, q: QueueKind) -> bool {
        !self.write[q.index()].is_empty() || !self.reads[q.index()].is_empty()
    }
    /// Every access on `q` a barrier there must wait for.
    fn all(&self, q: QueueKind) -> Vec<Access> {
        let mut v = self.write[q.index()].clone();
        for a in &self.reads[q.index()] {
            if !v.contains(a) {
                v.push(*a);
            }
        }
        if v.is_empty() {
            v.push(Access::Nothing);
        }
        v
    }
}

/// What one pass needs before it runs, worked out from its declared uses.
#[derive(Debug, Default)]
pub struct Transition {
    /// The other queue's timeline value this pass must wait for (a semaphore wait), if any.
    pub wait: Option<u64>,
    /// Barriers recorded on the pass's queue just before it (acquire halves included).
    pub barriers: Vec<(ResKey, Barrier)>,
    /// Release halves of queue-family ownership transfers: recorded at the end of the other
    /// queue's open batch, which the pass then waits for.
    pub releases: Vec<(ResKey, Barrier)>,
    /// Human-readable description, for `--verbose` and tests.
    pub log: Vec<String>,
    /// New states, committed with the timeline value of the batch the pass lands in.
    updates: Vec<(ResKey, ResState)>,
}

/// The last accesses of every resource on each queue, carried from pass to pass and frame to
/// frame: the source of every barrier, semaphore wait and ownership transfer.
#[derive(Default)]
pub struct StateTracker {
    state: HashMap<ResKey, ResState>,
    /// Queue family per [`QueueKind`] when the two differ (ownership transfers are needed).
    families: Option<[u32; 2]>,
}

impl StateTracker {
    /// `families`: the graphics and compute families when they differ.
    pub fn new(families: Option<[u32; 2]>) -> StateTracker {
        StateTracker { state: HashMap::new(), families }
    }

    /// Plan a pass on `queue` with these uses (state is updated by [`StateTracker::commit`]).
    pub fn plan(&self, uses: &[Use], queue: QueueKind) -> Transition {
        // Merge multiple uses of the same resource in one pass.
        let mut merged: Vec<(Res, Vec<Access>, bool)> = Vec::new();
        for u in uses {
            match merged.iter_mut().find(|(r, _, _)| r.key() == u.res.key()) {
                Some((_, accs, discard)) => {
                    accs.push(u.access);
                    *discard &= u.discard;
                }
                None => merged.push((u.res, vec![u.access], u.discard)),
            }
        }
        let mut t = Transition::default();
        for (res, next, discard) in merged {
            self.plan_one(&mut t, res.res_key(), res.name(), &next, discard, queue);
        }
        t
    }

    /// The core of [`StateTracker::plan`] for one resource (GPU-free, unit-tested).
    ///
    /// On the pass's own queue: a write waits for every earlier access there and makes its
    /// predecessor write visible; a read needs a barrier only if its stage and access have
    /// not yet been given the last write; a layout change is a write. Across queues: any
    /// hazard with the other queue's accesses (it wrote, this pass writes, the layout or
    /// the owning family changes) is a semaphore wait for the other queue's batch, plus an
    /// ownership transfer (release there, acquire here) when the families differ.
    pub fn plan_one(&self, t: &mut Transition, key: ResKey, name: &str, next: &[Access], discard: bool, q: QueueKind) {
        let p = PlannedUse::new(self, key, name, next, discard, q);
        let same = p.same_queue_barrier();
        if p.cross {
            p.plan_cross_queue(t, same.is_some());
        } else if let Some(b) = same {
            t.log.push(format!("{name}: {:?} -> {next:?} ({:?} -> {:?})", p.prev_q, b.old_layout, b.new_layout));
            t.barriers.push((key, b));
        }
        t.updates.push((key, p.into_new_state()));
    }

    /// Take a resource as last accessed by `access` on `queue` in a batch already complete
    /// (a swapchain image, which starts in the presentation engine's hands).
    pub fn adopt(&mut self, key: ResKey, access: Access, queue: QueueKind) {
        let mut st = ResState { layout: access.info().layout, owner: Some(queue), ..ResState::default() };
        st.write[queue.index()] = vec![access];
        self.state.insert(key, st);
    }

    /// Record the planned states, with `value` the timeline value of the pass's batch.
    pub fn commit(&mut self, t: &mut Transition, queue: QueueKind, value: u64) {
        for (key, mut st) in t.updates.drain(..) {
            st.val[queue.index()] = value;
            self.state.insert(key, st);
        }
    }
}

/// One resource's uses by one pass on queue `q`, against the resource's tracked state: the
/// hazards [`StateTracker::plan_one`] decides on.
struct PlannedUse<'a> {
    key: ResKey,
    name: &'a str,
    next: &'a [Access],
    discard: bool,
    q: QueueKind,
    /// Queue family per [`QueueKind`] when the two differ.
    families: Option<[u32; 2]>,
    /// The resource's state before the pass.
    st: ResState,
    /// The layout the pass needs (`UNDEFINED` for buffers).
    next_layout: vk::ImageLayout,
    /// The pass changes the image's layout (a discard always does): that is a write.
    layout_change: bool,
    /// The pass writes the resource.
    next_writes: bool,
    /// The other queue's family owns the image and its contents are kept: ownership moves here.
    transfer: bool,
    /// A hazard with the other queue's accesses: a semaphore wait for its batch.
    cross: bool,
    /// Every access on this queue a barrier here must wait for.
    prev_q: Vec<Access>,
}

impl<'a> PlannedUse<'a> {
    /// Compare the pass's accesses `next` (on `q`) with what `tracker` knows of the resource.
    fn new(
        tracker: &StateTracker,
        key: ResKey,
        name: &'a str,
        next: &'a [Access],
        discard: bool,
        q: QueueKind,
    ) -> PlannedUse<'a> {
        let st = tracker.state.get(&key).cloned().unwrap_or_default();
        let o = q.other();
        let next_layout = if key.is_image { layout_of(next) } else { vk::ImageLayout::UNDEFINED };
        let layout_change =
            key.is_image && next_layout != vk::ImageLayout::UNDEFINED && (discard || next_layout != st.layout);
        let next_writes = writes(next);
        let transfer = key.is_image && !key.concurrent && tracker.families.is_some() && st.owner == Some(o) && !discard;
        let cross = st.touched(o) && (st.writer == Some(o) || next_writes || layout_change || transfer);
        let prev_q = st.all(q);
        PlannedUse {
            key,
            name,
            next,
            discard,
            q,
            families: tracker.families,
            st,
            next_layout,
            layout_change,
            next_writes,
            transfer,
            cross,
            prev_q,
        }
    }

    /// The barrier after this queue's own earlier accesses: after all of them for a write or a
    /// layout change; after the last write for a read in a stage not yet given it; else none.
    fn same_queue_barrier(&self) -> Option<Barrier> {
        let (st, qi) = (&self.st, self.q.index());
        if self.next_writes || self.layout_change {
            barrier_from(&self.prev_q, st.layout, self.next, self.key.is_image, self.discard)
        } else if !st.write[qi].is_empty() && self.next.iter().any(|a| !st.reads[qi].contains(a)) {
            barrier_from(&st.write[qi], st.layout, self.next, self.key.is_image, false)
        } else {
            None
        }
    }

    /// A hazard with the other queue: wait for its batch, then a barrier here (the acquire half
    /// of an ownership transfer, whose release half the other queue records) when the pass
    /// transfers, changes the layout or needs a same-queue barrier (`same`).
    fn plan_cross_queue(&self, t: &mut Transition, same: bool) {
        let (name, next, q, o) = (self.name, self.next, self.q, self.q.other());
        let mut b = self.after_wait_barrier();
        let (old_layout, new_layout) = (b.old_layout, b.new_layout);
        if self.transfer {
            self.plan_release(t, &mut b);
        }
        let waited = self.st.val[o.index()];
        t.wait = t.wait.max(Some(waited));
        t.log.push(format!("{name}: wait for {} {waited} ({:?} then {next:?})", o.name(), self.st.all(o)));
        if self.transfer {
            let (from, to) = (o.name(), q.name());
            t.log.push(format!("{name}: acquire {from} -> {to} ({old_layout:?} -> {new_layout:?}) for {next:?}"));
        } else if self.layout_change || same {
            let prev_q = &self.prev_q;
            t.log.push(format!("{name}: {prev_q:?} -> {next:?} ({old_layout:?} -> {new_layout:?})"));
        }
        if self.transfer || self.layout_change || same {
            t.barriers.push((self.key, b));
        }
    }

    /// The barrier after the semaphore wait: it chains to the wait (ALL_COMMANDS) and also
    /// covers this queue's own earlier accesses; the layout is kept unless the pass needs another.
    fn after_wait_barrier(&self) -> Barrier {
        let st = &self.st;
        let new_layout = if self.next_layout == vk::ImageLayout::UNDEFINED { st.layout } else { self.next_layout };
        let old_layout = if self.discard { vk::ImageLayout::UNDEFINED } else { st.layout };
        Barrier {
            src_stage: vk::PipelineStageFlags2::ALL_COMMANDS,
            src_access: write_mask(&self.prev_q),
            dst_stage: stage_mask(self.next),
            dst_access: access_mask(self.next),
            old_layout,
            new_layout,
            src_family: vk::QUEUE_FAMILY_IGNORED,
            dst_family: vk::QUEUE_FAMILY_IGNORED,
        }
    }

    /// Make `acquire` the acquire half of an ownership transfer from the other queue's family
    /// and plan the matching release half, which waits for every access there.
    fn plan_release(&self, t: &mut Transition, acquire: &mut Barrier) {
        let (q, o) = (self.q, self.q.other());
        let fam = self.families.expect("families differ");
        acquire.src_family = fam[o.index()];
        acquire.dst_family = fam[q.index()];
        let prev_o = self.st.all(o);
        let release = Barrier {
            src_stage: stage_mask(&prev_o),
            src_access: write_mask(&prev_o),
            dst_stage: vk::PipelineStageFlags2::NONE,
            dst_access: vk::AccessFlags2::NONE,
            ..*acquire
        };
        acquire.src_access = vk::AccessFlags2::NONE;
        t.releases.push((self.key, release));
        let (old_layout, new_layout) = (release.old_layout, release.new_layout);
        t.log.push(format!("{}: release {} -> {} ({old_layout:?} -> {new_layout:?})", self.name, o.name(), q.name()));
    }

    /// The resource's state after the pass (the timeline value is set by [`StateTracker::commit`]).
    fn into_new_state(self) -> ResState {
        let (q, qi, next) = (self.q, self.q.index(), self.next);
        let mut new = self.st;
        if self.key.is_image && self.next_layout != vk::ImageLayout::UNDEFINED {
            new.layout = self.next_layout;
        }
        if self.key.is_image && (new.owner.is_none() || self.transfer || self.discard) {
            new.owner = Some(q);
        }
        if self.next_writes || self.layout_change || self.transfer {
            // A write (or a layout transition): everything before it is ordered before it.
            new.writer = Some(q);
            new.write = [vec![], vec![]];
            new.reads = [vec![], vec![]];
            new.write[qi] = next.to_vec();
            if !self.next_writes {
                new.reads[qi] = next.to_vec();
            }
        } else {
            for a in next {
                if !new.reads[qi].contains(a) {
                    new.reads[qi].push(*a);
                }
            }
        }
        new
    }
}

/// Record barriers on a command buffer (images looked up by key in `uses`).
pub fn record_barriers(ctx: &Context, cmd: vk::CommandBuffer, barriers: &[(ResKey, Barrier)], uses: &[Use]) {
    if barriers.is_empty() {
        return;
    }
    let mut images = Vec::new();
    let mut buffers = Vec::new();
    for (key, b) in barriers {
        let Some(u) = uses.iter().find(|u| u.res.res_key() == *key) else { continue };
        match u.res {
            Res::Image(img) => images.push(b.image(img.raw, img.desc.full_range())),
            Res::Buffer(buf) => buffers.push(b.buffer(buf.raw)),
        }
    }
    let dep = vk::DependencyInfo::default().image_memory_barriers(&images).buffer_memory_barriers(&buffers);
    unsafe { ctx.device.cmd_pipeline_barrier2(cmd, &dep) };
}

#[cfg(test)]
mod tests {
    use super::*;
    use vk::ImageLayout as L;
    use vk::PipelineStageFlags2 as S;
    use Access::*;
    use QueueKind::{Compute as C, Graphics as G};

    const IMG: ResKey = ResKey { id: 1, is_image: true, concurrent: false };
    const BUF: ResKey = ResKey { id: 2, is_image: false, concurrent: false };

    /// Plan and commit one use; returns the transition.
    fn use_(
        tr: &mut StateTracker,
        key: ResKey,
        next: &[Access],
        discard: bool,
        q: QueueKind,
        value: u64,
    ) -> Transition {
        let mut t = Transition::default();
        tr.plan_one(&mut t, key, "r", next, discard, q);
        tr.commit(&mut t, q, value);
        t
    }

    #[test]
    fn same_queue_uses_need_barriers_only() {
        let mut tr = StateTracker::new(None);
        let t = use_(&mut tr, IMG, &[ColorAttachmentWrite], true, G, 1);
        assert_eq!(t.wait, None);
        assert_eq!(t.barriers.len(), 1);
        let t = use_(&mut tr, IMG, &[ComputeShaderReadSampled], false, G, 1);
        assert_eq!(t.wait, None);
        assert_eq!(t.barriers[0].1.new_layout, L::SHADER_READ_ONLY_OPTIMAL);
    }

    #[test]
    fn write_on_graphics_read_on_compute_waits_and_transitions_there() {
        let mut tr = StateTracker::new(None);
        use_(&mut tr, IMG, &[ColorAttachmentWrite], true, G, 3);
        let t = use_(&mut tr, IMG, &[ComputeShaderReadSampled], false, C, 1);
        assert_eq!(t.wait, Some(3), "waits for the graphics batch that wrote it");
        assert!(t.releases.is_empty(), "one family: no ownership transfer");
        let b = t.barriers[0].1;
        assert_eq!((b.old_layout, b.new_layout), (L::COLOR_ATTACHMENT_OPTIMAL, L::SHADER_READ_ONLY_OPTIMAL));
        assert_eq!(b.src_stage, S::ALL_COMMANDS, "chains to the semaphore wait");
        assert_eq!(b.src_family, vk::QUEUE_FAMILY_IGNORED);
        // Read again on graphics in the same layout: the compute transition was a write, so
        // graphics waits for it too.
        let t = use_(&mut tr, IMG, &[ComputeShaderReadSampled], false, G, 4);
        assert_eq!(t.wait, Some(1));
    }

    #[test]
    fn reads_on_both_queues_do_not_wait_for_each_other() {
        let mut tr = StateTracker::new(None);
        use_(&mut tr, BUF, &[TransferWrite], false, G, 1);
        let t = use_(&mut tr, BUF, &[ComputeShaderReadBuffer], false, C, 1);
        assert_eq!(t.wait, Some(1));
        assert!(t.barriers.is_empty(), "the semaphore makes the write visible; buffers have no layout");
        // Graphics reads the same data: ordered after its own write by a barrier, no wait.
        let t = use_(&mut tr, BUF, &[GraphicsShaderReadBuffer], false, G, 2);
        assert_eq!(t.wait, None);
        assert_eq!(t.barriers.len(), 1);
        // The next frame's upload waits for the compute read (write after read).
        let t = use_(&mut tr, BUF, &[TransferWrite], false, G, 3);
        assert_eq!(t.wait, Some(1));
    }

    #[test]
    fn a_write_is_made_visible_to_each_new_reading_stage_once() {
        let mut tr = StateTracker::new(None);
        use_(&mut tr, BUF, &[TransferWrite], false, G, 1);
        let t = use_(&mut tr, BUF, &[GraphicsShaderReadBuffer], false, G, 1);
        assert_eq!(t.barriers[0].1.src_access, vk::AccessFlags2::TRANSFER_WRITE);
        let t = use_(&mut tr, BUF, &[ComputeShaderReadBuffer], false, G, 1);
        assert_eq!(t.barriers.len(), 1, "a new stage needs the write too");
        assert_eq!(t.barriers[0].1.src_stage, S::COPY | S::CLEAR, "from the write, not the reads");
        let t = use_(&mut tr, BUF, &[GraphicsShaderReadBuffer], false, G, 1);
        assert!(t.barriers.is_empty(), "already visible there");
        let t = use_(&mut tr, BUF, &[TransferWrite], false, G, 2);
        let b = t.barriers[0].1;
        assert!(b.src_stage.contains(S::COMPUTE_SHADER | S::FRAGMENT_SHADER), "waits for every read");
    }

    #[test]
    fn a_concurrent_image_moves_between_families_without_transfers() {
        // The voxel volumes (`ImageDesc::concurrent`): written on graphics, read on compute,
        // written again on graphics in the next frame. Each use waits only for the other
        // queue's last use of it; no release is recorded after the other queue's later work.
        let vol = ResKey { id: 3, is_image: true, concurrent: true };
        let mut tr = StateTracker::new(Some([0, 2]));
        use_(&mut tr, vol, &[FragmentShaderWrite], true, G, 4);
        let t = use_(&mut tr, vol, &[ComputeShaderReadStorage], false, C, 9);
        assert_eq!(t.wait, Some(4));
        assert!(t.releases.is_empty(), "{:?}", t.releases);
        let b = t.barriers.first().map(|b| b.1);
        assert!(b.map_or(true, |b| b.src_family == vk::QUEUE_FAMILY_IGNORED), "{b:?}");
        let t = use_(&mut tr, vol, &[FragmentShaderWrite], false, G, 5);
        assert_eq!(t.wait, Some(9), "the write waits for the read on compute (write after read)");
        assert!(t.releases.is_empty(), "{:?}", t.releases);
        assert!(t.barriers.iter().all(|(_, b)| b.src_family == vk::QUEUE_FAMILY_IGNORED));
    }

    #[test]
    fn distinct_families_transfer_ownership_with_matching_halves() {
        let mut tr = StateTracker::new(Some([0, 2]));
        use_(&mut tr, IMG, &[ComputeShaderWrite], true, C, 5);
        let t = use_(&mut tr, IMG, &[ComputeShaderReadStorage], false, G, 7);
        assert_eq!(t.wait, Some(5));
        let (r, a) = (t.releases[0].1, t.barriers[0].1);
        assert_eq!((r.src_family, r.dst_family), (2, 0));
        assert_eq!((a.src_family, a.dst_family), (2, 0));
        assert_eq!((r.old_layout, r.new_layout), (a.old_layout, a.new_layout));
        assert_eq!(r.src_access, vk::AccessFlags2::SHADER_STORAGE_WRITE | vk::AccessFlags2::SHADER_STORAGE_READ);
        assert_eq!(r.dst_stage, S::NONE);
        assert_eq!(a.src_access, vk::AccessFlags2::NONE);
        assert_eq!(a.dst_stage, S::COMPUTE_SHADER);
        // Back to compute, overwriting: no transfer (contents discarded), but a wait (WAR).
        let t = use_(&mut tr, IMG, &[ComputeShaderWrite], true, C, 6);
        assert_eq!(t.wait, Some(7));
        assert!(t.releases.is_empty());
        assert_eq!(t.barriers[0].1.old_layout, L::UNDEFINED);
        assert_eq!(t.barriers[0].1.src_family, vk::QUEUE_FAMILY_IGNORED);
    }

    #[test]
    fn same_family_second_queue_never_transfers() {
        let mut tr = StateTracker::new(None);
        use_(&mut tr, IMG, &[ComputeShaderWrite], true, C, 1);
        let t = use_(&mut tr, IMG, &[ComputeShaderReadStorage], false, G, 1);
        assert!(t.releases.is_empty());
        assert_eq!(t.wait, Some(1));
    }
}
