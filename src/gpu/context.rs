//! Vulkan instance, validation, device selection, queues and the memory allocator.

use super::error::{GpuError, GpuResult, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::ffi::{c_void, CStr, CString};
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::Duration;

/// How the context should be created.
#[derive(Debug, Clone, Default)]
pub struct ContextDesc {
    /// Enable the Khronos validation layer (with synchronization validation) and count
    /// its messages. Also turned on by the environment variable `DVSGI_VALIDATION=1`.
    pub validation: bool,
    /// `--device N|name`: index in `dvsgi info`'s list, or a case-insensitive part of the name.
    pub device: Option<String>,
}

/// Which compute queue the context could provide (recorded for every output that cares).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QueueTopology {
    /// A compute-only queue family separate from the graphics family.
    DedicatedComputeFamily,
    /// A second queue of the graphics family.
    SecondQueueSameFamily,
    /// Only one queue: compute work is submitted to the graphics queue.
    SingleQueue,
}

impl QueueTopology {
    pub fn describe(&self) -> &'static str {
        match self {
            QueueTopology::DedicatedComputeFamily => "separate compute queue (dedicated compute-only family)",
            QueueTopology::SecondQueueSameFamily => "separate compute queue (second queue of the graphics family)",
            QueueTopology::SingleQueue => {
                "single-queue fallback: the device has one queue, compute work goes to the graphics queue"
            }
        }
    }
}

#[derive(Debug, Clone, Copy)]
pub struct Queue {
    pub raw: vk::Queue,
    pub family: u32,
    pub index: u32,
}

/// Optional capabilities, enabled when the device has them.
#[derive(Debug, Clone, Copy, Default)]
pub struct OptionalFeatures {
    pub geometry_shader: bool,
    pub fragment_stores_and_atomics: bool,
    pub depth_clamp: bool,
    pub sampler_anisotropy: bool,
    pub conservative_rasterization: bool,
    pub calibrated_timestamps: bool,
    pub shader_image_float32_atomics: bool,
    /// Pipeline statistics queries (`bench --raster-profile` counts shader invocations).
    pub pipeline_statistics_query: bool,
    /// VK_KHR_ray_query with VK_KHR_acceleration_structure (and buffer device addresses):
    /// `gi.specular = "rt"`.
    pub ray_query: bool,
}

#[derive(Debug, Clone)]
pub struct QueueFamilyInfo {
    pub index: u32,
    pub flags: vk::QueueFlags,
    pub count: u32,
    pub timestamp_valid_bits: u32,
}

/// What `dvsgi info` prints about the chosen device.
#[derive(Debug, Clone)]
pub struct DeviceInfo {
    pub index: usize,
    pub name: String,
    pub device_type: vk::PhysicalDeviceType,
    pub vendor_id: u32,
    pub api_version: u32,
    pub driver_name: String,
    pub driver_info: String,
    pub families: Vec<QueueFamilyInfo>,
    pub timestamp_period_ns: f32,
    pub limits: vk::PhysicalDeviceLimits,
    pub optional: OptionalFeatures,
    /// Size of the largest DEVICE_LOCAL memory heap (bytes): what a frame's resources must fit.
    pub device_local_heap: u64,
    /// `maxMemoryAllocationSize` (Vulkan 1.1): the largest single allocation.
    pub max_allocation: u64,
}

impl DeviceInfo {
    pub fn is_cpu(&self) -> bool {
        self.device_type == vk::PhysicalDeviceType::CPU
    }
    pub fn api_version_string(&self) -> String {
        format!(
            "{}.{}.{}",
            vk::api_version_major(self.api_version),
            vk::api_version_minor(self.api_version),
            vk::api_version_patch(self.api_version)
        )
    }
}

/// Counts of validation-layer messages since the context was created.
#[derive(Debug, Default)]
pub struct ValidationCounts {
    errors: AtomicU32,
    warnings: AtomicU32,
    messages: Mutex<Vec<String>>,
}

impl ValidationCounts {
    pub fn errors(&self) -> u32 {
        self.errors.load(Ordering::SeqCst)
    }
    pub fn warnings(&self) -> u32 {
        self.warnings.load(Ordering::SeqCst)
    }
    /// The first messages (at most 64), for test failure output.
    pub fn messages(&self) -> Vec<String> {
        self.messages.lock().map(|m| m.clone()).unwrap_or_default()
    }
}

