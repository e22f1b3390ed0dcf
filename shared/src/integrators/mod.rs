//! Single scattering from point lights along primary rays (Sec. 5.2): free-flight and
//! equiangular distance sampling, their MIS combinations with jackknife or naive MIS weights
//! (Eq. 9), the biased combined estimate (Eq. 10), Miller et al. 2019 (balance heuristic,
//! ratio-tracking densities) and the power heuristic through Re g (beyond the paper).

use crate::complex::Complex;
use crate::estimators::estimate;
use crate::estimators::optical_depth::{
    estimate_pair, estimate_single, mu_at, prepare, DepthPairEstimate,
};
use crate::estimators::tracking::{delta_tracking, ratio_tracking, FreeFlight};
use crate::estimators::transmittance;
use crate::geometry::{to_index_space, Ray, V3};
use crate::math::{self, sqrt};
use crate::mis::Mobius;
use crate::params::{
    Config, Estimator, Importance, Integrator, Jitter, RenderParams, TransmittanceHat,
};
use crate::rng::HashRng;
use crate::sampling::equiangular::Equiangular;
use crate::sampling::lights::{select_light, PointLight};
use crate::sampling::phase::phase_hg;
use crate::tally::Tally;
use crate::volume::dda::clip_to_box;
use crate::volume::grid::{Lookup, VolumeView};

/// Everything about one camera ray that the strategies share.
struct Context<'a> {
    vol: &'a VolumeView<'a>,
    params: &'a RenderParams,
    cfg: &'a Config,
    /// World-space unit ray.
    world: Ray,
    /// The same ray in index space (t is world distance).
    ray: Ray,
    ta: f32,
    tb: f32,
    light: PointLight,
    /// Probability of having selected `light`.
    p_light: f32,
    eq: Equiangular,
    lookup: Lookup,
}

/// The box [0, dims] of the grid as a vector.
#[inline]
fn grid_hi(vol: &VolumeView) -> V3 {
    let d = &vol.desc.dims;
    V3::new(d[0] as f32, d[1] as f32, d[2] as f32)
}

/// Two optical depth estimates of [t_start, t_end] of an index-space ray (Alg. 2 + Alg. 1).
#[inline]
fn depth_pair(
    vol: &VolumeView,
    ray: &Ray,
    t_start: f32,
    t_end: f32,
    n: u32,
    lookup: Lookup,
    rng: HashRng,
) -> (DepthPairEstimate, HashRng) {
    if !(t_start < t_end) {
        return (DepthPairEstimate::default(), rng);
    }
    let prep = prepare(vol, ray, t_start, t_end, Importance::VarianceAware);
    estimate_pair(
        vol,
        ray,
        &prep,
        n,
        Importance::VarianceAware,
        Jitter::Stratified,
        lookup,
        rng,
    )
}

/// One optical depth estimate X of [t_start, t_end] with n samples (m = 1; Alg. 2 + Alg. 1):
/// the naive MIS weight g(X) of the paper's Fig. 12d. Returns (X, samples, rng).
#[inline]
fn depth_single(
    vol: &VolumeView,
    ray: &Ray,
    t_start: f32,
    t_end: f32,
    n: u32,
    lookup: Lookup,
    rng: HashRng,
) -> (f32, u32, HashRng) {
    if !(t_start < t_end) {
        return (0.0, 0, rng);
    }
    let prep = prepare(vol, ray, t_start, t_end, Importance::VarianceAware);
    estimate_single(
        vol,
        ray,
        &prep,
        n,
        Importance::VarianceAware,
        Jitter::Stratified,
        lookup,
        rng,
    )
}

/// The tally of a pair of optical depth estimates used by a jackknife (regime flag set).
#[inline]
fn jackknife_tally(est: &DepthPairEstimate) -> Tally {
    Tally::lookups(est.samples).outside_if(transmittance::outside_regime(est.x0, est.x1))
}

/// Jackknife transmittance from world point x to the light (shadow ray, N per estimate).
fn shadow_transmittance(ctx: &Context, x: V3, rng: HashRng) -> (f32, Tally, HashRng) {
    let to = ctx.light.position - x;
    let dist = sqrt(to.dot(to));
    if !(dist > 0.0) {
        return (1.0, Tally::default(), rng);
    }
    let world = Ray {
        o: x,
        d: to * (1.0 / dist),
    };
    let ray = to_index_space(&world, &ctx.params.world_to_index);
    let (t0, t1) = clip_to_box(&ray, grid_hi(ctx.vol), 0.0, dist);
    if !(t0 < t1) {
        return (1.0, Tally::default(), rng);
    }
    // Shadow rays: the jackknife with variance-aware importance and stratified jitter (Sec. 5),
    // through the same estimate as camera rays.
    let shadow = Config {
        estimator: Estimator::Jackknife,
        importance: Importance::VarianceAware,
        jitter: Jitter::Stratified,
        ..*ctx.cfg
    };
    estimate::transmittance(ctx.vol, &shadow, ctx.params, &ray, t0, t1, rng)
}

