//! The ash (Vulkan) backend: one generic "dispatch kernel by entry-point name over N ids" path.
//!
//! Kernels follow one convention: push constants start with [`Launch`], then kernel-specific
//! bytes; storage buffers are bound at set 0, inputs first (bindings 0..i), then outputs.

mod device;
mod error;
mod resources;

pub use device::DeviceOwner;
pub use error::GpuError;
pub use resources::Buffer;
use resources::{Pipeline, Submitter, MAX_BINDINGS};

use ash::vk;
use shared::launch::{Launch, WORKGROUP_SIZE};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// The SPIR-V module of the `kernels` crate, compiled by `build.rs` with rust-gpu.
pub const KERNELS_SPV: &[u8] = include_bytes!(env!("kernels.spv"));

/// A Vulkan device with the kernels module loaded and pipelines built on first use.
pub struct Gpu {
    owner: Arc<DeviceOwner>,
    module: vk::ShaderModule,
    pipelines: Mutex<HashMap<String, Arc<Pipeline>>>,
    submitter: Mutex<Submitter>,
    /// Kernel time measured by timestamp queries since the last [`Gpu::take_kernel_ns`].
    kernel_ns: std::sync::atomic::AtomicU64,
}

impl Gpu {
    /// Opens the preferred Vulkan device and loads the kernels.
    pub fn new() -> Result<Self, GpuError> {
        let owner = Arc::new(DeviceOwner::new()?);
        let words = ash::util::read_spv(&mut std::io::Cursor::new(KERNELS_SPV))
            .map_err(|e| GpuError::Internal(format!("embedded SPIR-V is malformed: {e}")))?;
        let info = vk::ShaderModuleCreateInfo::default().code(&words);
        // SAFETY: valid SPIR-V produced by rust-gpu; destroyed in Drop.
        let module = unsafe { owner.device.create_shader_module(&info, None) }
            .map_err(|e| GpuError::Vulkan("vkCreateShaderModule", e))?;
        let submitter = match Submitter::new(&owner) {
            Ok(s) => s,
            Err(e) => {
                // SAFETY: the module is unused.
                unsafe { owner.device.destroy_shader_module(module, None) };
                return Err(e);
            }
        };
        Ok(Gpu {
            owner,
            module,
            pipelines: Mutex::new(HashMap::new()),
            submitter: Mutex::new(submitter),
            kernel_ns: std::sync::atomic::AtomicU64::new(0),
        })
    }

    /// Device name, type and Vulkan version.
    pub fn description(&self) -> &str {
        self.owner.description()
    }

    fn pipeline(
        &self,
        entry: &str,
        bindings: u32,
        push_size: u32,
    ) -> Result<Arc<Pipeline>, GpuError> {
        let mut cache = self
            .pipelines
            .lock()
            .map_err(|_| GpuError::Internal("poisoned".into()))?;
        if let Some(p) = cache.get(entry) {
            if p.bindings != bindings || p.push_size != push_size {
                return Err(GpuError::Internal(format!(
                    "{entry} called with {bindings} buffers / {push_size} push bytes, first with {} / {}",
                    p.bindings, p.push_size
                )));
            }
            return Ok(p.clone());
        }
        if !kernel_names().any(|n| n == entry) {
            return Err(GpuError::BadEntryPoint(entry.into()));
        }
        let p = Arc::new(Pipeline::new(
            &self.owner,
            self.module,
            entry,
            bindings,
            push_size,
        )?);
        cache.insert(entry.to_string(), p.clone());
        Ok(p)
    }

    /// A storage buffer holding `data`, kept on the device across dispatches.
    pub fn upload(&self, data: &[u8]) -> Result<Buffer, GpuError> {
        let mut b = self.buffer(data.len() as u64)?;
        b.write(data);
        Ok(b)
    }

    /// Kernel time (ns) measured by timestamp queries since the last call, or `None` if the
    /// device's compute queue has no timestamps.
    pub fn take_kernel_ns(&self) -> Option<u64> {
        let ns = self.kernel_ns.swap(0, std::sync::atomic::Ordering::Relaxed);
        self.owner_has_timestamps().then_some(ns)
    }

    fn owner_has_timestamps(&self) -> bool {
        self.owner.timestamp_bits > 0
    }

    /// The largest storage buffer in bytes: the device's maxStorageBufferRange, or less if the
    /// environment variable `JK_GPU_MAX_BUFFER_BYTES` says so (to exercise tiling in tests).
    pub fn max_buffer_bytes(&self) -> u64 {
        let device = u64::from(self.owner.limits.max_storage_buffer_range);
        let forced = std::env::var("JK_GPU_MAX_BUFFER_BYTES")
            .ok()
            .and_then(|v| v.parse::<u64>().ok());
        forced.map_or(device, |f| f.clamp(64, device))
    }

    /// An uninitialised storage buffer of `size` bytes (checked against the device limit).
    pub fn buffer(&self, size: u64) -> Result<Buffer, GpuError> {
        let limit = self.max_buffer_bytes();
        if size > limit {
            return Err(GpuError::TooLarge { size, limit });
        }
        Buffer::new(&self.owner, size)
    }