/// The device, its queues and the allocator. Resources hold an `Arc<Context>` so the device
/// outlives everything created from it.
pub struct Context {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    debug_instance: Option<ash::ext::debug_utils::Instance>,
    messenger: vk::DebugUtilsMessengerEXT,
    pub debug_utils: Option<ash::ext::debug_utils::Device>,
    pub physical_device: vk::PhysicalDevice,
    pub device: ash::Device,
    /// VK_KHR_acceleration_structure's functions, where the device has ray queries.
    pub acceleration_structure: Option<ash::khr::acceleration_structure::Device>,
    pub graphics_queue: Queue,
    pub compute_queue: Queue,
    pub topology: QueueTopology,
    pub info: DeviceInfo,
    pub validation_enabled: bool,
    validation: Box<ValidationCounts>,
    allocator: ManuallyDrop<Mutex<Allocator>>,
    /// Serialises vkQueueSubmit on the (possibly shared) queue.
    pub submit_lock: Mutex<()>,
    /// How long any GPU wait may take, in nanoseconds (`gpu_timeout`).
    timeout_ns: AtomicU64,
    /// A wait timed out or the device was lost: teardown must not wait for the GPU again.
    failed: AtomicBool,
}

/// How long a GPU wait may take before it is an error (a lost device or a hang becomes an
/// error, never a hang) on a GPU; `DVSGI_GPU_TIMEOUT=SECONDS` overrides it.
pub const GPU_TIMEOUT: Duration = Duration::from_secs(60);
/// The same on a CPU device (lavapipe), where one frame of a 256^3 grid takes a minute.
pub const CPU_DEVICE_TIMEOUT: Duration = Duration::from_secs(600);

/// `DVSGI_GPU_TIMEOUT` in seconds, if set.
fn env_timeout() -> GpuResult<Option<Duration>> {
    let Ok(v) = std::env::var("DVSGI_GPU_TIMEOUT") else { return Ok(None) };
    match v.trim().parse::<f64>() {
        Ok(s) if (1e-9..=1e6).contains(&s) => Ok(Some(Duration::from_secs_f64(s))),
        _ => Err(GpuError::Limit(format!("DVSGI_GPU_TIMEOUT={v:?} is not a number of seconds in 1e-9..=1e6"))),
    }
}

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _ty: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    let counts = &*(user as *const ValidationCounts);
    let msg = if data.is_null() || (*data).p_message.is_null() {
        String::from("(no message)")
    } else {
        CStr::from_ptr((*data).p_message).to_string_lossy().into_owned()
    };
    let level = if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        counts.errors.fetch_add(1, Ordering::SeqCst);
        "error"
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
        counts.warnings.fetch_add(1, Ordering::SeqCst);
        "warning"
    } else {
        return vk::FALSE;
    };
    eprintln!("[vulkan validation {level}] {msg}");
    if let Ok(mut m) = counts.messages.lock() {
        if m.len() < 64 {
            m.push(format!("{level}: {msg}"));
        }
    }
    vk::FALSE
}

fn env_flag(name: &str) -> bool {
    std::env::var(name).map(|v| !v.is_empty() && v != "0" && !v.eq_ignore_ascii_case("false")).unwrap_or(false)
}

fn cstr_field(bytes: &[std::ffi::c_char]) -> String {
    let bytes: Vec<u8> = bytes.iter().take_while(|&&c| c != 0).map(|&c| c as u8).collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// The instance, with the validation layer (and synchronization validation) when asked and the
/// instance extensions a window surface needs (`window`, empty when headless), and whether
/// VK_EXT_debug_utils is there (object names, labels, the validation messenger).
fn create_instance(entry: &ash::Entry, validation: bool, window: &[&CStr]) -> GpuResult<(ash::Instance, bool)> {
    let app_name = c"dvsgi";
    let app = vk::ApplicationInfo::default()
        .application_name(app_name)
        .engine_name(app_name)
        .api_version(vk::API_VERSION_1_3);
    let layer_props =
        unsafe { entry.enumerate_instance_layer_properties() }.vk("vkEnumerateInstanceLayerProperties")?;
    let has_layer = layer_props.iter().any(|l| l.layer_name_as_c_str().map(|n| n == VALIDATION_LAYER).unwrap_or(false));
    if validation && !has_layer {
        return Err(GpuError::NoValidationLayer);
    }
    let ext_props =
        unsafe { entry.enumerate_instance_extension_properties(None) }.vk("vkEnumerateInstanceExtensionProperties")?;
    let has_debug_utils = ext_props
        .iter()
        .any(|e| e.extension_name_as_c_str().map(|n| n == ash::ext::debug_utils::NAME).unwrap_or(false));
    let mut layers: Vec<*const std::ffi::c_char> = Vec::new();
    let mut extensions: Vec<*const std::ffi::c_char> = Vec::new();
    if validation {
        layers.push(VALIDATION_LAYER.as_ptr());
    }
    if has_debug_utils {
        extensions.push(ash::ext::debug_utils::NAME.as_ptr());
    }
    for name in window {
        if !ext_props.iter().any(|e| e.extension_name_as_c_str() == Ok(*name)) {
            return Err(GpuError::NoDevice(format!(
                "the Vulkan loader has no {} (needed to show a window): install your platform's Vulkan \
                 WSI support, or render headless with `dvsgi render`",
                name.to_string_lossy()
            )));
        }
        extensions.push(name.as_ptr());
    }
    let enables = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
    let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&enables);
    let mut ici = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_layer_names(&layers)
        .enabled_extension_names(&extensions);
    if validation {
        ici = ici.push_next(&mut features);
    }
    let instance = unsafe { entry.create_instance(&ici, None) }.map_err(|e| match e {
        vk::Result::ERROR_INCOMPATIBLE_DRIVER => {
            GpuError::NoDevice("the Vulkan loader found no driver (VK_ERROR_INCOMPATIBLE_DRIVER)".into())
        }
        result => GpuError::Vk { call: "vkCreateInstance", result },
    })?;
    Ok((instance, has_debug_utils))
}