/// In-scattered radiance from the selected light at distance t, divided by the light's
/// selection probability: phase * I * T_shadow / d^2 / P(light).
fn inscattered(ctx: &Context, t: f32, rng: HashRng) -> (f32, Tally, HashRng) {
    let x = ctx.world.at(t);
    let to = ctx.light.position - x;
    let d2 = to.dot(to);
    if !(d2 > 0.0) || !(ctx.p_light > 0.0) {
        return (0.0, Tally::default(), rng);
    }
    let (tr, n, rng) = shadow_transmittance(ctx, x, rng);
    let cos_theta = (ctx.world.d * -1.0).dot(to * (1.0 / sqrt(d2)));
    let l = phase_hg(cos_theta, ctx.params.hg_g) * ctx.light.intensity * tr / d2 / ctx.p_light;
    (l, n, rng)
}

/// Free-flight sample on the camera ray by delta tracking (see [`delta_tracking`]).
#[inline]
fn free_flight(ctx: &Context, rng: HashRng) -> (FreeFlight, HashRng) {
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
const FREE_FLIGHT_SALT: u32 = 0x27d4_eb2f;

/// Extinction at distance t along the camera ray.
#[inline]
fn mu_on_ray(ctx: &Context, t: f32, rng: HashRng) -> (f32, HashRng) {
    let (bits, rng) = rng.next_u32();
    (
        mu_at(ctx.vol, ctx.ray.at(t), ctx.lookup, [bits, 0x1656_67b1, 7]),
        rng,
    )
}

/// Power-heuristic weight of free-flight sampling, Re g(X̄ + iS) with
/// g(tau) = mu^2 e^-2tau / (p0^2 + mu^2 e^-2tau); `other` gives 1 - g's form instead.
fn power_weight(mu: f32, p0: f32, est: &DepthPairEstimate, other: bool) -> f32 {
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

/// Radiance along one world-space camera ray; returns (L, tally, rng) (decodes `params`; a render
/// decodes once per pass and calls [`trace_radiance`]).
pub fn radiance(
    vol: &VolumeView,
    params: &RenderParams,
    lights: &[PointLight],
    world: &Ray,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    trace_radiance(
        vol,
        &Config::decode(params, vol.desc),
        params,
        lights,
        world,
        rng,
    )
}

/// [`radiance`] with the enums already decoded.
pub fn trace_radiance(
    vol: &VolumeView,
    cfg: &Config,
    params: &RenderParams,
    lights: &[PointLight],
    world: &Ray,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let ray = to_index_space(world, &params.world_to_index);
    let (ta, tb) = clip_to_box(&ray, grid_hi(vol), 0.0, f32::INFINITY);
    if !(ta < tb) || params.light_count == 0 {
        return (0.0, Tally::default(), rng);
    }
    let (u, rng) = rng.next_f32();
    let (k, p_light) = select_light(lights, params.light_count, world.o, world.d, ta, tb, u);
    let light = lights[k as usize];
    let ctx = Context {
        vol,
        params,
        cfg,
        world: *world,
        ray,
        ta,
        tb,
        light,
        p_light,
        eq: Equiangular::new(world.o, world.d, light.position, ta, tb),
        lookup: cfg.lookup,
    };
    let which = cfg.integrator;
    let mut total = 0.0f32;
    let mut tally = Tally::default();
    let mut rng = rng;
    if which != Integrator::FreeFlight {
        let (l, t, r) = equiangular_strategy(&ctx, which, rng);
        total += l;
        tally = tally.merge(t);
        rng = r;
    }
    if which != Integrator::Equiangular {
        let (l, t, r) = free_flight_strategy(&ctx, which, rng);
        total += l;
        tally = tally.merge(t);
        rng = r;
    }
    (total, tally, rng)
}

/// Strategy 0 of Eq. 9/10: an equiangular sample t0 toward the light, weighted by the chosen
/// integrator's MIS weight. Returns (contribution, tally, rng).
fn equiangular_strategy(ctx: &Context, which: Integrator, rng: HashRng) -> (f32, Tally, HashRng) {
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
                    let (x, n, r) = depth_single(vol, ray, ta, t0, params.n, ctx.lookup, rng);
                    rng = r;
                    tally = tally.merge(Tally::lookups(n));
                    Mobius::other_weight(mu0, p0).naive(x, x)
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
                tally = tally.merge(Tally::lookups(est.samples));
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

/// Strategy 1 of Eq. 9/10: a free-flight sample t1 (delta tracking), weighted by the chosen
/// integrator's MIS weight. Returns (contribution, tally, rng).
fn free_flight_strategy(ctx: &Context, which: Integrator, rng: HashRng) -> (f32, Tally, HashRng) {
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
            let (x, n, r) = depth_single(vol, ray, ta, ff.t, params.n, ctx.lookup, rng);
            rng = r;
            tally = tally.merge(Tally::lookups(n));
            Mobius::free_flight_weight(ff.mu, p0).naive(x, x)
        }
        _ => {
            let (est, r) = depth_pair(vol, ray, ta, ff.t, params.n, ctx.lookup, rng);
            rng = r;
            let g = Mobius::free_flight_weight(ff.mu, p0);
            match which {
                Integrator::CombinedNaive => {
                    tally = tally.merge(Tally::lookups(est.samples));
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
