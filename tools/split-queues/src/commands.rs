//! Command pools and buffers (each buffer's family), sharing modes and barriers.

use crate::rules::{self, BarrierFields};
use crate::state::*;
use ash::vk;
use ash::vk::Handle;

pub(crate) unsafe extern "system" fn create_command_pool(
    device: vk::Device,
    ci: *const vk::CommandPoolCreateInfo,
    alloc: *const vk::AllocationCallbacks,
    out: *mut vk::CommandPool,
) -> vk::Result {
    let Some(d) = device_of(device) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    let family = (*ci).queue_family_index;
    let real = vk::CommandPoolCreateInfo { queue_family_index: rules::map_family(family), ..*ci };
    let r = (d.fns.create_pool)(device, &real, alloc, out);
    if r == vk::Result::SUCCESS {
        lock(&d.pools).insert((*out).as_raw(), (family, Vec::new()));
    }
    r
}

pub(crate) unsafe extern "system" fn destroy_command_pool(
    device: vk::Device,
    pool: vk::CommandPool,
    alloc: *const vk::AllocationCallbacks,
) {
    let Some(d) = device_of(device) else { return };
    if let Some((_, cmds)) = lock(&d.pools).remove(&pool.as_raw()) {
        let mut fams = lock(&d.command_families);
        for c in cmds {
            fams.remove(&c);
        }
    }
    (d.fns.destroy_pool)(device, pool, alloc)
}

pub(crate) unsafe extern "system" fn allocate_command_buffers(
    device: vk::Device,
    ai: *const vk::CommandBufferAllocateInfo,
    out: *mut vk::CommandBuffer,
) -> vk::Result {
    let Some(d) = device_of(device) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    let r = (d.fns.allocate)(device, ai, out);
    if r == vk::Result::SUCCESS {
        let cmds: Vec<u64> = slice(out, (*ai).command_buffer_count).iter().map(|c| c.as_raw()).collect();
        let mut pools = lock(&d.pools);
        if let Some((family, list)) = pools.get_mut(&(*ai).command_pool.as_raw()) {
            let mut fams = lock(&d.command_families);
            for &c in &cmds {
                fams.insert(c, *family);
            }
            list.extend(cmds);
        }
    }
    r
}

pub(crate) unsafe extern "system" fn free_command_buffers(
    device: vk::Device,
    pool: vk::CommandPool,
    n: u32,
    cmds: *const vk::CommandBuffer,
) {
    let Some(d) = device_of(device) else { return };
    {
        let freed: Vec<u64> = slice(cmds, n).iter().map(|c| c.as_raw()).collect();
        let mut fams = lock(&d.command_families);
        for c in &freed {
            fams.remove(c);
        }
        if let Some((_, list)) = lock(&d.pools).get_mut(&pool.as_raw()) {
            list.retain(|c| !freed.contains(c));
        }
    }
    (d.fns.free)(device, pool, n, cmds)
}

// ----- Sharing modes. -----

/// A create info's sharing as the driver must see it ([`rules::map_sharing`]).
struct DriverSharing {
    mode: vk::SharingMode,
    families: Vec<u32>,
}

impl DriverSharing {
    unsafe fn of(mode: vk::SharingMode, families: *const u32, count: u32) -> DriverSharing {
        let (mode, families) = rules::map_sharing(mode, slice(families, count));
        DriverSharing { mode, families }
    }
    fn pointer(&self) -> *const u32 {
        if self.families.is_empty() {
            std::ptr::null()
        } else {
            self.families.as_ptr()
        }
    }
}

pub(crate) unsafe extern "system" fn create_buffer(
    device: vk::Device,
    ci: *const vk::BufferCreateInfo,
    alloc: *const vk::AllocationCallbacks,
    out: *mut vk::Buffer,
) -> vk::Result {
    let Some(d) = device_of(device) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    let c = &*ci;
    let s = DriverSharing::of(c.sharing_mode, c.p_queue_family_indices, c.queue_family_index_count);
    let real = vk::BufferCreateInfo {
        sharing_mode: s.mode,
        queue_family_index_count: s.families.len() as u32,
        p_queue_family_indices: s.pointer(),
        ..*c
    };
    (d.fns.create_buffer)(device, &real, alloc, out)
}

