//! Queue calls on the real queue: submits (held back in an adversarial order when asked), host waits, the trace.

use crate::rules;
use crate::state::*;
use ash::vk;
use ash::vk::Handle;
use std::ffi::c_void;
use std::io::Write;
use std::sync::MutexGuard;

pub(crate) unsafe extern "system" fn queue_submit(
    q: vk::Queue,
    n: u32,
    submits: *const vk::SubmitInfo,
    fence: vk::Fence,
) -> vk::Result {
    let Some(d) = device_of(q) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    let _g = d.flushed();
    if let Some(t) = &d.trace {
        for s in slice(submits, n) {
            trace_submit(&mut lock(t), d.virtual_family_of(q), &submit_semaphores(s), s.command_buffer_count);
        }
    }
    (d.fns.submit)(d.real(q), n, submits, fence)
}

pub(crate) unsafe extern "system" fn queue_submit2(
    q: vk::Queue,
    n: u32,
    submits: *const vk::SubmitInfo2,
    fence: vk::Fence,
) -> vk::Result {
    let Some(d) = device_of(q) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    let Some(next) = d.fns.submit2 else {
        return vk::Result::ERROR_EXTENSION_NOT_PRESENT;
    };
    let mut held = lock(&d.queue);
    let family = d.virtual_family_of(q);
    let batches = slice(submits, n);
    if let Some(t) = &d.trace {
        for s in batches {
            let (waits, signals) = (s.waits(), s.signals());
            trace_submit(&mut lock(t), family, &(waits, signals), s.command_buffer_info_count);
        }
    }
    let holds_this = d.order.held_family() == Some(family);
    if holds_this && fence == vk::Fence::null() {
        if let Some(copies) = batches.iter().map(|b| Held::copy(b)).collect::<Option<Vec<_>>>() {
            held.extend(copies);
            return vk::Result::SUCCESS;
        }
    }
    // Runs now: first whatever held work it waits for (all of it, on the held queue itself,
    // where order within the queue must stay, or with a fence).
    let through = if holds_this || fence != vk::Fence::null() {
        held.len()
    } else {
        let waits: Vec<(u64, u64)> = batches.iter().flat_map(|s| s.waits()).collect();
        let signals: Vec<Vec<(u64, u64)>> =
            held.iter().map(|h| h.signals.iter().map(|i| (i.semaphore.as_raw(), i.value)).collect()).collect();
        rules::flush_through(&signals, &waits)
    };
    let r = d.run_held(&mut held, through);
    if r != vk::Result::SUCCESS {
        return r;
    }
    next(d.real(q), n, submits, fence)
}

/// The (semaphore, value) pairs of a `VkSubmitInfo2`.
pub(crate) trait SubmitPairs {
    fn waits(&self) -> Vec<(u64, u64)>;
    fn signals(&self) -> Vec<(u64, u64)>;
}

impl SubmitPairs for vk::SubmitInfo2<'_> {
    fn waits(&self) -> Vec<(u64, u64)> {
        unsafe { slice(self.p_wait_semaphore_infos, self.wait_semaphore_info_count) }
            .iter()
            .map(|i| (i.semaphore.as_raw(), i.value))
            .collect()
    }
    fn signals(&self) -> Vec<(u64, u64)> {
        unsafe { slice(self.p_signal_semaphore_infos, self.signal_semaphore_info_count) }
            .iter()
            .map(|i| (i.semaphore.as_raw(), i.value))
            .collect()
    }
}

/// A batch held back (see [`rules::Order`]): a copy of what the application submitted.
pub(crate) struct Held {
    pub(crate) flags: vk::SubmitFlags,
    pub(crate) waits: Vec<vk::SemaphoreSubmitInfo<'static>>,
    pub(crate) commands: Vec<vk::CommandBufferSubmitInfo<'static>>,
    pub(crate) signals: Vec<vk::SemaphoreSubmitInfo<'static>>,
}