/// The messenger that counts validation errors and warnings into `counts` (and prints them).
fn create_messenger(
    entry: &ash::Entry,
    instance: &ash::Instance,
    counts: &ValidationCounts,
) -> GpuResult<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)> {
    let di = ash::ext::debug_utils::Instance::new(entry, instance);
    let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING)
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(debug_callback))
        .user_data(counts as *const ValidationCounts as *mut c_void);
    let m = unsafe { di.create_debug_utils_messenger(&info, None) }.vk("vkCreateDebugUtilsMessengerEXT");
    match m {
        Ok(m) => Ok((di, m)),
        Err(e) => {
            unsafe { instance.destroy_instance(None) };
            Err(e)
        }
    }
}

/// The queues dvsgi asks for: a graphics+compute queue, and a separate compute queue where
/// the device has one (a compute-only family first, else a second queue of the graphics family).
struct QueuePlan {
    graphics_family: u32,
    compute_family: u32,
    compute_index: u32,
    topology: QueueTopology,
}

impl QueuePlan {
    fn of(fams: &[vk::QueueFamilyProperties]) -> GpuResult<QueuePlan> {
        let gfx = fams
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE))
            .ok_or_else(|| GpuError::NoDevice("no graphics+compute queue family".into()))? as u32;
        let dedicated = fams.iter().position(|f| {
            f.queue_flags.contains(vk::QueueFlags::COMPUTE) && !f.queue_flags.contains(vk::QueueFlags::GRAPHICS)
        });
        let (topology, compute_family, compute_index) = if let Some(cf) = dedicated {
            (QueueTopology::DedicatedComputeFamily, cf as u32, 0)
        } else if fams[gfx as usize].queue_count >= 2 {
            (QueueTopology::SecondQueueSameFamily, gfx, 1)
        } else {
            (QueueTopology::SingleQueue, gfx, 0)
        };
        Ok(QueuePlan { graphics_family: gfx, compute_family, compute_index, topology })
    }
}

/// What the device has of the features and extensions dvsgi uses where present.
struct Negotiated {
    optional: OptionalFeatures,
    core: vk::PhysicalDeviceFeatures,
    scalar_block_layout: bool,
    host_query_reset: bool,
    has_atomic_float: bool,
    buffer_float32_atomics: bool,
    /// Device extensions to enable.
    extensions: Vec<&'static CStr>,
}

