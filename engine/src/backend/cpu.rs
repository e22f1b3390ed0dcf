//! The CPU backend: the same `shared` kernel bodies over the same ids, on all cores with rayon.

use crate::backend::schedule::{RenderBackend, Schedule};
use crate::backend::wide::{transmittance_pass, X8};
use crate::lighting::SceneLights;
use crate::scene::bricks::PackedVolume;
use anyhow::Result;
use indicatif::ProgressBar;
use rayon::prelude::*;
use shared::integrators::restir::{stage_count, RestirState};
use shared::integrators::stages::Wavefront;
use shared::kernels::render::{
    cpu_pixel_pass, is_reuse_stage, restir_reuse_step, restir_store_reuse, restir_wave_step,
    tile_order_pixel, PixelSums, StageAt,
};
use shared::kernels::shadow_map::{msm_raw_texel, msm_store_texel, MsmPass};
use shared::lanes::Lanes;
use shared::params::Integrator;
use shared::params::RenderParams;
use shared::sampling::lighting::Lighting;
use shared::sampling::lighting::Scene;
use shared::shadows::map::Shadows;
use shared::volume::grid::VolumeView;

/// Applies `f` to every input on all cores, in id order.
pub fn map<I, O, F>(inputs: &[I], f: F) -> Vec<O>
where
    I: Sync + Copy,
    O: Send,
    F: Fn(I) -> O + Sync,
{
    inputs.par_iter().map(|&x| f(x)).collect()
}

/// Evaluates `f(id)` for ids 0..count on all cores, in id order.
pub fn generate<O, F>(count: u32, f: F) -> Vec<O>
where
    O: Send,
    F: Fn(u32) -> O + Sync,
{
    (0..count).into_par_iter().map(&f).collect()
}

/// Whether the CPU backend renders `params` on `vol` eight pixels per instruction
/// ([`shared::kernels::wide`]).
pub fn renders_wide(vol: &PackedVolume, params: &RenderParams) -> bool {
    shared::kernels::wide::renders(&CpuVolume::new(vol).view(), params)
}

/// A volume rendered on the CPU: the render loop of the CPU backend.
pub struct CpuVolume<'a> {
    vol: &'a PackedVolume,
}

impl<'a> CpuVolume<'a> {
    /// The CPU backend's view of `vol` (nothing to upload).
    pub fn new(vol: &'a PackedVolume) -> Self {
        CpuVolume { vol }
    }

    /// The view the CPU renders with: its traversals step through all-zero bricks wherever
    /// that is exact (`GridDesc::can_step`), as on software GPUs; the same bytes as skipping,
    /// and faster here too (anchor jackknife 217 -> 193 ms, a Disney-cloud-sized sparse file
    /// 185 -> 156 ms; docs/results/speed.md). Grids whose budgets the builder lowered below
    /// the stepping bound (long, mostly empty ones) keep the skip.
    fn view(&self) -> VolumeView<'a> {
        let mut view = self.vol.view();
        view.desc.brick_stepping = u32::from(view.desc.can_step());
        view
    }
}

