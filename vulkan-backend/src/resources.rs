//! RAII wrappers for the Vulkan objects a dispatch uses; each holds the device owner alive.

use super::device::{DeviceOwner, MemoryRole, MAX_BINDINGS};
use super::error::GpuError;
use ash::vk;
use std::sync::{Arc, OnceLock};

/// A device-local storage buffer (see [`MemoryRole::Storage`]); filled and read through
/// [`Staging`] copies by the [`super::Gpu`].
pub struct Buffer {
    owner: Arc<DeviceOwner>,
    pub(crate) buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    pub(crate) size: u64,
    /// Its words as a uniform texel buffer (`VK_FORMAT_R32_UINT`), made on first use.
    texel_view: OnceLock<vk::BufferView>,
}

/// A host-visible, coherent buffer, persistently mapped: the source of uploads and the
/// destination of readbacks.
pub struct Staging {
    inner: Buffer,
    mapped: *mut u8,
}

// SAFETY: the mapped pointer is only dereferenced through &self/&mut self methods, and the GPU
// only accesses the memory between a submit and its fence wait, which the submitter serializes.
unsafe impl Send for Staging {}
// SAFETY: see Send; shared references only read.
unsafe impl Sync for Staging {}

/// A buffer and its bound memory; destroys both on the error paths of [`Buffer::create`].
fn create_buffer(
    owner: &Arc<DeviceOwner>,
    size: u64,
    usage: vk::BufferUsageFlags,
    role: MemoryRole,
) -> Result<Buffer, GpuError> {
    let size = size.max(4);
    let device = &owner.device;
    let info = vk::BufferCreateInfo::default()
        .size(size)
        .usage(usage)
        .sharing_mode(vk::SharingMode::EXCLUSIVE);
    // SAFETY: valid create info; destroyed in Drop or on the error paths below.
    let buffer = unsafe { device.create_buffer(&info, None) }
        .map_err(|e| GpuError::Vulkan("vkCreateBuffer", e))?;
    // SAFETY: query on the buffer just created.
    let req = unsafe { device.get_buffer_memory_requirements(buffer) };
    let Some(choice) = owner.memory_type(req.memory_type_bits, role) else {
        // SAFETY: the buffer is unused.
        unsafe { device.destroy_buffer(buffer, None) };
        let what = match role {
            MemoryRole::Storage => "memory for storage buffers",
            MemoryRole::Staging => "host-visible coherent memory",
        };
        return Err(GpuError::Unsupported(owner.description.clone(), what));
    };
    if choice.fallback {
        owner.warn_storage_fallback();
    }
    let alloc = vk::MemoryAllocateInfo::default()
        .allocation_size(req.size)
        .memory_type_index(choice.index);
    // SAFETY: valid allocation info; freed in Drop.
    let memory = match unsafe { device.allocate_memory(&alloc, None) } {
        Ok(m) => m,
        Err(e) => {
            // SAFETY: the buffer is unused.
            unsafe { device.destroy_buffer(buffer, None) };
            return Err(GpuError::OutOfMemory(size, e));
        }
    };
    let buffer = Buffer {
        owner: owner.clone(),
        buffer,
        memory,
        size,
        texel_view: OnceLock::new(),
    };
    // SAFETY: memory of a compatible type, offset 0 (dropping `buffer` frees both on error).
    unsafe { device.bind_buffer_memory(buffer.buffer, memory, 0) }
        .map_err(|e| GpuError::Vulkan("vkBindBufferMemory", e))?;
    Ok(buffer)
}

impl Buffer {
    /// A device-local storage (or uniform) buffer of `size` bytes (at least 4), uninitialised.
    pub fn new(owner: &Arc<DeviceOwner>, size: u64) -> Result<Self, GpuError> {
        use vk::BufferUsageFlags as U;
        let usage = U::STORAGE_BUFFER
            | U::UNIFORM_BUFFER
            | U::UNIFORM_TEXEL_BUFFER
            | U::TRANSFER_SRC
            | U::TRANSFER_DST;
        create_buffer(owner, size, usage, MemoryRole::Storage)
    }

    /// Size in bytes.
    pub fn size(&self) -> u64 {
        self.size
    }

