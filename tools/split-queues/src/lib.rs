//! `VK_LAYER_DVSGI_split_queues`: a Vulkan layer that presents a device with one queue family
//! and one queue (lavapipe, SwiftShader) as a GPU with a graphics family and a separate
//! compute-only family, both backed by the one real queue.
//!
//! Loaded *below* the Khronos validation layer (tools/with-split-queues.sh orders them), it
//! lets validation check an application's queue-family ownership transfers, per-family command
//! pools and cross-queue semaphores exactly as on a GPU with a dedicated compute family:
//! validation sees two families and two distinct `VkQueue`s; the driver sees one.
//!
//! What the layer does (the rules are in [`rules`], unit-tested without a device):
//! * `vkGetPhysicalDeviceQueueFamilyProperties(2)`: a second, compute+transfer family.
//! * `vkCreateDevice`: every requested queue maps onto real family 0, queue 0.
//! * `vkGetDeviceQueue(2)`: family 1 gets its own dispatchable handle (a layer-made object).
//! * Queue calls (submit, wait idle, sparse binding, labels) on that handle go to the real
//!   queue, serialised by one lock per device (two "queues" may be used from two threads).
//! * Family indices are rewritten where the driver sees them: command pools, CONCURRENT
//!   sharing (which becomes EXCLUSIVE on the one real family), and barriers, where a release
//!   becomes the plain barrier that performs the transition and the acquire a plain barrier.
//! * Everything else passes through untouched; a device that already has more than one
//!   queue family or queue is not split at all.
//!
//! * One real queue runs everything in submission order, which hides a missing semaphore
//!   wait. `DVSGI_SPLIT_QUEUES_ORDER=compute-first|graphics-first` holds one family's batches
//!   back for as long as the application's semaphores allow (a host wait, a query or a
//!   presentation runs them), so work that forgot to wait runs before what it reads, as it
//!   may on a GPU.
//!
//! With `DVSGI_SPLIT_QUEUES_TRACE=FILE`, every submit (its virtual family, the semaphore
//! waits and signals it was handed, and its command buffers) is appended to FILE as one line:
//! what the application actually gave `vkQueueSubmit(2)`, for tests.
//!
//! Modules: `loader` (the loader-layer interface), `state` (instances and devices by dispatch
//! key), `instance` (families), `device` (creation, queues, names), `queue` (submits, the
//! held batches, host waits), `commands` (pools, sharing, barriers); [`rules`] decides.

mod commands;
mod device;
mod instance;
mod loader;
mod queue;
pub mod rules;
mod state;

use ash::vk;
use commands::*;
use device::*;
use instance::*;
use loader::LAYER_NEGOTIATE_INTERFACE_STRUCT;
use queue::*;
use state::{device_of, instance_of};
use std::ffi::{c_char, c_void, CStr};

/// The layer's name, as in its manifest.
pub const LAYER_NAME: &CStr = c"VK_LAYER_DVSGI_split_queues";

#[repr(C)]
pub struct NegotiateLayerInterface {
    s_type: i32,
    p_next: *mut c_void,
    loader_layer_interface_version: u32,
    gipa: Option<vk::PFN_vkGetInstanceProcAddr>,
    gdpa: Option<vk::PFN_vkGetDeviceProcAddr>,
    gpdpa: *const c_void,
}

/// The loader's entry point into the layer (interface version 2).
///
/// # Safety
/// Called by the Vulkan loader with a valid `VkNegotiateLayerInterface`.
#[no_mangle]
pub unsafe extern "system" fn vkNegotiateLoaderLayerInterfaceVersion(v: *mut NegotiateLayerInterface) -> vk::Result {
    if v.is_null() || (*v).s_type != LAYER_NEGOTIATE_INTERFACE_STRUCT {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    }
    if (*v).loader_layer_interface_version < 2 {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    }
    (*v).loader_layer_interface_version = 2;
    (*v).gipa = Some(get_instance_proc_addr);
    (*v).gdpa = Some(get_device_proc_addr);
    (*v).gpdpa = std::ptr::null();
    vk::Result::SUCCESS
}

// ----- Proc-address lookup. -----

macro_rules! intercept {
    ($name:expr, $($vk:literal => $f:expr),* $(,)?) => {{
        let name: &[u8] = $name;
        $(if name == $vk.to_bytes() {
            return Some(std::mem::transmute::<*const (), unsafe extern "system" fn()>($f as *const ()));
        })*
    }};
}

