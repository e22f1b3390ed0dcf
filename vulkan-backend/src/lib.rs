//! The ash (Vulkan) backend. Work is described as a [`Work`] (uploads, steps, readbacks), planned
//! into dispatches ([`plan`]), recorded into one command buffer and submitted once.
//!
//! Kernels follow one convention: push constants are one `shared` struct starting with
//! [`Launch`]; storage buffers are bound at set 0 in the order of `shared::kernels::launch::bindings`.
//! Storage buffers are device-local; uploads and readbacks go through a staging buffer.

mod device;
mod error;
mod kernels;
pub mod module_stats;
mod pipelines;
mod plan;
pub mod present;
mod resources;
/// The kernels' source hash, as build.rs computes it (a test compares the build's choice).
#[cfg(test)]
#[path = "../build/source_hash.rs"]
#[allow(dead_code)]
mod source_hash;

pub use device::{pick_memory_type, DeviceOwner, Display, MemoryChoice, MemoryRole};
pub use error::GpuError;
pub use kernels::{
    Kernel, KernelDef, LitBuffers, MapBuffers, MsmBuildBuffers, MsmStoreBuffers, PushConstants,
    RenderBuffers, DIRECT, EQUIANGULAR, MATH_VALUES, MSM_BUILD, MSM_LOOKUP, MSM_STORE, PATH, PHASE,
    RESTIR_CANDIDATE, RESTIR_QUERY, RESTIR_RESOLVE, RESTIR_REUSE, RESTIR_START, RNG_DRAWS,
    SCATTERING, TRANSMITTANCE, TRANSMITTANCE_PAIR,
};
pub use pipelines::BuildTime;
use pipelines::Pipelines;
pub use plan::{plan, Command, Step};
pub use resources::Buffer;
use resources::{Pipeline, Staging, Submitter};

use ash::vk;
use std::sync::{Arc, Mutex};

/// A Vulkan device with each kernel's pipeline built on first use from its own module.
pub struct Gpu {
    owner: Arc<DeviceOwner>,
    /// Pipelines by kernel and specialization-constant values.
    pipelines: Pipelines,
    submitter: Mutex<Submitter>,
    /// Kernel time measured by timestamp queries since the last [`Gpu::take_kernel_ns`].
    kernel_ns: std::sync::atomic::AtomicU64,
}

/// A dispatch's kernel and specialization-constant values, from its push constants.
pub type PipelineOf<'a, P, const N: usize> = dyn Fn(&P) -> (&'a KernelDef<P, N>, Vec<u32>) + 'a;

/// GPU work submitted at once: uploads, then the kernel's steps, then readbacks.
pub struct Work<'a, P, const N: usize> {
    /// The pipeline of each dispatch, from its push constants: its kernel (all of one push-constant
    /// type and binding layout: one kernel, or one per stage kind of a wavefront, `restir_*_cs`)
    /// and the values of that kernel's specialization constants by id (empty: the module's
    /// defaults). Each distinct pair is its own pipeline, built on first use.
    pub pipeline: &'a PipelineOf<'a, P, N>,
    /// The storage buffers in binding order (see [`RenderBuffers::slots`]).
    pub buffers: [&'a Buffer; N],
    /// Host bytes copied into device buffers before the first dispatch.
    pub uploads: Vec<(&'a Buffer, &'a [u8])>,
    /// Dispatches and barriers, in order.
    pub steps: Vec<Step<P>>,
    /// Device buffers copied into host slices after the last dispatch.
    pub readbacks: Vec<(&'a Buffer, &'a mut [u8])>,
}

/// The kernel part of a submission after planning, with Pod pushes as bytes.
struct Recording {
    /// The kernels it runs, for messages (`restir_start_cs, restir_candidate_cs`).
    name: String,
    /// The pipelines of the dispatches (identical layouts).
    pipelines: Vec<Arc<Pipeline>>,
    /// Per binding: the buffer, its size, and its texel view where the binding is a texel
    /// buffer.
    buffers: Vec<(vk::Buffer, u64, Option<vk::BufferView>)>,
    /// Each command with the index of its pipeline (dispatches only).
    commands: Vec<(Command<Vec<u8>>, usize)>,
}

impl Gpu {
    /// Opens the preferred Vulkan device.
    pub fn new() -> Result<Self, GpuError> {
        Self::from_owner(Arc::new(DeviceOwner::new()?))
    }

