//! Rendering primary-ray transmittance images on either backend, with progress.

pub mod diagnostics;
pub mod exact;
pub mod progressive;
pub mod shadow_map;
pub mod totals;

pub use crate::backend::schedule::{RenderBackend, Schedule, LOOP_BUDGET};
use crate::backend::Backend;
use crate::lighting::SceneLights;
use crate::scene::bricks::PackedVolume;
use anyhow::{Context, Result};
use rayon::prelude::*;
pub use shared::integrators::budget::loop_iterations_per_ray;
use shared::kernels::render::{finish_pixel, PixelOut, PixelSums, SAMPLE_BLOCK};
use shared::params::RenderParams;
use shared::sampling::lights::PointLight;
use totals::PixelTotals;

/// Most samples per pixel per pass (see [`shared::kernels::render::RenderPass`] for why passes exist).
pub const SPP_PER_PASS: u32 = 16;

/// Smallest collision cap [`fit_collision_cap`] lowers to before refusing the render.
pub const MIN_COLLISION_CAP: u32 = 1000;

/// `params` with the tracking loops' collision cap lowered, where one invocation holds so many
/// tracking loops that the full cap would exceed a GPU invocation's loop budget (none of the
/// integrators does today: `direct` and `path` run one loop per dispatch; a safeguard for
/// volumes whose traversals alone approach the budget). Both backends use the returned cap, so images stay identical;
/// rays that reach it are counted as capped.
pub fn fit_collision_cap(
    params: &RenderParams,
    desc: &shared::volume::grid::GridDesc,
) -> RenderParams {
    let mut p = *params;
    if loop_iterations_per_ray(&p, desc) <= LOOP_BUDGET {
        return p;
    }
    // The bound is linear in the cap: find the slope from two caps.
    p.max_collisions = 1;
    let at_one = loop_iterations_per_ray(&p, desc);
    p.max_collisions = 2;
    let slope = loop_iterations_per_ray(&p, desc) - at_one;
    if slope == 0 || at_one > LOOP_BUDGET {
        return *params;
    }
    let cap = 1 + (LOOP_BUDGET - at_one) / slope;
    if cap < MIN_COLLISION_CAP as u64 {
        return *params;
    }
    p.max_collisions = cap.min(shared::params::MAX_TENTATIVE_COLLISIONS as u64) as u32;
    p
}

/// Samples per pixel per pass so that one invocation stays within the loop budget (on the GPU;
/// the CPU has none, and its passes only pace the progress bar: results do not depend on them).
pub fn spp_per_pass(params: &RenderParams, desc: &shared::volume::grid::GridDesc) -> Result<u32> {
    spp_per_pass_within(params, desc, Some(LOOP_BUDGET))
}

/// [`spp_per_pass`] for a backend whose invocations may run at most `budget` loop iterations
/// (None: no limit, the CPU); a ray that may need more is refused with advice.
pub fn spp_per_pass_within(
    params: &RenderParams,
    desc: &shared::volume::grid::GridDesc,
    budget: Option<u64>,
) -> Result<u32> {
    let per_ray = loop_iterations_per_ray(params, desc);
    if let Some(budget) = budget {
        anyhow::ensure!(
            per_ray <= budget,
            "one ray of this estimator may need {per_ray} loop iterations through this {}x{}x{} \
             grid, more than the {budget} a GPU invocation may run (lavapipe ends longer loops \
             silently); use --backend cpu, lower --n, or crop the volume's bounding box",
            desc.dims[0],
            desc.dims[1],
            desc.dims[2]
        );
    }
    Ok(((LOOP_BUDGET / per_ray.max(1)) as u32).clamp(1, SPP_PER_PASS))
}

/// Renders every pixel of `params` on `backend`. Pixels go in row-major order. The work runs in
/// passes of at most [`SPP_PER_PASS`] samples; within a pass, in chunks for the progress bar.
pub fn render(
    backend: &Backend,
    vol: &PackedVolume,
    params: &RenderParams,
    progress: bool,
) -> Result<Vec<PixelOut>> {
    render_scene(backend, vol, params, &[], progress)
}