/// Device-level functions the layer rewrites (on split devices).
unsafe fn device_function(name: &[u8]) -> vk::PFN_vkVoidFunction {
    intercept!(name,
        c"vkGetDeviceProcAddr" => get_device_proc_addr as vk::PFN_vkGetDeviceProcAddr,
        c"vkDestroyDevice" => destroy_device as vk::PFN_vkDestroyDevice,
        c"vkGetDeviceQueue" => get_device_queue as vk::PFN_vkGetDeviceQueue,
        c"vkGetDeviceQueue2" => get_device_queue2 as vk::PFN_vkGetDeviceQueue2,
        c"vkQueueSubmit" => queue_submit as vk::PFN_vkQueueSubmit,
        c"vkQueueSubmit2" => queue_submit2 as vk::PFN_vkQueueSubmit2,
        c"vkQueueSubmit2KHR" => queue_submit2 as vk::PFN_vkQueueSubmit2,
        c"vkQueueWaitIdle" => queue_wait_idle as vk::PFN_vkQueueWaitIdle,
        c"vkQueueBindSparse" => queue_bind_sparse as vk::PFN_vkQueueBindSparse,
        c"vkQueuePresentKHR" => queue_present as vk::PFN_vkQueuePresentKHR,
        c"vkCreateCommandPool" => create_command_pool as vk::PFN_vkCreateCommandPool,
        c"vkDestroyCommandPool" => destroy_command_pool as vk::PFN_vkDestroyCommandPool,
        c"vkAllocateCommandBuffers" => allocate_command_buffers as vk::PFN_vkAllocateCommandBuffers,
        c"vkFreeCommandBuffers" => free_command_buffers as vk::PFN_vkFreeCommandBuffers,
        c"vkCreateBuffer" => create_buffer as vk::PFN_vkCreateBuffer,
        c"vkCreateImage" => create_image as vk::PFN_vkCreateImage,
        c"vkCmdPipelineBarrier" => cmd_pipeline_barrier as vk::PFN_vkCmdPipelineBarrier,
        c"vkCmdPipelineBarrier2" => cmd_pipeline_barrier2 as vk::PFN_vkCmdPipelineBarrier2,
        c"vkCmdPipelineBarrier2KHR" => cmd_pipeline_barrier2 as vk::PFN_vkCmdPipelineBarrier2,
        c"vkCmdWaitEvents" => cmd_wait_events as vk::PFN_vkCmdWaitEvents,
        c"vkCmdWaitEvents2" => cmd_wait_events2 as vk::PFN_vkCmdWaitEvents2,
        c"vkCmdWaitEvents2KHR" => cmd_wait_events2 as vk::PFN_vkCmdWaitEvents2,
        c"vkCmdSetEvent2" => cmd_set_event2 as vk::PFN_vkCmdSetEvent2,
        c"vkCmdSetEvent2KHR" => cmd_set_event2 as vk::PFN_vkCmdSetEvent2,
        c"vkSetDebugUtilsObjectNameEXT" => set_object_name as vk::PFN_vkSetDebugUtilsObjectNameEXT,
        c"vkSetDebugUtilsObjectTagEXT" => set_object_tag as vk::PFN_vkSetDebugUtilsObjectTagEXT,
        c"vkQueueBeginDebugUtilsLabelEXT" => queue_begin_label as vk::PFN_vkQueueBeginDebugUtilsLabelEXT,
        c"vkQueueEndDebugUtilsLabelEXT" => queue_end_label as vk::PFN_vkQueueEndDebugUtilsLabelEXT,
        c"vkQueueInsertDebugUtilsLabelEXT" => queue_insert_label as vk::PFN_vkQueueInsertDebugUtilsLabelEXT,
        c"vkWaitSemaphores" => wait_semaphores as vk::PFN_vkWaitSemaphores,
        c"vkWaitSemaphoresKHR" => wait_semaphores as vk::PFN_vkWaitSemaphores,
        c"vkGetSemaphoreCounterValue" => counter_value as vk::PFN_vkGetSemaphoreCounterValue,
        c"vkGetSemaphoreCounterValueKHR" => counter_value as vk::PFN_vkGetSemaphoreCounterValue,
        c"vkWaitForFences" => wait_fences as vk::PFN_vkWaitForFences,
        c"vkGetFenceStatus" => fence_status as vk::PFN_vkGetFenceStatus,
        c"vkDeviceWaitIdle" => device_wait_idle as vk::PFN_vkDeviceWaitIdle,
        c"vkGetQueryPoolResults" => query_results as vk::PFN_vkGetQueryPoolResults,
    );
    None
}

unsafe extern "system" fn get_instance_proc_addr(
    instance: vk::Instance,
    name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    if name.is_null() {
        return None;
    }
    let n = CStr::from_ptr(name).to_bytes();
    intercept!(n,
        c"vkGetInstanceProcAddr" => get_instance_proc_addr as vk::PFN_vkGetInstanceProcAddr,
        c"vkCreateInstance" => create_instance as vk::PFN_vkCreateInstance,
        c"vkDestroyInstance" => destroy_instance as vk::PFN_vkDestroyInstance,
        c"vkCreateDevice" => create_device as vk::PFN_vkCreateDevice,
        c"vkGetPhysicalDeviceQueueFamilyProperties" =>
            queue_family_properties as vk::PFN_vkGetPhysicalDeviceQueueFamilyProperties,
        c"vkGetPhysicalDeviceQueueFamilyProperties2" =>
            queue_family_properties2 as vk::PFN_vkGetPhysicalDeviceQueueFamilyProperties2,
        c"vkGetPhysicalDeviceQueueFamilyProperties2KHR" =>
            queue_family_properties2 as vk::PFN_vkGetPhysicalDeviceQueueFamilyProperties2,
    );
    if let Some(f) = device_function(n) {
        return Some(f);
    }
    let inst = if instance == vk::Instance::null() { None } else { instance_of(instance) };
    inst.and_then(|i| (i.gipa)(i.raw, name))
}

unsafe extern "system" fn get_device_proc_addr(device: vk::Device, name: *const c_char) -> vk::PFN_vkVoidFunction {
    if name.is_null() || device == vk::Device::null() {
        return None;
    }
    let d = device_of(device)?;
    let next = (d.gdpa)(device, name);
    if !d.is_split() || next.is_none() {
        // Not split (a real multi-family GPU): the layer is not in the way at all.
        return next;
    }
    device_function(CStr::from_ptr(name).to_bytes()).or(next)
}
