//! Single scattering from point lights along primary rays (Sec. 5.2): free-flight and
//! equiangular distance sampling, their MIS combinations with jackknife or naive MIS weights
//! (Eq. 9), the biased combined estimate (Eq. 10), Miller et al. 2019 (balance heuristic,
//! ratio-tracking densities) and the power heuristic through Re g (beyond the paper).

use crate::camera::{sqrt, to_index_space};
use crate::complex::Complex;
use crate::dda::{clip_to_box, Ray};
use crate::grid::{Lookup, VolumeView};
use crate::lights::{phase_hg, select_light, Equiangular, PointLight};
use crate::mis::Mobius;
use crate::optical_depth::{estimate_pair, mu_at, prepare, DepthPairEstimate, Importance, Jitter};
use crate::render::RenderParams;
use crate::rng::HashRng;
use crate::tracking::{ratio_tracking, MajorantSampler};
use crate::transmittance;
use crate::vec3::V3;

/// Light transport integrators selectable at run time (`RenderParams::integrator`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Integrator {
    /// No integrator: the image is primary-ray transmittance.
    Transmittance = 0,
    /// Free-flight distance sampling (delta tracking) only.
    FreeFlight = 1,
    /// Equiangular sampling toward the selected light only, with an estimate T̂(t0).
    Equiangular = 2,
    /// Eq. 9 with jackknife MIS weights Re g(X̄ + iS) and an independent T̂(t0).
    MisJackknife = 3,
    /// Eq. 9 with naive MIS weights g(X̄).
    MisNaive = 4,
    /// Eq. 10 (MIS weight times transmittance estimated at once), jackknife; biased.
    CombinedJackknife = 5,
    /// Eq. 10 with naive g(X̄); biased.
    CombinedNaive = 6,
    /// Miller et al. 2019 reduced to the balance heuristic with ratio-tracking densities.
    Miller = 7,
    /// Eq. 9 with the power heuristic (exponent 2) through Re g (beyond the paper).
    MisPowerJackknife = 8,
}

impl Integrator {
    /// From the stored u32 (unknown values read as transmittance).
    #[inline]
    pub fn from_u32(v: u32) -> Self {
        match v {
            1 => Integrator::FreeFlight,
            2 => Integrator::Equiangular,
            3 => Integrator::MisJackknife,
            4 => Integrator::MisNaive,
            5 => Integrator::CombinedJackknife,
            6 => Integrator::CombinedNaive,
            7 => Integrator::Miller,
            8 => Integrator::MisPowerJackknife,
            _ => Integrator::Transmittance,
        }
    }
}

/// Which estimate of T(t0) the equiangular strategy of Eq. 9 uses (`RenderParams::t_hat`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransmittanceHat {
    /// Jackknife (Eq. 4; tiny bias).
    Jackknife = 0,
    /// Ratio tracking (unbiased: the whole image is then unbiased up to shadow rays).
    Ratio = 1,
}

/// Everything about one camera ray that the strategies share.
struct Context<'a> {
    vol: &'a VolumeView<'a>,
    params: &'a RenderParams,
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

/// Jackknife transmittance from world point x to the light (shadow ray, N per estimate).
fn shadow_transmittance(ctx: &Context, x: V3, rng: HashRng) -> (f32, u32, HashRng) {
    let to = ctx.light.position - x;
    let dist = sqrt(to.dot(to));
    if !(dist > 0.0) {
        return (1.0, 0, rng);
    }
    let world = Ray {
        o: x,
        d: to * (1.0 / dist),
    };
    let ray = to_index_space(&world, &ctx.params.world_to_index);
    let (t0, t1) = clip_to_box(&ray, grid_hi(ctx.vol), 0.0, dist);
    if !(t0 < t1) {
        return (1.0, 0, rng);
    }
    let (est, rng) = depth_pair(ctx.vol, &ray, t0, t1, ctx.params.n, ctx.lookup, rng);
    (transmittance::jackknife(est.x0, est.x1), est.samples, rng)
}