    /// The device of `owner`, with no pipeline built yet.
    fn from_owner(owner: Arc<DeviceOwner>) -> Result<Self, GpuError> {
        let submitter = Submitter::new(&owner)?;
        Ok(Gpu {
            owner,
            pipelines: Pipelines::new(),
            submitter: Mutex::new(submitter),
            kernel_ns: std::sync::atomic::AtomicU64::new(0),
        })
    }

    /// Device name, type and Vulkan version.
    pub fn description(&self) -> &str {
        self.owner.description()
    }

    /// Whether the device is a software implementation on the host's CPU (lavapipe).
    pub fn is_software(&self) -> bool {
        self.owner.is_software()
    }

    /// The pipeline builds of this device so far: a render's first use of a kernel variant
    /// compiles it (lavapipe: seconds to minutes), which timed renders report apart.
    pub fn pipeline_builds(&self) -> BuildTime {
        self.pipelines.build_time()
    }

    /// A device-local storage buffer holding `data`, kept on the device across submissions.
    pub fn upload(&self, data: &[u8]) -> Result<Buffer, GpuError> {
        let b = self.buffer(data.len() as u64)?;
        self.submit_raw(&[(&b, data)], None, &mut [])?;
        Ok(b)
    }

    /// Copies the first `out.len()` bytes of `buffer` into `out`.
    pub fn read(&self, buffer: &Buffer, out: &mut [u8]) -> Result<(), GpuError> {
        self.submit_raw(&[], None, &mut [(buffer, out)])
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

    /// The largest storage buffer in bytes: the device's maxStorageBufferRange (or its
    /// maxMemoryAllocationSize if smaller), or less if the environment variable
    /// `JK_GPU_MAX_BUFFER_BYTES` says so (to exercise tiling in tests).
    pub fn max_buffer_bytes(&self) -> u64 {
        let range = u64::from(self.owner.limits.max_storage_buffer_range);
        let device = match self.owner.max_allocation {
            0 => range,
            a => range.min(a),
        };
        // Checked before any work (`host::cli::run`); an invalid value is refused there.
        let forced = forced_max_buffer_bytes().ok().flatten();
        forced.map_or(device, |f| f.clamp(64, device))
    }

    /// The most 32-bit words a uniform texel buffer may hold: maxTexelBufferElements.
    pub fn max_texel_words(&self) -> u64 {
        u64::from(self.owner.limits.max_texel_buffer_elements)
    }

    /// Bytes of the largest device-local memory heap (what the volume's buffers must fit).
    pub fn device_local_bytes(&self) -> u64 {
        let m = &self.owner.memory;
        m.memory_heaps[..m.memory_heap_count as usize]
            .iter()
            .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|h| h.size)
            .max()
            .unwrap_or(0)
    }

    /// An uninitialised device-local storage buffer of `size` bytes (checked against the limit).
    pub fn buffer(&self, size: u64) -> Result<Buffer, GpuError> {
        let limit = self.max_buffer_bytes();
        if size > limit {
            return Err(GpuError::TooLarge { size, limit });
        }
        Buffer::new(&self.owner, size)
    }

    /// Most workgroups one dispatch may have: the device's limit, at most 65,535.
    fn max_groups(&self) -> u32 {
        self.owner.limits.max_compute_work_group_count[0].min(65_535)
    }

