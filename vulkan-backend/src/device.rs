//! The Vulkan instance and device: one owner that the buffers and pipelines hold by `Arc`.

use super::error::GpuError;
use ash::vk;

/// Most bindings of one kernel (`direct_cs`, `path_cs`: ten buffers, the seven pages of the
/// voxel pool beyond the first, and the two texel buffers).
pub const MAX_BINDINGS: u32 = 19;
/// Most storage buffers one kernel binds (`direct_cs`, `path_cs`); devices must allow as many
/// per stage.
pub const MAX_STORAGE_BUFFERS: u32 = 17;

/// Owns the Vulkan entry, instance and logical device; destroyed last, after `device_wait_idle`.
pub struct DeviceOwner {
    _entry: ash::Entry,
    pub(crate) instance: ash::Instance,
    pub(crate) device: ash::Device,
    pub(crate) physical: vk::PhysicalDevice,
    pub(crate) queue: vk::Queue,
    pub(crate) queue_family: u32,
    pub(crate) memory: vk::PhysicalDeviceMemoryProperties,
    pub(crate) limits: vk::PhysicalDeviceLimits,
    /// `maxMemoryAllocationSize` (Vulkan 1.1): the largest single allocation.
    pub(crate) max_allocation: u64,
    /// Valid bits of the compute queue's timestamps (0: no timestamp queries).
    pub(crate) timestamp_bits: u32,
    /// Human-readable device name, driver and type, e.g. "llvmpipe (LLVM 15.0.6, 256 bits) [cpu]".
    pub(crate) description: String,
    /// Whether the device is a software implementation on the host's CPU (lavapipe,
    /// SwiftShader: `VK_PHYSICAL_DEVICE_TYPE_CPU`).
    pub(crate) software: bool,
    /// [`DeviceOwner::interleave`], read once when the device is opened.
    interleave: u32,
    /// Whether the fallback to non-device-local storage memory was reported.
    storage_fallback_warned: std::sync::atomic::AtomicBool,
    /// The window's surface where the device was opened for one ([`crate::present`]); the
    /// device's queue can present to it and `VK_KHR_swapchain` is enabled.
    pub(crate) surface: Option<(ash::khr::surface::Instance, vk::SurfaceKHR)>,
}

/// A window to show images in: its raw display and window handles (from winit or any other
/// windowing library). The window must outlive the [`crate::Gpu`] opened for it.
#[derive(Clone, Copy, Debug)]
pub struct Display {
    pub display: raw_window_handle::RawDisplayHandle,
    pub window: raw_window_handle::RawWindowHandle,
}

/// Preference order of device types: a real GPU over a software rasterizer.
fn type_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

fn type_name(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU (software)",
        _ => "other",
    }
}

/// The index of `JK_VULKAN_DEVICE=<value>` among `count` devices, or why it is not one.
pub fn forced_index(value: &str, count: usize) -> Result<usize, GpuError> {
    match value.trim().parse::<usize>() {
        Ok(i) if i < count => Ok(i),
        _ => Err(GpuError::BadDeviceIndex(value.to_string(), count)),
    }
}

/// The first feature the kernels need (shaderInt64, vulkanMemoryModel) that a device lacks.
pub fn missing_feature(
    shader_int64: bool,
    vulkan_memory_model: bool,
    uniform_buffer_standard_layout: bool,
) -> Option<&'static str> {
    if !shader_int64 {
        Some("shaderInt64")
    } else if !vulkan_memory_model {
        Some("vulkanMemoryModel")
    } else if !uniform_buffer_standard_layout {
        Some("uniformBufferStandardLayout")
    } else {
        None
    }
}

/// What a buffer's memory is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MemoryRole {
    /// Storage buffers the kernels read and write: device-local, filled and read by copies.
    Storage,
    /// Host-visible, coherent staging memory for uploads and readbacks.
    Staging,
}

/// A memory type picked for a [`MemoryRole`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryChoice {
    /// Index into the device's memory types.
    pub index: u32,
    /// `Storage` only: no device-local type was allowed, so the buffer lives in whatever memory
    /// the device offers (slower on a discrete GPU, still correct).
    pub fallback: bool,
}

