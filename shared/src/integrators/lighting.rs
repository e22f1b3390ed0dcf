//! Light arriving at a point of the camera ray: shadow-ray transmittance (through the same
//! estimate as camera rays) and in-scattered radiance.

use super::context::{grid_hi, Context};
use crate::estimators::estimate;
use crate::geometry::{to_index_space, Ray, V3};
use crate::math::sqrt;
use crate::params::{Config, Estimator, Importance, Jitter};
use crate::rng::HashRng;
use crate::sampling::phase::phase_hg;
use crate::tally::Tally;
use crate::volume::dda::clip_to_box;
use crate::volume::texels::Texels;

/// Jackknife transmittance from world point x to the light (shadow ray, N per estimate).
pub(super) fn shadow_transmittance(
    ctx: &Context<impl Texels>,
    x: V3,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
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
    let (t0, t1) = clip_to_box(&ray, grid_hi(&ctx.vol), 0.0, dist);
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
    estimate::transmittance(&ctx.vol, &shadow, ctx.params, &ray, t0, t1, rng)
}

/// In-scattered radiance from the selected light at distance t, divided by the light's
/// selection probability: phase * I * T_shadow / d^2 / P(light).
pub(super) fn inscattered(
    ctx: &Context<impl Texels>,
    t: f32,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
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
