//! One transmittance estimate of a ray segment by any estimator: the function camera rays and
//! shadow rays share.

use crate::estimators::optical_depth::{
    adaptive_capped, estimate_pair, estimate_pair_adaptive, estimate_single, prepare,
};
use crate::estimators::ray_marching::{biased_ray_marching, unbiased_ray_marching};
use crate::estimators::tracking::{ratio_tracking, regular_tracking_tau, track_length};
use crate::estimators::transmittance;
use crate::geometry::Ray;
use crate::math;
use crate::params::{Config, RenderParams};
use crate::rng::HashRng;
use crate::tally::Tally;
use crate::volume::grid::VolumeView;

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

/// Transmittance estimate of the index-space segment [t0, t1] (t0 < t1, inside the grid) by the
/// estimator of `cfg`, with N = `params.n` samples per optical-depth estimate. Returns
/// (T, tally, rng).
#[inline]
pub fn transmittance(
    vol: &VolumeView,
    cfg: &Config,
    params: &RenderParams,
    ray: &Ray,
    t0: f32,
    t1: f32,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let (n, f_delta, rm_scale) = (params.n, params.f_delta, params.rm_scale);
    let which = cfg.estimator;
    match which {
        Estimator::Jackknife | Estimator::NaiveMean => {
            let prep = prepare(vol, ray, t0, t1, cfg.importance);
            let (est, rng) = estimate_pair(
                vol,
                ray,
                &prep,
                n,
                cfg.importance,
                cfg.jitter,
                cfg.lookup,
                rng,
            );
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
            let prep = prepare(vol, ray, t0, t1, cfg.importance);
            let (x, n, rng) = estimate_single(
                vol,
                ray,
                &prep,
                2 * n,
                cfg.importance,
                cfg.jitter,
                cfg.lookup,
                rng,
            );
            (math::exp(-x), Tally::lookups(n), rng)
        }
        Estimator::JackknifeAdaptive => {
            let prep = prepare(vol, ray, t0, t1, cfg.importance);
            let capped = adaptive_capped(&prep, f_delta);
            let (est, rng) = estimate_pair_adaptive(
                vol,
                ray,
                &prep,
                f_delta,
                cfg.importance,
                cfg.jitter,
                cfg.lookup,
                rng,
            );
            let tally = Tally::lookups(est.samples)
                .capped_if(capped)
                .outside_if(transmittance::outside_regime(est.x0, est.x1));
            (transmittance::jackknife(est.x0, est.x1), tally, rng)
        }
        Estimator::BiasedRayMarching => {
            biased_ray_marching(vol, ray, t0, t1, rm_scale, cfg.lookup, rng)
        }
        Estimator::UnbiasedRayMarching => {
            unbiased_ray_marching(vol, ray, t0, t1, rm_scale, cfg.lookup, rng)
        }
        Estimator::RegularTracking => {
            let (tau, n) = regular_tracking_tau(vol, ray, t0, t1);
            (math::exp(-tau), Tally::lookups(n), rng)
        }
        Estimator::TrackLength => track_length(vol, ray, t0, t1, cfg.lookup, rng),
        Estimator::RatioTracking => ratio_tracking(vol, ray, t0, t1, cfg.lookup, cfg.roulette, rng),
    }
}
