//! Backend selection and the operations every backend runs identically.

use crate::cpu;
use crate::gpu::{self, Gpu, GpuError, KernelDef, MapBuffers, Step, Work};
use anyhow::{Context, Result};
use bytemuck::{Pod, Zeroable};
use shared::kernels::launch::Launch;
use shared::kernels::probe::{self, DepthPair, MathValues, RngDraws, TransmittancePair};
use std::sync::Arc;

/// Which backend the user asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackendChoice {
    /// The Vulkan GPU if a driver is present, else the CPU (with a warning).
    Auto,
    /// The Vulkan GPU; fail if there is none.
    Gpu,
    /// The CPU on all cores.
    Cpu,
}

/// A backend ready to run kernels.
pub enum Backend {
    Cpu,
    /// Shared so that callers (tests, studies) can reuse one device and its built pipelines.
    Gpu(Arc<Gpu>),
}

impl Backend {
    /// Opens the chosen backend. `Auto` falls back to the CPU with a one-line warning.
    pub fn open(choice: BackendChoice) -> Result<Self> {
        match choice {
            BackendChoice::Cpu => Ok(Backend::Cpu),
            BackendChoice::Gpu => Ok(Backend::Gpu(Arc::new(
                Gpu::new().context("--backend gpu: cannot use the Vulkan GPU backend")?,
            ))),
            BackendChoice::Auto => match Gpu::new() {
                Ok(g) => Ok(Backend::Gpu(Arc::new(g))),
                Err(e) => {
                    tracing::warn!(
                        "no usable Vulkan device ({e}); falling back to the CPU backend"
                    );
                    Ok(Backend::Cpu)
                }
            },
        }
    }

    /// log2 of the words per page of the voxel pool this backend binds (see
    /// [`crate::bricks::pack_paged`]): the GPU's largest page; the CPU reads the pool as one
    /// page whatever its layout and keeps the layout every device binds.
    pub fn page_log2(&self) -> u32 {
        match self {
            Backend::Cpu => shared::volume::pages::GPU_PAGE_LOG2,
            Backend::Gpu(g) => g.page_log2(),
        }
    }

    /// This backend, opened for `choice`, for rendering `volume` (packed with
    /// [`Backend::page_log2`]): a volume the GPU cannot hold (a page or the brick array above
    /// its largest storage buffer, more pages than the kernels bind, or more bytes than its
    /// device-local memory) makes `auto` fall back to the CPU with a warning and a forced
    /// `--backend gpu` fail with advice.
    pub fn fit(self, choice: BackendChoice, volume: &crate::bricks::PackedVolume) -> Result<Self> {
        let Some(why) = self.cannot_hold(volume) else {
            return Ok(self);
        };
        if choice == BackendChoice::Gpu {
            anyhow::bail!(
                "--backend gpu: {why}; use --backend cpu, or a smaller volume (--resolution for \
                 embedded volumes; crop or resample a file)"
            );
        }
        tracing::warn!("{why}; falling back to the CPU backend");
        Ok(Backend::Cpu)
    }

    /// Why this backend cannot hold `volume` (a GPU whose largest storage buffer is smaller
    /// than a page of the voxel pool or the brick array, or whose device-local memory is
    /// smaller than both), or `None` if it can.
    pub fn cannot_hold(&self, volume: &crate::bricks::PackedVolume) -> Option<String> {
        let Backend::Gpu(gpu) = self else {
            return None;
        };
        let limit = gpu.max_buffer_bytes();
        let d = volume.desc.dims;
        if let Some(why) = crate::bricks::too_many_pages(volume) {
            return Some(why);
        }
        let largest = volume
            .pages()
            .map(|p| std::mem::size_of_val(p) as u64)
            .max()
            .unwrap_or(0)
            .max(std::mem::size_of_val(volume.bricks.as_slice()) as u64);
        if largest > limit {
            return Some(format!(
                "the {}x{}x{} volume needs a {largest}-byte storage buffer, more than this GPU's \
                 maxStorageBufferRange of {limit} bytes ({})",
                d[0],
                d[1],
                d[2],
                gpu.description()
            ));
        }
        let total = std::mem::size_of_val(volume.voxels.as_slice()) as u64
            + std::mem::size_of_val(volume.bricks.as_slice()) as u64;
        let memory = gpu.device_local_bytes();
        (memory > 0 && total > memory).then(|| {
            format!(
                "the {}x{}x{} volume's voxel pool and brick table need {:.2} GiB, more than this \
                 GPU's {:.2} GiB of device-local memory ({})",
                d[0],
                d[1],
                d[2],
                total as f64 / f64::from(1 << 30),
                memory as f64 / f64::from(1 << 30),
                gpu.description()
            )
        })
    }

    /// The GPU pipeline builds so far (none on the CPU), for [`Backend::timed`].
    fn pipeline_builds(&self) -> gpu::BuildTime {
        match self {
            Backend::Cpu => gpu::BuildTime::default(),
            Backend::Gpu(g) => g.pipeline_builds(),
        }
    }

    /// Runs `render` and returns its result, its wall time in ms without the GPU pipeline
    /// builds it waited for (each kernel variant compiles on first use), and those builds.
    pub fn timed<T>(&self, render: impl FnOnce() -> Result<T>) -> Result<(T, f64, gpu::BuildTime)> {
        let before = self.pipeline_builds();
        let start = std::time::Instant::now();
        let out = render()?;
        let wall = start.elapsed();
        let built = self.pipeline_builds().since(before);
        let ms = wall.saturating_sub(built.wall).as_secs_f64() * 1e3;
        Ok((out, ms, built))
    }

