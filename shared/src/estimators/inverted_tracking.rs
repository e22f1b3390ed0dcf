//! The free flight of a path vertex under a stratified sampler: delta tracking whose
//! real-collision tests share one uniform xi. Delta tracking accepts tentative collision k with
//! probability p_k = mu_k / sigma_maj, an independent test each; here the flight collides at the
//! first tentative collision where the product P_k of the null-collision probabilities
//! (1 - p_j), j <= k (ratio tracking's running estimate of T) falls below xi. Given the
//! tentative collisions, P(collision at k) = P_(k-1) - P_k = p_k P_(k-1), as for delta tracking,
//! so the distances have exactly delta tracking's distribution (and cost); but collision or
//! escape is now a monotone function of xi (escape iff xi <= P_K), so a stratified xi stratifies
//! it, which independent tests lose after the first tentative collision.

use crate::estimators::lane_volume::mu_at;
use crate::estimators::tracking::{delta_tracking_capped, exact_free_flight, FreeFlight};
use crate::geometry::Ray;
use crate::math;
use crate::rng::HashRng;
use crate::sampling::exponential::MajorantSampler;
use crate::sampling::sampler::Lead;
use crate::tally::Tally;
use crate::volume::grid::{Lookup, VolumeView};
use crate::volume::texels::Texels;

/// The free flight of a path vertex over [t0, t1]: [`inverted_delta_tracking`] led by the
/// sampler's free-flight pattern when the sampler is on; delta tracking with every number from
/// the generator when it is off (the numbers of a render without a sampler).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn vertex_flight(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    lookup: Lookup,
    salt: u32,
    cap: u32,
    lead: Lead,
    rng: HashRng,
) -> (FreeFlight, HashRng) {
    if lead.on != 0 {
        inverted_delta_tracking(vol, ray, t0, t1, lookup, salt, cap, lead, rng)
    } else {
        delta_tracking_capped(vol, ray, t0, t1, lookup, salt, cap, true, rng)
    }
}

/// Delta tracking over [t0, t1] with one uniform xi for all real-collision tests (see the module
/// doc): xi is `lead`'s first uniform and the first tentative collision's exponential its second
/// (or both the generator's when `lead` is off); every later exponential comes from the
/// generator. `null_product` is the product of (1 - mu / sigma_maj) before the collision, as
/// delta tracking's. At `cap` lookups the flight continues exactly in the nearest-neighbour
/// grid from its last tentative collision with the uniform xi / P that is left (uniform given
/// that xi <= P), as delta tracking continues there, and is counted as capped.
#[allow(clippy::too_many_arguments)]
pub fn inverted_delta_tracking(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    lookup: Lookup,
    salt: u32,
    cap: u32,
    lead: Lead,
    rng: HashRng,
) -> (FreeFlight, HashRng) {
    let (xi, rng) = lead.take(0, rng);
    let (u_first, rng) = lead.take(1, rng);
    let mut rng = rng;
    let mut sampler = MajorantSampler::new(vol, ray, t0, t1);
    let mut lookups = 0u32;
    let mut out = FreeFlight {
        null_product: 1.0,
        ..Default::default()
    };
    // P: the product of the null-collision probabilities so far.
    let mut p = 1.0f32;
    let mut t_last = t0;
    let mut first = true;
    while !sampler.done && lookups < cap {
        let (drawn, next) = rng.next_f32();
        let u = if first { u_first } else { drawn };
        let (c, drew) = sampler.next_collision_at(vol, u);
        rng = if !first && drew { next } else { rng };
        first = false;
        if c.found {
            let mu = mu_at(vol, ray.at(c.t), lookup, [rng.state, lookups, salt]);
            t_last = c.t;
            lookups += 1;
            let f = 1.0 - mu / c.sigma_maj;
            let p_next = p * if f > 0.0 { f } else { 0.0 };
            if p_next < xi {
                out.t = c.t;
                out.mu = mu;
                out.found = true;
                out.null_product = p;
                sampler.done = true;
            }
            p = p_next;
        }
    }
    out.tally = Tally::lookups(lookups).capped_if(sampler.capped());
    if !sampler.done {
        // The cap: xi <= P, so xi / P is uniform in [0, 1]; the rest collides where the exact
        // optical depth from t_last reaches -ln(xi / P).
        let rest = if p > 0.0 { xi / p } else { 0.0 };
        let flight = exact_free_flight(vol, ray, t_last, t1, -math::ln(rest));
        if flight.found {
            out.t = flight.t;
            out.mu = flight.mu;
            out.found = true;
            out.null_product = p;
        }
        out.tally = Tally::lookups(out.tally.lookups + flight.visited).capped_if(true);
    }
    (out, rng)
}