impl Negotiated {
    /// With `present`, VK_KHR_swapchain is required (a window shows the frames).
    fn of(instance: &ash::Instance, pd: vk::PhysicalDevice, present: bool) -> GpuResult<Negotiated> {
        let exts =
            unsafe { instance.enumerate_device_extension_properties(pd) }.vk("vkEnumerateDeviceExtensionProperties")?;
        let has_ext =
            |name: &CStr| exts.iter().any(|e| e.extension_name_as_c_str().map(|n| n == name).unwrap_or(false));
        let ext_float = has_ext(ash::ext::shader_atomic_float::NAME);
        let ray_exts = [
            ash::khr::acceleration_structure::NAME,
            ash::khr::ray_query::NAME,
            ash::khr::deferred_host_operations::NAME,
        ];
        let ext_rays = ray_exts.iter().all(|e| has_ext(e));
        let mut has12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut has13 = vk::PhysicalDeviceVulkan13Features::default();
        let mut has_float = vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT::default();
        let mut has_accel = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default();
        let mut has_query = vk::PhysicalDeviceRayQueryFeaturesKHR::default();
        let core = {
            let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut has12).push_next(&mut has13);
            if ext_float {
                f2 = f2.push_next(&mut has_float);
            }
            if ext_rays {
                f2 = f2.push_next(&mut has_accel).push_next(&mut has_query);
            }
            unsafe { instance.get_physical_device_features2(pd, &mut f2) };
            f2.features
        };
        let optional = OptionalFeatures {
            geometry_shader: core.geometry_shader != 0,
            fragment_stores_and_atomics: core.fragment_stores_and_atomics != 0,
            depth_clamp: core.depth_clamp != 0,
            sampler_anisotropy: core.sampler_anisotropy != 0,
            conservative_rasterization: has_ext(ash::ext::conservative_rasterization::NAME),
            calibrated_timestamps: has_ext(ash::ext::calibrated_timestamps::NAME),
            shader_image_float32_atomics: ext_float && has_float.shader_image_float32_atomics != 0,
            pipeline_statistics_query: core.pipeline_statistics_query != 0,
            ray_query: ext_rays
                && has_accel.acceleration_structure != 0
                && has_query.ray_query != 0
                && has12.buffer_device_address != 0,
        };
        let mut extensions = Vec::new();
        if ext_float {
            extensions.push(ash::ext::shader_atomic_float::NAME);
        }
        if optional.conservative_rasterization {
            extensions.push(ash::ext::conservative_rasterization::NAME);
        }
        if optional.calibrated_timestamps {
            extensions.push(ash::ext::calibrated_timestamps::NAME);
        }
        if optional.ray_query {
            extensions.extend(ray_exts);
        }
        if present {
            if !has_ext(ash::khr::swapchain::NAME) {
                return Err(GpuError::NoDevice(
                    "the device has no VK_KHR_swapchain, so it cannot show a window; render headless with \
                     `dvsgi render`, or choose another device with --device"
                        .into(),
                ));
            }
            extensions.push(ash::khr::swapchain::NAME);
        }
        Ok(Negotiated {
            optional,
            core,
            scalar_block_layout: has12.scalar_block_layout != 0,
            host_query_reset: has12.host_query_reset != 0,
            has_atomic_float: ext_float,
            buffer_float32_atomics: has_float.shader_buffer_float32_atomics != 0,
            extensions,
        })
    }
}

/// What `dvsgi info` and the outputs record of the device.
fn describe_device(
    instance: &ash::Instance,
    pd: vk::PhysicalDevice,
    index: usize,
    fams: &[vk::QueueFamilyProperties],
    optional: OptionalFeatures,
) -> DeviceInfo {
    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    let mut maint3 = vk::PhysicalDeviceMaintenance3Properties::default();
    let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver).push_next(&mut maint3);
    unsafe { instance.get_physical_device_properties2(pd, &mut p2) };
    let props = p2.properties;
    let memory = unsafe { instance.get_physical_device_memory_properties(pd) };
    let device_local_heap = memory.memory_heaps[..memory.memory_heap_count as usize]
        .iter()
        .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
        .map(|h| h.size)
        .max()
        .unwrap_or(0);
    DeviceInfo {
        index,
        name: cstr_field(&props.device_name),
        device_type: props.device_type,
        vendor_id: props.vendor_id,
        api_version: props.api_version,
        driver_name: cstr_field(&driver.driver_name),
        driver_info: cstr_field(&driver.driver_info),
        families: fams
            .iter()
            .enumerate()
            .map(|(i, f)| QueueFamilyInfo {
                index: i as u32,
                flags: f.queue_flags,
                count: f.queue_count,
                timestamp_valid_bits: f.timestamp_valid_bits,
            })
            .collect(),
        timestamp_period_ns: props.limits.timestamp_period,
        limits: props.limits,
        optional,
        device_local_heap,
        max_allocation: maint3.max_memory_allocation_size,
    }
}

/// A physical device as listed by `dvsgi info`, with why it can or cannot be used.
#[derive(Debug, Clone)]
pub struct DeviceCandidate {
    pub index: usize,
    pub name: String,
    pub device_type: vk::PhysicalDeviceType,
    pub api_version: u32,
    /// `None` when usable, else what it lacks.
    pub unusable: Option<String>,
}

impl Context {
    pub fn new(desc: &ContextDesc) -> GpuResult<std::sync::Arc<Context>> {
        Context::with_window(desc, &[])
    }