    /// "cpu" or "gpu".
    pub fn kind(&self) -> &'static str {
        match self {
            Backend::Cpu => "cpu",
            Backend::Gpu(_) => "gpu",
        }
    }

    /// What runs the kernels, e.g. "llvmpipe (LLVM 15.0.6, 256 bits) [CPU (software), Vulkan 1.3.230]".
    pub fn device(&self) -> String {
        match self {
            Backend::Cpu => format!("CPU, {} threads (rayon)", rayon::current_num_threads()),
            Backend::Gpu(g) => g.description().to_string(),
        }
    }

    /// Jackknife (Eq. 4) and naive transmittance for each (X0, X1) pair.
    pub fn transmittance_pairs(&self, input: &[DepthPair]) -> Result<Vec<TransmittancePair>> {
        match self {
            Backend::Cpu => Ok(cpu::map(input, probe::transmittance_pair)),
            Backend::Gpu(g) => map_on_gpu(g, &gpu::TRANSMITTANCE_PAIR, input),
        }
    }

    /// exp, ln, sin, cos of each input.
    pub fn math_values(&self, input: &[f32]) -> Result<Vec<MathValues>> {
        match self {
            Backend::Cpu => Ok(cpu::map(input, probe::math_values)),
            Backend::Gpu(g) => map_on_gpu(g, &gpu::MATH_VALUES, input),
        }
    }

    /// Equiangular sampling setup, sample and pdf per configuration.
    pub fn equiangular(
        &self,
        input: &[probe::EquiangularIn],
    ) -> Result<Vec<probe::EquiangularOut>> {
        match self {
            Backend::Cpu => Ok(cpu::map(input, probe::equiangular)),
            Backend::Gpu(g) => map_on_gpu(g, &gpu::EQUIANGULAR, input),
        }
    }

    /// Henyey-Greenstein samples and phase values per configuration.
    pub fn phase(&self, input: &[probe::PhaseIn]) -> Result<Vec<probe::PhaseOut>> {
        match self {
            Backend::Cpu => Ok(cpu::map(input, probe::phase)),
            Backend::Gpu(g) => map_on_gpu(g, &gpu::PHASE, input),
        }
    }

    /// Moment-shadow-map lookups of 2 x 2 maps.
    pub fn msm_lookup(&self, input: &[probe::MsmLookupIn]) -> Result<Vec<probe::MsmLookupOut>> {
        match self {
            Backend::Cpu => Ok(cpu::map(input, probe::msm_lookup)),
            Backend::Gpu(g) => map_on_gpu(g, &gpu::MSM_LOOKUP, input),
        }
    }

    /// Generator outputs for ids 0..count with a user seed.
    pub fn rng_draws(&self, count: u32, seed: u32) -> Result<Vec<RngDraws>> {
        match self {
            Backend::Cpu => Ok(cpu::generate(count, |id| probe::rng_draws(id, seed))),
            Backend::Gpu(g) => rng_on_gpu(g, count, seed).map_err(gpu_err(&gpu::RNG_DRAWS)),
        }
    }
}

/// [`Backend::rng_draws`] on the GPU: one submission.
fn rng_on_gpu(g: &Gpu, count: u32, seed: u32) -> Result<Vec<RngDraws>, GpuError> {
    let mut out = vec![RngDraws::zeroed(); count as usize];
    let output = g.buffer(std::mem::size_of_val(out.as_slice()) as u64)?;
    let push = Launch {
        seed,
        ..Launch::default()
    };
    g.submit(Work {
        pipeline: &|_: &Launch| (&gpu::RNG_DRAWS, Vec::new()),
        buffers: [&output],
        uploads: vec![],
        steps: vec![Step::Run {
            push,
            ids: 0..count,
        }],
        readbacks: vec![(&output, bytemuck::cast_slice_mut(&mut out))],
    })?;
    Ok(out)
}

/// One input buffer to one output buffer of the same length on the GPU, in one submission.
fn map_on_gpu<I: Pod, O: Pod>(
    g: &Gpu,
    kernel: &KernelDef<Launch, { shared::kernels::launch::bindings::map::COUNT }>,
    input: &[I],
) -> Result<Vec<O>> {
    let count = u32::try_from(input.len()).context("more than 2^32 ids in one launch")?;
    let run = || -> Result<Vec<O>, GpuError> {
        let mut out = vec![O::zeroed(); input.len()];
        let bytes: &[u8] = bytemuck::cast_slice(input);
        let buffers = MapBuffers {
            input: &g.buffer(bytes.len() as u64)?,
            output: &g.buffer(std::mem::size_of_val(out.as_slice()) as u64)?,
        };
        g.submit(Work {
            pipeline: &|_: &Launch| (kernel, Vec::new()),
            buffers: buffers.slots(),
            uploads: vec![(buffers.input, bytes)],
            steps: vec![Step::Run {
                push: Launch::default(),
                ids: 0..count,
            }],
            readbacks: vec![(buffers.output, bytemuck::cast_slice_mut(&mut out))],
        })?;
        Ok(out)
    };
    run().map_err(gpu_err(kernel))
}

/// Adds the kernel's name to a GPU error.
fn gpu_err<P, const N: usize>(kernel: &KernelDef<P, N>) -> impl FnOnce(GpuError) -> anyhow::Error {
    let name = kernel.kernel.name();
    move |e| anyhow::Error::new(e).context(format!("GPU kernel {name}"))
}
