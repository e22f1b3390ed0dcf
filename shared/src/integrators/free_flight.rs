//! Strategy 1 of Eq. 9/10: free-flight sampling by delta tracking, with each integrator's MIS
//! weight.

use super::context::Context;
use super::lighting::inscattered;
use super::weights::{depth_pair, depth_single, jackknife_tally, power_weight};
use crate::estimators::tracking::{delta_tracking, FreeFlight};
use crate::mis::Mobius;
use crate::params::Integrator;
use crate::rng::HashRng;
use crate::tally::Tally;

/// Free-flight sample on the camera ray by delta tracking (see [`delta_tracking`]).
#[inline]
pub(super) fn free_flight(ctx: &Context, rng: HashRng) -> (FreeFlight, HashRng) {
    delta_tracking(
        ctx.vol,
        &ctx.ray,
        ctx.ta,
        ctx.tb,
        ctx.lookup,
        FREE_FLIGHT_SALT,
        rng,
    )
}

/// Salt of the stochastic-lookup jitter key of free-flight sampling on camera rays.
pub(super) const FREE_FLIGHT_SALT: u32 = 0x27d4_eb2f;

/// Strategy 1 of Eq. 9/10: a free-flight sample t1 (delta tracking), weighted by the chosen
/// integrator's MIS weight. Returns (contribution, tally, rng).
pub(super) fn free_flight_strategy(
    ctx: &Context,
    which: Integrator,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let (vol, params, ray, ta) = (ctx.vol, ctx.params, &ctx.ray, ctx.ta);
    let (ff, mut rng) = free_flight(ctx, rng);
    let mut tally = ff.tally;
    if !ff.found {
        return (0.0, tally, rng);
    }
    let (ls, t, r) = inscattered(ctx, ff.t, rng);
    rng = r;
    tally = tally.merge(t);
    let p0 = ctx.eq.pdf(ff.t);
    let w1 = match which {
        Integrator::FreeFlight => 1.0,
        Integrator::Miller => {
            let q = ff.mu * ff.null_product;
            if q + p0 > 0.0 {
                q / (q + p0)
            } else {
                0.0
            }
        }
        Integrator::MisNaive => {
            // Fig. 12d: g(X) from ONE estimate with N samples (m = 1).
            let (est, r) = depth_single(vol, ray, ta, ff.t, params.n, ctx.lookup, rng);
            rng = r;
            tally = tally.merge(est.tally());
            Mobius::free_flight_weight(ff.mu, p0).naive(est.x0, est.x0)
        }
        _ => {
            let (est, r) = depth_pair(vol, ray, ta, ff.t, params.n, ctx.lookup, rng);
            rng = r;
            let g = Mobius::free_flight_weight(ff.mu, p0);
            match which {
                Integrator::CombinedNaive => {
                    tally = tally.merge(est.tally());
                    g.naive(est.x0, est.x1)
                }
                Integrator::MisPowerJackknife => {
                    tally = tally.merge(jackknife_tally(&est));
                    power_weight(ff.mu, p0, &est, false)
                }
                _ => {
                    tally = tally.merge(jackknife_tally(&est));
                    g.jackknife(est.x0, est.x1)
                }
            }
        }
    };
    (w1 * params.albedo * ls, tally, rng)
}
