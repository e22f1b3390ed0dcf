//! Russian roulette of a path vertex's shadow ray by a prediction of its transmittance:
//! exp(-tau_mean), tau_mean the bricks' mean extinction integrated along the ray (Alg. 2's
//! traversal of the super-voxels sums it beside F; no voxel lookup). A ray whose prediction is
//! below [`T_RR`] is estimated with probability [`survival`] and weighted by its inverse, else
//! it counts 0: the expectation is unchanged for every estimator (the survival probability is
//! never 0), and the shadow rays of vertices deep in a dense medium, whose light is all but
//! blocked, skip their voxel lookups. Only the jackknife (and the naive mean of its pair)
//! take it: their Alg. 2 traversal gives the prediction for free.
//! Added variance per ray: T^2 (1/P - 1), about T x T_RR where the prediction holds. The
//! minorants' optical depth, a true bound, was measured too: on the peers' cloud (fbm noise
//! within each brick) it almost never fell below the threshold, so it skipped nothing.

use super::direct::{shadow_segment, ShadowQuery};
use crate::estimators::estimate;
use crate::estimators::optical_depth::prepare_with_mean;
use crate::geometry::Ray;
use crate::math;
use crate::params::{Config, Estimator, RenderParams};
use crate::rng::HashRng;
use crate::tally::Tally;
use crate::volume::grid::VolumeView;
use crate::volume::texels::Texels;

/// Predicted transmittance below which a shadow ray may be skipped.
pub const T_RR: f32 = 0.25;
/// Smallest survival probability (bounds the weight 1/P of a ray whose bound is 0).
pub const P_MIN: f32 = 1.0 / 64.0;

/// The probability that a shadow ray with predicted optical depth `tau` is estimated:
/// 1 where exp(-tau) >= T_RR, else max(exp(-tau) / T_RR, P_MIN).
#[inline]
pub fn survival(tau: f32) -> f32 {
    let predicted = math::exp(-tau);
    if predicted >= T_RR {
        1.0
    } else {
        let p = predicted / T_RR;
        if p > P_MIN {
            p
        } else {
            P_MIN
        }
    }
}

/// The transmittance of a query's shadow ray by the render's estimator, after roulette by its
/// predicted transmittance ([`rouletted_transmittance`]). Beside [`super::direct::shadow`], not
/// a flag of it: rust-gpu inlines every call of the estimators, and a kernel that holds both
/// arms compiles far longer (docs/design/kernel-build.md, one call site per heavy function).
pub(super) fn rouletted_shadow(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    q: &ShadowQuery,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let (ray, t0, t1) = shadow_segment(vol, params, q);
    if !(t0 < t1) {
        return (1.0, Tally::default(), rng);
    }
    rouletted_transmittance(vol, cfg, params, &ray, t0, t1, rng)
}

/// The transmittance of the index-space segment [t0, t1] (t0 < t1, inside the grid) by the
/// estimator of `cfg` ([`estimate::transmittance`]); for the estimators that run Alg. 2 (the
/// jackknife and the naive mean of a pair), after roulette by the prediction that Alg. 2's
/// traversal gives (see the module doc): T / P if the ray survives, 0 if not. A ray that
/// survives with P = 1 draws no uniform, so it takes exactly the numbers of an estimate without
/// roulette. The other estimators' shadow rays are estimated as they are (a traversal of their
/// own for the prediction cost ratio tracking more than it saved).
pub fn rouletted_transmittance(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    ray: &Ray,
    t0: f32,
    t1: f32,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    if !matches!(cfg.estimator, Estimator::Jackknife | Estimator::NaiveMean) {
        return estimate::transmittance(vol, cfg, params, ray, t0, t1, rng);
    }
    let prep = prepare_with_mean(vol, ray, t0, t1, cfg.importance);
    let p = survival(prep.tau_mean);
    let mut rng = rng;
    if p < 1.0 {
        let (u, r) = rng.next_f32();
        rng = r;
        if u >= p {
            return (0.0, Tally::default(), rng);
        }
    }
    let (tr, tally, rng) = estimate::pair_transmittance_prepared(vol, cfg, params, ray, &prep, rng);
    (tr / p, tally, rng)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn survival_is_one_above_the_threshold_and_floored_below() {
        assert_eq!(survival(0.0), 1.0);
        assert_eq!(survival(-(T_RR.ln()) - 1e-3), 1.0);
        let tau = 4.0f32;
        let p = survival(tau);
        assert!((p - (-tau).exp() / T_RR).abs() < 1e-6, "{p}");
        assert_eq!(survival(50.0), P_MIN);
        assert_eq!(survival(f32::INFINITY), P_MIN);
        // Monotone: a larger bound never survives less often.
        let mut last = 1.0;
        for k in 0..400 {
            let p = survival(k as f32 * 0.05);
            assert!(p <= last && p >= P_MIN, "tau {}: {p}", k as f32 * 0.05);
            last = p;
        }
    }
}