/// The memory type for `role` among `types` allowed by `type_bits`: storage prefers
/// device-local memory the host cannot see (a discrete GPU's VRAM), then any device-local type,
/// then falls back to any allowed type; staging needs host-visible coherent memory and prefers
/// host-cached (fast readbacks).
pub fn pick_memory_type(
    types: &[vk::MemoryType],
    type_bits: u32,
    role: MemoryRole,
) -> Option<MemoryChoice> {
    use vk::MemoryPropertyFlags as F;
    let find = |want: F, avoid: F| {
        (0..types.len() as u32).find(|&i| {
            let flags = types[i as usize].property_flags;
            i < 32 && type_bits & (1 << i) != 0 && flags.contains(want) && !flags.intersects(avoid)
        })
    };
    let pick = |index, fallback| Some(MemoryChoice { index, fallback });
    match role {
        MemoryRole::Storage => {
            if let Some(i) = find(F::DEVICE_LOCAL, F::HOST_VISIBLE) {
                return pick(i, false);
            }
            if let Some(i) = find(F::DEVICE_LOCAL, F::empty()) {
                return pick(i, false);
            }
            find(F::empty(), F::empty()).and_then(|i| pick(i, true))
        }
        MemoryRole::Staging => {
            let coherent = F::HOST_VISIBLE | F::HOST_COHERENT;
            find(coherent | F::HOST_CACHED, F::empty())
                .or_else(|| find(coherent, F::empty()))
                .and_then(|i| pick(i, false))
        }
    }
}

/// Everything [`DeviceOwner`] holds but the entry and the instance.
struct DeviceParts {
    device: ash::Device,
    physical: vk::PhysicalDevice,
    queue: vk::Queue,
    queue_family: u32,
    memory: vk::PhysicalDeviceMemoryProperties,
    limits: vk::PhysicalDeviceLimits,
    max_allocation: u64,
    timestamp_bits: u32,
    description: String,
    software: bool,
}

impl DeviceParts {
    /// The owner of these parts, the instance they came from and the loader.
    fn into_owner(self, entry: ash::Entry, instance: ash::Instance) -> DeviceOwner {
        DeviceOwner {
            _entry: entry,
            instance,
            device: self.device,
            physical: self.physical,
            queue: self.queue,
            queue_family: self.queue_family,
            memory: self.memory,
            limits: self.limits,
            max_allocation: self.max_allocation,
            timestamp_bits: self.timestamp_bits,
            description: self.description,
            software: self.software,
            interleave: if self.software {
                software_threads(std::env::var("LP_NUM_THREADS").ok().as_deref())
            } else {
                1
            },
            storage_fallback_warned: std::sync::atomic::AtomicBool::new(false),
            surface: None,
        }
    }
}

impl DeviceOwner {
    /// Opens the Vulkan loader, picks a device (a GPU before a CPU implementation such as lavapipe,
    /// or `JK_VULKAN_DEVICE=<index>`), and creates a device with one compute queue.
    pub fn new() -> Result<Self, GpuError> {
        Self::open(None)
    }

    /// [`DeviceOwner::new`], with a surface for `display`'s window where given: the instance
    /// has the window system's surface extensions, the device is one whose compute queue can
    /// present to the surface, and it has `VK_KHR_swapchain`.
    pub fn open(display: Option<&Display>) -> Result<Self, GpuError> {
        // SAFETY: loading the system Vulkan loader; its symbols are trusted.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::NoLoader(e.to_string()))?;
        let app = vk::ApplicationInfo::default()
            .application_name(c"jackknife")
            .api_version(vk::API_VERSION_1_2);
        let extensions: &[*const std::ffi::c_char] = match display {
            Some(d) => ash_window::enumerate_required_extensions(d.display)
                .map_err(|e| GpuError::Vulkan("the window system's surface extensions", e))?,
            None => &[],
        };
        let info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_extension_names(extensions);
        // SAFETY: valid create info; the instance is destroyed in Drop (or below on error).
        let instance = unsafe { entry.create_instance(&info, None) }.map_err(|e| match e {
            vk::Result::ERROR_INCOMPATIBLE_DRIVER => GpuError::NoDevice,
            vk::Result::ERROR_EXTENSION_NOT_PRESENT => GpuError::NoPresentation(
                "the Vulkan driver has no surface extension for this window system".into(),
            ),
            e => GpuError::Vulkan("vkCreateInstance", e),
        })?;
        let surface = match display {
            None => None,
            Some(d) => {
                // SAFETY: the handles come from a live window that outlives the owner (the
                // caller's contract, see `Display`); the surface is destroyed in Drop.
                match unsafe {
                    ash_window::create_surface(&entry, &instance, d.display, d.window, None)
                } {
                    Ok(s) => Some((ash::khr::surface::Instance::new(&entry, &instance), s)),
                    Err(e) => {
                        // SAFETY: nothing was created from the instance.
                        unsafe { instance.destroy_instance(None) };
                        return Err(GpuError::Vulkan("creating the window's Vulkan surface", e));
                    }
                }
            }
        };
        match Self::with_instance(&instance, surface.as_ref()) {
            Ok(parts) => {
                let mut owner = parts.into_owner(entry, instance);
                owner.surface = surface;
                Ok(owner)
            }
            Err(e) => {
                if let Some((loader, s)) = surface {
                    // SAFETY: no swapchain was created on the surface.
                    unsafe { loader.destroy_surface(s, None) };
                }
                // SAFETY: no child objects were created from this instance. `entry` (the loaded
                // loader library) is still alive here: destroying the instance after dropping it
                // called into unmapped code (the segfault of a bad JK_VULKAN_DEVICE).
                unsafe { instance.destroy_instance(None) };
                drop(entry);
                Err(e)
            }
        }
    }

