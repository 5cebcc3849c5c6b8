//! The loader-layer interface (vk_layer.h), which ash does not carry, and function-pointer loading.

use ash::vk;
use std::ffi::c_void;

pub(crate) const LAYER_LINK_INFO: i32 = 0;
pub(crate) const LOADER_DATA_CALLBACK: i32 = 1;
pub(crate) const LAYER_NEGOTIATE_INTERFACE_STRUCT: i32 = 1;

#[repr(C)]
pub(crate) struct LayerInstanceLink {
    pub(crate) next: *mut LayerInstanceLink,
    pub(crate) next_gipa: vk::PFN_vkGetInstanceProcAddr,
    pub(crate) next_gpdpa: *const c_void,
}

#[repr(C)]
pub(crate) struct LayerInstanceCreateInfo {
    pub(crate) s_type: vk::StructureType,
    pub(crate) p_next: *const c_void,
    pub(crate) function: i32,
    pub(crate) link: *mut LayerInstanceLink,
}

#[repr(C)]
pub(crate) struct LayerDeviceLink {
    pub(crate) next: *mut LayerDeviceLink,
    pub(crate) next_gipa: vk::PFN_vkGetInstanceProcAddr,
    pub(crate) next_gdpa: vk::PFN_vkGetDeviceProcAddr,
}

#[repr(C)]
pub(crate) struct LayerDeviceCreateInfo {
    pub(crate) s_type: vk::StructureType,
    pub(crate) p_next: *const c_void,
    pub(crate) function: i32,
    /// `pLayerInfo` for LAYER_LINK_INFO, `pfnSetDeviceLoaderData` for LOADER_DATA_CALLBACK.
    pub(crate) u: *mut c_void,
}

pub(crate) type SetDeviceLoaderData = unsafe extern "system" fn(vk::Device, *mut c_void) -> vk::Result;

/// A function pointer from `vkGet*ProcAddr` as its own type (`None` if the next layer has none).
pub(crate) unsafe fn load<T: Copy>(f: vk::PFN_vkVoidFunction) -> Option<T> {
    f.map(|f| std::mem::transmute_copy::<unsafe extern "system" fn(), T>(&f))
}

/// The loader's `VkLayer{Instance,Device}CreateInfo` with `function` in a create-info chain.
pub(crate) unsafe fn find_chain<T>(mut p: *const c_void, s_type: vk::StructureType, function: i32) -> *mut T {
    while !p.is_null() {
        let base = p as *const vk::BaseInStructure;
        if (*base).s_type == s_type {
            let info = p as *const LayerDeviceCreateInfo; // same head as the instance one
            if (*info).function == function {
                return p as *mut T;
            }
        }
        p = (*base).p_next as *const c_void;
    }
    std::ptr::null_mut()
}
