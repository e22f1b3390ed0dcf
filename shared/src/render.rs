//! Primary-ray transmittance images (like the paper's Fig. 8): one pure function per pixel.

use crate::camera::{to_index_space, Affine3x4, Camera};
use crate::dda::clip_to_box;
use crate::grid::{Lookup, VolumeView};
use crate::lights::PointLight;
use crate::math;
use crate::optical_depth::{
    adaptive_capped, estimate_pair, estimate_pair_adaptive, estimate_single, prepare, Importance,
    Jitter,
};
use crate::ray_marching::{biased_ray_marching, unbiased_ray_marching};
use crate::rng::HashRng;
use crate::tally::Tally;
use crate::tracking::{ratio_tracking, regular_tracking_tau, track_length};
use crate::transmittance;
use crate::vec3::V3;
use bytemuck::{Pod, Zeroable};

/// Transmittance estimators selectable at run time (u32 in [`RenderParams`]).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Estimator {
    /// Jackknife K = cos(S) exp(-X̄) from Alg. 1's two estimates (Eq. 4).
    Jackknife = 0,
    /// Naive exp(-X̄) from the same two estimates (m = 2).
    NaiveMean = 1,
    /// Naive exp(-X) from one estimate with all 2N samples (m = 1).
    NaiveSingle = 2,
    /// Jackknife with a constant CDF step F_delta instead of F / N (Fig. 8d).
    JackknifeAdaptive = 3,
    /// Kettunen et al.'s biased ray marching, exp(-X) with N_CMF mean-importance samples.
    BiasedRayMarching = 4,
    /// Kettunen et al.'s unbiased ray marching (power series, roulette, U-statistics).
    UnbiasedRayMarching = 5,
    /// exp(-tau) with tau exact for the nearest-neighbour grid (voxel DDA): the reference.
    RegularTracking = 6,
    /// Track-length estimate (delta tracking over per-brick majorants): 0 or 1.
    TrackLength = 7,
    /// Ratio tracking over per-brick majorants (Russian roulette only with `RenderParams::roulette`).
    RatioTracking = 8,
}

impl Estimator {
    /// Every estimator, in enum order.
    pub const ALL: [Estimator; 9] = [
        Estimator::Jackknife,
        Estimator::NaiveMean,
        Estimator::NaiveSingle,
        Estimator::JackknifeAdaptive,
        Estimator::BiasedRayMarching,
        Estimator::UnbiasedRayMarching,
        Estimator::RegularTracking,
        Estimator::TrackLength,
        Estimator::RatioTracking,
    ];

    /// From the stored u32 (unknown values read as the jackknife).
    #[inline]
    pub fn from_u32(v: u32) -> Self {
        match v {
            1 => Estimator::NaiveMean,
            2 => Estimator::NaiveSingle,
            3 => Estimator::JackknifeAdaptive,
            4 => Estimator::BiasedRayMarching,
            5 => Estimator::UnbiasedRayMarching,
            6 => Estimator::RegularTracking,
            7 => Estimator::TrackLength,
            8 => Estimator::RatioTracking,
            _ => Estimator::Jackknife,
        }
    }
}

/// Everything a render kernel needs besides the volume buffers.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RenderParams {
    pub camera: Camera,
    pub world_to_index: Affine3x4,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u32,
    /// Samples per optical depth estimate, N (default 10, so m N = 20 per ray).
    pub n: u32,
    /// [`Estimator`] as u32.
    pub estimator: u32,
    /// [`Importance`] as u32.
    pub importance: u32,
    /// [`Jitter`] as u32.
    pub jitter: u32,
    /// Sample-count multiplier of Kettunen et al.'s ray marching (1 as published, 2 doubled).
    pub rm_scale: f32,
    /// CDF step of the adaptive jackknife variant (author's default 0.3).
    pub f_delta: f32,
    /// 1: jitter rays within their pixel (anti-aliasing); 0: every sample uses the pixel center,
    /// so per-pixel statistics measure the transmittance estimator alone (`host eval`).
    pub pixel_jitter: u32,
    /// [`crate::integrator::Integrator`] as u32; 0 renders transmittance.
    pub integrator: u32,
    /// Number of valid entries in the lights buffer.
    pub light_count: u32,
    /// Single-scattering albedo mu_s / mu.
    pub albedo: f32,
    /// Henyey-Greenstein anisotropy g (0: isotropic).
    pub hg_g: f32,
    /// [`crate::integrator::TransmittanceHat`] as u32.
    pub t_hat: u32,
    /// 1: ratio tracking uses pbrt-v4's Russian roulette; 0: none, as the paper and the author's
    /// code (Miller et al.'s MIS always runs without it: its weights need the plain product).
    pub roulette: u32,
    pub _pad: u32,
}