/// [`render`] with point lights, for the single-scattering integrators.
pub fn render_scene(
    backend: &Backend,
    vol: &PackedVolume,
    params: &RenderParams,
    lights: &[PointLight],
    progress: bool,
) -> Result<Vec<PixelOut>> {
    render_lit(
        backend,
        vol,
        params,
        &SceneLights::points_only(lights),
        progress,
    )
}

/// [`render`] with every kind of light (the `direct` integrator).
pub fn render_lit(
    backend: &Backend,
    vol: &PackedVolume,
    params: &RenderParams,
    lights: &SceneLights,
    progress: bool,
) -> Result<Vec<PixelOut>> {
    let resident = Resident::new(backend, vol)?;
    render_resident_lit(&resident, params, lights, progress)
}

/// A volume made ready for rendering on one backend: on a GPU its voxels and bricks are uploaded
/// once, and the image buffers of the last render are kept for the next one of the same size,
/// so repeated frames (`host bench`) allocate nothing.
pub struct Resident<'a> {
    vol: &'a PackedVolume,
    backend: Box<dyn RenderBackend + 'a>,
    /// The backend it was uploaded to (named in outputs: who rendered a shard).
    on: &'a Backend,
}

impl<'a> Resident<'a> {
    /// The backend the volume is resident on.
    pub fn backend(&self) -> &'a Backend {
        self.on
    }

    /// Uploads `vol` if `backend` is a GPU.
    pub fn new(backend: &'a Backend, vol: &'a PackedVolume) -> Result<Self> {
        let backend_of = backend;
        let backend: Box<dyn RenderBackend + 'a> = match backend {
            Backend::Cpu => Box::new(crate::backend::cpu::CpuVolume::new(vol)),
            Backend::Gpu(gpu) => {
                Box::new(crate::backend::gpu::render::GpuVolume::upload(gpu, vol)?)
            }
        };
        Ok(Resident {
            vol,
            backend,
            on: backend_of,
        })
    }

    /// The stored words of the sun's moment shadow map of `lighting` on this backend.
    pub fn build_shadow_map(
        &self,
        params: &RenderParams,
        lighting: &shared::sampling::lighting::Lighting,
        pass: &shared::kernels::shadow_map::MsmPass,
    ) -> Result<Vec<u32>> {
        self.backend.build_shadow_map(params, lighting, pass)
    }
}

/// [`render_scene`] of a [`Resident`] volume.
pub fn render_resident(
    resident: &Resident,
    params: &RenderParams,
    lights: &[PointLight],
    progress: bool,
) -> Result<Vec<PixelOut>> {
    render_resident_lit(
        resident,
        params,
        &SceneLights::points_only(lights),
        progress,
    )
}

/// [`render_lit`] of a [`Resident`] volume. Renders of more than one sample block add the
/// blocks' sums exactly ([`render_totals`]); one block's sums are the pixels' sums themselves.
pub fn render_resident_lit(
    resident: &Resident,
    params: &RenderParams,
    lights: &SceneLights,
    progress: bool,
) -> Result<Vec<PixelOut>> {
    let spp = params.spp;
    anyhow::ensure!(spp > 0, "--spp must be at least 1");
    if sample_blocks(0..spp).len() > 1 {
        let totals = render_totals(resident, params, lights, 0..spp, progress)?;
        return finish_totals(&totals, spp);
    }
    let mut pixels = Vec::new();
    render_blocks(resident, params, lights, 0..spp, progress, |sums| {
        pixels = sums.into_iter().map(|s| finish_pixel(s, spp)).collect();
        Ok(())
    })?;
    Ok(pixels)
}

