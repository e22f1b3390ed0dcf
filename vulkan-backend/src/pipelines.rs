//! The pipelines of a device by kernel and specialization: each built once, on first use, by the
//! thread that first needs it; distinct pipelines build in parallel, at most
//! [`PARALLEL_BUILDS`] at once.
//!
//! A driver compiles one pipeline on one core, and lavapipe takes up to minutes and gigabytes
//! for one of our wavefront stages (docs/design/kernel-build.md): a submission that needs several new
//! pipelines (one per `restir` stage kind) builds them side by side, and a thread that needs a
//! built pipeline never waits for another's build.

use super::device::{DeviceOwner, MAX_BINDINGS};
use super::error::GpuError;
use super::kernels::Kernel;
use super::resources::{KernelLayout, Pipeline};
use ash::vk;
use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// Most pipelines one device builds at once: lavapipe needs up to 3.4 GB for one `restir` stage
/// (measured, docs/design/kernel-build.md), so more would risk a small machine's memory for little gain on few cores.
pub const PARALLEL_BUILDS: usize = 2;

/// What building (or finding) one pipeline gave.
type Built = Result<Arc<Pipeline>, GpuError>;

/// One pipeline's slot: empty until its first build succeeds.
type Slot = Arc<Mutex<Option<Arc<Pipeline>>>>;

/// The pipelines of one device.
pub struct Pipelines {
    slots: Mutex<HashMap<(Kernel, Vec<u32>), Slot>>,
    /// Builds in flight (at most [`PARALLEL_BUILDS`]) and what they took, with the condition
    /// variable a waiting build sleeps on.
    building: (Mutex<Building>, Condvar),
}

/// The builds of one device: in flight, and done so far.
#[derive(Default)]
struct Building {
    /// Builds in flight.
    active: usize,
    /// When the current stretch of builds (some build in flight) began.
    since: Option<Instant>,
    /// Builds done.
    done: u64,
    /// Wall time with at least one build in flight (parallel builds counted once).
    wall: Duration,
}

/// Pipeline builds of a device so far: how many, and the wall time they took (overlapping
/// builds counted once), which a timed render subtracts from its own.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BuildTime {
    pub count: u64,
    pub wall: Duration,
}

impl BuildTime {
    /// The wall time in milliseconds.
    pub fn ms(self) -> f64 {
        self.wall.as_secs_f64() * 1e3
    }

    /// The builds since `before`, an earlier reading of the same device.
    pub fn since(self, before: BuildTime) -> BuildTime {
        BuildTime {
            count: self.count - before.count,
            wall: self.wall.saturating_sub(before.wall),
        }
    }
}

/// Holds one of the [`PARALLEL_BUILDS`] build permits until dropped.
struct Permit<'a>(&'a (Mutex<Building>, Condvar));

impl Drop for Permit<'_> {
    fn drop(&mut self) {
        let (state, freed) = self.0;
        if let Ok(mut b) = state.lock() {
            b.active -= 1;
            b.done += 1;
            if b.active == 0 {
                if let Some(since) = b.since.take() {
                    b.wall += since.elapsed();
                }
            }
        }
        freed.notify_one();
    }
}

fn poisoned<T>(_: T) -> GpuError {
    GpuError::Internal("a thread panicked while building a pipeline".into())
}

impl Pipelines {
    pub fn new() -> Self {
        Pipelines {
            slots: Mutex::new(HashMap::new()),
            building: (Mutex::new(Building::default()), Condvar::new()),
        }
    }

    /// The builds done so far and the wall time they took.
    pub fn build_time(&self) -> BuildTime {
        let b = self.building.0.lock().unwrap_or_else(|e| e.into_inner());
        BuildTime {
            count: b.done,
            wall: b.wall,
        }
    }