impl Held {
    /// A copy, or `None` when the batch carries extension structures (it then runs at once).
    pub(crate) unsafe fn copy(s: &vk::SubmitInfo2) -> Option<Held> {
        let waits = slice(s.p_wait_semaphore_infos, s.wait_semaphore_info_count);
        let commands = slice(s.p_command_buffer_infos, s.command_buffer_info_count);
        let signals = slice(s.p_signal_semaphore_infos, s.signal_semaphore_info_count);
        let plain = s.p_next.is_null()
            && waits.iter().chain(signals).all(|i| i.p_next.is_null())
            && commands.iter().all(|c| c.p_next.is_null());
        if !plain {
            return None;
        }
        let own = |v: &[vk::SemaphoreSubmitInfo]| -> Vec<vk::SemaphoreSubmitInfo<'static>> {
            v.iter()
                .map(|i| {
                    vk::SemaphoreSubmitInfo::default()
                        .semaphore(i.semaphore)
                        .value(i.value)
                        .stage_mask(i.stage_mask)
                        .device_index(i.device_index)
                })
                .collect()
        };
        Some(Held {
            flags: s.flags,
            waits: own(waits),
            commands: commands
                .iter()
                .map(|c| {
                    vk::CommandBufferSubmitInfo::default().command_buffer(c.command_buffer).device_mask(c.device_mask)
                })
                .collect(),
            signals: own(signals),
        })
    }
}

impl Device {
    /// Submit the first `n` held batches to the real queue, oldest first.
    pub(crate) unsafe fn run_held(&self, held: &mut Vec<Held>, n: usize) -> vk::Result {
        let Some(next) = self.fns.submit2 else {
            return vk::Result::SUCCESS;
        };
        for h in held.drain(..n.min(held.len())) {
            let info = vk::SubmitInfo2::default()
                .flags(h.flags)
                .wait_semaphore_infos(&h.waits)
                .command_buffer_infos(&h.commands)
                .signal_semaphore_infos(&h.signals);
            let r = next(self.real_queue(), 1, &info, vk::Fence::null());
            if r != vk::Result::SUCCESS {
                return r;
            }
        }
        vk::Result::SUCCESS
    }

    /// The real queue's lock, with every held batch submitted: before anything that waits
    /// on or observes the GPU from the host, and before work that cannot be held.
    pub(crate) fn flushed(&self) -> MutexGuard<'_, Vec<Held>> {
        let mut held = lock(&self.queue);
        let n = held.len();
        let _ = unsafe { self.run_held(&mut held, n) };
        held
    }
}

// ----- Host waits and queries: the held work runs first, so no host wait can hang. -----

pub(crate) unsafe extern "system" fn wait_semaphores(
    device: vk::Device,
    info: *const vk::SemaphoreWaitInfo,
    timeout: u64,
) -> vk::Result {
    let Some(d) = device_of(device) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    let Some(f) = d.fns.wait_semaphores else {
        return vk::Result::ERROR_EXTENSION_NOT_PRESENT;
    };
    drop(d.flushed());
    f(device, info, timeout)
}

pub(crate) unsafe extern "system" fn counter_value(
    device: vk::Device,
    sem: vk::Semaphore,
    value: *mut u64,
) -> vk::Result {
    let Some(d) = device_of(device) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    let Some(f) = d.fns.counter_value else {
        return vk::Result::ERROR_EXTENSION_NOT_PRESENT;
    };
    drop(d.flushed());
    f(device, sem, value)
}

pub(crate) unsafe extern "system" fn wait_fences(
    device: vk::Device,
    n: u32,
    fences: *const vk::Fence,
    all: vk::Bool32,
    timeout: u64,
) -> vk::Result {
    let Some(d) = device_of(device) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    drop(d.flushed());
    (d.fns.wait_fences)(device, n, fences, all, timeout)
}

pub(crate) unsafe extern "system" fn fence_status(device: vk::Device, fence: vk::Fence) -> vk::Result {
    let Some(d) = device_of(device) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    drop(d.flushed());
    (d.fns.fence_status)(device, fence)
}

pub(crate) unsafe extern "system" fn device_wait_idle(device: vk::Device) -> vk::Result {
    let Some(d) = device_of(device) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    drop(d.flushed());
    (d.fns.device_wait_idle)(device)
}

#[allow(clippy::too_many_arguments)]
pub(crate) unsafe extern "system" fn query_results(
    device: vk::Device,
    pool: vk::QueryPool,
    first: u32,
    count: u32,
    size: usize,
    data: *mut c_void,
    stride: vk::DeviceSize,
    flags: vk::QueryResultFlags,
) -> vk::Result {
    let Some(d) = device_of(device) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    drop(d.flushed());
    (d.fns.query_results)(device, pool, first, count, size, data, stride, flags)
}

