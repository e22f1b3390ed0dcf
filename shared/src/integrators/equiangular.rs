//! Strategy 0 of Eq. 9/10: equiangular sampling toward the light, with each integrator's MIS
//! weight (Miller et al.'s ratio-tracking density included).

use super::context::{mu_on_ray, Context};
use super::lighting::inscattered;
use super::weights::{depth_pair, depth_single, jackknife_tally, power_weight};
use crate::estimators::tracking::ratio_tracking;
use crate::estimators::transmittance;
use crate::mis::Mobius;
use crate::params::{Integrator, TransmittanceHat};
use crate::rng::HashRng;
use crate::tally::Tally;

/// Strategy 0 of Eq. 9/10: an equiangular sample t0 toward the light, weighted by the chosen
/// integrator's MIS weight. Returns (contribution, tally, rng).
pub(super) fn equiangular_strategy(
    ctx: &Context,
    which: Integrator,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let (vol, params, ray, ta) = (ctx.vol, ctx.params, &ctx.ray, ctx.ta);
    let (u, rng) = rng.next_f32();
    let (t0, p0) = ctx.eq.sample(u);
    let (mu0, mut rng) = mu_on_ray(ctx, t0, rng);
    let mut tally = Tally::lookups(1);
    if !(p0 > 0.0 && mu0 > 0.0 && t0 > ta && t0 < ctx.tb) {
        return (0.0, tally, rng);
    }
    let (ls, t, r) = inscattered(ctx, t0, rng);
    rng = r;
    tally = tally.merge(t);
    let f_over_mu_t = params.albedo * ls * mu0 / p0; // f(t0) / p0 without T(t0)
    let c0 = match which {
        Integrator::Equiangular
        | Integrator::MisJackknife
        | Integrator::MisNaive
        | Integrator::MisPowerJackknife => {
            // Weight from estimates on [ta, t0], T̂(t0) from independent ones.
            let w0 = match which {
                Integrator::Equiangular => 1.0,
                Integrator::MisNaive => {
                    // Fig. 12d: g(X) from ONE estimate with N samples (m = 1).
                    let (est, r) = depth_single(vol, ray, ta, t0, params.n, ctx.lookup, rng);
                    rng = r;
                    tally = tally.merge(est.tally());
                    Mobius::other_weight(mu0, p0).naive(est.x0, est.x0)
                }
                _ => {
                    let (est, r) = depth_pair(vol, ray, ta, t0, params.n, ctx.lookup, rng);
                    rng = r;
                    tally = tally.merge(jackknife_tally(&est));
                    if which == Integrator::MisJackknife {
                        Mobius::other_weight(mu0, p0).jackknife(est.x0, est.x1)
                    } else {
                        power_weight(mu0, p0, &est, true)
                    }
                }
            };
            let (t_hat, t, r) = if ctx.cfg.t_hat == TransmittanceHat::Ratio {
                ratio_tracking(vol, ray, ta, t0, ctx.lookup, ctx.cfg.roulette, rng)
            } else {
                let (est, r) = depth_pair(vol, ray, ta, t0, params.n, ctx.lookup, rng);
                (
                    transmittance::jackknife(est.x0, est.x1),
                    jackknife_tally(&est),
                    r,
                )
            };
            rng = r;
            tally = tally.merge(t);
            w0 * t_hat * f_over_mu_t
        }
        Integrator::CombinedJackknife | Integrator::CombinedNaive => {
            // Eq. 10: T mu / (p0 + T mu) * albedo * Ls estimated in one go.
            let (est, r) = depth_pair(vol, ray, ta, t0, params.n, ctx.lookup, rng);
            rng = r;
            let g = Mobius::free_flight_weight(mu0, p0);
            if which == Integrator::CombinedJackknife {
                tally = tally.merge(jackknife_tally(&est));
                g.jackknife(est.x0, est.x1) * params.albedo * ls
            } else {
                tally = tally.merge(est.tally());
                g.naive(est.x0, est.x1) * params.albedo * ls
            }
        }
        Integrator::Miller => {
            // Roulette-free ratio tracking: the same estimate of T as the free-flight side's
            // null-collision product, so the two balance-heuristic weights sum to one.
            let (p_hat, t, r) = ratio_tracking(vol, ray, ta, t0, ctx.lookup, false, rng);
            rng = r;
            tally = tally.merge(t);
            let q = mu0 * p_hat;
            if q + p0 > 0.0 {
                params.albedo * ls * q / (q + p0)
            } else {
                0.0
            }
        }
        _ => 0.0,
    };
    (c0, tally, rng)
}
