//! Optical depth estimates for MIS weights and T̂: pairs (jackknife), single estimates (the
//! naive g(X) of Fig. 12d), and the power heuristic through Re g (beyond the paper).

use crate::complex::Complex;
use crate::estimators::optical_depth::{estimate_interleaved, prepare, DepthPairEstimate};
use crate::estimators::transmittance;
use crate::estimators::wide::Strata;
use crate::geometry::Ray;
use crate::math;
use crate::params::{Importance, Jitter};
use crate::rng::HashRng;
use crate::tally::Tally;
use crate::volume::grid::{Lookup, VolumeView};
use crate::volume::texels::Texels;

/// Optical depth estimates of [t_start, t_end] of an index-space ray with n0 and n1 samples
/// (Alg. 2 + Alg. 1): a pair (n1 = n0) for a jackknife, or one estimate X in `x0` (n1 = 0), the
/// naive MIS weight g(X) of the paper's Fig. 12d.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(super) fn depth(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t_start: f32,
    t_end: f32,
    n0: u32,
    n1: u32,
    lookup: Lookup,
    rng: HashRng,
) -> (DepthPairEstimate, HashRng) {
    if !(t_start < t_end) {
        return (DepthPairEstimate::default(), rng);
    }
    let prep = prepare(vol, ray, t_start, t_end, Importance::VarianceAware);
    let plan = Strata::fixed(&prep, n0, n1);
    estimate_interleaved(
        vol,
        ray,
        &prep,
        &plan,
        Importance::VarianceAware,
        Jitter::Stratified,
        lookup,
        rng,
    )
}

/// The tally of a pair of optical depth estimates used by a jackknife (regime flag set).
#[inline]
pub(super) fn jackknife_tally(est: &DepthPairEstimate) -> Tally {
    est.tally()
        .outside_if(transmittance::outside_regime(est.x0, est.x1))
}

/// Power-heuristic weight of free-flight sampling, Re g(X̄ + iS) with
/// g(tau) = mu^2 e^-2tau / (p0^2 + mu^2 e^-2tau); `other` gives 1 - g's form instead.
pub(super) fn power_weight(mu: f32, p0: f32, est: &DepthPairEstimate, other: bool) -> f32 {
    let z = Complex::new(
        -2.0 * transmittance::x_bar(est.x0, est.x1),
        -2.0 * transmittance::s(est.x0, est.x1),
    );
    let e2 = z.exp().scale(mu * mu);
    let den = e2 + Complex::real(p0 * p0);
    let num = if other { Complex::real(p0 * p0) } else { e2 };
    let w = (num / den).re;
    if math::is_finite(w) {
        w
    } else {
        0.5
    }
}
