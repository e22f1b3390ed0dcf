//! One transmittance estimate of a ray segment by any estimator: the function camera rays and
//! shadow rays share.

use crate::estimators::optical_depth::{
    adaptive_capped, adaptive_unsampled, estimate_pair, estimate_pair_adaptive, estimate_single,
    prepare, Prep,
};
use crate::estimators::ray_marching::{biased_ray_marching, unbiased_ray_marching};
use crate::estimators::telescoping::{telescoping, telescoping_cycles};
use crate::estimators::tracking::{
    ratio_tracking_capped, regular_tracking_tau, track_length_capped,
};
use crate::estimators::transmittance;
use crate::geometry::Ray;
use crate::math;
use crate::params::{Config, Estimator, RenderParams};
use crate::rng::HashRng;
use crate::tally::Tally;
use crate::volume::grid::VolumeView;
use crate::volume::texels::Texels;

/// Transmittance estimate of the index-space segment [t0, t1] (t0 < t1, inside the grid) by the
/// estimator of `cfg`, with N = `params.n` samples per optical-depth estimate. Returns
/// (T, tally, rng).
#[inline]
pub fn transmittance(
    vol: &VolumeView<impl Texels>,
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
            pair_transmittance(vol, cfg, params, ray, t0, t1, rng)
        }
        Estimator::NaiveSingle => {
            let prep = prepare(vol, ray, t0, t1, cfg.importance);
            let (est, rng) = estimate_single(
                vol,
                ray,
                &prep,
                2 * n,
                cfg.importance,
                cfg.jitter,
                cfg.lookup,
                rng,
            );
            (math::exp(-est.x0), est.tally(), rng)
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
            let tally = est.tally().capped_if(capped).outside_if(
                transmittance::outside_regime(est.x0, est.x1)
                    | adaptive_unsampled(&prep, f_delta, est.samples),
            );
            (transmittance::jackknife(est.x0, est.x1), tally, rng)
        }
        Estimator::BiasedRayMarching => {
            biased_ray_marching(vol, ray, t0, t1, rm_scale, cfg.lookup, rng)
        }
        Estimator::UnbiasedRayMarching => {
            unbiased_ray_marching(vol, ray, t0, t1, rm_scale, cfg.lookup, rng)
        }
        Estimator::RegularTracking => {
            let (tau, tally) = regular_tracking_tau(vol, ray, t0, t1);
            (math::exp(-tau), tally, rng)
        }
        Estimator::TrackLength | Estimator::FirstCollision => {
            track_length_capped(vol, ray, t0, t1, cfg.lookup, cfg.max_collisions, rng)
        }
        Estimator::RatioTracking => ratio_transmittance(vol, cfg, ray, t0, t1, rng),
        Estimator::Telescoping => telescoping(vol, ray, t0, t1, n, cfg.importance, cfg.lookup, rng),
        Estimator::TelescopingCycles => telescoping_cycles(vol, ray, t0, t1, cfg.lookup, rng),
    }
}

/// The jackknife (Eq. 4) or the naive exp(-mean) (`NaiveMean`) of one pair of optical-depth
/// estimates (Alg. 1 over Alg. 2's `Prep`) of [t0, t1]; [`transmittance`]'s arm for both, and
/// alone where only these estimators can be asked for (a kernel that inlines it holds no other
/// estimator's code: `restir`'s target, [`crate::integrators::restir::p_hat`]).
#[inline]
pub fn pair_transmittance(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    ray: &Ray,
    t0: f32,
    t1: f32,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let prep = prepare(vol, ray, t0, t1, cfg.importance);
    pair_transmittance_prepared(vol, cfg, params, ray, &prep, rng)
}

/// [`pair_transmittance`] over the segment Alg. 2 has prepared (`prep`, by `cfg.importance`).
#[inline]
pub fn pair_transmittance_prepared(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    ray: &Ray,
    prep: &Prep,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let (est, rng) = estimate_pair(
        vol,
        ray,
        prep,
        params.n,
        cfg.importance,
        cfg.jitter,
        cfg.lookup,
        rng,
    );
    let tally = est.tally();
    if cfg.estimator == Estimator::Jackknife {
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

/// Ratio tracking of [t0, t1] with the lookup, roulette and collision cap of `cfg`
/// ([`transmittance`]'s arm, and alone as [`pair_transmittance`] is).
#[inline]
pub fn ratio_transmittance(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    ray: &Ray,
    t0: f32,
    t1: f32,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    ratio_tracking_capped(
        vol,
        ray,
        t0,
        t1,
        cfg.lookup,
        cfg.roulette,
        cfg.max_collisions,
        rng,
    )
}
