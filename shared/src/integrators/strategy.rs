//! One sampling strategy of Eq. 9/10 (0: equiangular, 1: free flight) with the chosen
//! integrator's weight, as one body for both strategies: each heavy function (the shadow ray,
//! the optical depth estimates of Alg. 2 + Alg. 1, ratio tracking) has one call site, so a GPU
//! kernel holds it once (lavapipe's compile time grows faster than the kernel's size).

use super::context::Context;
use super::equiangular::equiangular_sample;
use super::free_flight::free_flight;
use super::lighting::inscattered;
use super::weights::{depth, jackknife_tally, power_weight};
use crate::estimators::optical_depth::DepthPairEstimate;
use crate::estimators::tracking::ratio_tracking;
use crate::estimators::transmittance;
use crate::mis::Mobius;
use crate::params::{Integrator, TransmittanceHat};
use crate::rng::HashRng;
use crate::tally::Tally;
use crate::volume::texels::Texels;

/// An estimate on [ta, t] of the strategy's sample t that a weight or T̂(t) needs.
#[derive(Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
enum Job {
    /// No further estimate.
    Done,
    /// One optical depth estimate with N samples (the naive g(X) of Fig. 12d).
    Single,
    /// A pair of optical depth estimates, tallied without the jackknife's regime flag.
    Naive,
    /// A pair of optical depth estimates for a jackknife.
    Jackknife,
    /// Ratio tracking without roulette (Miller et al.'s density).
    Ratio,
    /// Ratio tracking as T̂ (with roulette when the config asks for it).
    RatioHat,
}

/// The `j`-th estimate that strategy `s` of integrator `which` takes, in the order the random
/// numbers are drawn (the weight's before T̂'s).
#[inline]
fn job(which: Integrator, t_hat: TransmittanceHat, s: u32, j: u32) -> Job {
    let hat = if t_hat == TransmittanceHat::Ratio {
        Job::RatioHat
    } else {
        Job::Jackknife
    };
    let (first, second) = if s == 0 {
        match which {
            Integrator::Equiangular => (hat, Job::Done),
            Integrator::MisNaive => (Job::Single, hat),
            Integrator::MisJackknife | Integrator::MisPowerJackknife => (Job::Jackknife, hat),
            Integrator::CombinedJackknife => (Job::Jackknife, Job::Done),
            Integrator::CombinedNaive => (Job::Naive, Job::Done),
            Integrator::Miller => (Job::Ratio, Job::Done),
            _ => (Job::Done, Job::Done),
        }
    } else {
        match which {
            Integrator::MisNaive => (Job::Single, Job::Done),
            Integrator::CombinedNaive => (Job::Naive, Job::Done),
            Integrator::MisJackknife
            | Integrator::MisPowerJackknife
            | Integrator::CombinedJackknife => (Job::Jackknife, Job::Done),
            _ => (Job::Done, Job::Done),
        }
    };
    match j {
        0 => first,
        1 => second,
        _ => Job::Done,
    }
}

/// What one [`Job`] estimated: the optical depths, or ratio tracking's transmittance.
#[derive(Clone, Copy, Default)]
struct Estimate {
    est: DepthPairEstimate,
    ratio: f32,
}

/// Runs `job` on [ta, t] of the camera ray. Returns (estimate, tally, rng).
#[inline]
fn run(ctx: &Context<impl Texels>, job: Job, t: f32, rng: HashRng) -> (Estimate, Tally, HashRng) {
    if job == Job::Ratio || job == Job::RatioHat {
        let roulette = job == Job::RatioHat && ctx.cfg.roulette;
        let (ratio, tally, rng) =
            ratio_tracking(&ctx.vol, &ctx.ray, ctx.ta, t, ctx.lookup, roulette, rng);
        let e = Estimate {
            est: DepthPairEstimate::default(),
            ratio,
        };
        (e, tally, rng)
    } else {
        let n = ctx.params.n;
        let n1 = if job == Job::Single { 0 } else { n };
        let (est, rng) = depth(&ctx.vol, &ctx.ray, ctx.ta, t, n, n1, ctx.lookup, rng);
        let tally = if job == Job::Jackknife {
            jackknife_tally(&est)
        } else {
            est.tally()
        };
        (Estimate { est, ratio: 0.0 }, tally, rng)
    }
}

