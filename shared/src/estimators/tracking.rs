//! Baseline transmittance estimators: regular tracking (exact optical depth of the nearest-neighbour
//! voxel grid, the reference for nearest lookups), and track-length and ratio tracking over the
//! per-brick majorants (Novák et al. 2014), built on a majorant iterator and an exponential
//! free-flight sampler in the design of pbrt-v4 (`DDAMajorantIterator`, `SampleT_maj`).
//!
//! The sampler is a pull iterator rather than pbrt-v4's callback, so every loop is flat, bounded
//! and free of closures on the GPU.

use crate::estimators::lane_volume::mu_at;
use crate::geometry::Ray;
use crate::math;
use crate::rng::HashRng;
use crate::sampling::exponential::{Collision, MajorantSampler};
use crate::tally::Tally;
use crate::volume::dda::GridDda;
use crate::volume::grid::{Lookup, VolumeView};
use crate::volume::texels::Texels;

pub use crate::params::MAX_TENTATIVE_COLLISIONS;

/// Ratio tracking starts Russian roulette once the running estimate drops below this (pbrt-v4).
pub const RR_THRESHOLD: f32 = 0.05;

/// Probability q that Russian roulette terminates ratio tracking (pbrt-v4: terminate with
/// q = 0.75, otherwise divide by the survival probability 1 - q = 0.25).
pub const RR_TERMINATE: f32 = 0.75;

/// Salt of the stochastic-lookup jitter key of tracking (Alg. 1 uses another one).
pub(crate) const JITTER_SALT: u32 = 0x85eb_ca6b;

/// Exact optical depth of the nearest-neighbour grid over [t0, t1] (already clipped to the grid
/// box) by a voxel DDA (regular tracking): sum of segment length times voxel extinction, over
/// the voxels outside all-zero cubes of bricks (skipped: they add exactly 0). Returns (tau,
/// tally: the voxels read, capped if the traversal's budget ended it).
pub fn regular_tracking_tau(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
) -> (f32, Tally) {
    let mut tau = 0.0f32;
    let mut visited = 0u32;
    let mut dda = GridDda::voxels(&vol.desc, ray, t0, t1);
    while !dda.done() {
        let (seg, read) = dda.step_voxel(vol);
        if read {
            tau += (seg.t1 - seg.t0) * vol.voxel(seg.cell[0], seg.cell[1], seg.cell[2]);
            visited += 1;
        }
    }
    (tau, Tally::lookups(visited).capped_if(dda.exhausted()))
}

/// Track-length estimator (delta tracking, Novák et al. 2014; pbrt-v4): 0 if the free flight
/// of [`delta_tracking`] meets a real collision before t1, 1 if it escapes. Returns
/// (T, tally, rng).
#[inline]
pub fn track_length(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    lookup: Lookup,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    track_length_capped(vol, ray, t0, t1, lookup, MAX_TENTATIVE_COLLISIONS, rng)
}

/// [`track_length`] with a collision cap `cap` (at most [`MAX_TENTATIVE_COLLISIONS`]).
pub fn track_length_capped(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    lookup: Lookup,
    cap: u32,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let (flight, rng) =
        delta_tracking_capped(vol, ray, t0, t1, lookup, JITTER_SALT, cap, false, rng);
    (if flight.found { 0.0 } else { 1.0 }, flight.tally, rng)
}

/// A free-flight distance sampled by delta tracking, and the product of the null-collision
/// probabilities before it (Miller et al.'s estimate of T(t)).
#[derive(Clone, Copy, Debug, Default)]
pub struct FreeFlight {
    /// Distance of the real collision (when `found`).
    pub t: f32,
    /// Extinction there.
    pub mu: f32,
    /// False when the flight escaped past t1.
    pub found: bool,
    /// Product of (1 - mu / sigma_maj) over the null collisions before t: ratio tracking's
    /// estimate of T(t) without roulette.
    pub null_product: f32,
    /// Lookups, and whether the collision cap was reached.
    pub tally: Tally,
}

/// The next tentative collision of `sampler` and, when one is found, the extinction there
/// (jitter key: the rng state after the collision, the lookup's number `lookups`, `salt`; 0
/// otherwise). The one lookup step of delta and ratio tracking. Returns (collision, mu, rng).
#[inline]
fn next_lookup(
    sampler: &mut MajorantSampler,
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    lookup: Lookup,
    salt: u32,
    lookups: u32,
    rng: HashRng,
) -> (Collision, f32, HashRng) {
    let (c, rng) = sampler.next_collision(vol, rng);
    let mut mu = 0.0f32;
    if c.found {
        mu = mu_at(vol, ray.at(c.t), lookup, [rng.state, lookups, salt]);
    }
    (c, mu, rng)
}