/// In-scattered radiance from the selected light at distance t, divided by the light's
/// selection probability: phase * I * T_shadow / d^2 / P(light).
fn inscattered(ctx: &Context, t: f32, rng: HashRng) -> (f32, u32, HashRng) {
    let x = ctx.world.at(t);
    let to = ctx.light.position - x;
    let d2 = to.dot(to);
    if !(d2 > 0.0) || !(ctx.p_light > 0.0) {
        return (0.0, 0, rng);
    }
    let (tr, n, rng) = shadow_transmittance(ctx, x, rng);
    let cos_theta = (ctx.world.d * -1.0).dot(to * (1.0 / sqrt(d2)));
    let l = phase_hg(cos_theta, ctx.params.hg_g) * ctx.light.intensity * tr / d2 / ctx.p_light;
    (l, n, rng)
}

/// Free-flight sample by delta tracking over the brick majorants: (t, mu(t), found), plus the
/// product of null-collision probabilities before t (Miller et al.'s density estimate).
fn free_flight(ctx: &Context, rng: HashRng) -> (f32, f32, bool, f32, u32, HashRng) {
    let mut sampler = MajorantSampler::new(ctx.vol, &ctx.ray, ctx.ta, ctx.tb);
    let mut rng = rng;
    let mut lookups = 0u32;
    let mut null_product = 1.0f32;
    let (mut t, mut mu, mut found) = (0.0f32, 0.0f32, false);
    while !sampler.done && lookups < crate::tracking::MAX_TENTATIVE_COLLISIONS {
        let (c, r) = sampler.next_collision(ctx.vol, rng);
        rng = r;
        if c.found {
            let key = [rng.state, lookups, 0x27d4_eb2f];
            let m = mu_at(ctx.vol, ctx.ray.at(c.t), ctx.lookup, key);
            lookups += 1;
            let (u, r) = rng.next_f32();
            rng = r;
            if u < m / c.sigma_maj {
                t = c.t;
                mu = m;
                found = true;
                sampler.done = true;
            } else {
                let f = 1.0 - m / c.sigma_maj;
                null_product *= if f > 0.0 { f } else { 0.0 };
            }
        }
    }
    (t, mu, found, null_product, lookups, rng)
}

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
    if crate::math::is_finite(w) {
        w
    } else {
        0.5
    }
}

