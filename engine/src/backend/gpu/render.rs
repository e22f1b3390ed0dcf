//! The GPU backend's render loop: a resident volume, image tiles, passes as submissions.

use super::{
    Buffer, Gpu, LitBuffers, MsmBuildBuffers, MsmStoreBuffers, RenderBuffers, Step, Work, DIRECT,
    MSM_BUILD, MSM_STORE, PATH, RESTIR_CANDIDATE, RESTIR_QUERY, RESTIR_RESOLVE, RESTIR_REUSE,
    RESTIR_START, SCATTERING, TRANSMITTANCE,
};
use crate::backend::schedule::{RenderBackend, Schedule};
use crate::lighting::SceneLights;
use crate::scene::bricks::PackedVolume;
use anyhow::{Context, Result};
use indicatif::ProgressBar;
use shared::integrators::stages::{StageKernel, Wavefront};
use shared::kernels::launch::bindings::path;
use shared::kernels::launch::Launch;
use shared::kernels::render::{PathPass, PixelSums, RenderPass};
use shared::kernels::shadow_map::MsmPass;
use shared::params::{Integrator, RenderParams, UNSPECIALIZED};
use shared::sampling::lighting::Lighting;
use shared::sampling::lights::PointLight;
use shared::shadows::map::{Shadows, RAW_PER_TEXEL};
use shared::volume::grid::BRICK_WORDS;
use shared::volume::pages::MAX_PAGES;
use std::sync::Mutex;

/// A volume resident on the GPU: the render loop of the GPU backend.
pub struct GpuVolume<'a> {
    gpu: &'a Gpu,
    /// The voxel pool's pages (at least one).
    pages: Vec<Buffer>,
    bricks: Buffer,
    desc: Buffer,
    /// The layout and lookup of the resident grid, as the kernels' specialization constants.
    grid: GridSpec,
    /// Image tile buffers, reused across frames of the same size.
    tiles: Mutex<Vec<Buffer>>,
}

impl<'a> GpuVolume<'a> {
    /// Uploads the voxels (page by page), bricks and grid description of `vol`.
    pub fn upload(gpu: &'a Gpu, vol: &PackedVolume) -> Result<Self> {
        if let Some(why) = crate::scene::bricks::too_many_pages(vol) {
            anyhow::bail!("{why}; use --backend cpu, or crop or resample the volume");
        }
        let desc = vol
            .paged_desc()
            .context("internal: the pages were just checked")?;
        let pages = vol
            .pages()
            .map(|page| gpu.upload(bytemuck::cast_slice(page)))
            .collect::<Result<Vec<_>, _>>()
            .context("uploading the volume")?;
        let mut grid = GridSpec::of(&desc, pages.len() > 1, gpu.is_software());
        grid.texels = u32::from(
            grid.texels == 1
                && texels_fit(
                    vol.voxels.len() as u64,
                    vol.bricks.len() as u64,
                    gpu.max_texel_words(),
                ),
        );
        Ok(GpuVolume {
            gpu,
            pages,
            bricks: gpu
                .upload(bytemuck::cast_slice(&vol.bricks))
                .context("uploading the bricks")?,
            desc: gpu.upload(bytemuck::bytes_of(&desc))?,
            grid,
            tiles: Mutex::new(Vec::new()),
        })
    }
}

impl GpuVolume<'_> {
    /// The pages in binding order; unused slots repeat page 0 (never read).
    fn page_slots(&self) -> [&Buffer; MAX_PAGES] {
        std::array::from_fn(|k| self.pages.get(k).unwrap_or(&self.pages[0]))
    }
}