/// The exact totals of every pixel (row-major) over samples `samples` of `params`' render:
/// each sample block's sums added without rounding, so that any cut of a render into sample
/// ranges at block boundaries adds up to the same totals (`host render --samples`, `host merge`).
pub fn render_totals(
    resident: &Resident,
    params: &RenderParams,
    lights: &SceneLights,
    samples: std::ops::Range<u32>,
    progress: bool,
) -> Result<Vec<PixelTotals>> {
    let count = params.width as usize * params.height as usize;
    let mut totals = vec![PixelTotals::default(); count];
    render_blocks(resident, params, lights, samples, progress, |sums| {
        totals
            .par_iter_mut()
            .zip(&sums)
            .for_each(|(t, s)| t.add_block(s));
        Ok(())
    })?;
    Ok(totals)
}

/// The pixels of a render of `spp` samples from their totals.
pub fn finish_totals(totals: &[PixelTotals], spp: u32) -> Result<Vec<PixelOut>> {
    totals
        .par_iter()
        .map(|t| Ok(finish_pixel(t.to_sums()?, spp)))
        .collect()
}

/// The sums of every pixel (row-major) after samples `samples` of `params`' render, all within
/// one sample block, continuing from `start`, the sums of the block's samples before
/// `samples.start` (`None` where `samples.start` starts the block): one frame of a progressive
/// render ([`progressive::Progressive`]), in the passes [`render_totals`] would run.
pub fn render_frame(
    resident: &Resident,
    params: &RenderParams,
    lights: &SceneLights,
    samples: std::ops::Range<u32>,
    start: Option<&[PixelSums]>,
) -> Result<Vec<PixelSums>> {
    anyhow::ensure!(
        samples.start < samples.end && sample_blocks(samples.clone()).len() == 1,
        "internal: samples {}..{} are not a range within one sample block",
        samples.start,
        samples.end
    );
    anyhow::ensure!(
        start.is_some() != shared::kernels::render::starts_block(samples.start),
        "internal: samples {}..{} continue sums where a block starts or start none where it \
         continues",
        samples.start,
        samples.end
    );
    let count = params
        .width
        .checked_mul(params.height)
        .context("image too large")?;
    if let Some(start) = start {
        anyhow::ensure!(
            start.len() == count as usize,
            "internal: {} starting sums for {count} pixels",
            start.len()
        );
    }
    let step = spp_per_pass_within(params, &resident.vol.desc, resident.backend.loop_budget())?;
    let passes: Vec<(u32, u32)> = samples
        .clone()
        .step_by(step as usize)
        .map(|s| (s, (s + step).min(samples.end)))
        .collect();
    // Chunks as a whole render's (each a whole number of workgroups; the longest dispatch).
    let per_pass = (64 / passes.len().max(1) as u32).max(1);
    let chunk = count.div_ceil(per_pass).next_multiple_of(64).max(64);
    let schedule = Schedule { passes, chunk };
    resident
        .backend
        .render_sums(params, lights, &schedule, start, None)
}

/// Samples `samples` cut at the multiples of [`SAMPLE_BLOCK`]: the blocks whose sums start from
/// zero.
pub fn sample_blocks(samples: std::ops::Range<u32>) -> Vec<(u32, u32)> {
    let mut blocks = Vec::new();
    let mut s = samples.start;
    while s < samples.end {
        let end = (s / SAMPLE_BLOCK + 1)
            .saturating_mul(SAMPLE_BLOCK)
            .min(samples.end);
        blocks.push((s, end));
        s = end;
    }
    blocks
}