    /// Picks the physical device, checks what the kernels need and creates the logical device.
    fn with_instance(
        instance: &ash::Instance,
        surface: Option<&(ash::khr::surface::Instance, vk::SurfaceKHR)>,
    ) -> Result<DeviceParts, GpuError> {
        // SAFETY: plain queries on a live instance.
        let devices = unsafe { instance.enumerate_physical_devices() }
            .map_err(|e| GpuError::Vulkan("vkEnumeratePhysicalDevices", e))?;
        if devices.is_empty() {
            return Err(GpuError::NoDevice);
        }
        // The compute queue family of a device that can present to `surface` (any, without one).
        let present_family = |d: vk::PhysicalDevice| -> Option<u32> {
            // SAFETY: queries on a device handle returned by the instance.
            let families = unsafe { instance.get_physical_device_queue_family_properties(d) };
            (0..families.len() as u32).find(|&i| {
                families[i as usize]
                    .queue_flags
                    .contains(vk::QueueFlags::COMPUTE)
                    && surface.is_none_or(|(loader, s)| {
                        // SAFETY: a live surface of this instance.
                        unsafe { loader.get_physical_device_surface_support(d, i, *s) }
                            .unwrap_or(false)
                    })
            })
        };
        let devices: Vec<vk::PhysicalDevice> = if surface.is_some() {
            let can = devices
                .iter()
                .copied()
                .filter(|&d| present_family(d).is_some())
                .collect::<Vec<_>>();
            if can.is_empty() {
                return Err(GpuError::NoPresentation(
                    "no Vulkan device can present to this window".into(),
                ));
            }
            can
        } else {
            devices
        };
        // A value that is not UTF-8 is a bad index too (never silently the default device).
        let forced = std::env::var_os("JK_VULKAN_DEVICE").map(|v| v.to_string_lossy().into_owned());
        let physical = match forced {
            Some(s) => devices[forced_index(&s, devices.len())?],
            None => *devices
                .iter()
                .min_by_key(|&&d| {
                    // SAFETY: query on a device handle returned by the instance.
                    type_rank(unsafe { instance.get_physical_device_properties(d) }.device_type)
                })
                .expect("non-empty"),
        };
        // SAFETY: queries on a valid physical device.
        let (props, families, memory) = unsafe {
            (
                instance.get_physical_device_properties(physical),
                instance.get_physical_device_queue_family_properties(physical),
                instance.get_physical_device_memory_properties(physical),
            )
        };
        let name = props
            .device_name_as_c_str()
            .unwrap_or(c"unknown")
            .to_string_lossy()
            .into_owned();
        let description = format!(
            "{name} [{}, Vulkan {}.{}.{}]",
            type_name(props.device_type),
            vk::api_version_major(props.api_version),
            vk::api_version_minor(props.api_version),
            vk::api_version_patch(props.api_version)
        );
        if props.api_version < vk::API_VERSION_1_2 {
            return Err(GpuError::Unsupported(description, "Vulkan 1.2"));
        }
        let queue_family = present_family(physical).ok_or_else(|| {
            GpuError::Unsupported(
                description.clone(),
                if surface.is_some() {
                    "a compute queue that presents to the window"
                } else {
                    "a compute queue"
                },
            )
        })?;
        let timestamp_bits = families[queue_family as usize].timestamp_valid_bits;

        let mut have12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut have = vk::PhysicalDeviceFeatures2::default().push_next(&mut have12);
        // SAFETY: query with a correctly chained output struct.
        unsafe { instance.get_physical_device_features2(physical, &mut have) };
        let int64 = have.features.shader_int64 == vk::TRUE;
        let mut maintenance3 = vk::PhysicalDeviceMaintenance3Properties::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut maintenance3);
        // SAFETY: query with a correctly chained output struct (core in Vulkan 1.1).
        unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
        let max_allocation = maintenance3.max_memory_allocation_size;
        let memory_model = have12.vulkan_memory_model == vk::TRUE;
        let ubo_layout = have12.uniform_buffer_standard_layout == vk::TRUE;
        if let Some(feature) = missing_feature(int64, memory_model, ubo_layout) {
            return Err(GpuError::Unsupported(description, feature));
        }
        if props.limits.max_per_stage_descriptor_storage_buffers < MAX_STORAGE_BUFFERS {
            return Err(GpuError::Unsupported(
                description,
                "maxPerStageDescriptorStorageBuffers >= 17 (the kernels bind up to 17 buffers)",
            ));
        }

        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let features = vk::PhysicalDeviceFeatures::default().shader_int64(true);
        // Uniform blocks (the render kernels' parameters) in the shared structs' layout.
        let mut features12 = vk::PhysicalDeviceVulkan12Features::default()
            .vulkan_memory_model(true)
            .uniform_buffer_standard_layout(true);
        let swapchain = [ash::khr::swapchain::NAME.as_ptr()];
        let device_extensions: &[*const std::ffi::c_char] =
            if surface.is_some() { &swapchain } else { &[] };
        let device_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_features(&features)
            .enabled_extension_names(device_extensions)
            .push_next(&mut features12);
        // SAFETY: features were checked above; the device is destroyed in Drop.
        let device = unsafe { instance.create_device(physical, &device_info, None) }
            .map_err(|e| GpuError::Vulkan("vkCreateDevice", e))?;
        // SAFETY: queue 0 of a family we requested.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        Ok(DeviceParts {
            device,
            physical,
            queue,
            queue_family,
            memory,
            limits: props.limits,
            max_allocation,
            timestamp_bits,
            description,
            software: props.device_type == vk::PhysicalDeviceType::CPU,
        })
    }

    /// Memory type index and flags for a buffer of `role` allowed by `type_bits`, or `None`.
    pub(crate) fn memory_type(&self, type_bits: u32, role: MemoryRole) -> Option<MemoryChoice> {
        let types = &self.memory.memory_types[..self.memory.memory_type_count as usize];
        pick_memory_type(types, type_bits, role)
    }
    /// Warns once that storage buffers live in memory that is not device-local.
    pub(crate) fn warn_storage_fallback(&self) {
        if !self
            .storage_fallback_warned
            .swap(true, std::sync::atomic::Ordering::Relaxed)
        {
            tracing::warn!(
                "{}: no device-local memory type fits a storage buffer; using host memory (slower)",
                self.description
            );
        }
    }

    /// The device's name, type and Vulkan version.
    pub fn description(&self) -> &str {
        &self.description
    }

    /// Whether the device is a software implementation on the host's CPU.
    pub fn is_software(&self) -> bool {
        self.software
    }

    /// The threads a software device runs a dispatch's workgroups on, as one contiguous range
    /// of workgroups per thread ([`shared::kernels::launch::interleaved_group`]); 1 on a GPU,
    /// whose scheduler hands out workgroups as units free up.
    pub fn interleave(&self) -> u32 {
        self.interleave
    }

    /// Name of the selected device as a C string (for logs).
    pub fn name(&self) -> &str {
        self.description.split(" [").next().unwrap_or("")
    }

    /// The underlying physical device (for queries by later passes).
    pub fn physical(&self) -> vk::PhysicalDevice {
        self.physical
    }
}