/// Radiance along one world-space camera ray; returns (L, high-resolution lookups, rng).
pub fn radiance(
    vol: &VolumeView,
    params: &RenderParams,
    lights: &[PointLight],
    world: &Ray,
    rng: HashRng,
) -> (f32, u32, HashRng) {
    let ray = to_index_space(world, &params.world_to_index);
    let (ta, tb) = clip_to_box(&ray, grid_hi(vol), 0.0, f32::INFINITY);
    if !(ta < tb) || params.light_count == 0 {
        return (0.0, 0, rng);
    }
    let (u, rng) = rng.next_f32();
    let (k, p_light) = select_light(lights, params.light_count, world.o, world.d, ta, tb, u);
    let light = lights[k as usize];
    let ctx = Context {
        vol,
        params,
        world: *world,
        ray,
        ta,
        tb,
        light,
        p_light,
        eq: Equiangular::new(world.o, world.d, light.position, ta, tb),
        lookup: Lookup::from_u32(vol.desc.lookup),
    };
    let albedo = params.albedo;
    let which = Integrator::from_u32(params.integrator);
    let mut lookups = 0u32;
    let mut total = 0.0f32;
    let mut rng = rng;

    // ---- Strategy 0: equiangular sample t0 toward the light ----
    let uses_eq = which != Integrator::FreeFlight;
    if uses_eq {
        let (u, r) = rng.next_f32();
        rng = r;
        let (t0, p0) = ctx.eq.sample(u);
        let (mu0, r) = mu_on_ray(&ctx, t0, rng);
        rng = r;
        lookups += 1;
        if p0 > 0.0 && mu0 > 0.0 && t0 > ta && t0 < tb {
            let (ls, n, r) = inscattered(&ctx, t0, rng);
            rng = r;
            lookups += n;
            let f_over_mu_t = albedo * ls * mu0 / p0; // f(t0) / p0 without T(t0)
            let c0 = match which {
                Integrator::Equiangular
                | Integrator::MisJackknife
                | Integrator::MisNaive
                | Integrator::MisPowerJackknife => {
                    // Weight from one pair of estimates on [ta, t0], T̂(t0) from independent ones.
                    let w0 = if which == Integrator::Equiangular {
                        1.0
                    } else {
                        let (est, r) = depth_pair(vol, &ray, ta, t0, params.n, ctx.lookup, rng);
                        rng = r;
                        lookups += est.samples;
                        match which {
                            Integrator::MisJackknife => {
                                Mobius::other_weight(mu0, p0).jackknife(est.x0, est.x1)
                            }
                            Integrator::MisNaive => {
                                Mobius::other_weight(mu0, p0).naive(est.x0, est.x1)
                            }
                            _ => power_weight(mu0, p0, &est, true),
                        }
                    };
                    let (t_hat, n, r) = if params.t_hat == TransmittanceHat::Ratio as u32 {
                        ratio_tracking(vol, &ray, ta, t0, ctx.lookup, rng)
                    } else {
                        let (est, r) = depth_pair(vol, &ray, ta, t0, params.n, ctx.lookup, rng);
                        (transmittance::jackknife(est.x0, est.x1), est.samples, r)
                    };
                    rng = r;
                    lookups += n;
                    w0 * t_hat * f_over_mu_t
                }
                Integrator::CombinedJackknife | Integrator::CombinedNaive => {
                    // Eq. 10: T mu / (p0 + T mu) * albedo * Ls estimated in one go.
                    let (est, r) = depth_pair(vol, &ray, ta, t0, params.n, ctx.lookup, rng);
                    rng = r;
                    lookups += est.samples;
                    let g = Mobius::free_flight_weight(mu0, p0);
                    let w = if which == Integrator::CombinedJackknife {
                        g.jackknife(est.x0, est.x1)
                    } else {
                        g.naive(est.x0, est.x1)
                    };
                    w * albedo * ls
                }
                Integrator::Miller => {
                    let (p_hat, n, r) = ratio_tracking(vol, &ray, ta, t0, ctx.lookup, rng);
                    rng = r;
                    lookups += n;
                    let q = mu0 * p_hat;
                    if q + p0 > 0.0 {
                        albedo * ls * q / (q + p0)
                    } else {
                        0.0
                    }
                }
                _ => 0.0,
            };
            total += c0;
        }
    }

    // ---- Strategy 1: free-flight sample t1 (delta tracking) ----
    let uses_ff = which != Integrator::Equiangular;
    if uses_ff {
        let (t1, mu1, found, null_product, n, r) = free_flight(&ctx, rng);
        rng = r;
        lookups += n;
        if found {
            let (ls, n, r) = inscattered(&ctx, t1, rng);
            rng = r;
            lookups += n;
            let p0 = ctx.eq.pdf(t1);
            let w1 = match which {
                Integrator::FreeFlight => 1.0,
                Integrator::Miller => {
                    let q = mu1 * null_product;
                    if q + p0 > 0.0 {
                        q / (q + p0)
                    } else {
                        0.0
                    }
                }
                _ => {
                    let (est, r) = depth_pair(vol, &ray, ta, t1, params.n, ctx.lookup, rng);
                    rng = r;
                    lookups += est.samples;
                    let g = Mobius::free_flight_weight(mu1, p0);
                    match which {
                        Integrator::MisNaive | Integrator::CombinedNaive => g.naive(est.x0, est.x1),
                        Integrator::MisPowerJackknife => power_weight(mu1, p0, &est, false),
                        _ => g.jackknife(est.x0, est.x1),
                    }
                }
            };
            total += w1 * albedo * ls;
        }
    }
    (total, lookups, rng)
}