/// Strategy `s` of Eq. 9/10 (0: an equiangular sample t0 toward the light; 1: a free-flight
/// sample t1 by delta tracking), weighted by integrator `which`'s MIS weight (Miller et al.'s
/// ratio-tracking density included). Returns (contribution, tally, rng).
pub(super) fn strategy(
    ctx: &Context<impl Texels>,
    which: Integrator,
    s: u32,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let (v, p0, mut rng) = if s == 0 {
        equiangular_sample(ctx, rng)
    } else {
        let (ff, rng) = free_flight(ctx, rng);
        (ff, 0.0, rng)
    };
    let mut tally = v.tally;
    if !v.found {
        return (0.0, tally, rng);
    }
    let (ls, t, r) = inscattered(ctx, v.t, rng);
    rng = r;
    tally = tally.merge(t);
    // The other strategy's density at the sample (equiangular: its own, as drawn).
    let p0 = if s == 0 { p0 } else { ctx.eq.pdf(v.t) };
    let mut a = Estimate::default();
    let mut b = Estimate::default();
    let mut j = 0;
    loop {
        let next = job(which, ctx.cfg.t_hat, s, j);
        if next == Job::Done {
            break;
        }
        let (e, t, r) = run(ctx, next, v.t, rng);
        rng = r;
        tally = tally.merge(t);
        if j == 0 {
            a = e;
        } else {
            b = e;
        }
        j += 1;
    }
    (contribution(ctx, which, s, &v, p0, ls, &a, &b), tally, rng)
}

/// Strategy `s`'s weighted contribution from its sample `v` (other density `p0`, in-scattered
/// radiance `ls`) and its estimates `a` (the weight's; T̂ for `equiangular`) and `b` (T̂).
#[allow(clippy::too_many_arguments)]
#[inline]
fn contribution(
    ctx: &Context<impl Texels>,
    which: Integrator,
    s: u32,
    v: &crate::estimators::tracking::FreeFlight,
    p0: f32,
    ls: f32,
    a: &Estimate,
    b: &Estimate,
) -> f32 {
    let albedo = ctx.params.albedo;
    let mu = v.mu;
    if which == Integrator::Miller {
        // Roulette-free ratio tracking on both sides: the same estimate of T as the free-flight
        // side's null-collision product, so the two balance-heuristic weights sum to one.
        let q = mu * if s == 0 { a.ratio } else { v.null_product };
        let positive = q + p0 > 0.0;
        return if s != 0 {
            let w = if positive { q / (q + p0) } else { 0.0 };
            w * albedo * ls
        } else if positive {
            albedo * ls * q / (q + p0)
        } else {
            0.0
        };
    }
    let combined = which == Integrator::CombinedJackknife || which == Integrator::CombinedNaive;
    // Eq. 10 weighs both strategies with the free-flight form; Eq. 9's strategy 0 with 1 - it.
    let g = if s == 0 && !combined {
        Mobius::other_weight(mu, p0)
    } else {
        Mobius::free_flight_weight(mu, p0)
    };
    let w = match which {
        Integrator::Equiangular | Integrator::FreeFlight => 1.0,
        // Fig. 12d: g(X) from ONE estimate with N samples (m = 1).
        Integrator::MisNaive => g.naive(a.est.x0, a.est.x0),
        Integrator::CombinedNaive => g.naive(a.est.x0, a.est.x1),
        Integrator::MisPowerJackknife => power_weight(mu, p0, &a.est, s == 0),
        Integrator::MisJackknife | Integrator::CombinedJackknife => g.jackknife(a.est.x0, a.est.x1),
        _ => 0.0,
    };
    if s == 0 && !combined {
        // f(t0) / p0 = albedo Ls mu(t0) T(t0) / p0, with T from independent estimates.
        // (Scalars, not a reference, are selected: SPIR-V selects no pointers here.)
        let (x0, x1, ratio) = if which == Integrator::Equiangular {
            (a.est.x0, a.est.x1, a.ratio)
        } else {
            (b.est.x0, b.est.x1, b.ratio)
        };
        let t_hat = if ctx.cfg.t_hat == TransmittanceHat::Ratio {
            ratio
        } else {
            transmittance::jackknife(x0, x1)
        };
        w * t_hat * (albedo * ls * mu / p0)
    } else {
        w * albedo * ls
    }
}