/// Delta tracking over [t0, t1] (Woodcock; pbrt-v4's `SampleT_maj` with the real-collision
/// test): the one free-flight sampler of the track-length estimator and of free-flight distance
/// sampling. `salt` decorrelates the stochastic-lookup jitter of its users. At the collision cap
/// the flight continues exactly in the nearest-neighbour grid ([`exact_free_flight`];
/// memoryless, so the distance keeps its distribution), the null product takes the exact T of
/// that part, and the ray is counted as capped.
#[inline]
pub fn delta_tracking(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    lookup: Lookup,
    salt: u32,
    rng: HashRng,
) -> (FreeFlight, HashRng) {
    delta_tracking_capped(
        vol,
        ray,
        t0,
        t1,
        lookup,
        salt,
        MAX_TENTATIVE_COLLISIONS,
        true,
        rng,
    )
}

/// [`delta_tracking`] with a collision cap `cap` (at most [`MAX_TENTATIVE_COLLISIONS`]). With
/// `null_product` false, a flight completed exactly at the cap leaves `null_product` as it
/// stood at the cap, without the regular-tracking pass that completes it (the track-length
/// estimator reads only `found`; a constant at every call, so the pass is compiled out where it
/// is not wanted).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn delta_tracking_capped(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    lookup: Lookup,
    salt: u32,
    cap: u32,
    null_product: bool,
    rng: HashRng,
) -> (FreeFlight, HashRng) {
    let mut sampler = MajorantSampler::new(vol, ray, t0, t1);
    let mut rng = rng;
    let mut lookups = 0u32;
    let mut out = FreeFlight {
        null_product: 1.0,
        ..Default::default()
    };
    let mut t_last = t0;
    while !sampler.done && lookups < cap {
        let (c, m, r) = next_lookup(&mut sampler, vol, ray, lookup, salt, lookups, rng);
        rng = r;
        if c.found {
            t_last = c.t;
            lookups += 1;
            let (u, r) = rng.next_f32();
            rng = r;
            if u < m / c.sigma_maj {
                out.t = c.t;
                out.mu = m;
                out.found = true;
                sampler.done = true;
            } else {
                let f = 1.0 - m / c.sigma_maj;
                out.null_product *= if f > 0.0 { f } else { 0.0 };
            }
        }
    }
    out.tally = Tally::lookups(lookups).capped_if(sampler.capped());
    if !sampler.done {
        let (u, r) = rng.next_f32();
        rng = r;
        let flight = exact_free_flight(vol, ray, t_last, t1, -math::ln(1.0 - u));
        if flight.found {
            if null_product {
                let (rest, visited) = complete_exactly(vol, ray, t_last, flight.t);
                out.null_product *= rest;
                out.tally.lookups += visited;
            }
            out.t = flight.t;
            out.mu = flight.mu;
            out.found = true;
        }
        out.tally = Tally::lookups(out.tally.lookups + flight.visited).capped_if(true);
    }
    (out, rng)
}

/// Ratio tracking (Novák et al. 2014): product of (1 - mu / sigma_maj) over tentative
/// collisions; without roulette as in the paper and the author's code, or with pbrt-v4's Russian
/// roulette below [`RR_THRESHOLD`] when `roulette` is set. Returns (T, tally, rng).
#[inline]
pub fn ratio_tracking(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    lookup: Lookup,
    roulette: bool,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    ratio_tracking_capped(
        vol,
        ray,
        t0,
        t1,
        lookup,
        roulette,
        MAX_TENTATIVE_COLLISIONS,
        rng,
    )
}

