//! The Vulkan instance and device: one owner that the buffers and pipelines hold by `Arc`.

use super::error::GpuError;
use ash::vk;

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
    /// Valid bits of the compute queue's timestamps (0: no timestamp queries).
    pub(crate) timestamp_bits: u32,
    /// Human-readable device name, driver and type, e.g. "llvmpipe (LLVM 15.0.6, 256 bits) [cpu]".
    pub(crate) description: String,
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
pub fn missing_feature(shader_int64: bool, vulkan_memory_model: bool) -> Option<&'static str> {
    if !shader_int64 {
        Some("shaderInt64")
    } else if !vulkan_memory_model {
        Some("vulkanMemoryModel")
    } else {
        None
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
    timestamp_bits: u32,
    description: String,
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
            timestamp_bits: self.timestamp_bits,
            description: self.description,
        }
    }
}

impl DeviceOwner {
    /// Opens the Vulkan loader, picks a device (a GPU before a CPU implementation such as lavapipe,
    /// or `JK_VULKAN_DEVICE=<index>`), and creates a device with one compute queue.
    pub fn new() -> Result<Self, GpuError> {
        // SAFETY: loading the system Vulkan loader; its symbols are trusted.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::NoLoader(e.to_string()))?;
        let app = vk::ApplicationInfo::default()
            .application_name(c"jackknife")
            .api_version(vk::API_VERSION_1_2);
        let info = vk::InstanceCreateInfo::default().application_info(&app);
        // SAFETY: valid create info; the instance is destroyed in Drop (or below on error).
        let instance = unsafe { entry.create_instance(&info, None) }.map_err(|e| match e {
            vk::Result::ERROR_INCOMPATIBLE_DRIVER => GpuError::NoDevice,
            e => GpuError::Vulkan("vkCreateInstance", e),
        })?;
        match Self::with_instance(&instance) {
            Ok(parts) => Ok(parts.into_owner(entry, instance)),
            Err(e) => {
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
    fn with_instance(instance: &ash::Instance) -> Result<DeviceParts, GpuError> {
        // SAFETY: plain queries on a live instance.
        let devices = unsafe { instance.enumerate_physical_devices() }
            .map_err(|e| GpuError::Vulkan("vkEnumeratePhysicalDevices", e))?;
        if devices.is_empty() {
            return Err(GpuError::NoDevice);
        }
        let forced = std::env::var("JK_VULKAN_DEVICE").ok();
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
        let queue_family = families
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE))
            .ok_or_else(|| GpuError::Unsupported(description.clone(), "a compute queue"))?
            as u32;
        let timestamp_bits = families[queue_family as usize].timestamp_valid_bits;

        let mut have12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut have = vk::PhysicalDeviceFeatures2::default().push_next(&mut have12);
        // SAFETY: query with a correctly chained output struct.
        unsafe { instance.get_physical_device_features2(physical, &mut have) };
        let int64 = have.features.shader_int64 == vk::TRUE;
        let memory_model = have12.vulkan_memory_model == vk::TRUE;
        if let Some(feature) = missing_feature(int64, memory_model) {
            return Err(GpuError::Unsupported(description, feature));
        }

        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let features = vk::PhysicalDeviceFeatures::default().shader_int64(true);
        let mut features12 =
            vk::PhysicalDeviceVulkan12Features::default().vulkan_memory_model(true);
        let device_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_features(&features)
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
            timestamp_bits,
            description,
        })
    }

    /// Index of a memory type allowed by `type_bits` with all of `flags`.
    pub(crate) fn memory_type(
        &self,
        type_bits: u32,
        flags: vk::MemoryPropertyFlags,
    ) -> Option<u32> {
        (0..self.memory.memory_type_count).find(|&i| {
            type_bits & (1 << i) != 0
                && self.memory.memory_types[i as usize]
                    .property_flags
                    .contains(flags)
        })
    }

    /// The device's name, type and Vulkan version.
    pub fn description(&self) -> &str {
        &self.description
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
            self.instance.destroy_instance(None);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn a_device_without_a_needed_feature_is_named() {
        assert_eq!(missing_feature(true, true), None);
        assert_eq!(missing_feature(false, true), Some("shaderInt64"));
        assert_eq!(missing_feature(true, false), Some("vulkanMemoryModel"));
    }
}
