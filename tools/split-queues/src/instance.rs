//! Instance creation and the queue families the application sees.

use crate::loader::*;
use crate::rules;
use crate::state::*;
use ash::vk;
use std::ffi::CStr;
use std::sync::Arc;

pub(crate) unsafe extern "system" fn create_instance(
    ci: *const vk::InstanceCreateInfo,
    alloc: *const vk::AllocationCallbacks,
    out: *mut vk::Instance,
) -> vk::Result {
    let chain: *mut LayerInstanceCreateInfo =
        find_chain((*ci).p_next, vk::StructureType::LOADER_INSTANCE_CREATE_INFO, LAYER_LINK_INFO);
    if chain.is_null() || (*chain).link.is_null() {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    }
    let gipa = (*(*chain).link).next_gipa;
    (*chain).link = (*(*chain).link).next;
    let Some(create) = load::<vk::PFN_vkCreateInstance>(gipa(vk::Instance::null(), c"vkCreateInstance".as_ptr()))
    else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    let r = create(ci, alloc, out);
    if r != vk::Result::SUCCESS {
        return r;
    }
    let i = *out;
    let f = |n: &CStr| gipa(i, n.as_ptr());
    let (Some(destroy), Some(families)) =
        (load(f(c"vkDestroyInstance")), load(f(c"vkGetPhysicalDeviceQueueFamilyProperties")))
    else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    let families2 = load(f(c"vkGetPhysicalDeviceQueueFamilyProperties2"));
    let inst = Instance { raw: i, gipa, destroy, families, families2 };
    lock(&INSTANCES).push((key(i), Arc::new(inst)));
    vk::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn destroy_instance(instance: vk::Instance, alloc: *const vk::AllocationCallbacks) {
    if instance == vk::Instance::null() {
        return;
    }
    let k = key(instance);
    let inst = {
        let mut l = lock(&INSTANCES);
        let i = l.iter().position(|(key, _)| *key == k);
        i.map(|i| l.remove(i).1)
    };
    if let Some(inst) = inst {
        (inst.destroy)(instance, alloc);
    }
}

pub(crate) unsafe extern "system" fn queue_family_properties(
    pd: vk::PhysicalDevice,
    count: *mut u32,
    props: *mut vk::QueueFamilyProperties,
) {
    let Some(inst) = instance_of(pd) else { return };
    let real = inst.real_families(pd);
    if !rules::should_split(&real) {
        return (inst.families)(pd, count, props);
    }
    let all = rules::virtual_families(real[0]);
    if props.is_null() {
        *count = all.len() as u32;
        return;
    }
    let n = (*count as usize).min(all.len());
    std::ptr::copy_nonoverlapping(all.as_ptr(), props, n);
    *count = n as u32;
}

pub(crate) unsafe extern "system" fn queue_family_properties2(
    pd: vk::PhysicalDevice,
    count: *mut u32,
    props: *mut vk::QueueFamilyProperties2,
) {
    let Some(inst) = instance_of(pd) else { return };
    let Some(next) = inst.families2 else { return };
    let real = inst.real_families(pd);
    if !rules::should_split(&real) {
        return next(pd, count, props);
    }
    if props.is_null() {
        *count = 2;
        return;
    }
    let n = (*count).min(2);
    for i in 0..n as usize {
        // The driver fills each entry (and its extension structures) with the real family's
        // properties; the virtual entry then gets its own flags and queue count.
        let mut one = 1u32;
        next(pd, &mut one, props.add(i));
        if i == 1 {
            let p = &mut (*props.add(i)).queue_family_properties;
            *p = rules::virtual_family(*p);
        }
    }
    *count = n;
}