impl RenderBackend for CpuVolume<'_> {
    /// Pass after pass, chunk after chunk on all cores; work item k is pixel
    /// `tile_order_pixel(k)` (cache locality), returned in row-major order.
    fn render_sums(
        &self,
        params: &RenderParams,
        lights: &SceneLights,
        schedule: &Schedule,
        start: Option<&[PixelSums]>,
        bar: Option<&ProgressBar>,
    ) -> Result<Vec<PixelSums>> {
        let view = self.view();
        let scene = lights.view();
        let wave = Integrator::from_u32(params.integrator).wavefront();
        let count = params.width * params.height;
        if wave == Some(Wavefront::Restir) && params.restir.passes > 0 {
            return Ok(restir_wave(
                &view,
                params,
                &scene,
                schedule.samples(),
                start,
                bar,
            ));
        }
        let chunk = schedule.chunk;
        // Work item k holds pixel tile_order_pixel(k).
        let mut sums: Vec<PixelSums> = match start {
            Some(start) => (0..count)
                .map(|k| start[tile_order_pixel(k, params.width, params.height) as usize])
                .collect(),
            None => vec![PixelSums::default(); count as usize],
        };
        // Primary-ray jackknife and naive-mean images on the layouts the wide pass reads: eight
        // pixels per instruction, the same bytes (shared::kernels::wide).
        let wide = shared::kernels::wide::renders(&view, params);
        for &(s0, s1) in &schedule.passes {
            for (c, block) in sums.chunks_mut(chunk as usize).enumerate() {
                let base = c as u32 * chunk;
                if wide {
                    block
                        .par_chunks_mut(X8::N)
                        .enumerate()
                        .for_each(|(j, accs)| {
                            let first = base + (j * X8::N) as u32;
                            let pixels: [u32; X8::N] = std::array::from_fn(|i| {
                                tile_order_pixel(first + i as u32, params.width, params.height)
                            });
                            let pixels = &pixels[..accs.len()];
                            transmittance_pass(&view, params, pixels, s0, s1, accs);
                        });
                } else {
                    block.par_iter_mut().enumerate().for_each(|(i, acc)| {
                        let pixel = tile_order_pixel(base + i as u32, params.width, params.height);
                        *acc = cpu_pixel_pass(&view, params, &scene, pixel, s0, s1, *acc);
                    });
                }
                if let Some(bar) = bar {
                    bar.inc(block.len() as u64 * (s1 - s0) as u64);
                }
            }
        }
        // Work item k held pixel tile_order_pixel(k): back to row-major order.
        let mut rows = vec![PixelSums::default(); sums.len()];
        for (k, s) in sums.into_iter().enumerate() {
            rows[tile_order_pixel(k as u32, params.width, params.height) as usize] = s;
        }
        Ok(rows)
    }

    /// Pass 1 over every texel on all cores, then pass 2.
    fn build_shadow_map(
        &self,
        params: &RenderParams,
        lighting: &Lighting,
        pass: &MsmPass,
    ) -> Result<Vec<u32>> {
        let view = self.view();
        let m = &lighting.shadow_map;
        let texels = m.width * m.height;
        let raw: Vec<f32> = generate(texels, |k| msm_raw_texel(&view, params, lighting, k))
            .into_iter()
            .flatten()
            .collect();
        let n = Shadows::from_u32(lighting.shadows).words_per_texel() as usize;
        let words = generate(texels, |k| msm_store_texel(lighting, &raw, pass, k));
        Ok(words.into_iter().flat_map(|w| w[..n].to_vec()).collect())
    }
}

/// `restir` with spatial reuse, samples `samples`: the GPU's wavefront over the whole image
/// (row-major states).
/// Each reuse stage reads a snapshot of every state and stores what it changed; the stages
/// between reuse stages run per pixel in one sweep (the same calls in the same order as the
/// GPU's dispatches, so the same bits, with fewer sweeps over the states).
fn restir_wave(
    view: &VolumeView,
    params: &RenderParams,
    scene: &Scene,
    samples: std::ops::Range<u32>,
    start: Option<&[PixelSums]>,
    bar: Option<&ProgressBar>,
) -> Vec<PixelSums> {
    let count = (params.width * params.height) as usize;
    let mut states = vec![RestirState::default(); count];
    let mut sums = start.map_or_else(|| vec![PixelSums::default(); count], <[_]>::to_vec);
    let stages = stage_count(params);
    for s in samples {
        let mut stage = 0;
        while stage < stages {
            if is_reuse_stage(params, stage) {
                let next: Vec<RestirState> = (0..count as u32)
                    .into_par_iter()
                    .map(|id| {
                        let at = StageAt::restir(params, id, s, stage);
                        restir_reuse_step(view, params, scene, at, &states, 0)
                    })
                    .collect();
                states
                    .par_iter_mut()
                    .zip(&next)
                    .for_each(|(dst, src)| restir_store_reuse(dst, src, params, stage));
                stage += 1;
                continue;
            }
            let end = (stage..stages)
                .find(|&t| is_reuse_stage(params, t))
                .unwrap_or(stages);
            states
                .par_iter_mut()
                .zip(sums.par_iter_mut())
                .enumerate()
                .for_each(|(id, (st, acc))| {
                    for t in stage..end {
                        let at = StageAt::restir(params, id as u32, s, t);
                        (*st, *acc) = restir_wave_step(view, params, scene, at, *st, *acc);
                    }
                });
            stage = end;
        }
        if let Some(bar) = bar {
            bar.inc(count as u64);
        }
    }
    sums
}