    /// Runs kernel `entry` over ids 0..count: copies `inputs` to bindings 0..i, the `outputs` to
    /// the next bindings, dispatches, waits, and copies the outputs back. `extra_push` follows
    /// the [`Launch`] header in push constants.
    pub fn dispatch(
        &self,
        entry: &str,
        count: u32,
        seed: u32,
        extra_push: &[u8],
        inputs: &[&[u8]],
        outputs: &mut [&mut [u8]],
    ) -> Result<(), GpuError> {
        let mut bindings: Vec<Binding> = inputs.iter().map(|d| Binding::Input(d)).collect();
        bindings.extend(outputs.iter_mut().map(|d| Binding::Output(d)));
        self.dispatch_range(entry, 0..count, count, seed, extra_push, &mut bindings)
    }

    /// Runs kernel `entry` over ids `ids` of a launch of `count` ids, with the given bindings
    /// (binding i of set 0 is `bindings[i]`), in as many dispatches as the device's
    /// workgroup-count limit needs; waits for completion and copies `Output` bindings back.
    pub fn dispatch_range(
        &self,
        entry: &str,
        ids: std::ops::Range<u32>,
        count: u32,
        seed: u32,
        extra_push: &[u8],
        bindings: &mut [Binding],
    ) -> Result<(), GpuError> {
        if ids.is_empty() {
            return Ok(());
        }
        let n_bindings = bindings.len() as u32;
        if n_bindings > MAX_BINDINGS || !extra_push.len().is_multiple_of(4) || ids.end > count {
            return Err(GpuError::Internal(format!(
                "bad dispatch shape for {entry}"
            )));
        }
        let push_size = (std::mem::size_of::<Launch>() + extra_push.len()) as u32;
        let pipeline = self.pipeline(entry, n_bindings, push_size)?;
        // Fresh buffers for Input/Output bindings; resident ones are used as they are.
        let mut fresh: Vec<Option<Buffer>> = Vec::with_capacity(bindings.len());
        for b in bindings.iter() {
            fresh.push(match b {
                Binding::Input(data) => Some(self.upload(data)?),
                Binding::Output(data) => Some(self.buffer(data.len() as u64)?),
                Binding::Resident(_) => None,
            });
        }
        let handles: Vec<(vk::Buffer, u64)> = bindings
            .iter()
            .zip(&fresh)
            .map(|(b, f)| match (b, f) {
                (Binding::Resident(r), _) => (r.buffer, r.size),
                (_, Some(f)) => (f.buffer, f.size),
                _ => unreachable!("fresh buffer exists for every non-resident binding"),
            })
            .collect();

        let sub = self
            .submitter
            .lock()
            .map_err(|_| GpuError::Internal("poisoned".into()))?;
        let d = &self.owner.device;
        // SAFETY: all handles are alive; the command buffer is re-recorded only after the
        // previous submission's fence was waited for (the submitter lock serializes this).
        unsafe {
            d.reset_descriptor_pool(sub.descriptors, vk::DescriptorPoolResetFlags::empty())
                .map_err(|e| GpuError::Vulkan("vkResetDescriptorPool", e))?;
            let layouts = [pipeline.set_layout];
            let alloc = vk::DescriptorSetAllocateInfo::default()
                .descriptor_pool(sub.descriptors)
                .set_layouts(&layouts);
            let set = d
                .allocate_descriptor_sets(&alloc)
                .map_err(|e| GpuError::Vulkan("vkAllocateDescriptorSets", e))?[0];
            let infos: Vec<[vk::DescriptorBufferInfo; 1]> = handles
                .iter()
                .map(|&(buffer, size)| {
                    [vk::DescriptorBufferInfo::default()
                        .buffer(buffer)
                        .offset(0)
                        .range(size)]
                })
                .collect();
            let writes: Vec<_> = infos
                .iter()
                .enumerate()
                .map(|(i, info)| {
                    vk::WriteDescriptorSet::default()
                        .dst_set(set)
                        .dst_binding(i as u32)
                        .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                        .buffer_info(info)
                })
                .collect();
            d.update_descriptor_sets(&writes, &[]);

            d.reset_command_buffer(sub.cmd, vk::CommandBufferResetFlags::empty())
                .map_err(|e| GpuError::Vulkan("vkResetCommandBuffer", e))?;
            let begin = vk::CommandBufferBeginInfo::default()
                .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            d.begin_command_buffer(sub.cmd, &begin)
                .map_err(|e| GpuError::Vulkan("vkBeginCommandBuffer", e))?;
            if let Some(q) = sub.timestamps {
                d.cmd_reset_query_pool(sub.cmd, q, 0, 2);
                d.cmd_write_timestamp(sub.cmd, vk::PipelineStageFlags::TOP_OF_PIPE, q, 0);
            }
            d.cmd_bind_pipeline(sub.cmd, vk::PipelineBindPoint::COMPUTE, pipeline.pipeline);
            d.cmd_bind_descriptor_sets(
                sub.cmd,
                vk::PipelineBindPoint::COMPUTE,
                pipeline.layout,
                0,
                &[set],
                &[],
            );
            let max_groups = self.owner.limits.max_compute_work_group_count[0].min(65_535);
            let chunk = max_groups * WORKGROUP_SIZE;
            let mut offset = ids.start;
            while offset < ids.end {
                let n = (ids.end - offset).min(chunk);
                let launch = Launch {
                    offset,
                    count: offset + n,
                    seed,
                    _pad: 0,
                };
                let mut push = bytemuck::bytes_of(&launch).to_vec();
                push.extend_from_slice(extra_push);
                d.cmd_push_constants(
                    sub.cmd,
                    pipeline.layout,
                    vk::ShaderStageFlags::COMPUTE,
                    0,
                    &push,
                );
                d.cmd_dispatch(sub.cmd, n.div_ceil(WORKGROUP_SIZE), 1, 1);
                offset += n;
            }
            if let Some(q) = sub.timestamps {
                d.cmd_write_timestamp(sub.cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, q, 1);
            }
            let barrier = [vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::SHADER_WRITE)
                .dst_access_mask(vk::AccessFlags::HOST_READ)];
            d.cmd_pipeline_barrier(
                sub.cmd,
                vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::PipelineStageFlags::HOST,
                vk::DependencyFlags::empty(),
                &barrier,
                &[],
                &[],
            );
            d.end_command_buffer(sub.cmd)
                .map_err(|e| GpuError::Vulkan("vkEndCommandBuffer", e))?;
            let cmds = [sub.cmd];
            let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
            d.reset_fences(&[sub.fence])
                .map_err(|e| GpuError::Vulkan("vkResetFences", e))?;
            d.queue_submit(self.owner.queue, &submit, sub.fence)
                .map_err(|e| lost_or(e, entry, "vkQueueSubmit"))?;
            d.wait_for_fences(&[sub.fence], true, u64::MAX)
                .map_err(|e| lost_or(e, entry, "vkWaitForFences"))?;
            if let Some(q) = sub.timestamps {
                let mut ticks = [0u64; 2];
                let read =
                    d.get_query_pool_results(q, 0, &mut ticks, vk::QueryResultFlags::TYPE_64);
                if read.is_ok() {
                    let bits = self.owner.timestamp_bits;
                    let mask = if bits >= 64 {
                        u64::MAX
                    } else {
                        (1u64 << bits) - 1
                    };
                    let delta = ticks[1].wrapping_sub(ticks[0]) & mask;
                    let period = f64::from(self.owner.limits.timestamp_period);
                    let ns = (delta as f64 * period) as u64;
                    self.kernel_ns
                        .fetch_add(ns, std::sync::atomic::Ordering::Relaxed);
                }
            }
        }
        for (b, f) in bindings.iter_mut().zip(&fresh) {
            if let (Binding::Output(out), Some(f)) = (b, f) {
                f.read(out);
            }
        }
        Ok(())
    }
}