/// Per-pixel result: mean transmittance over spp and the high-resolution lookups taken.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PixelOut {
    pub t_mean: f32,
    /// Mean of the squared estimates (for the per-pixel standard deviation).
    pub t2_mean: f32,
    pub samples: u32,
    /// Samples (rays) of this pixel whose estimate a loop bound changed ([`Tally::capped`]).
    pub capped: u32,
    /// Samples with a jackknife estimate outside its regime ([`Tally::outside`]).
    pub outside: u32,
    pub _pad: [u32; 3],
}

/// Transmittance estimate of one world-space ray through the whole volume, and its tally.
#[inline]
pub fn ray_transmittance(
    vol: &VolumeView,
    params: &RenderParams,
    world: &crate::dda::Ray,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let ray = to_index_space(world, &params.world_to_index);
    let d = &vol.desc.dims;
    let hi = V3::new(d[0] as f32, d[1] as f32, d[2] as f32);
    let (t0, t1) = clip_to_box(&ray, hi, 0.0, f32::INFINITY);
    if !(t0 < t1) {
        return (1.0, Tally::default(), rng);
    }
    let mode = if params.importance == 1 {
        Importance::Mean
    } else {
        Importance::VarianceAware
    };
    let jitter = if params.jitter == 1 {
        Jitter::Uniform
    } else {
        Jitter::Stratified
    };
    let lookup = Lookup::from_u32(vol.desc.lookup);
    let which = Estimator::from_u32(params.estimator);
    match which {
        Estimator::Jackknife | Estimator::NaiveMean => {
            let prep = prepare(vol, &ray, t0, t1, mode);
            let (est, rng) = estimate_pair(vol, &ray, &prep, params.n, mode, jitter, lookup, rng);
            let tally = Tally::lookups(est.samples);
            if which == Estimator::Jackknife {
                let outside = transmittance::outside_regime(est.x0, est.x1);
                (
                    transmittance::jackknife(est.x0, est.x1),
                    tally.outside_if(outside),
                    rng,
                )
            } else {
                (transmittance::naive(est.x0, est.x1), tally, rng)
            }
        }
        Estimator::NaiveSingle => {
            let prep = prepare(vol, &ray, t0, t1, mode);
            let (x, n, rng) =
                estimate_single(vol, &ray, &prep, 2 * params.n, mode, jitter, lookup, rng);
            (math::exp(-x), Tally::lookups(n), rng)
        }
        Estimator::JackknifeAdaptive => {
            let prep = prepare(vol, &ray, t0, t1, mode);
            let capped = adaptive_capped(&prep, params.f_delta);
            let (est, rng) =
                estimate_pair_adaptive(vol, &ray, &prep, params.f_delta, mode, jitter, lookup, rng);
            let tally = Tally::lookups(est.samples)
                .capped_if(capped)
                .outside_if(transmittance::outside_regime(est.x0, est.x1));
            (transmittance::jackknife(est.x0, est.x1), tally, rng)
        }
        Estimator::BiasedRayMarching => {
            biased_ray_marching(vol, &ray, t0, t1, params.rm_scale, lookup, rng)
        }
        Estimator::UnbiasedRayMarching => {
            unbiased_ray_marching(vol, &ray, t0, t1, params.rm_scale, lookup, rng)
        }
        Estimator::RegularTracking => {
            let (tau, n) = regular_tracking_tau(vol, &ray, t0, t1);
            (math::exp(-tau), Tally::lookups(n), rng)
        }
        Estimator::TrackLength => track_length(vol, &ray, t0, t1, lookup, rng),
        Estimator::RatioTracking => {
            ratio_tracking(vol, &ray, t0, t1, lookup, params.roulette != 0, rng)
        }
    }
}