/// Renders samples `samples` of every pixel, block by block ([`sample_blocks`]), and hands
/// each block's sums (row-major, from zero) to `block` in order. A block runs in passes that
/// keep one GPU invocation within its loop budget; within a pass, in chunks for the progress
/// bar.
fn render_blocks(
    resident: &Resident,
    params: &RenderParams,
    lights: &SceneLights,
    samples: std::ops::Range<u32>,
    progress: bool,
    mut block: impl FnMut(Vec<PixelSums>) -> Result<()>,
) -> Result<()> {
    let vol = resident.vol;
    // The single-scattering integrators weigh every light per segment; `direct`, `path` and
    // `restir` draw by power from the alias table (any number).
    let lit = shared::params::Integrator::from_u32(params.integrator).is_lit();
    anyhow::ensure!(
        params.light_count as usize <= lights.points.len()
            && (lit || params.light_count <= shared::sampling::lights::MAX_LIGHTS),
        "at most {} lights",
        shared::sampling::lights::MAX_LIGHTS
    );
    let count = params
        .width
        .checked_mul(params.height)
        .context("image too large")?;
    anyhow::ensure!(
        samples.start < samples.end && samples.end <= params.spp,
        "samples {}..{} are not a range within the render's {} samples per pixel",
        samples.start,
        samples.end,
        params.spp
    );
    let step = spp_per_pass_within(params, &vol.desc, resident.backend.loop_budget())?;
    let blocks: Vec<Vec<(u32, u32)>> = sample_blocks(samples.clone())
        .into_iter()
        .map(|(b0, b1)| {
            (b0..b1)
                .step_by(step as usize)
                .map(|s| (s, (s + step).min(b1)))
                .collect()
        })
        .collect();
    let pass_count: usize = blocks.iter().map(Vec::len).sum();
    // About 64 progress updates overall; each chunk is a whole number of workgroups.
    let per_pass = (64 / pass_count.max(1) as u32).max(1);
    let chunk = count.div_ceil(per_pass).next_multiple_of(64).max(64);
    let done = u64::from(count) * u64::from(samples.end - samples.start);
    let bar = crate::output::progress(done, "rendering", !progress);
    for passes in blocks {
        let schedule = Schedule { passes, chunk };
        let sums = resident.backend.render_sums(
            params,
            lights,
            &schedule,
            None,
            progress.then_some(&bar),
        )?;
        block(sums)?;
    }
    bar.finish_and_clear();
    Ok(())
}

/// Bytes a render holds per pixel at its peak, on either backend: the running sums, the
/// finished pixels and the EXR and PNG buffers. Measured: peak RSS of `host render --backend cpu
/// --width 4096 --height 4096 --spp 1` at 16^3 (transmittance and `direct`), 1.19 GB for
/// 16.8 M pixels, 71 bytes each.
pub const BYTES_PER_PIXEL: u64 = 80;

/// Bytes a render of more than one sample block also holds per pixel: the exact totals.
pub const TOTALS_BYTES_PER_PIXEL: u64 = std::mem::size_of::<PixelTotals>() as u64;

/// Refuses a `width` x `height` image (`images` of them held at once: an evaluation keeps its
/// reference beside each estimate; `totals`: with exact totals, as renders of more than one
/// sample block and shards keep) whose buffers need more than the memory this process may
/// still allocate, before any work: an allocation past a limit aborts the process.
pub fn check_image_memory(width: u32, height: u32, images: u64, totals: bool) -> Result<()> {
    let per_pixel = BYTES_PER_PIXEL + if totals { TOTALS_BYTES_PER_PIXEL } else { 0 };
    let need = u64::from(width) * u64::from(height) * per_pixel * images;
    if let Some(available) = volume_io::available_memory() {
        let gib = |b: u64| b as f64 / f64::from(1 << 30);
        anyhow::ensure!(
            need <= available,
            "--width {width} --height {height}: the image's buffers need about {:.1} GiB \
             ({per_pixel} bytes per pixel{}), more than the {:.1} GiB of memory available \
             (the least of free memory, `ulimit -v` and the cgroup's limit); render a smaller \
             image{}",
            gib(need),
            if images > 1 {
                format!(", {images} images at once")
            } else {
                String::new()
            },
            gib(available),
            if totals {
                format!(
                    ", or at most {SAMPLE_BLOCK} samples per pixel (more keep exact totals of \
                     {TOTALS_BYTES_PER_PIXEL} bytes per pixel)"
                )
            } else {
                String::new()
            }
        );
    }
    Ok(())
}

/// Whether a render of `spp` samples keeps exact totals (more than one sample block).
pub fn keeps_totals(spp: u32) -> bool {
    spp > SAMPLE_BLOCK
}
