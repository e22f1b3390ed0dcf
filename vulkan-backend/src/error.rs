//! The errors of the GPU backend.

use ash::vk;

/// What can go wrong on the GPU path; every variant says what to do about it.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("no Vulkan loader found ({0}); install one with `apt-get install libvulkan1 mesa-vulkan-drivers`")]
    NoLoader(String),
    #[error("no Vulkan device found; install a GPU driver or lavapipe (`apt-get install mesa-vulkan-drivers`)")]
    NoDevice,
    #[error(
        "JK_VULKAN_DEVICE={0:?} is not a device index: this machine has {1} Vulkan device(s), \
         numbered 0 to {last}; unset it to pick the best device",
        last = .1.saturating_sub(1)
    )]
    BadDeviceIndex(String, usize),
    #[error("Vulkan device {0} lacks {1}, which the kernels need")]
    Unsupported(String, &'static str),
    #[error("{0} failed: {1}")]
    Vulkan(&'static str, vk::Result),
    #[error("could not allocate {0} bytes of GPU memory ({1}); use a smaller image or volume, or --backend cpu")]
    OutOfMemory(u64, vk::Result),
    #[error("buffer of {size} bytes exceeds this device's maxStorageBufferRange of {limit} bytes")]
    TooLarge { size: u64, limit: u64 },
    #[error("the GPU was lost (VK_ERROR_DEVICE_LOST) while running {0}; a driver reset or watchdog ended it")]
    DeviceLost(String),
    #[error("{0}; `host view` needs a Vulkan driver that presents to windows (a GPU driver, or Mesa's lavapipe: `apt-get install mesa-vulkan-drivers`)")]
    NoPresentation(String),
    #[error("internal: {0}")]
    Internal(String),
}
