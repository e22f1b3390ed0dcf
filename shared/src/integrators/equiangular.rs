//! Strategy 0 of Eq. 9/10: a distance sampled equiangularly toward the light.

use super::context::{mu_on_ray, Context};
use crate::estimators::tracking::FreeFlight;
use crate::rng::HashRng;
use crate::tally::Tally;
use crate::volume::texels::Texels;

/// Strategy 0 of Eq. 9/10: an equiangular sample t0 toward the light and the extinction there,
/// as a [`FreeFlight`] (`found` when its density p0 and mu(t0) are positive and t0 lies inside
/// (ta, tb); `null_product` unused). Returns (sample, p0, rng).
#[inline]
pub(super) fn equiangular_sample(
    ctx: &Context<impl Texels>,
    rng: HashRng,
) -> (FreeFlight, f32, HashRng) {
    let (u, rng) = rng.next_f32();
    let (t0, p0) = ctx.eq.sample(u);
    let (mu0, rng) = mu_on_ray(ctx, t0, rng);
    let sample = FreeFlight {
        t: t0,
        mu: mu0,
        found: p0 > 0.0 && mu0 > 0.0 && t0 > ctx.ta && t0 < ctx.tb,
        null_product: 0.0,
        tally: Tally::lookups(1),
    };
    (sample, p0, rng)
}
