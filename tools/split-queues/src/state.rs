//! Per-instance and per-device state, found by the dispatch key.

use crate::queue::Held;
use crate::rules;
use ash::vk;
use ash::vk::Handle;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard};

/// Every dispatchable object starts with the loader's dispatch-table pointer, shared by an
/// instance and its physical devices, and by a device and its queues and command buffers.
pub(crate) unsafe fn key<H: Handle>(h: H) -> usize {
    *(h.as_raw() as *const usize)
}

pub(crate) struct Instance {
    pub(crate) raw: vk::Instance,
    pub(crate) gipa: vk::PFN_vkGetInstanceProcAddr,
    pub(crate) destroy: vk::PFN_vkDestroyInstance,
    pub(crate) families: vk::PFN_vkGetPhysicalDeviceQueueFamilyProperties,
    pub(crate) families2: Option<vk::PFN_vkGetPhysicalDeviceQueueFamilyProperties2>,
}

impl Instance {
    pub(crate) unsafe fn real_families(&self, pd: vk::PhysicalDevice) -> Vec<vk::QueueFamilyProperties> {
        let mut n = 0;
        (self.families)(pd, &mut n, std::ptr::null_mut());
        let mut v = vec![vk::QueueFamilyProperties::default(); n as usize];
        (self.families)(pd, &mut n, v.as_mut_ptr());
        v.truncate(n as usize);
        v
    }
}

/// The real device's functions the layer calls with rewritten arguments.
pub(crate) struct DeviceFns {
    pub(crate) destroy: vk::PFN_vkDestroyDevice,
    pub(crate) get_queue: vk::PFN_vkGetDeviceQueue,
    pub(crate) get_queue2: Option<vk::PFN_vkGetDeviceQueue2>,
    pub(crate) submit: vk::PFN_vkQueueSubmit,
    pub(crate) submit2: Option<vk::PFN_vkQueueSubmit2>,
    pub(crate) wait_idle: vk::PFN_vkQueueWaitIdle,
    pub(crate) bind_sparse: vk::PFN_vkQueueBindSparse,
    /// Where the device has VK_KHR_swapchain.
    pub(crate) present: Option<vk::PFN_vkQueuePresentKHR>,
    pub(crate) create_pool: vk::PFN_vkCreateCommandPool,
    pub(crate) destroy_pool: vk::PFN_vkDestroyCommandPool,
    pub(crate) allocate: vk::PFN_vkAllocateCommandBuffers,
    pub(crate) free: vk::PFN_vkFreeCommandBuffers,
    pub(crate) create_buffer: vk::PFN_vkCreateBuffer,
    pub(crate) create_image: vk::PFN_vkCreateImage,
    pub(crate) barrier: vk::PFN_vkCmdPipelineBarrier,
    pub(crate) barrier2: Option<vk::PFN_vkCmdPipelineBarrier2>,
    pub(crate) wait_events: vk::PFN_vkCmdWaitEvents,
    pub(crate) wait_events2: Option<vk::PFN_vkCmdWaitEvents2>,
    pub(crate) set_event2: Option<vk::PFN_vkCmdSetEvent2>,
    pub(crate) set_name: Option<vk::PFN_vkSetDebugUtilsObjectNameEXT>,
    pub(crate) set_tag: Option<vk::PFN_vkSetDebugUtilsObjectTagEXT>,
    pub(crate) begin_label: Option<vk::PFN_vkQueueBeginDebugUtilsLabelEXT>,
    pub(crate) end_label: Option<vk::PFN_vkQueueEndDebugUtilsLabelEXT>,
    pub(crate) insert_label: Option<vk::PFN_vkQueueInsertDebugUtilsLabelEXT>,
    pub(crate) wait_semaphores: Option<vk::PFN_vkWaitSemaphores>,
    pub(crate) counter_value: Option<vk::PFN_vkGetSemaphoreCounterValue>,
    pub(crate) wait_fences: vk::PFN_vkWaitForFences,
    pub(crate) fence_status: vk::PFN_vkGetFenceStatus,
    pub(crate) device_wait_idle: vk::PFN_vkDeviceWaitIdle,
    pub(crate) query_results: vk::PFN_vkGetQueryPoolResults,
}

/// A layer-made dispatchable object standing for the compute family's queue: its first word
/// is the loader's dispatch pointer, like any queue's.
pub(crate) struct VirtualQueue(pub(crate) Box<[usize; 4]>);

impl VirtualQueue {
    pub(crate) fn handle(&self) -> vk::Queue {
        vk::Queue::from_raw(self.0.as_ptr() as u64)
    }
}

pub(crate) struct Device {
    pub(crate) gdpa: vk::PFN_vkGetDeviceProcAddr,
    pub(crate) fns: DeviceFns,
    /// The virtual family's queue (`None` for a device that is not split).
    pub(crate) compute: Option<VirtualQueue>,
    /// The one real queue's lock (two "queues" above may be used from two threads at once),
    /// holding the batches held back by `order`, oldest first.
    pub(crate) queue: Mutex<Vec<Held>>,
    pub(crate) order: rules::Order,
    /// Command pool -> (its virtual family, its command buffers).
    pub(crate) pools: Mutex<HashMap<u64, (u32, Vec<u64>)>>,
    /// Command buffer -> the virtual family of its pool.
    pub(crate) command_families: Mutex<HashMap<u64, u32>>,
    pub(crate) trace: Option<Mutex<std::fs::File>>,
}

// The raw pointers inside are only handles and driver function pointers.
unsafe impl Send for Device {}
unsafe impl Sync for Device {}
unsafe impl Send for Instance {}
unsafe impl Sync for Instance {}

pub(crate) static INSTANCES: Mutex<Vec<(usize, Arc<Instance>)>> = Mutex::new(Vec::new());
pub(crate) static DEVICES: Mutex<Vec<(usize, Arc<Device>)>> = Mutex::new(Vec::new());

pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

pub(crate) fn find<T>(list: &Mutex<Vec<(usize, Arc<T>)>>, k: usize) -> Option<Arc<T>> {
    lock(list).iter().find(|(key, _)| *key == k).map(|(_, v)| v.clone())
}

pub(crate) unsafe fn instance_of<H: Handle>(h: H) -> Option<Arc<Instance>> {
    find(&INSTANCES, key(h))
}

pub(crate) unsafe fn device_of<H: Handle>(h: H) -> Option<Arc<Device>> {
    find(&DEVICES, key(h))
}

impl Device {
    /// The real queue behind a queue handle from above.
    pub(crate) fn real(&self, q: vk::Queue) -> vk::Queue {
        match &self.compute {
            Some(v) if v.handle() == q => self.real_queue(),
            _ => q,
        }
    }
    pub(crate) fn real_queue(&self) -> vk::Queue {
        vk::Queue::from_raw(self.compute.as_ref().map(|v| v.0[1] as u64).unwrap_or(0))
    }
    pub(crate) fn virtual_family_of(&self, q: vk::Queue) -> u32 {
        match &self.compute {
            Some(v) if v.handle() == q => rules::VIRTUAL_FAMILY,
            _ => 0,
        }
    }
    pub(crate) fn command_family(&self, cmd: vk::CommandBuffer) -> Option<u32> {
        lock(&self.command_families).get(&cmd.as_raw()).copied()
    }
    pub(crate) fn is_split(&self) -> bool {
        self.compute.is_some()
    }
}

pub(crate) unsafe fn slice<'a, T>(p: *const T, n: u32) -> &'a [T] {
    if p.is_null() || n == 0 {
        &[]
    } else {
        std::slice::from_raw_parts(p, n as usize)
    }
}