    /// The buffer's words as a uniform texel buffer of `VK_FORMAT_R32_UINT` (the first
    /// `maxTexelBufferElements` words where it is longer: the kernels read such a buffer
    /// through its storage binding instead).
    pub(crate) fn texel_view(&self) -> Result<vk::BufferView, GpuError> {
        if let Some(v) = self.texel_view.get() {
            return Ok(*v);
        }
        let words = (self.size / 4).min(u64::from(self.owner.limits.max_texel_buffer_elements));
        let info = vk::BufferViewCreateInfo::default()
            .buffer(self.buffer)
            .format(vk::Format::R32_UINT)
            .offset(0)
            .range(words.max(1) * 4);
        // SAFETY: a view of this buffer (created with UNIFORM_TEXEL_BUFFER usage, at least 4
        // bytes) within its size; destroyed in Drop.
        let view = unsafe { self.owner.device.create_buffer_view(&info, None) }
            .map_err(|e| GpuError::Vulkan("vkCreateBufferView", e))?;
        if let Err(v) = self.texel_view.set(view) {
            // SAFETY: another thread's view won; this one is unused.
            unsafe { self.owner.device.destroy_buffer_view(v, None) };
        }
        Ok(*self.texel_view.get().expect("just set"))
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // SAFETY: the submitter waits for its fence before buffers can be dropped; freeing
        // mapped memory unmaps it.
        unsafe {
            if let Some(v) = self.texel_view.get() {
                self.owner.device.destroy_buffer_view(*v, None);
            }
            self.owner.device.destroy_buffer(self.buffer, None);
            self.owner.device.free_memory(self.memory, None);
        }
    }
}

impl Staging {
    /// A mapped staging buffer of `size` bytes (at least 4).
    pub fn new(owner: &Arc<DeviceOwner>, size: u64) -> Result<Self, GpuError> {
        use vk::BufferUsageFlags as U;
        let usage = U::TRANSFER_SRC | U::TRANSFER_DST;
        let inner = create_buffer(owner, size, usage, MemoryRole::Staging)?;
        // SAFETY: host-visible memory bound at offset 0; mapping the whole allocation.
        let mapped = unsafe {
            owner
                .device
                .map_memory(inner.memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty())
        }
        .map_err(|e| GpuError::Vulkan("vkMapMemory", e))?;
        Ok(Staging {
            inner,
            mapped: mapped as *mut u8,
        })
    }

    /// The Vulkan buffer, for copy commands.
    pub(crate) fn buffer(&self) -> vk::Buffer {
        self.inner.buffer
    }

    /// Size in bytes.
    pub fn size(&self) -> u64 {
        self.inner.size
    }

    /// Copies `data` to byte `offset` of the buffer.
    pub fn write(&mut self, offset: u64, data: &[u8]) {
        assert!(
            offset + data.len() as u64 <= self.size(),
            "write past the end of a staging buffer"
        );
        // SAFETY: the mapping covers `size` bytes and the GPU is idle (submitter invariant).
        unsafe {
            std::ptr::copy_nonoverlapping(
                data.as_ptr(),
                self.mapped.add(offset as usize),
                data.len(),
            )
        };
    }

    /// Copies `out.len()` bytes from byte `offset` of the buffer into `out`.
    pub fn read(&self, offset: u64, out: &mut [u8]) {
        assert!(
            offset + out.len() as u64 <= self.size(),
            "read past the end of a staging buffer"
        );
        // SAFETY: as in `write`.
        unsafe {
            std::ptr::copy_nonoverlapping(
                self.mapped.add(offset as usize),
                out.as_mut_ptr(),
                out.len(),
            )
        };
    }
}

/// A compute pipeline for one entry point, with its layouts.
pub struct Pipeline {
    owner: Arc<DeviceOwner>,
    pub(crate) pipeline: vk::Pipeline,
    pub(crate) layout: vk::PipelineLayout,
    pub(crate) set_layout: vk::DescriptorSetLayout,
    /// Bit b set: binding b is a uniform buffer, else a storage buffer.
    pub(crate) uniforms: u32,
    /// Bit b set: binding b is a uniform texel buffer of 32-bit words.
    pub(crate) texel_buffers: u32,
}

