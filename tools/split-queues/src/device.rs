//! Device creation with one real queue behind every queue, the virtual queue, names.

use crate::loader::*;
use crate::rules::{self, QueueRequest};
use crate::state::*;
use crate::LAYER_NAME;
use ash::vk;
use ash::vk::Handle;
use std::collections::HashMap;
use std::ffi::{c_void, CStr};
use std::sync::{Arc, Mutex};

pub(crate) unsafe extern "system" fn create_device(
    pd: vk::PhysicalDevice,
    ci: *const vk::DeviceCreateInfo,
    alloc: *const vk::AllocationCallbacks,
    out: *mut vk::Device,
) -> vk::Result {
    let Some(inst) = instance_of(pd) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    let chain: *mut LayerDeviceCreateInfo =
        find_chain((*ci).p_next, vk::StructureType::LOADER_DEVICE_CREATE_INFO, LAYER_LINK_INFO);
    if chain.is_null() || (*chain).u.is_null() {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    }
    let link = (*chain).u as *mut LayerDeviceLink;
    let (gipa, gdpa) = ((*link).next_gipa, (*link).next_gdpa);
    (*chain).u = (*link).next as *mut c_void;
    let loader_data: *mut LayerDeviceCreateInfo =
        find_chain((*ci).p_next, vk::StructureType::LOADER_DEVICE_CREATE_INFO, LOADER_DATA_CALLBACK);
    let set_loader_data: Option<SetDeviceLoaderData> =
        (!loader_data.is_null()).then(|| std::mem::transmute::<*mut c_void, SetDeviceLoaderData>((*loader_data).u));
    let Some(create) = load::<vk::PFN_vkCreateDevice>(gipa(inst.raw, c"vkCreateDevice".as_ptr())) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    let split = rules::should_split(&inst.real_families(pd));
    let r = if split { create_split(create, pd, &*ci, alloc, out) } else { create(pd, ci, alloc, out) };
    if r != vk::Result::SUCCESS {
        return r;
    }
    let device = *out;
    let Some(fns) = device_fns(device, gdpa) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    let compute = if split && requested_family(&*ci, rules::VIRTUAL_FAMILY) {
        let mut real = vk::Queue::null();
        (fns.get_queue)(device, 0, 0, &mut real);
        // Word 0: the loader's dispatch pointer; word 1: the real queue behind it.
        let v = VirtualQueue(Box::new([key(device), real.as_raw() as usize, 0, 0]));
        if let Some(set) = set_loader_data {
            let _ = set(device, v.handle().as_raw() as *mut c_void);
        }
        Some(v)
    } else if split {
        // Split, but the application asked for no compute-family queue: nothing to back.
        let mut real = vk::Queue::null();
        (fns.get_queue)(device, 0, 0, &mut real);
        Some(VirtualQueue(Box::new([0, real.as_raw() as usize, 0, 0])))
    } else {
        None
    };
    let order = match rules::Order::parse(std::env::var("DVSGI_SPLIT_QUEUES_ORDER").ok().as_deref()) {
        Ok(o) if split => o,
        Ok(_) => rules::Order::Submission,
        Err(e) => {
            eprintln!("[{}] {e}", LAYER_NAME.to_string_lossy());
            (fns.destroy)(device, alloc);
            return vk::Result::ERROR_INITIALIZATION_FAILED;
        }
    };
    let trace = std::env::var_os("DVSGI_SPLIT_QUEUES_TRACE")
        .filter(|_| split)
        .and_then(|p| std::fs::OpenOptions::new().create(true).append(true).open(p).ok())
        .map(Mutex::new);
    let d = Device {
        gdpa,
        fns,
        compute,
        queue: Mutex::new(Vec::new()),
        order,
        pools: Mutex::new(HashMap::new()),
        command_families: Mutex::new(HashMap::new()),
        trace,
    };
    lock(&DEVICES).push((key(device), Arc::new(d)));
    vk::Result::SUCCESS
}

pub(crate) fn requested_family(ci: &vk::DeviceCreateInfo, family: u32) -> bool {
    queue_infos(ci).iter().any(|q| q.queue_family_index == family)
}

pub(crate) fn queue_infos<'a>(ci: &'a vk::DeviceCreateInfo) -> &'a [vk::DeviceQueueCreateInfo<'a>] {
    if ci.p_queue_create_infos.is_null() {
        return &[];
    }
    unsafe { std::slice::from_raw_parts(ci.p_queue_create_infos, ci.queue_create_info_count as usize) }
}

/// Create the real device with one queue (family 0, index 0) behind every queue requested.
pub(crate) unsafe fn create_split(
    create: vk::PFN_vkCreateDevice,
    pd: vk::PhysicalDevice,
    ci: &vk::DeviceCreateInfo,
    alloc: *const vk::AllocationCallbacks,
    out: *mut vk::Device,
) -> vk::Result {
    let infos = queue_infos(ci);
    let requests: Vec<QueueRequest> =
        infos.iter().map(|q| QueueRequest { family: q.queue_family_index, count: q.queue_count }).collect();
    if let Err(e) = rules::check_requests(&requests) {
        eprintln!("[{}] vkCreateDevice: {e:?}", LAYER_NAME.to_string_lossy());
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    }
    let Some(first) = infos.first() else {
        return create(pd, ci, alloc, out);
    };
    let one = vk::DeviceQueueCreateInfo { queue_family_index: 0, queue_count: 1, ..*first };
    let real = vk::DeviceCreateInfo { queue_create_info_count: 1, p_queue_create_infos: &one, ..*ci };
    create(pd, &real, alloc, out)
}

