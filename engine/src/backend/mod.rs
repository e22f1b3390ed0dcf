//! Backend selection and the operations every backend runs identically.

pub mod cpu;
pub mod gpu;
pub mod job;
pub mod schedule;
pub mod wide;

use anyhow::{Context, Result};
use bytemuck::{Pod, Zeroable};
use gpu::{Gpu, GpuError, KernelDef, MapBuffers, Step, Work};
use job::{Estimate, Job};
use shared::kernels::launch::Launch;
use shared::kernels::probe::{self, DepthPair, MathValues, RngDraws, TransmittancePair};
use shared::volume::grid::Brick;
use std::sync::Arc;

/// Which backend the user asked for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BackendChoice {
    /// The Vulkan GPU if a driver is present, else the CPU (with a warning); on a software
    /// device (lavapipe) the backend a cost model of the job says finishes sooner.
    #[default]
    Auto,
    /// The Vulkan GPU; fail if there is none.
    Gpu,
    /// The CPU on all cores.
    Cpu,
}

/// Whether a render asked for with `choice` runs on the CPU rather than on a Vulkan device that
/// is (`software`) or is not a software implementation: `auto` skips a software device (lavapipe
/// runs the kernels on the same cores as the CPU backend) where the cost model says the CPU
/// finishes the job no later ([`job::Estimate`]: the device's pipeline builds take
/// seconds, and the wavefront integrators are slower there per sample; docs/results/speed.md,
/// "`--backend auto` on a software device"); `gpu` always uses the device.
pub fn prefers_cpu(choice: BackendChoice, software: bool, estimate: &Estimate) -> bool {
    choice == BackendChoice::Auto && software && estimate.cpu_is_faster()
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
    /// [`crate::scene::bricks::pack_paged`]): the GPU's largest page; the CPU reads the pool as one
    /// page whatever its layout and keeps the layout every device binds.
    pub fn page_log2(&self) -> u32 {
        match self {
            Backend::Cpu => shared::volume::pages::GPU_PAGE_LOG2,
            Backend::Gpu(g) => crate::scene::bricks::page_log2_for(g.max_buffer_bytes()),
        }
    }

    /// This backend, opened for `choice`, for rendering `volume` (packed with
    /// [`Backend::page_log2`]): a volume the GPU cannot hold (a page or the brick array above
    /// its largest storage buffer, more pages than the kernels bind, or more bytes than its
    /// device-local memory) makes `auto` fall back to the CPU with a warning and a forced
    /// `--backend gpu` fail with advice.
    ///
    /// On a software device (on the host's cores) `auto` renders `job` where the cost model
    /// says it finishes sooner ([`prefers_cpu`]), and says which and why.
    pub fn fit(
        self,
        choice: BackendChoice,
        volume: &crate::scene::bricks::PackedVolume,
        job: &Job,
    ) -> Result<Self> {
        if let Backend::Gpu(g) = &self {
            if choice == BackendChoice::Auto && g.is_software() {
                let e = job.estimate(rayon::current_num_threads());
                let (kind, samples) = (job.kind.name(), job.samples);
                if prefers_cpu(choice, true, &e) {
                    tracing::warn!(
                        "{} is a software Vulkan device on the same cores as the CPU backend; \
                         for {samples} samples of {kind} the cost model estimates {:.1} s \
                         on the CPU and {:.1} s there (pipeline builds included): falling back \
                         to the CPU backend (--backend gpu renders on it; docs/results/speed.md)",
                        g.description(),
                        e.cpu_s,
                        e.software_s
                    );
                    return Ok(Backend::Cpu);
                }
                tracing::info!(
                    "{} is a software Vulkan device; for {samples} samples of {kind} the cost \
                     model estimates {:.1} s there (pipeline builds included) and {:.1} s on the \
                     CPU backend: rendering on the device (--backend cpu renders on the CPU)",
                    g.description(),
                    e.software_s,
                    e.cpu_s
                );
            }
        }
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
    pub fn cannot_hold(&self, volume: &crate::scene::bricks::PackedVolume) -> Option<String> {
        let Backend::Gpu(gpu) = self else {
            return None;
        };
        if let Some(why) = crate::scene::bricks::too_many_pages(volume) {
            return Some(why);
        }
        let d = volume.desc.dims.map(u64::from);
        let largest = volume
            .pages()
            .map(|p| std::mem::size_of_val(p) as u64)
            .max()
            .unwrap_or(0)
            .max(std::mem::size_of_val(volume.bricks.as_slice()) as u64);
        let total = std::mem::size_of_val(volume.voxels.as_slice()) as u64
            + std::mem::size_of_val(volume.bricks.as_slice()) as u64;
        GpuRoom::of(gpu).refusal(
            [d[0], d[1], d[2]],
            largest,
            total,
            "voxel pool and brick table need",
        )
    }

    /// The check of a volume's topology before any voxel is loaded or generated (see
    /// [`topology_refusal`]); with `--backend gpu` (`choice`) it also refuses a volume this GPU
    /// cannot hold for certain: its brick table (exact from the box) or the voxels of its
    /// nonzero active tiles. The pool's size is known only once the values are read (active
    /// voxels may hold zeros), so [`Backend::fit`] checks it after packing; `auto` decides
    /// there too.
    pub fn topology_check(
        &self,
        choice: BackendChoice,
        brick_size: u32,
    ) -> impl Fn(&crate::io::Topology) -> Result<()> + Sync + std::panic::RefUnwindSafe {
        let room = match self {
            Backend::Gpu(gpu) if choice == BackendChoice::Gpu => Some(GpuRoom::of(gpu)),
            _ => None,
        };
        move |t: &crate::io::Topology| {
            // An invalid brick size is refused later, by the grid builder, naming the flag.
            if !(2..=256).contains(&brick_size) {
                return Ok(());
            }
            if let Some(why) = topology_refusal(t, brick_size, crate::io::available_memory()) {
                anyhow::bail!("{why}");
            }
            match room
                .as_ref()
                .and_then(|r| r.topology_refusal(t, brick_size))
            {
                Some(why) => anyhow::bail!(
                    "--backend gpu: {why}, known from its topology before any voxel is read; use \
                     --backend cpu, a larger --brick-size, or crop the volume"
                ),
                None => Ok(()),
            }
        }
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

/// Bytes the grid builder holds per brick of the box while packing, whether the brick is
/// occupied or not (its table record, slot, occupancy scan and statistics), rounded up from the
/// 52-53 measured: peak RSS of `host --backend cpu --volume tests/fixtures/huge.vdb
/// --brick-size B` less its 64 MB cell table, over 2.0 M (B = 16), 15.8 M (8) and 126 M (4)
/// bricks: 174 MB, 906 MB, 6.73 GB.
pub const PACK_BYTES_PER_BRICK: u64 = 64;

/// Why a volume is refused from its topology alone, on every backend, or `None`: its box's
/// bricks need more memory to pack than is `available` (when known; an estimate of
/// [`PACK_BYTES_PER_BRICK`] each, so a box of mostly empty bricks fails here instead of aborting
/// on an allocation), or its active tiles of nonzero value alone hold more voxels than the f16
/// pool's u32 index reaches (every such voxel is stored: a tile's value becomes 0 in f16 only
/// 2^40 below the largest density, and the builder would then refuse the volume as empty or
/// report the loss).
pub fn topology_refusal(
    t: &crate::io::Topology,
    brick_size: u32,
    available: Option<u64>,
) -> Option<String> {
    let [x, y, z] = t.dims;
    let pool = u64::from(shared::volume::grid::FIRST_EMPTY_SLOT);
    if t.tile_voxels >= pool {
        return Some(format!(
            "the {x}x{y}x{z} volume's active tiles hold {} voxels of nonzero density, more than \
             the {pool} f16 voxels (8 GiB) the voxel pool addresses; crop the volume or resample \
             it coarser",
            t.tile_voxels
        ));
    }
    let bricks = brick_count(t.dims, brick_size);
    let need = bricks.saturating_mul(PACK_BYTES_PER_BRICK);
    let gib = |b: u64| b as f64 / f64::from(1 << 30);
    let fits = |b: u32| brick_count(t.dims, b).saturating_mul(PACK_BYTES_PER_BRICK);
    available.filter(|&a| need > a).map(|a| {
        let what = format!(
            "the {x}x{y}x{z} volume's box holds {bricks} bricks of {brick_size}^3, which need \
             about {:.1} GiB to pack ({PACK_BYTES_PER_BRICK} bytes each, empty or not: the \
             renderer's brick grid spans the box of the active voxels), more than the {:.1} GiB \
             of memory available",
            gib(need),
            gib(a)
        );
        let larger = (1..=MAX_BRICK_SIZE.trailing_zeros())
            .map(|k| 1u32 << k)
            .filter(|&b| b > brick_size);
        // Half the memory for the bricks: the rest of the load (the brick table's growth, the
        // pool, threads) needs room too, in address space under `ulimit -v`.
        match larger.into_iter().find(|&b| 2 * fits(b) <= a) {
            Some(b) => format!(
                "{what}; --brick-size {b} or larger fits ({:.2} GiB), or crop the volume",
                gib(fits(b))
            ),
            None => format!(
                "{what}; no --brick-size fits with room to spare (even {MAX_BRICK_SIZE} needs \
                 {:.2} GiB): crop the volume to the region of interest or resample it coarser",
                gib(fits(MAX_BRICK_SIZE))
            ),
        }
    })
}

/// The largest `--brick-size`.
pub const MAX_BRICK_SIZE: u32 = 256;

/// Bytes of the brick table of a `dims` box in `brick_size`^3 bricks (the fixed grid; adaptive
/// super-voxels add their cells to it).
pub fn table_bytes(dims: [u64; 3], brick_size: u32) -> u64 {
    brick_count(dims, brick_size).saturating_mul(std::mem::size_of::<Brick>() as u64)
}

/// Bricks of `brick_size`^3 over a `dims` box (saturating).
fn brick_count(dims: [u64; 3], brick_size: u32) -> u64 {
    dims.iter()
        .map(|&d| d.div_ceil(u64::from(brick_size)))
        .fold(1u64, u64::saturating_mul)
}

/// What one GPU can hold: its largest storage buffer, its voxel pool's pages and its
/// device-local memory.
#[derive(Clone, Debug)]
struct GpuRoom {
    max_buffer: u64,
    /// Bytes of the largest pool the kernels bind ([`MAX_PAGES`] pages of this device's size).
    ///
    /// [`MAX_PAGES`]: shared::volume::pages::MAX_PAGES
    max_pool: u64,
    /// 0: not reported.
    memory: u64,
    description: String,
}

impl GpuRoom {
    fn of(gpu: &Gpu) -> Self {
        GpuRoom {
            max_buffer: gpu.max_buffer_bytes(),
            max_pool: shared::volume::pages::MAX_PAGES as u64
                * (4u64 << crate::scene::bricks::page_log2_for(gpu.max_buffer_bytes())),
            memory: gpu.device_local_bytes(),
            description: gpu.description().to_string(),
        }
    }

    /// Why this GPU cannot hold a volume of topology `t` in `brick_size`^3 bricks, from what is
    /// certain before its values are read: the brick table (exact from the box) and the f16
    /// voxels of its nonzero active tiles (a lower bound of the pool: leaves may hold zeros).
    fn topology_refusal(&self, t: &crate::io::Topology, brick_size: u32) -> Option<String> {
        let table = table_bytes(t.dims, brick_size);
        let pool = t.tile_voxels.saturating_mul(2);
        let [x, y, z] = t.dims;
        if pool > self.max_pool {
            return Some(format!(
                "the {x}x{y}x{z} volume's nonzero active tiles alone hold {} voxels, {:.0} MiB of \
                 f16, more than the {} MiB of voxel pool the kernels bind on this GPU ({})",
                t.tile_voxels,
                pool as f64 / f64::from(1 << 20),
                self.max_pool >> 20,
                self.description
            ));
        }
        let what = if pool > 0 {
            "brick table and the voxels of its nonzero active tiles need"
        } else {
            "brick table needs"
        };
        self.refusal(t.dims, table, table.saturating_add(pool), what)
    }

    /// Why a `dims` volume whose largest buffer is `largest` bytes and whose buffers (`what`,
    /// with its verb: "brick table needs") are `total` bytes does not fit, or `None`.
    fn refusal(&self, dims: [u64; 3], largest: u64, total: u64, what: &str) -> Option<String> {
        let [x, y, z] = dims;
        let gib = |b: u64| b as f64 / f64::from(1 << 30);
        if largest > self.max_buffer {
            return Some(format!(
                "the {x}x{y}x{z} volume needs a {largest}-byte storage buffer, more than this \
                 GPU's maxStorageBufferRange of {} bytes ({})",
                self.max_buffer, self.description
            ));
        }
        (self.memory > 0 && total > self.memory).then(|| {
            format!(
                "the {x}x{y}x{z} volume's {what} {:.2} GiB, more than this GPU's {:.2} GiB \
                 of device-local memory ({})",
                gib(total),
                gib(self.memory),
                self.description
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_bytes_count_every_brick_of_the_box() {
        // 24-byte records over ceil(dims / B) bricks per axis.
        assert_eq!(table_bytes([2001; 3], 16), 126u64.pow(3) * 24);
        assert_eq!(table_bytes([48, 48, 1], 2), 24 * 24 * 24);
        assert_eq!(
            table_bytes([u64::MAX; 3], 2),
            u64::MAX,
            "saturates, never wraps"
        );
    }

    #[test]
    fn topologies_are_refused_for_packing_memory_and_the_pool_index_only() {
        use crate::io::Topology;
        let huge = Topology {
            dims: [2001; 3],
            tile_voxels: 0,
        };
        // 126^3 bricks x 64 bytes = 128 MB to pack.
        assert_eq!(topology_refusal(&huge, 16, Some(200 << 20)), None);
        assert_eq!(topology_refusal(&huge, 16, None), None);
        let why = topology_refusal(&huge, 16, Some(100 << 20)).unwrap();
        assert!(
            why.contains("2001x2001x2001 volume's box holds 2000376 bricks of 16^3"),
            "{why}"
        );
        // 63^3 bricks of 32^3: 16 MB, with room to spare in 100 MB (issue 43, item 5: advice
        // that names a size that loads).
        assert!(why.contains("--brick-size 32 or larger fits"), "{why}");
        // 1001^3 bricks of 2^3: 64 GB; 8^3 bricks: 1 GB, not twice within 1.5 GB; 16^3 bricks
        // fit.
        let why = topology_refusal(&huge, 2, Some(3 << 29)).unwrap();
        assert!(why.contains("--brick-size 16 or larger fits"), "{why}");
        // In 32 KB no size fits with room to spare (8^3 bricks of 256^3: 32 KB, twice that 64).
        let why = topology_refusal(&huge, 16, Some(32 << 10)).unwrap();
        assert!(why.contains("no --brick-size fits"), "{why}");
        let pool = u64::from(shared::volume::grid::FIRST_EMPTY_SLOT);
        let tiles = |tile_voxels| Topology {
            dims: [4096; 3],
            tile_voxels,
        };
        assert_eq!(topology_refusal(&tiles(pool - 1), 16, None), None);
        let why = topology_refusal(&tiles(pool), 16, None).unwrap();
        assert!(
            why.contains("active tiles hold") && why.contains("crop"),
            "{why}"
        );
    }

    #[test]
    fn a_gpu_refuses_the_larger_of_its_buffer_and_memory_limits() {
        let room = GpuRoom {
            max_buffer: 1000,
            max_pool: 8000,
            memory: 5000,
            description: "test GPU".into(),
        };
        assert_eq!(room.refusal([1, 2, 3], 1000, 5000, "x need"), None);
        let why = room.refusal([1, 2, 3], 1001, 1001, "x need").unwrap();
        assert!(
            why.contains("1x2x3 volume needs a 1001-byte storage buffer"),
            "{why}"
        );
        assert!(
            why.contains("maxStorageBufferRange of 1000 bytes (test GPU)"),
            "{why}"
        );
        let why = room.refusal([1, 2, 3], 10, 5001, "x need").unwrap();
        assert!(
            why.contains("volume's x need 0.00 GiB") && why.contains("device-local"),
            "{why}"
        );
        let unknown = GpuRoom { memory: 0, ..room };
        assert_eq!(unknown.refusal([1, 2, 3], 10, u64::MAX, "x need"), None);
    }

    #[test]
    fn a_gpu_refuses_a_topology_by_its_table_and_its_tiles_voxels() {
        use crate::io::Topology;
        let room = GpuRoom {
            max_buffer: 1 << 20,
            max_pool: 8 << 20,
            memory: 16 << 20,
            description: "test GPU".into(),
        };
        let t = |dims, tile_voxels| Topology { dims, tile_voxels };
        // 42^3 bricks of 16^3: 1.78 MB of table, above the 1 MiB buffer.
        let why = room.topology_refusal(&t([672; 3], 0), 16).unwrap();
        assert!(
            why.contains("storage buffer") && why.contains("672x672x672"),
            "{why}"
        );
        assert_eq!(room.topology_refusal(&t([256; 3], 0), 16), None);
        // 4 M tile voxels: 8 MiB of f16 fit the pool's pages; one more does not.
        assert_eq!(room.topology_refusal(&t([256; 3], 4 << 20), 16), None);
        let why = room
            .topology_refusal(&t([256; 3], (4 << 20) + 1), 16)
            .unwrap();
        assert!(
            why.contains("nonzero active tiles alone hold 4194305 voxels"),
            "{why}"
        );
        // Table + tiles above the device's memory, each within its own limit.
        let small = GpuRoom {
            memory: 8 << 20,
            ..room
        };
        let why = small.topology_refusal(&t([256; 3], 4 << 20), 16).unwrap();
        assert!(
            why.contains("voxels of its nonzero active tiles need"),
            "{why}"
        );
    }
}

#[cfg(test)]
mod auto_tests {
    use super::*;

    /// `auto` renders on the CPU instead of a software Vulkan device where the cost model says
    /// the CPU is faster, never instead of a real GPU; `gpu` is obeyed.
    #[test]
    fn auto_prefers_the_cpu_to_a_software_device_only_where_it_is_faster() {
        let short = Estimate {
            cpu_s: 1.0,
            software_s: 5.0,
        };
        let long = Estimate {
            cpu_s: 100.0,
            software_s: 60.0,
        };
        assert!(prefers_cpu(BackendChoice::Auto, true, &short));
        assert!(!prefers_cpu(BackendChoice::Auto, true, &long));
        assert!(!prefers_cpu(BackendChoice::Auto, false, &short));
        assert!(!prefers_cpu(BackendChoice::Gpu, true, &short));
        assert!(!prefers_cpu(BackendChoice::Gpu, false, &short));
    }
}