/// A batch's (semaphore, value) waits and signals.
pub(crate) type SubmitSemaphores = (Vec<(u64, u64)>, Vec<(u64, u64)>);

/// The (semaphore, value) waits and signals of a `VkSubmitInfo` (values from its
/// `VkTimelineSemaphoreSubmitInfo`, 0 for binary semaphores).
pub(crate) unsafe fn submit_semaphores(s: &vk::SubmitInfo) -> SubmitSemaphores {
    let mut p = s.p_next as *const vk::BaseInStructure;
    let mut timeline: Option<&vk::TimelineSemaphoreSubmitInfo> = None;
    while !p.is_null() {
        if (*p).s_type == vk::StructureType::TIMELINE_SEMAPHORE_SUBMIT_INFO {
            timeline = Some(&*(p as *const vk::TimelineSemaphoreSubmitInfo));
        }
        p = (*p).p_next;
    }
    let value = |values: *const u64, count: u32, i: usize| -> u64 {
        if i < count as usize && !values.is_null() {
            *values.add(i)
        } else {
            0
        }
    };
    let waits = slice(s.p_wait_semaphores, s.wait_semaphore_count)
        .iter()
        .enumerate()
        .map(|(i, sem)| {
            (sem.as_raw(), timeline.map_or(0, |t| value(t.p_wait_semaphore_values, t.wait_semaphore_value_count, i)))
        })
        .collect();
    let signals = slice(s.p_signal_semaphores, s.signal_semaphore_count)
        .iter()
        .enumerate()
        .map(|(i, sem)| {
            (
                sem.as_raw(),
                timeline.map_or(0, |t| value(t.p_signal_semaphore_values, t.signal_semaphore_value_count, i)),
            )
        })
        .collect();
    (waits, signals)
}

/// One trace line: `submit family=F waits=SEM:VALUE,... signals=SEM:VALUE,... commands=N`.
pub(crate) fn trace_submit(f: &mut std::fs::File, family: u32, sems: &SubmitSemaphores, commands: u32) {
    let list = |v: &[(u64, u64)]| v.iter().map(|(s, v)| format!("{s:x}:{v}")).collect::<Vec<_>>().join(",");
    let line =
        format!("submit family={family} waits={} signals={} commands={commands}\n", list(&sems.0), list(&sems.1));
    let _ = f.write_all(line.as_bytes());
}

pub(crate) unsafe extern "system" fn queue_wait_idle(q: vk::Queue) -> vk::Result {
    let Some(d) = device_of(q) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    let _g = d.flushed();
    (d.fns.wait_idle)(d.real(q))
}

pub(crate) unsafe extern "system" fn queue_bind_sparse(
    q: vk::Queue,
    n: u32,
    info: *const vk::BindSparseInfo,
    fence: vk::Fence,
) -> vk::Result {
    let Some(d) = device_of(q) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    let _g = d.flushed();
    (d.fns.bind_sparse)(d.real(q), n, info, fence)
}

/// A presentation waits for semaphores that held batches may signal: they run first.
pub(crate) unsafe extern "system" fn queue_present(q: vk::Queue, info: *const vk::PresentInfoKHR) -> vk::Result {
    let Some(d) = device_of(q) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    let Some(present) = d.fns.present else {
        return vk::Result::ERROR_EXTENSION_NOT_PRESENT;
    };
    let _g = d.flushed();
    present(d.real(q), info)
}

pub(crate) unsafe extern "system" fn queue_begin_label(q: vk::Queue, label: *const vk::DebugUtilsLabelEXT) {
    if let Some(d) = device_of(q) {
        if let Some(f) = d.fns.begin_label {
            let _g = d.flushed();
            f(d.real(q), label)
        }
    }
}

pub(crate) unsafe extern "system" fn queue_end_label(q: vk::Queue) {
    if let Some(d) = device_of(q) {
        if let Some(f) = d.fns.end_label {
            let _g = d.flushed();
            f(d.real(q))
        }
    }
}

pub(crate) unsafe extern "system" fn queue_insert_label(q: vk::Queue, label: *const vk::DebugUtilsLabelEXT) {
    if let Some(d) = device_of(q) {
        if let Some(f) = d.fns.insert_label {
            let _g = d.flushed();
            f(d.real(q), label)
        }
    }
}