    /// A context that can present to a window: `window` names the instance extensions the
    /// window's surface needs (`ash_window::enumerate_required_extensions`), and the device
    /// gets VK_KHR_swapchain.
    pub fn with_window(desc: &ContextDesc, window: &[&'static CStr]) -> GpuResult<std::sync::Arc<Context>> {
        let validation = desc.validation || env_flag("DVSGI_VALIDATION");
        let device_req = desc.device.clone().or_else(|| std::env::var("DVSGI_DEVICE").ok());
        let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::Loader(e.to_string()))?;

        let (instance, has_debug_utils) = create_instance(&entry, validation, window)?;
        let counts = Box::new(ValidationCounts::default());
        let (debug_instance, messenger) =
            match (has_debug_utils && validation).then(|| create_messenger(&entry, &instance, &counts)).transpose()? {
                Some((di, m)) => (Some(di), m),
                None => (None, vk::DebugUtilsMessengerEXT::null()),
            };

        // From here on, destroy the instance on error.
        let cleanup = |e: GpuError| {
            unsafe {
                if let Some(di) = &debug_instance {
                    di.destroy_debug_utils_messenger(messenger, None);
                }
                instance.destroy_instance(None);
            }
            e
        };

        let (physical, chosen) = match Self::pick(&instance, device_req.as_deref()) {
            Ok(p) => p,
            Err(e) => return Err(cleanup(e)),
        };
        let present = !window.is_empty();
        let result = Self::create_device(instance.clone(), physical, chosen, present, has_debug_utils);
        match result {
            Ok((device, debug_utils, gq, cq, topology, info)) => {
                // Buffer device addresses are on where ray queries are (acceleration structures).
                let allocator = Allocator::new(&AllocatorCreateDesc {
                    instance: instance.clone(),
                    device: device.clone(),
                    physical_device: physical,
                    debug_settings: Default::default(),
                    buffer_device_address: info.optional.ray_query,
                    allocation_sizes: Default::default(),
                })
                .map_err(|e| GpuError::Alloc { name: "allocator".into(), bytes: 0, source: e });
                let timeout =
                    env_timeout().map(|t| t.unwrap_or(if info.is_cpu() { CPU_DEVICE_TIMEOUT } else { GPU_TIMEOUT }));
                let (allocator, timeout) = match (allocator, timeout) {
                    (Ok(a), Ok(t)) => (a, t),
                    (a, t) => {
                        let e = t.err().or(a.err()).expect("one failed");
                        unsafe { device.destroy_device(None) };
                        return Err(cleanup(e));
                    }
                };
                let acceleration_structure =
                    info.optional.ray_query.then(|| ash::khr::acceleration_structure::Device::new(&instance, &device));
                let ctx = Context {
                    entry,
                    instance,
                    debug_instance,
                    messenger,
                    debug_utils,
                    physical_device: physical,
                    device,
                    acceleration_structure,
                    graphics_queue: gq,
                    compute_queue: cq,
                    topology,
                    info,
                    validation_enabled: validation,
                    validation: counts,
                    allocator: ManuallyDrop::new(Mutex::new(allocator)),
                    submit_lock: Mutex::new(()),
                    timeout_ns: AtomicU64::new(timeout.as_nanos() as u64),
                    failed: AtomicBool::new(false),
                };
                ctx.name_queues();
                Ok(std::sync::Arc::new(ctx))
            }
            Err(e) => Err(cleanup(e)),
        }
    }

    fn name_queues(&self) {
        self.name_object(self.graphics_queue.raw, "graphics queue");
        if self.topology != QueueTopology::SingleQueue {
            self.name_object(self.compute_queue.raw, "compute queue");
        }
    }

    /// The physical device `request` names (else the best usable one) and its index.
    fn pick(instance: &ash::Instance, request: Option<&str>) -> GpuResult<(vk::PhysicalDevice, usize)> {
        let chosen = Self::choose(&Self::candidates(instance)?, request)?;
        let devices = unsafe { instance.enumerate_physical_devices() }.vk("vkEnumeratePhysicalDevices")?;
        Ok((devices[chosen], chosen))
    }