pub(crate) unsafe extern "system" fn create_image(
    device: vk::Device,
    ci: *const vk::ImageCreateInfo,
    alloc: *const vk::AllocationCallbacks,
    out: *mut vk::Image,
) -> vk::Result {
    let Some(d) = device_of(device) else {
        return vk::Result::ERROR_DEVICE_LOST;
    };
    let c = &*ci;
    let s = DriverSharing::of(c.sharing_mode, c.p_queue_family_indices, c.queue_family_index_count);
    let real = vk::ImageCreateInfo {
        sharing_mode: s.mode,
        queue_family_index_count: s.families.len() as u32,
        p_queue_family_indices: s.pointer(),
        ..*c
    };
    (d.fns.create_image)(device, &real, alloc, out)
}

// ----- Barriers. -----

pub(crate) fn fields2_image(b: &vk::ImageMemoryBarrier2) -> BarrierFields {
    BarrierFields {
        src_family: b.src_queue_family_index,
        dst_family: b.dst_queue_family_index,
        old_layout: b.old_layout,
        new_layout: b.new_layout,
        src_stage: b.src_stage_mask,
        src_access: b.src_access_mask,
        dst_stage: b.dst_stage_mask,
        dst_access: b.dst_access_mask,
    }
}

pub(crate) fn map_image2<'a>(b: &vk::ImageMemoryBarrier2<'a>, fam: Option<u32>) -> vk::ImageMemoryBarrier2<'a> {
    let m = rules::map_barrier(fields2_image(b), fam);
    vk::ImageMemoryBarrier2 {
        src_queue_family_index: m.src_family,
        dst_queue_family_index: m.dst_family,
        old_layout: m.old_layout,
        new_layout: m.new_layout,
        src_stage_mask: m.src_stage,
        src_access_mask: m.src_access,
        dst_stage_mask: m.dst_stage,
        dst_access_mask: m.dst_access,
        ..*b
    }
}

pub(crate) fn map_buffer2<'a>(b: &vk::BufferMemoryBarrier2<'a>, fam: Option<u32>) -> vk::BufferMemoryBarrier2<'a> {
    let f = BarrierFields {
        src_family: b.src_queue_family_index,
        dst_family: b.dst_queue_family_index,
        old_layout: vk::ImageLayout::UNDEFINED,
        new_layout: vk::ImageLayout::UNDEFINED,
        src_stage: b.src_stage_mask,
        src_access: b.src_access_mask,
        dst_stage: b.dst_stage_mask,
        dst_access: b.dst_access_mask,
    };
    let m = rules::map_barrier(f, fam);
    vk::BufferMemoryBarrier2 {
        src_queue_family_index: m.src_family,
        dst_queue_family_index: m.dst_family,
        src_stage_mask: m.src_stage,
        src_access_mask: m.src_access,
        dst_stage_mask: m.dst_stage,
        dst_access_mask: m.dst_access,
        ..*b
    }
}

/// A dependency info with its barriers rewritten (the vectors must outlive its use).
pub(crate) struct MappedDependency<'a> {
    pub(crate) buffers: Vec<vk::BufferMemoryBarrier2<'a>>,
    pub(crate) images: Vec<vk::ImageMemoryBarrier2<'a>>,
    pub(crate) info: vk::DependencyInfo<'a>,
}

pub(crate) unsafe fn map_dependency<'a>(info: &vk::DependencyInfo<'a>, fam: Option<u32>) -> MappedDependency<'a> {
    let buffers = slice(info.p_buffer_memory_barriers, info.buffer_memory_barrier_count)
        .iter()
        .map(|b| map_buffer2(b, fam))
        .collect();
    let images = slice(info.p_image_memory_barriers, info.image_memory_barrier_count)
        .iter()
        .map(|b| map_image2(b, fam))
        .collect();
    MappedDependency { buffers, images, info: *info }
}

impl MappedDependency<'_> {
    fn get(&self) -> vk::DependencyInfo<'_> {
        vk::DependencyInfo {
            p_buffer_memory_barriers: self.buffers.as_ptr(),
            p_image_memory_barriers: self.images.as_ptr(),
            ..self.info
        }
    }
}

pub(crate) unsafe extern "system" fn cmd_pipeline_barrier2(cmd: vk::CommandBuffer, info: *const vk::DependencyInfo) {
    let Some(d) = device_of(cmd) else { return };
    let Some(next) = d.fns.barrier2 else { return };
    let m = map_dependency(&*info, d.command_family(cmd));
    next(cmd, &m.get())
}