    /// Waits for one of the build permits.
    fn permit(&self) -> Result<Permit<'_>, GpuError> {
        let (state, freed) = &self.building;
        let mut b = state.lock().map_err(poisoned)?;
        while b.active >= PARALLEL_BUILDS {
            b = freed.wait(b).map_err(poisoned)?;
        }
        if b.active == 0 {
            b.since = Some(Instant::now());
        }
        b.active += 1;
        Ok(Permit(&self.building))
    }

    /// The pipeline of `kernel` with its specialization constants `spec` (by id), built on first
    /// use from the layout the module declares.
    pub fn get(
        &self,
        owner: &Arc<DeviceOwner>,
        kernel: Kernel,
        spec: &[u32],
    ) -> Result<Arc<Pipeline>, GpuError> {
        let slot = {
            let mut slots = self.slots.lock().map_err(poisoned)?;
            slots.entry((kernel, spec.to_vec())).or_default().clone()
        };
        let mut built = slot.lock().map_err(poisoned)?;
        if let Some(p) = built.as_ref() {
            return Ok(p.clone());
        }
        let _permit = self.permit()?;
        let p = Arc::new(build(owner, kernel, spec)?);
        *built = Some(p.clone());
        Ok(p)
    }

    /// The pipeline of each (kernel, specialization) of `keys`, the missing ones built on up to
    /// [`PARALLEL_BUILDS`] threads.
    pub fn get_all(
        &self,
        owner: &Arc<DeviceOwner>,
        keys: &[(Kernel, Vec<u32>)],
    ) -> Result<Vec<Arc<Pipeline>>, GpuError> {
        let threads = PARALLEL_BUILDS.min(keys.len());
        if threads <= 1 {
            return keys.iter().map(|(k, s)| self.get(owner, *k, s)).collect();
        }
        let next = AtomicUsize::new(0);
        let results: Vec<Mutex<Option<Built>>> = keys.iter().map(|_| Mutex::new(None)).collect();
        std::thread::scope(|scope| {
            for _ in 0..threads {
                scope.spawn(|| loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some((kernel, spec)) = keys.get(i) else {
                        break;
                    };
                    let r = self.get(owner, *kernel, spec);
                    if let Ok(mut slot) = results[i].lock() {
                        *slot = Some(r);
                    }
                });
            }
        });
        results
            .into_iter()
            .map(|r| {
                r.into_inner()
                    .map_err(poisoned)?
                    .unwrap_or_else(|| Err(poisoned(())))
            })
            .collect()
    }
}

/// Builds the pipeline of `kernel` with specialization `spec` from its embedded module.
fn build(owner: &Arc<DeviceOwner>, kernel: Kernel, spec: &[u32]) -> Result<Pipeline, GpuError> {
    let bindings = kernel.strides().len() as u32;
    if bindings > MAX_BINDINGS {
        return Err(GpuError::Internal(format!(
            "{} binds {bindings} buffers, more than {MAX_BINDINGS}",
            kernel.name()
        )));
    }
    let words = ash::util::read_spv(&mut std::io::Cursor::new(kernel.spirv())).map_err(|e| {
        GpuError::Internal(format!(
            "embedded SPIR-V of {} is malformed: {e}",
            kernel.name()
        ))
    })?;
    let info = vk::ShaderModuleCreateInfo::default().code(&words);
    // SAFETY: valid SPIR-V produced by rust-gpu and validated by build.rs; destroyed below, after
    // the pipeline is built (Vulkan allows it).
    let module = unsafe { owner.device.create_shader_module(&info, None) }
        .map_err(|e| GpuError::Vulkan("vkCreateShaderModule", e))?;
    let start = std::time::Instant::now();
    let layout = KernelLayout {
        entry: kernel.c_name(),
        bindings,
        uniforms: kernel.uniforms(),
        texel_buffers: kernel.texel_buffers(),
        push_size: kernel.push_size(),
    };
    let p = Pipeline::new(owner, module, &layout, spec);
    // SAFETY: no pipeline creation with this module is in flight; the pipeline does not need it.
    unsafe { owner.device.destroy_shader_module(module, None) };
    tracing::debug!(
        "built the pipeline of {} with specialization {spec:?} in {:.1} s",
        kernel.name(),
        start.elapsed().as_secs_f64()
    );
    p
}