/// [`ratio_tracking`] with a collision cap `cap` (at most [`MAX_TENTATIVE_COLLISIONS`]).
#[allow(clippy::too_many_arguments)]
pub fn ratio_tracking_capped(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    lookup: Lookup,
    roulette: bool,
    cap: u32,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let mut sampler = MajorantSampler::new(vol, ray, t0, t1);
    let mut rng = rng;
    let mut transmittance = 1.0f32;
    let mut lookups = 0u32;
    let mut t_last = t0;
    while !sampler.done && lookups < cap {
        let (c, mu, r) = next_lookup(&mut sampler, vol, ray, lookup, JITTER_SALT, lookups, rng);
        rng = r;
        if c.found {
            t_last = c.t;
            lookups += 1;
            let (t, r, stop) = ratio_step(transmittance, mu, c.sigma_maj, roulette, rng);
            transmittance = t;
            rng = r;
            if stop {
                sampler.done = true;
            }
        }
    }
    let mut tally = Tally::lookups(lookups).capped_if(sampler.capped());
    if !sampler.done {
        // At the collision cap: the rest's expected factor given the collisions so far is T of
        // the rest (memoryless), exactly known for nearest lookups.
        let (rest, visited) = complete_exactly(vol, ray, t_last, t1);
        transmittance *= rest;
        tally = Tally::lookups(lookups + visited).capped_if(true);
    }
    (transmittance, tally, rng)
}

/// The rest of a tracking estimate cut off at the collision cap: T(t_last, t1) of the
/// nearest-neighbour grid by regular tracking, whose work is bounded by the voxel count, not by
/// the density. Given the collisions so far, the remaining factor of both ratio tracking and the
/// track-length estimate has this expectation (the collision process is memoryless), so the
/// completed estimate stays unbiased for nearest lookups (approximate for stochastic ones).
/// Returns (T of the rest, voxels read).
#[inline]
pub fn complete_exactly(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t_last: f32,
    t1: f32,
) -> (f32, u32) {
    if !(t_last < t1) {
        return (1.0, 0);
    }
    // Called at the collision cap: the ray is counted as capped already.
    let (tau, tally) = regular_tracking_tau(vol, ray, t_last, t1);
    (math::exp(-tau), tally.lookups)
}

/// A free-flight distance sampled exactly in the nearest-neighbour grid by a voxel DDA: the
/// first t in [t0, t1] where the optical depth from t0 reaches `target` (an Exp(1) draw).
/// Used where delta tracking reaches the collision cap: work bounded by the voxel count.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExactFlight {
    /// Distance of the collision (when `found`).
    pub t: f32,
    /// Extinction of the voxel at `t`.
    pub mu: f32,
    /// False when the flight escaped past t1.
    pub found: bool,
    /// Voxels read (skipped all-zero cubes read none).
    pub visited: u32,
}

/// Samples [`ExactFlight`] over [t0, t1] with optical depth `target` (regular tracking).
pub fn exact_free_flight(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    target: f32,
) -> ExactFlight {
    let mut out = ExactFlight::default();
    if !(t0 < t1) {
        return out;
    }
    let mut tau = 0.0f32;
    let mut dda = GridDda::voxels(&vol.desc, ray, t0, t1);
    while !dda.done() && !out.found {
        let (seg, read) = dda.step_voxel(vol);
        if !read {
            // An all-zero cube: no collision, nothing added to tau.
            continue;
        }
        let mu = vol.voxel(seg.cell[0], seg.cell[1], seg.cell[2]);
        out.visited += 1;
        let dtau = (seg.t1 - seg.t0) * mu;
        if mu > 0.0 && tau + dtau >= target {
            let t = seg.t0 + (target - tau) / mu;
            out.t = if t < seg.t1 { t } else { seg.t1 };
            out.mu = mu;
            out.found = true;
        }
        tau += dtau;
    }
    out
}

/// One ratio tracking update: T *= max(0, 1 - mu / sigma_maj); with `roulette`, pbrt-v4's
/// Russian roulette below the threshold (terminate with probability q: T = 0; otherwise divide
/// by 1 - q). Returns (T, rng, stop).
#[inline]
pub fn ratio_step(
    transmittance: f32,
    mu: f32,
    sigma_maj: f32,
    roulette: bool,
    rng: HashRng,
) -> (f32, HashRng, bool) {
    let mut factor = 1.0 - mu / sigma_maj;
    // pbrt-v4 clamps the null density sigma_n to >= 0; majorants are conservative, so this only
    // guards against a lookup that rounds into a hotter voxel outside the brick's window.
    if !(factor > 0.0) {
        factor = 0.0;
    }
    let mut t = transmittance * factor;
    let mut rng = rng;
    if roulette && t > 0.0 && t < RR_THRESHOLD {
        let (u, r) = rng.next_f32();
        rng = r;
        if u < RR_TERMINATE {
            t = 0.0;
        } else {
            t /= 1.0 - RR_TERMINATE;
        }
    }
    (t, rng, !(t > 0.0))
}