impl Drop for DeviceOwner {
    fn drop(&mut self) {
        // SAFETY: every child object holds an Arc to this owner, so none is alive any more.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_device(None);
            if let Some((loader, surface)) = self.surface.take() {
                loader.destroy_surface(surface, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// lavapipe's threads for compute dispatches: `LP_NUM_THREADS` where it is a number, else one
/// per CPU this process may run on; at most llvmpipe's 32. A wrong guess costs speed only: the
/// workgroups' ids are a permutation either way.
fn software_threads(lp_num_threads: Option<&str>) -> u32 {
    lp_num_threads
        .and_then(|v| v.trim().parse::<u32>().ok())
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get() as u32))
        .clamp(1, 32)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// lavapipe's thread count: the variable where it is a number (clamped to llvmpipe's
    /// 1..=32), else the CPUs this process may use.
    #[test]
    fn software_threads_follow_lp_num_threads() {
        assert_eq!(software_threads(Some("3")), 3);
        assert_eq!(software_threads(Some(" 8 ")), 8);
        assert_eq!(software_threads(Some("0")), 1);
        assert_eq!(software_threads(Some("100")), 32);
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get() as u32);
        assert_eq!(software_threads(None), cpus.clamp(1, 32));
        assert_eq!(software_threads(Some("many")), cpus.clamp(1, 32));
    }

    #[test]
    fn forced_index_accepts_only_existing_devices() {
        assert_eq!(forced_index("0", 1).unwrap(), 0);
        assert_eq!(forced_index(" 1 ", 2).unwrap(), 1);
        for bad in ["5", "1", "-1", "abc", "", "1e3", "99999999999999999999999"] {
            let e = forced_index(bad, 1).unwrap_err().to_string();
            assert!(
                e.contains("JK_VULKAN_DEVICE") && e.contains("0 to 0"),
                "{bad}: {e}"
            );
        }
    }

    /// A memory type with `flags` in heap 0.
    fn ty(flags: vk::MemoryPropertyFlags) -> vk::MemoryType {
        vk::MemoryType {
            property_flags: flags,
            heap_index: 0,
        }
    }

    #[test]
    fn storage_goes_to_vram_and_staging_to_host_memory_on_a_discrete_gpu() {
        use vk::MemoryPropertyFlags as F;
        let types = [
            ty(F::HOST_VISIBLE | F::HOST_COHERENT),
            ty(F::DEVICE_LOCAL | F::HOST_VISIBLE | F::HOST_COHERENT),
            ty(F::DEVICE_LOCAL),
            ty(F::HOST_VISIBLE | F::HOST_COHERENT | F::HOST_CACHED),
        ];
        let storage = pick_memory_type(&types, 0b1111, MemoryRole::Storage).unwrap();
        assert_eq!((storage.index, storage.fallback), (2, false));
        let staging = pick_memory_type(&types, 0b1111, MemoryRole::Staging).unwrap();
        assert_eq!(staging.index, 3);
        // Not allowed by the buffer: the next best type.
        let storage = pick_memory_type(&types, 0b0011, MemoryRole::Storage).unwrap();
        assert_eq!((storage.index, storage.fallback), (1, false));
        let staging = pick_memory_type(&types, 0b0111, MemoryRole::Staging).unwrap();
        assert_eq!(staging.index, 0);
    }

    #[test]
    fn storage_falls_back_without_device_local_memory_and_staging_needs_coherence() {
        use vk::MemoryPropertyFlags as F;
        let types = [ty(F::HOST_VISIBLE), ty(F::HOST_VISIBLE | F::HOST_COHERENT)];
        let storage = pick_memory_type(&types, 0b01, MemoryRole::Storage).unwrap();
        assert_eq!((storage.index, storage.fallback), (0, true));
        assert_eq!(pick_memory_type(&types, 0b01, MemoryRole::Staging), None);
        assert_eq!(pick_memory_type(&types, 0, MemoryRole::Storage), None);
    }

    #[test]
    fn a_device_without_a_needed_feature_is_named() {
        assert_eq!(missing_feature(true, true, true), None);
        assert_eq!(missing_feature(false, true, true), Some("shaderInt64"));
        assert_eq!(
            missing_feature(true, false, true),
            Some("vulkanMemoryModel")
        );
        assert_eq!(
            missing_feature(true, true, false),
            Some("uniformBufferStandardLayout")
        );
    }
}