pub(crate) unsafe fn device_fns(device: vk::Device, gdpa: vk::PFN_vkGetDeviceProcAddr) -> Option<DeviceFns> {
    let f = |n: &CStr| gdpa(device, n.as_ptr());
    Some(DeviceFns {
        destroy: load(f(c"vkDestroyDevice"))?,
        get_queue: load(f(c"vkGetDeviceQueue"))?,
        get_queue2: load(f(c"vkGetDeviceQueue2")),
        submit: load(f(c"vkQueueSubmit"))?,
        submit2: load(f(c"vkQueueSubmit2")).or_else(|| load(f(c"vkQueueSubmit2KHR"))),
        wait_idle: load(f(c"vkQueueWaitIdle"))?,
        bind_sparse: load(f(c"vkQueueBindSparse"))?,
        present: load(f(c"vkQueuePresentKHR")),
        create_pool: load(f(c"vkCreateCommandPool"))?,
        destroy_pool: load(f(c"vkDestroyCommandPool"))?,
        allocate: load(f(c"vkAllocateCommandBuffers"))?,
        free: load(f(c"vkFreeCommandBuffers"))?,
        create_buffer: load(f(c"vkCreateBuffer"))?,
        create_image: load(f(c"vkCreateImage"))?,
        barrier: load(f(c"vkCmdPipelineBarrier"))?,
        barrier2: load(f(c"vkCmdPipelineBarrier2")).or_else(|| load(f(c"vkCmdPipelineBarrier2KHR"))),
        wait_events: load(f(c"vkCmdWaitEvents"))?,
        wait_events2: load(f(c"vkCmdWaitEvents2")).or_else(|| load(f(c"vkCmdWaitEvents2KHR"))),
        set_event2: load(f(c"vkCmdSetEvent2")).or_else(|| load(f(c"vkCmdSetEvent2KHR"))),
        set_name: load(f(c"vkSetDebugUtilsObjectNameEXT")),
        set_tag: load(f(c"vkSetDebugUtilsObjectTagEXT")),
        begin_label: load(f(c"vkQueueBeginDebugUtilsLabelEXT")),
        end_label: load(f(c"vkQueueEndDebugUtilsLabelEXT")),
        insert_label: load(f(c"vkQueueInsertDebugUtilsLabelEXT")),
        wait_semaphores: load(f(c"vkWaitSemaphores")).or_else(|| load(f(c"vkWaitSemaphoresKHR"))),
        counter_value: load(f(c"vkGetSemaphoreCounterValue")).or_else(|| load(f(c"vkGetSemaphoreCounterValueKHR"))),
        wait_fences: load(f(c"vkWaitForFences"))?,
        fence_status: load(f(c"vkGetFenceStatus"))?,
        device_wait_idle: load(f(c"vkDeviceWaitIdle"))?,
        query_results: load(f(c"vkGetQueryPoolResults"))?,
    })
}

pub(crate) unsafe extern "system" fn destroy_device(device: vk::Device, alloc: *const vk::AllocationCallbacks) {
    if device == vk::Device::null() {
        return;
    }
    let k = key(device);
    let d = {
        let mut l = lock(&DEVICES);
        let i = l.iter().position(|(key, _)| *key == k);
        i.map(|i| l.remove(i).1)
    };
    if let Some(d) = d {
        (d.fns.destroy)(device, alloc);
    }
}

pub(crate) unsafe extern "system" fn get_device_queue(
    device: vk::Device,
    family: u32,
    index: u32,
    out: *mut vk::Queue,
) {
    let Some(d) = device_of(device) else { return };
    match &d.compute {
        Some(v) if family == rules::VIRTUAL_FAMILY => *out = v.handle(),
        Some(_) => (d.fns.get_queue)(device, rules::map_family(family), 0, out),
        None => (d.fns.get_queue)(device, family, index, out),
    }
}

pub(crate) unsafe extern "system" fn get_device_queue2(
    device: vk::Device,
    info: *const vk::DeviceQueueInfo2,
    out: *mut vk::Queue,
) {
    let Some(d) = device_of(device) else { return };
    match (&d.compute, d.fns.get_queue2) {
        (Some(v), _) if (*info).queue_family_index == rules::VIRTUAL_FAMILY => *out = v.handle(),
        (Some(_), Some(next)) => {
            let real = vk::DeviceQueueInfo2 {
                queue_family_index: rules::map_family((*info).queue_family_index),
                queue_index: 0,
                ..*info
            };
            next(device, &real, out)
        }
        (None, Some(next)) => next(device, info, out),
        (_, None) => {}
    }
}

/// Names and tags of the virtual queue stay with the layers above (the driver never saw it).
pub(crate) fn is_virtual_queue(d: &Device, ty: vk::ObjectType, handle: u64) -> bool {
    ty == vk::ObjectType::QUEUE && d.compute.as_ref().is_some_and(|v| v.handle().as_raw() == handle)
}

pub(crate) unsafe extern "system" fn set_object_name(
    device: vk::Device,
    info: *const vk::DebugUtilsObjectNameInfoEXT,
) -> vk::Result {
    let Some(d) = device_of(device) else {
        return vk::Result::SUCCESS;
    };
    match d.fns.set_name {
        Some(_) if is_virtual_queue(&d, (*info).object_type, (*info).object_handle) => vk::Result::SUCCESS,
        Some(f) => f(device, info),
        None => vk::Result::SUCCESS,
    }
}

pub(crate) unsafe extern "system" fn set_object_tag(
    device: vk::Device,
    info: *const vk::DebugUtilsObjectTagInfoEXT,
) -> vk::Result {
    let Some(d) = device_of(device) else {
        return vk::Result::SUCCESS;
    };
    match d.fns.set_tag {
        Some(_) if is_virtual_queue(&d, (*info).object_type, (*info).object_handle) => vk::Result::SUCCESS,
        Some(f) => f(device, info),
        None => vk::Result::SUCCESS,
    }
}