impl RenderBackend for GpuVolume<'_> {
    /// The image in tiles of one storage buffer each; per tile, every pass over every chunk of
    /// ids, a barrier between passes. With a progress bar each chunk is its own submission (the
    /// bar moves per chunk); without, each tile is one.
    fn render_sums(
        &self,
        params: &RenderParams,
        lights: &SceneLights,
        schedule: &Schedule,
        start: Option<&[PixelSums]>,
        bar: Option<&ProgressBar>,
    ) -> Result<Vec<PixelSums>> {
        render_tiles(self, params, lights, schedule, start, bar)
    }

    /// lavapipe ends any shader loop after 65535 iterations.
    fn loop_budget(&self) -> Option<u64> {
        Some(crate::backend::schedule::LOOP_BUDGET)
    }

    /// Both passes as one submission (a barrier between), in dispatches of at most 2^16
    /// texels; the stored words are read back.
    fn build_shadow_map(
        &self,
        params: &RenderParams,
        lighting: &Lighting,
        pass: &MsmPass,
    ) -> Result<Vec<u32>> {
        let gpu = self.gpu;
        let m = &lighting.shadow_map;
        let texels = m.width * m.height;
        let n = Shadows::from_u32(lighting.shadows).words_per_texel();
        let raw_bytes = u64::from(texels) * (RAW_PER_TEXEL * 4) as u64;
        anyhow::ensure!(
            raw_bytes <= gpu.max_buffer_bytes(),
            "a {}x{} moment shadow map needs a {raw_bytes}-byte storage buffer, more than this \
              GPU's maxStorageBufferRange of {} bytes; use a smaller --msm-res",
            m.width,
            m.height,
            gpu.max_buffer_bytes()
        );
        let p = gpu.buffer(std::mem::size_of::<RenderParams>() as u64)?;
        let l = gpu.buffer(std::mem::size_of::<Lighting>() as u64)?;
        let raw = gpu.buffer(raw_bytes).context("allocating the shadow map")?;
        let map = gpu
            .buffer(u64::from(texels) * u64::from(n) * 4)
            .context("allocating the shadow map")?;
        let steps = || -> Vec<Step<MsmPass>> {
            (0..texels)
                .step_by(1 << 16)
                .map(|start| Step::Run {
                    push: *pass,
                    ids: start..start.saturating_add(1 << 16).min(texels),
                })
                .collect()
        };
        let build = MsmBuildBuffers {
            params: &p,
            desc: &self.desc,
            pages: self.page_slots(),
            bricks: &self.bricks,
            lighting: &l,
            raw: &raw,
        };
        let kernel = &MSM_BUILD;
        let grid = self.grid;
        gpu.submit(Work {
            pipeline: &|_: &MsmPass| (kernel, specialization(None, UNSPECIALIZED, grid)),
            buffers: build.slots(),
            uploads: vec![
                (&p, bytemuck::bytes_of(params)),
                (&l, bytemuck::bytes_of(lighting)),
            ],
            steps: steps(),
            readbacks: vec![],
        })
        .with_context(|| format!("GPU kernel {}", kernel.kernel.name()))?;
        let mut words = vec![0u32; (texels * n) as usize];
        let store = MsmStoreBuffers {
            lighting: &l,
            raw: &raw,
            map: &map,
        };
        gpu.submit(Work {
            pipeline: &|_: &MsmPass| (&MSM_STORE, Vec::new()),
            buffers: store.slots(),
            uploads: vec![],
            steps: steps(),
            readbacks: vec![(&map, bytemuck::cast_slice_mut::<u32, u8>(&mut words))],
        })
        .with_context(|| format!("GPU kernel {}", MSM_STORE.kernel.name()))?;
        Ok(words)
    }
}

/// The specialization constants of the render, wavefront and shadow-map kernels by id
/// (`kernels/src/lib.rs`): 0 the integrator and 1 the estimator of `params` (none: the kernel
/// has neither), 2 the wavefront stage's kind, 3 whether the voxel pool spans several pages. Each
/// pipeline holds one variant's code (the whole render kernel took lavapipe 261 s to compile;
/// see docs/design/kernel-build.md); ids a module lacks are ignored.
fn specialization(params: Option<&RenderParams>, stage_kind: u32, grid: GridSpec) -> Vec<u32> {
    let (integrator, estimator, importance) = params
        .map_or((UNSPECIALIZED, UNSPECIALIZED, UNSPECIALIZED), |p| {
            (p.integrator, p.estimator, p.importance)
        });
    vec![
        integrator,
        estimator,
        stage_kind,
        u32::from(grid.paged),
        grid.lookup,
        grid.cells_per_brick,
        grid.brick_log2,
        importance,
        grid.brick_stepping,
        grid.texels,
    ]
}