/// Running sums of one pixel's estimates (accumulated over render passes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PixelSums {
    pub t_sum: f32,
    pub t2_sum: f32,
    pub samples: u32,
    /// Samples whose estimate a loop bound changed.
    pub capped: u32,
    /// Samples with a jackknife estimate outside its regime.
    pub outside: u32,
    pub _pad: [u32; 3],
}

/// Push constants of the render kernel: the launch header, then the pass's sample range.
///
/// Passes keep each invocation's work short: lavapipe (gallivm) silently ends any shader loop
/// after 65535 iterations, so a whole-spp loop in one invocation gave wrong images.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RenderPass {
    pub launch: crate::launch::Launch,
    /// First sample index of this pass.
    pub s_begin: u32,
    /// One past the last sample index of this pass.
    pub s_end: u32,
    /// Pixel id held by element 0 of the sums buffer: images larger than one storage buffer
    /// are rendered tile by tile, each tile into its own buffer.
    pub sums_base: u32,
    pub _pad: u32,
}

/// Adds samples s_begin..s_end of pixel `id` (row-major) to `prev`: one pass of a render.
/// Accumulating pass after pass gives exactly the sums of one loop over all samples.
pub fn render_pixel_pass(
    vol: &VolumeView,
    params: &RenderParams,
    lights: &[PointLight],
    id: u32,
    s_begin: u32,
    s_end: u32,
    prev: PixelSums,
) -> PixelSums {
    let x = id % params.width;
    let y = id / params.width;
    let mut acc = prev;
    let mut s = s_begin;
    while s < s_end {
        let rng = HashRng::for_sample(id, s, params.seed);
        let (jx, rng) = rng.next_f32();
        let (jy, rng) = rng.next_f32();
        let (jx, jy) = if params.pixel_jitter == 0 {
            (0.5, 0.5)
        } else {
            (jx, jy)
        };
        let world = params
            .camera
            .world_ray(x, y, jx, jy, params.width, params.height);
        let (t, tally, _) = if params.integrator == 0 {
            ray_transmittance(vol, params, &world, rng)
        } else {
            crate::integrator::radiance(vol, params, lights, &world, rng)
        };
        acc.t_sum += t;
        acc.t2_sum += t * t;
        acc.samples += tally.lookups;
        acc.capped += tally.capped;
        acc.outside += tally.outside;
        s += 1;
    }
    acc
}

/// Side of the square pixel tiles that the CPU backend's consecutive work items cover, so one
/// thread traces neighbouring rays (measured 2-3% faster than row order on the CPU; on lavapipe
/// 8 x 8-tile workgroups were 8% slower for the jackknife, so the GPU kernel keeps row order).
pub const TILE: u32 = 8;

/// The pixel (row-major id) of work item `k` in tile order: full 8 x 8 tiles row by row, each
/// tile row-major inside; then the pixels right of the last full tile column (row-major), then
/// those below the last full tile row. A bijection of `0..width * height`.
#[inline]
pub fn tile_order_pixel(k: u32, width: u32, height: u32) -> u32 {
    let tw = width / TILE * TILE;
    let th = height / TILE * TILE;
    let full = tw * th;
    if k < full {
        let tile = k / (TILE * TILE);
        let inner = k % (TILE * TILE);
        let tiles_per_row = tw / TILE;
        let x = (tile % tiles_per_row) * TILE + inner % TILE;
        let y = (tile / tiles_per_row) * TILE + inner / TILE;
        return y * width + x;
    }
    let k = k - full;
    let right = width - tw;
    if k < th * right {
        return (k / right) * width + tw + k % right;
    }
    th * width + (k - th * right)
}

/// Per-pixel means from the sums of `spp` estimates.
pub fn finish_pixel(sums: PixelSums, spp: u32) -> PixelOut {
    PixelOut {
        t_mean: sums.t_sum / spp as f32,
        t2_mean: sums.t2_sum / spp as f32,
        samples: sums.samples,
        capped: sums.capped,
        outside: sums.outside,
        _pad: [0; 3],
    }
}

/// Mean transmittance of pixel `id` over all `spp` samples in one pass (tests, small renders).
pub fn render_pixel(
    vol: &VolumeView,
    params: &RenderParams,
    lights: &[PointLight],
    id: u32,
) -> PixelOut {
    let sums = render_pixel_pass(vol, params, lights, id, 0, params.spp, PixelSums::default());
    finish_pixel(sums, params.spp)
}
