use ash::vk;

/// The one error type of the GPU layer.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "could not load the Vulkan loader (libvulkan.so.1): {0}\n  \
         install it: apt-get install libvulkan1 mesa-vulkan-drivers"
    )]
    Loader(String),

    #[error(
        "no usable Vulkan device: {0}\n  \
         dvsgi needs Vulkan 1.3 with timelineSemaphore, synchronization2, dynamicRendering and maintenance4.\n  \
         For the CPU implementation (lavapipe): apt-get install mesa-vulkan-drivers libvulkan1\n  \
         `vulkaninfo --summary` (package vulkan-tools) lists the devices the loader sees."
    )]
    NoDevice(String),

    #[error("--device {requested:?} matches no device; available:\n{available}")]
    DeviceNotFound { requested: String, available: String },

    #[error(
        "the Khronos validation layer was requested but is not installed\n  \
         install it: apt-get install vulkan-validationlayers"
    )]
    NoValidationLayer,

    #[error("{call} failed: {result}")]
    Vk { call: &'static str, result: vk::Result },

    #[error("GPU memory allocation of {} MiB for {name:?} failed: {source}", *bytes as f64 / 1048576.0)]
    Alloc {
        name: String,
        bytes: u64,
        #[source]
        source: gpu_allocator::AllocationError,
    },

    #[error(
        "timed out after {seconds} s waiting for {what}: the GPU is hung, the device was lost, or the work is \
         too large for this device (DVSGI_GPU_TIMEOUT=SECONDS sets the limit)"
    )]
    Timeout { what: String, seconds: f64 },

    #[error("the device was lost while {0}")]
    DeviceLost(String),

    #[error("{0}")]
    Limit(String),
}

pub type GpuResult<T> = Result<T, GpuError>;

/// Attach the name of the failing Vulkan call to a `vk::Result`.
pub trait VkContext<T> {
    fn vk(self, call: &'static str) -> GpuResult<T>;
}

impl<T> VkContext<T> for Result<T, vk::Result> {
    fn vk(self, call: &'static str) -> GpuResult<T> {
        self.map_err(|result| {
            if result == vk::Result::ERROR_DEVICE_LOST {
                GpuError::DeviceLost(call.to_string())
            } else {
                GpuError::Vk { call, result }
            }
        })
    }
}