/// The resident grid's values of the kernels' specialization constants 3 to 6 and 8: whether
/// the pool spans several pages, the lookup, the cells per brick (1: the fixed grid),
/// `GridDesc::brick_log2`, each as the bound `GridDesc` holds it, and
/// `GridDesc::brick_stepping`, chosen per device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridSpec {
    pub paged: bool,
    pub lookup: u32,
    pub cells_per_brick: u32,
    pub brick_log2: u32,
    pub brick_stepping: u32,
    /// Specialization constant 9: 1 where the kernels read the pool and the brick table as
    /// uniform texel buffers (`shared::volume::texels`), 0 where they read storage buffers.
    pub texels: u32,
}

/// Whether a pool of `pool_words` words in one page and a table of `bricks` records fit
/// uniform texel buffers of at most `max_words` words.
fn texels_fit(pool_words: u64, bricks: u64, max_words: u64) -> bool {
    pool_words <= max_words && bricks * u64::from(BRICK_WORDS) <= max_words
}

impl GridSpec {
    /// The specialization of a grid described by `desc` (`paged`: its pool spans several
    /// pages). A trilinear lookup stays unspecialized (the kernels read the buffer's lookup):
    /// with it folded, lavapipe compiled the trilinear jackknife on adaptive super-voxels to
    /// round differently from the CPU in the last bit (2 of 384 pixels,
    /// `tests/tests/adaptive.rs`; its blend is what shader compilers like to fuse), and the
    /// bytes must agree.
    ///
    /// On a software device (`software`: lavapipe, which runs every branch arm of its 8 lanes
    /// under masks) the traversals step through all-zero bricks wherever that is exact
    /// (`GridDesc::can_step`): the straight-line skip costs more in every iteration
    /// than the iterations it saves (anchor jackknife 793 -> 421 ns/ray, docs/results/speed.md).
    /// Hardware GPUs skip until measured there (the CPU steps too: `cpu::CpuVolume`).
    ///
    /// A software device also reads a one-page pool and the brick table as uniform texel
    /// buffers (`texels`; [`GpuVolume::upload`] clears it where they exceed
    /// maxTexelBufferElements): lavapipe loads a storage buffer lane by lane and fetches texels
    /// as one gather (anchor jackknife 417 -> 374 ns/ray, docs/results/speed.md). Hardware
    /// GPUs read storage buffers until measured there.
    pub fn of(desc: &shared::volume::grid::GridDesc, paged: bool, software: bool) -> Self {
        use shared::volume::grid::Lookup;
        GridSpec {
            paged,
            lookup: if desc.lookup == Lookup::Trilinear as u32 {
                UNSPECIALIZED
            } else {
                desc.lookup
            },
            cells_per_brick: desc.cells_per_brick(),
            brick_log2: desc.brick_log2,
            brick_stepping: u32::from(software && desc.can_step()),
            texels: u32::from(software && !paged),
        }
    }

    /// A one-page pool of a fixed grid of 16^3 bricks with nearest lookups (tests).
    #[cfg(test)]
    fn plain() -> Self {
        GridSpec {
            paged: false,
            lookup: 0,
            cells_per_brick: 1,
            brick_log2: 4,
            brick_stepping: 0,
            texels: 0,
        }
    }
}

/// The specialization of `transmittance_cs` (integrator 0) or `scattering_cs`: single
/// scattering's shadow rays are always the jackknife (`integrators::lighting`), so one
/// `scattering_cs` pipeline per integrator serves every `--estimator`.
fn render_specialization(params: &RenderParams, grid: GridSpec) -> Vec<u32> {
    let mut spec = specialization(Some(params), UNSPECIALIZED, grid);
    if params.integrator != 0 {
        spec[1] = UNSPECIALIZED;
    }
    spec
}