    /// Every physical device with the reason it cannot be used, if any.
    fn candidates(instance: &ash::Instance) -> GpuResult<Vec<DeviceCandidate>> {
        let pds = unsafe { instance.enumerate_physical_devices() }.vk("vkEnumeratePhysicalDevices")?;
        let mut out = Vec::new();
        for (index, &pd) in pds.iter().enumerate() {
            let props = unsafe { instance.get_physical_device_properties(pd) };
            let name = cstr_field(&props.device_name);
            let mut v12 = vk::PhysicalDeviceVulkan12Features::default();
            let mut v13 = vk::PhysicalDeviceVulkan13Features::default();
            let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut v12).push_next(&mut v13);
            let mut missing = Vec::new();
            if props.api_version < vk::API_VERSION_1_3 {
                missing.push(format!(
                    "Vulkan 1.3 (has {}.{})",
                    vk::api_version_major(props.api_version),
                    vk::api_version_minor(props.api_version)
                ));
            } else {
                unsafe { instance.get_physical_device_features2(pd, &mut f2) };
                if v12.timeline_semaphore == 0 {
                    missing.push("timelineSemaphore".into());
                }
                if v13.synchronization2 == 0 {
                    missing.push("synchronization2".into());
                }
                if v13.dynamic_rendering == 0 {
                    missing.push("dynamicRendering".into());
                }
                if v13.maintenance4 == 0 {
                    missing.push("maintenance4".into());
                }
                let fams = unsafe { instance.get_physical_device_queue_family_properties(pd) };
                if !fams.iter().any(|f| f.queue_flags.contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE)) {
                    missing.push("a graphics+compute queue family".into());
                }
            }
            out.push(DeviceCandidate {
                index,
                name,
                device_type: props.device_type,
                api_version: props.api_version,
                unusable: if missing.is_empty() { None } else { Some(format!("lacks {}", missing.join(", "))) },
            });
        }
        Ok(out)
    }

    fn choose(candidates: &[DeviceCandidate], request: Option<&str>) -> GpuResult<usize> {
        let list = || {
            candidates
                .iter()
                .map(|c| {
                    format!(
                        "  [{}] {} ({:?}){}",
                        c.index,
                        c.name,
                        c.device_type,
                        c.unusable.as_ref().map(|u| format!(" — unusable: {u}")).unwrap_or_default()
                    )
                })
                .collect::<Vec<_>>()
                .join("\n")
        };
        if candidates.is_empty() {
            return Err(GpuError::NoDevice("the Vulkan loader reports no physical devices".into()));
        }
        if let Some(req) = request {
            let found = match req.trim().parse::<usize>() {
                Ok(i) => candidates.iter().find(|c| c.index == i),
                Err(_) => {
                    let lower = req.to_lowercase();
                    candidates.iter().find(|c| c.name.to_lowercase().contains(&lower))
                }
            };
            return match found {
                Some(c) if c.unusable.is_none() => Ok(c.index),
                Some(c) => Err(GpuError::NoDevice(format!(
                    "device [{}] {} {}",
                    c.index,
                    c.name,
                    c.unusable.clone().unwrap_or_default()
                ))),
                None => Err(GpuError::DeviceNotFound { requested: req.to_string(), available: list() }),
            };
        }
        let rank = |t: vk::PhysicalDeviceType| match t {
            vk::PhysicalDeviceType::DISCRETE_GPU => 0,
            vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
            vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
            vk::PhysicalDeviceType::CPU => 3,
            _ => 4,
        };
        candidates
            .iter()
            .filter(|c| c.unusable.is_none())
            .min_by_key(|c| (rank(c.device_type), c.index))
            .map(|c| c.index)
            .ok_or_else(|| GpuError::NoDevice(format!("no device has what dvsgi needs:\n{}", list())))
    }

    #[allow(clippy::type_complexity)]
    fn create_device(
        instance: ash::Instance,
        pd: vk::PhysicalDevice,
        index: usize,
        present: bool,
        has_debug_utils: bool,
    ) -> GpuResult<(ash::Device, Option<ash::ext::debug_utils::Device>, Queue, Queue, QueueTopology, DeviceInfo)> {
        let fams = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        let plan = QueuePlan::of(&fams)?;
        let n = Negotiated::of(&instance, pd, present)?;
        let priorities = [1.0f32, 1.0];
        let second = plan.topology == QueueTopology::SecondQueueSameFamily;
        let mut queue_infos = vec![vk::DeviceQueueCreateInfo::default()
            .queue_family_index(plan.graphics_family)
            .queue_priorities(if second { &priorities[..2] } else { &priorities[..1] })];
        if plan.topology == QueueTopology::DedicatedComputeFamily {
            queue_infos.push(
                vk::DeviceQueueCreateInfo::default()
                    .queue_family_index(plan.compute_family)
                    .queue_priorities(&priorities[..1]),
            );
        }
        let (o, has10) = (n.optional, &n.core);
        let f10 = vk::PhysicalDeviceFeatures::default()
            .geometry_shader(o.geometry_shader)
            .fragment_stores_and_atomics(o.fragment_stores_and_atomics)
            .depth_clamp(o.depth_clamp)
            .sampler_anisotropy(o.sampler_anisotropy)
            .pipeline_statistics_query(o.pipeline_statistics_query)
            .shader_storage_image_write_without_format(has10.shader_storage_image_write_without_format != 0)
            .shader_storage_image_read_without_format(has10.shader_storage_image_read_without_format != 0)
            .independent_blend(has10.independent_blend != 0)
            .shader_storage_image_extended_formats(has10.shader_storage_image_extended_formats != 0)
            .shader_sampled_image_array_dynamic_indexing(has10.shader_sampled_image_array_dynamic_indexing != 0);
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default()
            .timeline_semaphore(true)
            .scalar_block_layout(n.scalar_block_layout)
            .host_query_reset(n.host_query_reset)
            .buffer_device_address(o.ray_query);
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
            .synchronization2(true)
            .dynamic_rendering(true)
            .maintenance4(true);
        let mut ffloat = vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT::default()
            .shader_image_float32_atomics(o.shader_image_float32_atomics)
            .shader_buffer_float32_atomics(n.buffer_float32_atomics);
        let mut faccel = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default().acceleration_structure(true);
        let mut fquery = vk::PhysicalDeviceRayQueryFeaturesKHR::default().ray_query(true);
        let dev_exts: Vec<*const std::ffi::c_char> = n.extensions.iter().map(|e| e.as_ptr()).collect();
        let mut dci = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_infos)
            .enabled_features(&f10)
            .enabled_extension_names(&dev_exts)
            .push_next(&mut f12)
            .push_next(&mut f13);
        if n.has_atomic_float {
            dci = dci.push_next(&mut ffloat);
        }
        if o.ray_query {
            dci = dci.push_next(&mut faccel).push_next(&mut fquery);
        }
        let device = unsafe { instance.create_device(pd, &dci, None) }.vk("vkCreateDevice")?;
        let gq = Queue {
            raw: unsafe { device.get_device_queue(plan.graphics_family, 0) },
            family: plan.graphics_family,
            index: 0,
        };
        let cq = Queue {
            raw: unsafe { device.get_device_queue(plan.compute_family, plan.compute_index) },
            family: plan.compute_family,
            index: plan.compute_index,
        };
        let debug_utils = has_debug_utils.then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        let info = describe_device(&instance, pd, index, &fams, o);
        Ok((device, debug_utils, gq, cq, plan.topology, info))
    }

    /// All physical devices, for `dvsgi info` (creates a temporary instance).
    pub fn list_devices() -> GpuResult<Vec<DeviceCandidate>> {
        let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::Loader(e.to_string()))?;
        let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
        let instance =
            unsafe { entry.create_instance(&vk::InstanceCreateInfo::default().application_info(&app), None) }.map_err(
                |e| match e {
                    vk::Result::ERROR_INCOMPATIBLE_DRIVER => {
                        GpuError::NoDevice("the Vulkan loader found no driver".into())
                    }
                    result => GpuError::Vk { call: "vkCreateInstance", result },
                },
            )?;
        let out = Self::candidates(&instance);
        unsafe { instance.destroy_instance(None) };
        out
    }

    pub fn validation(&self) -> &ValidationCounts {
        &self.validation
    }

    pub fn allocator(&self) -> std::sync::MutexGuard<'_, Allocator> {
        // A poisoned lock only means another thread panicked mid-allocation; the allocator
        // state itself is still consistent for freeing.
        self.allocator.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Total bytes allocated from device memory through gpu-allocator.
    pub fn allocated_bytes(&self) -> u64 {
        self.allocator().generate_report().total_allocated_bytes
    }

    /// Give a Vulkan object a name visible in validation messages and RenderDoc.
    pub fn name_object<H: vk::Handle>(&self, handle: H, name: &str) {
        if let Some(du) = &self.debug_utils {
            if let Ok(cname) = CString::new(name) {
                let info = vk::DebugUtilsObjectNameInfoEXT::default().object_handle(handle).object_name(&cname);
                unsafe {
                    let _ = du.set_debug_utils_object_name(&info);
                }
            }
        }
    }

    pub fn begin_label(&self, cmd: vk::CommandBuffer, name: &str) {
        if let Some(du) = &self.debug_utils {
            if let Ok(cname) = CString::new(name) {
                let label = vk::DebugUtilsLabelEXT::default().label_name(&cname);
                unsafe { du.cmd_begin_debug_utils_label(cmd, &label) };
            }
        }
    }

    pub fn end_label(&self, cmd: vk::CommandBuffer) {
        if let Some(du) = &self.debug_utils {
            unsafe { du.cmd_end_debug_utils_label(cmd) };
        }
    }

    /// The graphics and compute queue families when they differ (resources then need
    /// ownership transfers or CONCURRENT sharing).
    pub fn distinct_families(&self) -> Option<[u32; 2]> {
        (self.graphics_queue.family != self.compute_queue.family)
            .then_some([self.graphics_queue.family, self.compute_queue.family])
    }

    /// How long any GPU wait may take before it is an error.
    pub fn gpu_timeout(&self) -> Duration {
        Duration::from_nanos(self.timeout_ns.load(Ordering::SeqCst))
    }

    /// Change the GPU wait timeout (tests; `DVSGI_GPU_TIMEOUT` sets it for a process).
    pub fn set_gpu_timeout(&self, timeout: Duration) {
        self.timeout_ns.store(timeout.as_nanos().clamp(1, u64::MAX as u128) as u64, Ordering::SeqCst);
    }

    /// Whether a wait timed out or the device was lost. Teardown then neither waits for the
    /// GPU nor frees what it may still use: the resources are left to the process's exit.
    pub fn has_failed(&self) -> bool {
        self.failed.load(Ordering::SeqCst)
    }

    /// The result of a bounded wait (`call` with `gpu_timeout`): a timeout or a lost device is
    /// an error naming `what`, and marks the context failed.
    pub fn wait_result(&self, r: Result<(), vk::Result>, call: &'static str, what: &str) -> GpuResult<()> {
        let err = match r {
            Ok(()) => return Ok(()),
            Err(vk::Result::TIMEOUT) => {
                GpuError::Timeout { what: what.to_string(), seconds: self.gpu_timeout().as_secs_f64() }
            }
            Err(vk::Result::ERROR_DEVICE_LOST) => GpuError::DeviceLost(format!("waiting for {what}")),
            Err(result) => GpuError::Vk { call, result },
        };
        self.failed.store(true, Ordering::SeqCst);
        Err(err)
    }

    /// Wait for fences with the timeout; a timeout or loss is an error, never a hang.
    pub fn wait_fences(&self, fences: &[vk::Fence], what: &str) -> GpuResult<()> {
        let r = unsafe { self.device.wait_for_fences(fences, true, self.gpu_timeout().as_nanos() as u64) };
        self.wait_result(r, "vkWaitForFences", what)
    }

    /// Record and run a one-off command buffer on the graphics queue and wait for it
    /// (uploads at load time; never used inside a frame).
    pub fn one_shot<F: FnOnce(vk::CommandBuffer)>(&self, name: &str, f: F) -> GpuResult<()> {
        let d = &self.device;
        unsafe {
            let pool = d
                .create_command_pool(
                    &vk::CommandPoolCreateInfo::default()
                        .queue_family_index(self.graphics_queue.family)
                        .flags(vk::CommandPoolCreateFlags::TRANSIENT),
                    None,
                )
                .vk("vkCreateCommandPool")?;
            let result = (|| {
                let cmd = d
                    .allocate_command_buffers(
                        &vk::CommandBufferAllocateInfo::default()
                            .command_pool(pool)
                            .level(vk::CommandBufferLevel::PRIMARY)
                            .command_buffer_count(1),
                    )
                    .vk("vkAllocateCommandBuffers")?[0];
                self.name_object(cmd, name);
                d.begin_command_buffer(
                    cmd,
                    &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .vk("vkBeginCommandBuffer")?;
                self.begin_label(cmd, name);
                f(cmd);
                self.end_label(cmd);
                d.end_command_buffer(cmd).vk("vkEndCommandBuffer")?;
                let fence = d.create_fence(&vk::FenceCreateInfo::default(), None).vk("vkCreateFence")?;
                let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(cmd)];
                let submit = vk::SubmitInfo2::default().command_buffer_infos(&cmds);
                let r = {
                    let _g = self.submit_lock.lock().unwrap_or_else(|p| p.into_inner());
                    d.queue_submit2(self.graphics_queue.raw, &[submit], fence).vk("vkQueueSubmit2")
                };
                let r = r.and_then(|_| self.wait_fences(&[fence], name));
                d.destroy_fence(fence, None);
                r
            })();
            d.destroy_command_pool(pool, None);
            result
        }
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        if self.has_failed() {
            // The GPU may still run (or never finish) work that uses this device: waiting could
            // hang and destroying it is undefined. Leave it to the process's exit.
            return;
        }
        unsafe {
            // Every owner waited (bounded) for its own work before dropping, so this returns at once.
            let _ = self.device.device_wait_idle();
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            if let Some(di) = &self.debug_instance {
                di.destroy_debug_utils_messenger(self.messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}