/// One storage-buffer binding of a dispatch.
pub enum Binding<'a> {
    /// Copied into a fresh buffer before the dispatch.
    Input(&'a [u8]),
    /// A buffer made by [`Gpu::upload`] or [`Gpu::buffer`], reused across dispatches.
    Resident(&'a Buffer),
    /// A fresh buffer copied back into the slice after the dispatch.
    Output(&'a mut [u8]),
}

fn lost_or(e: vk::Result, entry: &str, call: &'static str) -> GpuError {
    if e == vk::Result::ERROR_DEVICE_LOST {
        GpuError::DeviceLost(entry.to_string())
    } else {
        GpuError::Vulkan(call, e)
    }
}

/// Entry-point names in the embedded module (from its OpEntryPoint instructions).
pub fn kernel_names() -> impl Iterator<Item = String> {
    let words: Vec<u32> = KERNELS_SPV
        .as_chunks::<4>()
        .0
        .iter()
        .map(|c| u32::from_le_bytes(*c))
        .collect();
    let mut names = Vec::new();
    let mut i = 5;
    while i < words.len() {
        let len = (words[i] >> 16) as usize;
        let op = words[i] & 0xffff;
        if len == 0 {
            break;
        }
        // OpEntryPoint = 15: execution model, function id, then the name as a literal string.
        if op == 15 && i + 3 < words.len() {
            let bytes: Vec<u8> = words[i + 3..(i + len).min(words.len())]
                .iter()
                .flat_map(|w| w.to_le_bytes())
                .take_while(|&b| b != 0)
                .collect();
            names.push(String::from_utf8_lossy(&bytes).into_owned());
        }
        i += len;
    }
    names.into_iter()
}

impl Drop for Gpu {
    fn drop(&mut self) {
        // SAFETY: dispatches wait for their fences, so the module is no longer in use.
        unsafe {
            let _ = self.owner.device.device_wait_idle();
            self.owner.device.destroy_shader_module(self.module, None);
        }
    }
}