/// [`GpuVolume::render_sums`].
fn render_tiles(
    dev: &GpuVolume,
    params: &RenderParams,
    lights: &SceneLights,
    schedule: &Schedule,
    start: Option<&[PixelSums]>,
    bar: Option<&ProgressBar>,
) -> Result<Vec<PixelSums>> {
    let (gpu, passes) = (dev.gpu, &schedule.passes);
    // The longest dispatch: a chunk on a GPU (driver watchdogs). A software device runs each
    // dispatch as a fork and join of its threads, which the OS then often puts on one core
    // (docs/results/speed.md, "One dispatch per pass on software devices"): there a pass is one
    // dispatch where no progress bar needs chunks (and a wavefront's, which moves per sample).
    let (chunk, wave_chunk) = match (gpu.is_software(), bar) {
        (true, None) => (u32::MAX, u32::MAX),
        (true, Some(_)) => (schedule.chunk, u32::MAX),
        (false, _) => (schedule.chunk, schedule.chunk),
    };
    let count = params.width * params.height;
    let p = gpu.buffer(std::mem::size_of::<RenderParams>() as u64)?;
    // Storage buffers may not be empty: without point lights, one zeroed light is bound.
    let points: &[PointLight] = if lights.points.is_empty() {
        &[PointLight::new(
            shared::geometry::V3::new(0.0, 0.0, 0.0),
            0.0,
        )]
    } else {
        &lights.points
    };
    let l = gpu.buffer(std::mem::size_of_val(points) as u64)?;
    // `direct_cs` and `path_cs` (wavefronts) also read the lights' block, the map and the
    // samples' states; `transmittance_cs` and `scattering_cs` none of them.
    let wave = Integrator::from_u32(params.integrator).wavefront();
    let direct = wave.is_some();
    let env_data: &[f32] = if direct { &lights.env } else { &[0.0] };
    let lighting = gpu.buffer(std::mem::size_of::<Lighting>() as u64)?;
    let env = gpu
        .buffer(std::mem::size_of_val(env_data) as u64)
        .with_context(|| {
            let e = &lights.lighting.env;
            format!(
                "the light probe's {}x{} texels and sampling tables (4 floats per texel) do not \
                 fit one storage buffer of this device; downsample the probe (--env) or use \
                 --backend cpu",
                e.width, e.height
            )
        })?;
    let map_data: &[u32] = if direct { &lights.shadow_map } else { &[0] };
    let shadow_map = gpu.buffer(std::mem::size_of_val(map_data) as u64)?;
    let mut uploads = vec![
        (&p, bytemuck::bytes_of(params)),
        (&l, bytemuck::cast_slice::<PointLight, u8>(points)),
    ];
    if direct {
        uploads.push((&lighting, bytemuck::bytes_of(&lights.lighting)));
        uploads.push((&env, bytemuck::cast_slice::<f32, u8>(env_data)));
        uploads.push((&shadow_map, bytemuck::cast_slice::<u32, u8>(map_data)));
    }
    let mut tiles = dev
        .tiles
        .lock()
        .map_err(|_| anyhow::anyhow!("internal: poisoned tile cache"))?;
    let sums_size = std::mem::size_of::<PixelSums>() as u64;
    let state_size = wave.map_or(0, |w| u64::from(w.state_bytes()));
    let tile = tile_pixels(gpu, wave, params, count)?;
    let tile_count = count.div_ceil(tile) as usize;
    let tile_bytes = u64::from(tile) * sums_size;
    if tiles.len() != tile_count || tiles.iter().any(|b| b.size() != tile_bytes) {
        tiles.clear();
        for _ in 0..tile_count {
            tiles.push(gpu.buffer(tile_bytes).context("allocating the image")?);
        }
    }
    // The samples' states: one per pixel of a tile (wavefronts only).
    let states = gpu
        .buffer((u64::from(tile) * state_size).max(16))
        .context("allocating the wavefront states")?;
    let mut sums = vec![PixelSums::default(); count as usize];
    for (k, tile_start) in (0..count).step_by(tile as usize).enumerate() {
        let ids = tile_start..tile_start.saturating_add(tile).min(count);
        // The tile's sums continue from `start` (the kernels read them unless a pass starts a
        // sample block).
        if let Some(start) = start {
            let part = &start[ids.start as usize..ids.end as usize];
            uploads.push((&tiles[k], bytemuck::cast_slice::<PixelSums, u8>(part)));
        }
        let buffers = RenderBuffers {
            params: &p,
            desc: &dev.desc,
            pages: dev.page_slots(),
            bricks: &dev.bricks,
            lights: &l,
            sums: &tiles[k],
        };
        if let Some(wave) = wave {
            let slice = &mut sums[ids.start as usize..ids.end as usize];
            let buffers = LitBuffers {
                render: buffers,
                lighting: &lighting,
                env: &env,
                states: &states,
                shadow_map: &shadow_map,
            };
            let uploads_now = std::mem::take(&mut uploads);
            render_wave(
                gpu,
                wave,
                dev.grid,
                params,
                schedule.samples(),
                ids,
                wave_chunk,
                &buffers,
                uploads_now,
                slice,
                bar,
            )?;
            continue;
        }
        let slice = &mut sums[ids.start as usize..ids.end as usize];
        let pass = TilePass {
            params,
            passes,
            chunk,
            grid: dev.grid,
        };
        pass.submit(gpu, &buffers, ids, std::mem::take(&mut uploads), slice, bar)?;
    }
    Ok(sums)
}