    /// Plans, records and submits `work` as one command buffer and waits for it.
    pub fn submit<P: PushConstants, const N: usize>(
        &self,
        work: Work<'_, P, N>,
    ) -> Result<(), GpuError> {
        let mut keys: Vec<(Kernel, Vec<u32>)> = Vec::new();
        let mut commands = Vec::new();
        for c in plan(work.steps, self.max_groups(), self.owner.interleave()) {
            commands.push(match c {
                Command::Dispatch { push, groups } => {
                    let (def, spec) = (work.pipeline)(&push);
                    let key = (def.kernel, spec);
                    let index = match keys.iter().position(|k| *k == key) {
                        Some(i) => i,
                        None => {
                            keys.push(key);
                            keys.len() - 1
                        }
                    };
                    let push = bytemuck::bytes_of(&push).to_vec();
                    (Command::Dispatch { push, groups }, index)
                }
                Command::Barrier => (Command::Barrier, 0),
            });
        }
        let mut readbacks = work.readbacks;
        if keys.is_empty() {
            // Nothing to dispatch: the uploads and readbacks only.
            return self.submit_raw(&work.uploads, None, &mut readbacks);
        }
        let pipelines = self.pipelines.get_all(&self.owner, &keys)?;
        let texel_buffers = pipelines[0].texel_buffers;
        let buffers = work
            .buffers
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let view = (texel_buffers >> i & 1 == 1)
                    .then(|| b.texel_view())
                    .transpose()?;
                Ok((b.buffer, b.size, view))
            })
            .collect::<Result<_, GpuError>>()?;
        let mut names: Vec<&str> = Vec::new();
        for (k, _) in &keys {
            if !names.contains(&k.name()) {
                names.push(k.name());
            }
        }
        let recording = Recording {
            name: names.join(", "),
            pipelines,
            buffers,
            commands,
        };
        self.submit_raw(&work.uploads, Some(&recording), &mut readbacks)
    }

    /// Records uploads, the kernel's commands and readbacks into the command buffer, submits it
    /// once and waits; then copies the readbacks out of the staging buffer.
    fn submit_raw(
        &self,
        uploads: &[(&Buffer, &[u8])],
        recording: Option<&Recording>,
        readbacks: &mut [(&Buffer, &mut [u8])],
    ) -> Result<(), GpuError> {
        for (b, data) in uploads {
            check_fits(b, data.len(), "upload")?;
        }
        for (b, out) in readbacks.iter() {
            check_fits(b, out.len(), "readback")?;
        }
        let staged: u64 = uploads.iter().map(|(_, d)| d.len() as u64).sum::<u64>()
            + readbacks.iter().map(|(_, o)| o.len() as u64).sum::<u64>();
        let what = recording.map_or("a transfer", |r| r.name.as_str());
        let mut sub = self
            .submitter
            .lock()
            .map_err(|_| GpuError::Internal("poisoned".into()))?;
        let staging = self.staging(&mut sub, staged)?;
        let mut offset = 0;
        for (_, data) in uploads {
            staging.write(offset, data);
            offset += data.len() as u64;
        }
        let staging = staging.buffer();
        // SAFETY: all handles are alive; the command buffer is re-recorded only after the
        // previous submission's fence was waited for (the submitter lock serializes this).
        unsafe {
            self.record(&sub, staging, uploads, recording, readbacks)?;
            self.run_and_wait(&sub, what)?;
            if recording.is_some() {
                self.add_kernel_time(&sub);
            }
        }
        let staging = sub.staging.as_ref().expect("allocated above");
        for (_, out) in readbacks.iter_mut() {
            staging.read(offset, out);
            offset += out.len() as u64;
        }
        Ok(())
    }

    /// The submitter's staging buffer, grown to at least `size` bytes.
    fn staging<'s>(&self, sub: &'s mut Submitter, size: u64) -> Result<&'s mut Staging, GpuError> {
        if sub.staging.as_ref().is_none_or(|s| s.size() < size) {
            sub.staging = None;
            sub.staging = Some(Staging::new(&self.owner, size)?);
        }
        Ok(sub.staging.as_mut().expect("just allocated"))
    }

    /// Records one submission: staging -> device copies, the kernel's dispatches and barriers
    /// between timestamps, device -> staging copies.
    ///
    /// # Safety
    /// The submitter's previous submission has completed; every buffer is alive.
    unsafe fn record(
        &self,
        sub: &Submitter,
        staging: vk::Buffer,
        uploads: &[(&Buffer, &[u8])],
        recording: Option<&Recording>,
        readbacks: &[(&Buffer, &mut [u8])],
    ) -> Result<(), GpuError> {
        use vk::{AccessFlags as A, PipelineStageFlags as S};
        let d = &self.owner.device;
        d.reset_command_buffer(sub.cmd, vk::CommandBufferResetFlags::empty())
            .map_err(|e| GpuError::Vulkan("vkResetCommandBuffer", e))?;
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        d.begin_command_buffer(sub.cmd, &begin)
            .map_err(|e| GpuError::Vulkan("vkBeginCommandBuffer", e))?;
        // Earlier submissions' shader and transfer writes before this one's accesses.
        let work = S::COMPUTE_SHADER | S::TRANSFER;
        let writes = A::SHADER_WRITE | A::TRANSFER_WRITE;
        let all = writes | A::SHADER_READ | A::TRANSFER_READ;
        self.barrier(sub.cmd, work, writes, work, all);
        let mut offset = 0;
        for (b, data) in uploads {
            let region = [vk::BufferCopy::default()
                .src_offset(offset)
                .size(data.len() as u64)];
            if !data.is_empty() {
                d.cmd_copy_buffer(sub.cmd, staging, b.buffer, &region);
            }
            offset += data.len() as u64;
        }
        self.barrier(
            sub.cmd,
            S::TRANSFER,
            A::TRANSFER_WRITE,
            S::COMPUTE_SHADER,
            A::SHADER_READ | A::SHADER_WRITE,
        );
        if let Some(r) = recording {
            self.record_dispatches(sub, r)?;
        }
        self.barrier(
            sub.cmd,
            S::COMPUTE_SHADER,
            A::SHADER_WRITE,
            S::TRANSFER,
            A::TRANSFER_READ,
        );
        for (b, out) in readbacks {
            let region = [vk::BufferCopy::default()
                .dst_offset(offset)
                .size(out.len() as u64)];
            if !out.is_empty() {
                d.cmd_copy_buffer(sub.cmd, b.buffer, staging, &region);
            }
            offset += out.len() as u64;
        }
        self.barrier(
            sub.cmd,
            S::TRANSFER,
            A::TRANSFER_WRITE,
            S::HOST,
            A::HOST_READ,
        );
        d.end_command_buffer(sub.cmd)
            .map_err(|e| GpuError::Vulkan("vkEndCommandBuffer", e))
    }

    /// Records one global memory barrier.
    ///
    /// # Safety
    /// `cmd` is recording.
    unsafe fn barrier(
        &self,
        cmd: vk::CommandBuffer,
        src: vk::PipelineStageFlags,
        src_access: vk::AccessFlags,
        dst: vk::PipelineStageFlags,
        dst_access: vk::AccessFlags,
    ) {
        let barrier = [vk::MemoryBarrier::default()
            .src_access_mask(src_access)
            .dst_access_mask(dst_access)];
        self.owner.device.cmd_pipeline_barrier(
            cmd,
            src,
            dst,
            vk::DependencyFlags::empty(),
            &barrier,
            &[],
            &[],
        );
    }

    /// Records the descriptor set, pipeline, dispatches and barriers of `r` between timestamps.
    ///
    /// # Safety
    /// As [`Gpu::record`]; the command buffer is recording.
    unsafe fn record_dispatches(&self, sub: &Submitter, r: &Recording) -> Result<(), GpuError> {
        use vk::{AccessFlags as A, PipelineStageFlags as S};
        let d = &self.owner.device;
        let set = self.descriptor_set(sub, r)?;
        if let Some(q) = sub.timestamps {
            d.cmd_reset_query_pool(sub.cmd, q, 0, 2);
            d.cmd_write_timestamp(sub.cmd, S::TOP_OF_PIPE, q, 0);
        }
        // The pipelines' layouts are identically defined (one push type and binding count), so the set stays valid
        // across them; it is bound again with each pipeline all the same.
        let mut bound = None;
        for (c, index) in &r.commands {
            match c {
                Command::Dispatch { push, groups } => {
                    let p = &r.pipelines[*index];
                    if bound != Some(*index) {
                        d.cmd_bind_pipeline(sub.cmd, vk::PipelineBindPoint::COMPUTE, p.pipeline);
                        d.cmd_bind_descriptor_sets(
                            sub.cmd,
                            vk::PipelineBindPoint::COMPUTE,
                            p.layout,
                            0,
                            &[set],
                            &[],
                        );
                        bound = Some(*index);
                    }
                    let layout = p.layout;
                    d.cmd_push_constants(sub.cmd, layout, vk::ShaderStageFlags::COMPUTE, 0, push);
                    d.cmd_dispatch(sub.cmd, *groups, 1, 1);
                }
                Command::Barrier => self.barrier(
                    sub.cmd,
                    S::COMPUTE_SHADER,
                    A::SHADER_WRITE,
                    S::COMPUTE_SHADER,
                    A::SHADER_READ | A::SHADER_WRITE,
                ),
            }
        }
        if let Some(q) = sub.timestamps {
            d.cmd_write_timestamp(sub.cmd, S::BOTTOM_OF_PIPE, q, 1);
        }
        Ok(())
    }

    /// A descriptor set binding `r`'s buffers (the pool holds one set per submission).
    ///
    /// # Safety
    /// As [`Gpu::record`].
    unsafe fn descriptor_set(
        &self,
        sub: &Submitter,
        r: &Recording,
    ) -> Result<vk::DescriptorSet, GpuError> {
        let d = &self.owner.device;
        d.reset_descriptor_pool(sub.descriptors, vk::DescriptorPoolResetFlags::empty())
            .map_err(|e| GpuError::Vulkan("vkResetDescriptorPool", e))?;
        let layouts = [r.pipelines[0].set_layout];
        let alloc = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(sub.descriptors)
            .set_layouts(&layouts);
        let set = d
            .allocate_descriptor_sets(&alloc)
            .map_err(|e| GpuError::Vulkan("vkAllocateDescriptorSets", e))?[0];
        let infos: Vec<[vk::DescriptorBufferInfo; 1]> = r
            .buffers
            .iter()
            .map(|&(buffer, size, _)| {
                [vk::DescriptorBufferInfo::default()
                    .buffer(buffer)
                    .offset(0)
                    .range(size)]
            })
            .collect();
        let views: Vec<[vk::BufferView; 1]> = r
            .buffers
            .iter()
            .map(|&(_, _, view)| [view.unwrap_or_default()])
            .collect();
        let (uniforms, texel_buffers) = (r.pipelines[0].uniforms, r.pipelines[0].texel_buffers);
        let writes: Vec<_> = infos
            .iter()
            .zip(&views)
            .enumerate()
            .map(|(i, (info, view))| {
                let ty = resources::descriptor_type(uniforms, texel_buffers, i as u32);
                let w = vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(i as u32)
                    .descriptor_type(ty);
                if ty == vk::DescriptorType::UNIFORM_TEXEL_BUFFER {
                    w.texel_buffer_view(view)
                } else {
                    w.buffer_info(info)
                }
            })
            .collect();
        d.update_descriptor_sets(&writes, &[]);
        Ok(set)
    }

    /// Submits the recorded command buffer and waits for its fence.
    ///
    /// # Safety
    /// The command buffer was recorded by [`Gpu::record`].
    unsafe fn run_and_wait(&self, sub: &Submitter, what: &str) -> Result<(), GpuError> {
        let d = &self.owner.device;
        let cmds = [sub.cmd];
        let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
        d.reset_fences(&[sub.fence])
            .map_err(|e| GpuError::Vulkan("vkResetFences", e))?;
        d.queue_submit(self.owner.queue, &submit, sub.fence)
            .map_err(|e| lost_or(e, what, "vkQueueSubmit"))?;
        d.wait_for_fences(&[sub.fence], true, u64::MAX)
            .map_err(|e| lost_or(e, what, "vkWaitForFences"))
    }

    /// Adds the last submission's timestamp difference to the kernel time.
    ///
    /// # Safety
    /// The submission has completed.
    unsafe fn add_kernel_time(&self, sub: &Submitter) {
        let Some(q) = sub.timestamps else {
            return;
        };
        let mut ticks = [0u64; 2];
        let read = self.owner.device.get_query_pool_results(
            q,
            0,
            &mut ticks,
            vk::QueryResultFlags::TYPE_64,
        );
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

/// An error unless `len` bytes fit in `b`.
fn check_fits(b: &Buffer, len: usize, what: &str) -> Result<(), GpuError> {
    if len as u64 > b.size {
        return Err(GpuError::Internal(format!(
            "{what} of {len} bytes into a {}-byte buffer",
            b.size
        )));
    }
    Ok(())
}

fn lost_or(e: vk::Result, what: &str, call: &'static str) -> GpuError {
    if e == vk::Result::ERROR_DEVICE_LOST {
        GpuError::DeviceLost(what.to_string())
    } else {
        GpuError::Vulkan(call, e)
    }
}

impl Drop for Gpu {
    fn drop(&mut self) {
        // SAFETY: submissions wait for their fences; nothing is in use after this wait.
        unsafe {
            let _ = self.owner.device.device_wait_idle();
        }
    }
}

/// `JK_GPU_MAX_BUFFER_BYTES` (lowers the largest GPU buffer, to exercise tiling and paging in
/// tests): unset, or a whole number of bytes; anything else is an error naming it.
pub fn forced_max_buffer_bytes() -> anyhow::Result<Option<u64>> {
    match std::env::var("JK_GPU_MAX_BUFFER_BYTES") {
        Err(std::env::VarError::NotPresent) => Ok(None),
        Err(e) => {
            anyhow::bail!("JK_GPU_MAX_BUFFER_BYTES: {e}; unset it or give a whole number of bytes")
        }
        Ok(v) => match v.trim().parse::<u64>() {
            Ok(n) => Ok(Some(n)),
            Err(_) => anyhow::bail!(
                "JK_GPU_MAX_BUFFER_BYTES={v:?} is not a whole number of bytes (it lowers the \
                 largest GPU buffer, for tests); unset it or give a number such as 4096"
            ),
        },
    }
}