/// What a pipeline's layout takes from its kernel (`Kernel`'s generated metadata).
pub struct KernelLayout<'a> {
    /// The entry-point name.
    pub entry: &'a std::ffi::CStr,
    /// Number of bindings of set 0.
    pub bindings: u32,
    /// Bit b set: binding b is a uniform buffer.
    pub uniforms: u32,
    /// Bit b set: binding b is a uniform texel buffer of 32-bit words.
    pub texel_buffers: u32,
    /// Size in bytes of the push constants.
    pub push_size: u32,
}

/// The descriptor type of binding `b` of a layout whose uniform buffers are the bits of
/// `uniforms` and whose uniform texel buffers are the bits of `texel_buffers`.
pub fn descriptor_type(uniforms: u32, texel_buffers: u32, b: u32) -> vk::DescriptorType {
    if texel_buffers >> b & 1 == 1 {
        vk::DescriptorType::UNIFORM_TEXEL_BUFFER
    } else if uniforms >> b & 1 == 1 {
        vk::DescriptorType::UNIFORM_BUFFER
    } else {
        vk::DescriptorType::STORAGE_BUFFER
    }
}

impl Pipeline {
    /// Builds the pipeline of `layout.entry` in `module`, with `layout.bindings` bindings at
    /// 0.. of set 0 (uniform buffers, uniform texel buffers and storage buffers as `layout`
    /// says), its push constants and the u32 specialization constants `spec` (constant id i =
    /// `spec[i]`; ids the module lacks are ignored).
    pub fn new(
        owner: &Arc<DeviceOwner>,
        module: vk::ShaderModule,
        layout: &KernelLayout,
        spec: &[u32],
    ) -> Result<Self, GpuError> {
        let device = &owner.device;
        let (entry, bindings) = (layout.entry, layout.bindings);
        let (uniforms, texel_buffers) = (layout.uniforms, layout.texel_buffers);
        let binding_info: Vec<_> = (0..bindings)
            .map(|b| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b)
                    .descriptor_type(descriptor_type(uniforms, texel_buffers, b))
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let set_info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&binding_info);
        // SAFETY: valid create infos; every object is destroyed in Drop (or below on error).
        let set_layout = unsafe { device.create_descriptor_set_layout(&set_info, None) }
            .map_err(|e| GpuError::Vulkan("vkCreateDescriptorSetLayout", e))?;
        let ranges = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::COMPUTE)
            .offset(0)
            .size(layout.push_size)];
        let set_layouts = [set_layout];
        let layout_info = vk::PipelineLayoutCreateInfo::default()
            .set_layouts(&set_layouts)
            .push_constant_ranges(&ranges);
        // SAFETY: as above.
        let layout = match unsafe { device.create_pipeline_layout(&layout_info, None) } {
            Ok(l) => l,
            Err(e) => {
                // SAFETY: unused.
                unsafe { device.destroy_descriptor_set_layout(set_layout, None) };
                return Err(GpuError::Vulkan("vkCreatePipelineLayout", e));
            }
        };
        let entries: Vec<vk::SpecializationMapEntry> = (0..spec.len() as u32)
            .map(|id| {
                vk::SpecializationMapEntry::default()
                    .constant_id(id)
                    .offset(id * 4)
                    .size(4)
            })
            .collect();
        let spec_info = vk::SpecializationInfo::default()
            .map_entries(&entries)
            .data(bytemuck::cast_slice(spec));
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(entry)
            .specialization_info(&spec_info);
        let info = [vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(layout)];
        // SAFETY: the module outlives this call; the entry name comes from the module's metadata.
        let pipeline = match unsafe {
            device.create_compute_pipelines(vk::PipelineCache::null(), &info, None)
        } {
            Ok(p) => p[0],
            Err((_, e)) => {
                // SAFETY: unused.
                unsafe {
                    device.destroy_pipeline_layout(layout, None);
                    device.destroy_descriptor_set_layout(set_layout, None);
                }
                return Err(GpuError::Vulkan("vkCreateComputePipelines", e));
            }
        };
        Ok(Pipeline {
            owner: owner.clone(),
            pipeline,
            layout,
            set_layout,
            uniforms,
            texel_buffers,
        })
    }
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        // SAFETY: pipelines are dropped with the Gpu, after its last fence wait.
        unsafe {
            self.owner.device.destroy_pipeline(self.pipeline, None);
            self.owner.device.destroy_pipeline_layout(self.layout, None);
            self.owner
                .device
                .destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

/// A command pool on the device's queue family whose buffers can be reset one by one, and one
/// primary command buffer from it (the caller destroys the pool; on error a created pool leaks
/// until the device is destroyed, which frees it).
pub(crate) fn command_pool(
    owner: &DeviceOwner,
) -> Result<(vk::CommandPool, vk::CommandBuffer), GpuError> {
    let info = vk::CommandPoolCreateInfo::default()
        .queue_family_index(owner.queue_family)
        .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
    // SAFETY: valid create infos on a live device.
    unsafe {
        let pool = owner
            .device
            .create_command_pool(&info, None)
            .map_err(|e| GpuError::Vulkan("vkCreateCommandPool", e))?;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        let cmd = owner
            .device
            .allocate_command_buffers(&alloc)
            .map_err(|e| GpuError::Vulkan("vkAllocateCommandBuffers", e))?[0];
        Ok((pool, cmd))
    }
}

/// A command pool with one reusable command buffer, one descriptor pool and one fence.
pub struct Submitter {
    owner: Arc<DeviceOwner>,
    pool: vk::CommandPool,
    pub(crate) cmd: vk::CommandBuffer,
    pub(crate) descriptors: vk::DescriptorPool,
    pub(crate) fence: vk::Fence,
    /// Two timestamps around each submission's dispatches, if the queue supports them.
    pub(crate) timestamps: Option<vk::QueryPool>,
    /// The staging buffer of the last submission, reused while it is large enough.
    pub(crate) staging: Option<Staging>,
}

impl Submitter {
    pub fn new(owner: &Arc<DeviceOwner>) -> Result<Self, GpuError> {
        let device = &owner.device;
        let (pool, cmd) = command_pool(owner)?;
        // SAFETY: valid create infos; destroyed in Drop. On error the partially built objects
        // leak until the device is destroyed, which frees them.
        unsafe {
            let sizes = [
                vk::DescriptorPoolSize::default()
                    .ty(vk::DescriptorType::STORAGE_BUFFER)
                    .descriptor_count(MAX_BINDINGS),
                vk::DescriptorPoolSize::default()
                    .ty(vk::DescriptorType::UNIFORM_BUFFER)
                    .descriptor_count(MAX_BINDINGS),
                vk::DescriptorPoolSize::default()
                    .ty(vk::DescriptorType::UNIFORM_TEXEL_BUFFER)
                    .descriptor_count(MAX_BINDINGS),
            ];
            let dp_info = vk::DescriptorPoolCreateInfo::default()
                .max_sets(1)
                .pool_sizes(&sizes);
            let descriptors = device
                .create_descriptor_pool(&dp_info, None)
                .map_err(|e| GpuError::Vulkan("vkCreateDescriptorPool", e))?;
            let fence = device
                .create_fence(&vk::FenceCreateInfo::default(), None)
                .map_err(|e| GpuError::Vulkan("vkCreateFence", e))?;
            let timestamps = if owner.timestamp_bits > 0 {
                let info = vk::QueryPoolCreateInfo::default()
                    .query_type(vk::QueryType::TIMESTAMP)
                    .query_count(2);
                device.create_query_pool(&info, None).ok()
            } else {
                None
            };
            Ok(Submitter {
                owner: owner.clone(),
                pool,
                cmd,
                descriptors,
                fence,
                timestamps,
                staging: None,
            })
        }
    }
}

impl Drop for Submitter {
    fn drop(&mut self) {
        // SAFETY: the last submit was waited for; objects are not in use.
        unsafe {
            let d = &self.owner.device;
            if let Some(q) = self.timestamps {
                d.destroy_query_pool(q, None);
            }
            d.destroy_fence(self.fence, None);
            d.destroy_descriptor_pool(self.descriptors, None);
            d.destroy_command_pool(self.pool, None);
        }
    }
}