/// Pixels per tile: whole workgroups, with each tile's sums (and a wavefront's states, 80 or
/// 160 B per pixel) in one storage buffer. Refuses `restir`'s reuse passes when the image does
/// not fit one tile (they read every pixel's state).
fn tile_pixels(
    gpu: &Gpu,
    wave: Option<Wavefront>,
    params: &RenderParams,
    count: u32,
) -> Result<u32> {
    let sums_size = std::mem::size_of::<PixelSums>() as u64;
    let state_size = wave.map_or(0, |w| u64::from(w.state_bytes()));
    let per_pixel = sums_size.max(state_size);
    let tile = (gpu.max_buffer_bytes() / per_pixel / 64 * 64)
        .max(64)
        .min(u64::from(count)) as u32;
    if wave == Some(Wavefront::Restir) && params.restir.passes > 0 && tile < count {
        anyhow::bail!(
            "--restir-passes {} needs every pixel's state in one GPU buffer: {count} pixels of \
             {state_size} bytes exceed the device's largest buffer ({} bytes); lower the \
             resolution or use --restir-passes 0",
            params.restir.passes,
            gpu.max_buffer_bytes()
        );
    }
    Ok(tile)
}

/// The submissions of one tile of `transmittance_cs` or `scattering_cs`: the schedule's passes
/// over its ids, the sums read back after the last.
struct TilePass<'a> {
    params: &'a RenderParams,
    passes: &'a [(u32, u32)],
    chunk: u32,
    grid: GridSpec,
}

impl TilePass<'_> {
    /// Submits the tile `ids` (the first submission carries `uploads`) and reads its sums
    /// into `out`.
    fn submit(
        &self,
        gpu: &Gpu,
        buffers: &RenderBuffers,
        ids: std::ops::Range<u32>,
        mut uploads: Vec<(&Buffer, &[u8])>,
        out: &mut [PixelSums],
        bar: Option<&ProgressBar>,
    ) -> Result<()> {
        let params = self.params;
        let submissions =
            tile_submissions(params.seed, self.passes, ids, self.chunk, bar.is_none());
        let last = submissions.len() - 1;
        let mut readback = Some(bytemuck::cast_slice_mut::<PixelSums, u8>(out));
        let kernel = if params.integrator == 0 {
            &TRANSMITTANCE
        } else {
            &SCATTERING
        };
        for (i, (steps, work)) in submissions.into_iter().enumerate() {
            let readbacks = if i == last {
                vec![(
                    buffers.sums,
                    readback.take().expect("one readback per tile"),
                )]
            } else {
                vec![]
            };
            let grid = self.grid;
            gpu.submit(Work {
                pipeline: &|_: &RenderPass| (kernel, render_specialization(params, grid)),
                buffers: buffers.slots(),
                uploads: std::mem::take(&mut uploads),
                steps,
                readbacks,
            })
            .with_context(|| format!("GPU kernel {}", kernel.kernel.name()))?;
            if let Some(bar) = bar {
                bar.inc(work);
            }
        }
        Ok(())
    }
}

/// The Vulkan kernel of a wavefront stage kernel (`shared::integrators::stages`).
fn stage_kernel(kernel: StageKernel) -> &'static super::KernelDef<PathPass, { path::COUNT }> {
    match kernel {
        StageKernel::Direct => &DIRECT,
        StageKernel::Path => &PATH,
        StageKernel::RestirStart => &RESTIR_START,
        StageKernel::RestirCandidate => &RESTIR_CANDIDATE,
        StageKernel::RestirReuse => &RESTIR_REUSE,
        StageKernel::RestirResolve => &RESTIR_RESOLVE,
        StageKernel::RestirQuery => &RESTIR_QUERY,
    }
}