pub(crate) unsafe extern "system" fn cmd_set_event2(
    cmd: vk::CommandBuffer,
    event: vk::Event,
    info: *const vk::DependencyInfo,
) {
    let Some(d) = device_of(cmd) else { return };
    let Some(next) = d.fns.set_event2 else { return };
    let m = map_dependency(&*info, d.command_family(cmd));
    next(cmd, event, &m.get())
}

pub(crate) unsafe extern "system" fn cmd_wait_events2(
    cmd: vk::CommandBuffer,
    n: u32,
    events: *const vk::Event,
    infos: *const vk::DependencyInfo,
) {
    let Some(d) = device_of(cmd) else { return };
    let Some(next) = d.fns.wait_events2 else {
        return;
    };
    let fam = d.command_family(cmd);
    let mapped: Vec<MappedDependency> = slice(infos, n).iter().map(|i| map_dependency(i, fam)).collect();
    let list: Vec<vk::DependencyInfo> = mapped.iter().map(|m| m.get()).collect();
    next(cmd, n, events, list.as_ptr())
}

/// Synchronization-1 barriers: the same rules with the command's stage masks.
pub(crate) struct Mapped1<'a> {
    pub(crate) buffers: Vec<vk::BufferMemoryBarrier<'a>>,
    pub(crate) images: Vec<vk::ImageMemoryBarrier<'a>>,
}

pub(crate) unsafe fn map1<'a>(
    fam: Option<u32>,
    buffers: &[vk::BufferMemoryBarrier<'a>],
    images: &[vk::ImageMemoryBarrier<'a>],
) -> Mapped1<'a> {
    let fields = |s, d, o, n| BarrierFields {
        src_family: s,
        dst_family: d,
        old_layout: o,
        new_layout: n,
        src_stage: vk::PipelineStageFlags2::NONE,
        src_access: vk::AccessFlags2::NONE,
        dst_stage: vk::PipelineStageFlags2::NONE,
        dst_access: vk::AccessFlags2::NONE,
    };
    let buffers = buffers
        .iter()
        .map(|b| {
            let m = rules::map_barrier(
                fields(
                    b.src_queue_family_index,
                    b.dst_queue_family_index,
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::UNDEFINED,
                ),
                fam,
            );
            vk::BufferMemoryBarrier { src_queue_family_index: m.src_family, dst_queue_family_index: m.dst_family, ..*b }
        })
        .collect();
    let images = images
        .iter()
        .map(|b| {
            let m = rules::map_barrier(
                fields(b.src_queue_family_index, b.dst_queue_family_index, b.old_layout, b.new_layout),
                fam,
            );
            vk::ImageMemoryBarrier {
                src_queue_family_index: m.src_family,
                dst_queue_family_index: m.dst_family,
                old_layout: m.old_layout,
                new_layout: m.new_layout,
                ..*b
            }
        })
        .collect();
    Mapped1 { buffers, images }
}

#[allow(clippy::too_many_arguments)]
pub(crate) unsafe extern "system" fn cmd_pipeline_barrier(
    cmd: vk::CommandBuffer,
    src: vk::PipelineStageFlags,
    dst: vk::PipelineStageFlags,
    flags: vk::DependencyFlags,
    nm: u32,
    mem: *const vk::MemoryBarrier,
    nb: u32,
    bufs: *const vk::BufferMemoryBarrier,
    ni: u32,
    imgs: *const vk::ImageMemoryBarrier,
) {
    let Some(d) = device_of(cmd) else { return };
    let m = map1(d.command_family(cmd), slice(bufs, nb), slice(imgs, ni));
    (d.fns.barrier)(cmd, src, dst, flags, nm, mem, nb, m.buffers.as_ptr(), ni, m.images.as_ptr())
}

#[allow(clippy::too_many_arguments)]
pub(crate) unsafe extern "system" fn cmd_wait_events(
    cmd: vk::CommandBuffer,
    ne: u32,
    events: *const vk::Event,
    src: vk::PipelineStageFlags,
    dst: vk::PipelineStageFlags,
    nm: u32,
    mem: *const vk::MemoryBarrier,
    nb: u32,
    bufs: *const vk::BufferMemoryBarrier,
    ni: u32,
    imgs: *const vk::ImageMemoryBarrier,
) {
    let Some(d) = device_of(cmd) else { return };
    let m = map1(d.command_family(cmd), slice(bufs, nb), slice(imgs, ni));
    (d.fns.wait_events)(cmd, ne, events, src, dst, nm, mem, nb, m.buffers.as_ptr(), ni, m.images.as_ptr())
}