/// The specialization constants of a stage of kind `kind` ([`specialization`]); a stage that
/// does not read the render's estimator leaves constant 1 at [`UNSPECIALIZED`] (the kernel then
/// reads the params buffer's value, which it ignores), so one pipeline serves every
/// `--estimator`.
fn wave_specialization(
    wave: Wavefront,
    params: &RenderParams,
    kind: u32,
    grid: GridSpec,
) -> Vec<u32> {
    let mut spec = specialization(Some(params), kind, grid);
    if !wave.reads_estimator(kind) {
        spec[1] = UNSPECIALIZED;
    }
    spec
}

/// A wavefront render of samples `samples` of one tile: per sample, the stages of `wave` with a
/// barrier after each (one submission per sample, so the progress bar moves per sample); the
/// sums are read back after the last sample.
#[allow(clippy::too_many_arguments)]
fn render_wave(
    gpu: &Gpu,
    wave: Wavefront,
    grid: GridSpec,
    params: &RenderParams,
    samples: std::ops::Range<u32>,
    ids: std::ops::Range<u32>,
    chunk: u32,
    buffers: &LitBuffers,
    uploads: Vec<(&Buffer, &[u8])>,
    slice: &mut [PixelSums],
    bar: Option<&ProgressBar>,
) -> Result<()> {
    let modes: Vec<u32> = (0..wave.stage_count(params))
        .map(|s| wave.mode(s))
        .collect();
    let mut uploads = Some(uploads);
    let mut readback = Some(bytemuck::cast_slice_mut::<PixelSums, u8>(slice));
    for s in samples.clone() {
        let steps = wave_steps(params.seed, &modes, s, ids.clone(), chunk);
        let readbacks = if s + 1 == samples.end {
            vec![(
                buffers.render.sums,
                readback.take().expect("one readback per tile"),
            )]
        } else {
            vec![]
        };
        gpu.submit(Work {
            pipeline: &|push: &PathPass| {
                let kind = wave.kind(params, push.mode);
                (
                    stage_kernel(wave.kernel(kind)),
                    wave_specialization(wave, params, kind, grid),
                )
            },
            buffers: buffers.slots(),
            uploads: uploads.take().unwrap_or_default(),
            steps,
            readbacks,
        })
        .with_context(|| format!("GPU kernels of the {wave:?} wavefront"))?;
        if let Some(bar) = bar {
            bar.inc(u64::from(ids.end - ids.start));
        }
    }
    Ok(())
}

/// The steps of sample `s` of a tile: one step per mode, each over all ids in dispatches of at
/// most `chunk` ids, a barrier after each step.
fn wave_steps(
    seed: u32,
    modes: &[u32],
    s: u32,
    ids: std::ops::Range<u32>,
    chunk: u32,
) -> Vec<Step<PathPass>> {
    let mut steps = Vec::new();
    for &mode in modes {
        let push = PathPass {
            launch: Launch {
                seed,
                ..Launch::default()
            },
            sample: s,
            mode,
            sums_base: ids.start,
            _pad: 0,
        };
        let mut start = ids.start;
        while start < ids.end {
            let end = start.saturating_add(chunk).min(ids.end);
            steps.push(Step::Run {
                push,
                ids: start..end,
            });
            start = end;
        }
        steps.push(Step::Barrier);
    }
    steps
}

/// The submissions of one tile (ids `ids`): its steps and the samples they add. Pass after pass
/// (with a barrier between), each pass in dispatches of at most `chunk` ids; all in one
/// submission if `together`, else one submission per chunk.
fn tile_submissions(
    seed: u32,
    passes: &[(u32, u32)],
    ids: std::ops::Range<u32>,
    chunk: u32,
    together: bool,
) -> Vec<(Vec<Step<RenderPass>>, u64)> {
    let mut out: Vec<(Vec<Step<RenderPass>>, u64)> = Vec::new();
    for (k, &(s0, s1)) in passes.iter().enumerate() {
        let push = RenderPass {
            launch: Launch {
                seed,
                ..Launch::default()
            },
            s_begin: s0,
            s_end: s1,
            sums_base: ids.start,
            _pad: 0,
        };
        if together && k > 0 && !out.is_empty() {
            out[0].0.push(Step::Barrier);
        }
        let mut start = ids.start;
        while start < ids.end {
            let end = start.saturating_add(chunk).min(ids.end);
            let step = Step::Run {
                push,
                ids: start..end,
            };
            let work = u64::from(end - start) * u64::from(s1 - s0);
            match out.first_mut() {
                Some((steps, total)) if together => {
                    steps.push(step);
                    *total += work;
                }
                _ => out.push((vec![step], work)),
            }
            start = end;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The grid's specialization equals the buffer's values, but for the trilinear lookup,
    /// which stays at the buffer's value (see [`GridSpec::of`]).
    #[test]
    fn grid_specialization_follows_the_description() {
        use shared::params::UNSPECIALIZED;
        use shared::volume::grid::{brick_log2_of, GridDesc, Lookup};
        let desc = |lookup: Lookup, cells: u32, b: u32| GridDesc {
            lookup: lookup as u32,
            cells_per_brick: cells,
            brick_size: b,
            brick_log2: brick_log2_of(b),
            ..GridDesc::default()
        };
        let g = GridSpec::of(&desc(Lookup::Stochastic, 0, 16), true, false);
        assert_eq!(
            (g.paged, g.lookup, g.cells_per_brick, g.brick_log2),
            (true, 1, 1, 4)
        );
        let g = GridSpec::of(&desc(Lookup::Nearest, 4, 12), false, false);
        assert_eq!((g.lookup, g.cells_per_brick, g.brick_log2), (0, 4, 32));
        let g = GridSpec::of(&desc(Lookup::Trilinear, 1, 8), false, false);
        assert_eq!(
            (g.lookup, g.cells_per_brick, g.brick_log2),
            (UNSPECIALIZED, 1, 3)
        );
    }

    /// Software devices step through empty bricks exactly where the brick budget is the
    /// stepping bound; hardware devices and grids with a smaller (skipping) budget skip.
    #[test]
    fn software_devices_step_through_empty_bricks_only_within_the_stepping_bound() {
        use shared::volume::grid::GridDesc;
        let desc = |brick_steps: u32, voxel_steps: u32| GridDesc {
            dims: [256, 256, 256, 0],
            brick_dims: [16, 16, 16, 0],
            brick_steps,
            voxel_steps,
            ..GridDesc::default()
        };
        // The stepping bounds: 3 * 16 + 3 bricks, 3 * 256 + 3 voxels.
        for (b, v) in [(0, 0), (51, 771), (52, 1000), (1000, 0)] {
            assert_eq!(GridSpec::of(&desc(b, v), false, true).brick_stepping, 1);
            assert_eq!(GridSpec::of(&desc(b, v), false, false).brick_stepping, 0);
        }
        for (b, v) in [(1, 0), (50, 0), (0, 770), (20, 100)] {
            assert_eq!(GridSpec::of(&desc(b, v), false, true).brick_stepping, 0);
        }
    }

    /// Software devices read one-page pools through texel buffers where both tables fit.
    #[test]
    fn texel_buffers_on_software_devices_for_one_page_pools_that_fit() {
        use shared::volume::grid::GridDesc;
        let d = GridDesc::default();
        assert_eq!(GridSpec::of(&d, false, true).texels, 1);
        assert_eq!(GridSpec::of(&d, true, true).texels, 0);
        assert_eq!(GridSpec::of(&d, false, false).texels, 0);
        assert!(texels_fit(1 << 27, (1 << 27) / 6, 1 << 27));
        assert!(!texels_fit((1 << 27) + 1, 1, 1 << 27));
        assert!(!texels_fit(1, (1 << 27) / 6 + 1, 1 << 27));
        assert!(texels_fit(65_536, 10_922, 65_536));
    }

    /// (s_begin, ids) per run step, `None` per barrier.
    fn shape(steps: &[Step<RenderPass>]) -> Vec<Option<(u32, std::ops::Range<u32>)>> {
        steps
            .iter()
            .map(|s| match s {
                Step::Run { push, ids } => Some((push.s_begin, ids.clone())),
                Step::Barrier => None,
            })
            .collect()
    }

    #[test]
    fn a_quiet_tile_is_one_submission_with_a_barrier_between_passes() {
        let subs = tile_submissions(9, &[(0, 2), (2, 3)], 64..200, 64, true);
        assert_eq!(subs.len(), 1);
        let (steps, work) = &subs[0];
        assert_eq!(
            shape(steps),
            vec![
                Some((0, 64..128)),
                Some((0, 128..192)),
                Some((0, 192..200)),
                None,
                Some((2, 64..128)),
                Some((2, 128..192)),
                Some((2, 192..200)),
            ]
        );
        assert_eq!(*work, 136 * 3);
        assert!(steps.iter().all(|s| match s {
            Step::Run { push, .. } => push.sums_base == 64 && push.launch.seed == 9,
            Step::Barrier => true,
        }));
    }

    /// Single scattering ignores the render's estimator (its shadow rays are the jackknife):
    /// one pipeline per integrator; transmittance images are specialized to the estimator.
    #[test]
    fn scattering_shares_a_pipeline_across_estimators() {
        use shared::params::{Estimator, Integrator};
        let with = |i: Integrator, e: Estimator| RenderParams {
            integrator: i as u32,
            estimator: e as u32,
            ..RenderParams::default()
        };
        let (j, r) = (Estimator::Jackknife, Estimator::RatioTracking);
        let t = Integrator::Transmittance;
        assert_ne!(
            render_specialization(&with(t, j), GridSpec::plain()),
            render_specialization(&with(t, r), GridSpec::plain())
        );
        for i in [Integrator::MisJackknife, Integrator::FreeFlight] {
            let (a, b) = (
                render_specialization(&with(i, j), GridSpec::plain()),
                render_specialization(&with(i, r), GridSpec::plain()),
            );
            assert_eq!(a, b, "{i:?}");
            assert_eq!(a[0], i as u32, "{i:?}");
            assert_eq!(a[1], UNSPECIALIZED, "{i:?}");
        }
    }

    /// Stages that ignore the render's estimator share one pipeline across estimators; the
    /// others are specialized to it.
    #[test]
    fn only_stages_that_read_the_estimator_are_specialized_to_it() {
        use shared::integrators::restir::{
            KIND_CANDIDATE, KIND_QUERY, KIND_RESOLVE, KIND_REUSE, KIND_START,
        };
        use shared::params::Estimator;
        let with = |e: Estimator| RenderParams {
            estimator: e as u32,
            ..RenderParams::default()
        };
        let (a, b) = (with(Estimator::Jackknife), with(Estimator::RatioTracking));
        let cases = [
            (Wavefront::Direct, 0, false),
            (Wavefront::Direct, 1, true),
            (Wavefront::Path, 0, true),
            (Wavefront::Path, 1, true),
            (Wavefront::Restir, KIND_START, false),
            (Wavefront::Restir, KIND_CANDIDATE, false),
            (Wavefront::Restir, KIND_REUSE, false),
            (Wavefront::Restir, KIND_RESOLVE, false),
            (Wavefront::Restir, KIND_QUERY, true),
        ];
        for (wave, kind, reads) in cases {
            let (sa, sb) = (
                wave_specialization(wave, &a, kind, GridSpec::plain()),
                wave_specialization(wave, &b, kind, GridSpec::plain()),
            );
            assert_eq!(sa[2], kind, "{wave:?} {kind}");
            if reads {
                assert_eq!(sa[1], Estimator::Jackknife as u32, "{wave:?} {kind}");
                assert_ne!(sa, sb, "{wave:?} {kind}");
            } else {
                assert_eq!(sa[1], UNSPECIALIZED, "{wave:?} {kind}");
                assert_eq!(sa, sb, "{wave:?} {kind}");
            }
        }
    }

    #[test]
    fn with_progress_every_chunk_is_its_own_submission() {
        let subs = tile_submissions(0, &[(0, 2), (2, 3)], 0..100, 64, false);
        let shapes: Vec<_> = subs.iter().map(|(s, w)| (shape(s), *w)).collect();
        assert_eq!(
            shapes,
            vec![
                (vec![Some((0, 0..64))], 128),
                (vec![Some((0, 64..100))], 72),
                (vec![Some((2, 0..64))], 64),
                (vec![Some((2, 64..100))], 36),
            ]
        );
    }
}
