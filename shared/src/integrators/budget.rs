//! Upper bounds on the loop iterations one GPU invocation of a render takes, per family of
//! integrator ([`Integrator::family`]) and per estimator: the host plans its passes so that a
//! bound times the samples of a pass fits the device's loop budget (lavapipe ends a shader
//! silently after 65535 iterations summed over all its loops).

use super::stages::Wavefront;
use super::unit::Family;
use crate::estimators::ray_marching::{MAX_BIASED_SAMPLES, MAX_DEGREE, MAX_UNBIASED_SAMPLES};
use crate::estimators::telescoping::{MAX_CYCLES_SAMPLES, MAX_LEVEL, MAX_TELESCOPING_SAMPLES};
use crate::estimators::wide::MAX_ADAPTIVE_STRATA;
use crate::params::{Estimator, Integrator, RenderParams};
use crate::sampling::lights::MAX_LIGHTS;
use crate::volume::grid::GridDesc;

/// Loop iterations one high-resolution sample of Alg. 1 (and of the ray-marching baselines)
/// costs a GPU invocation: one of the sample loop and one for entering the brick loop inside it.
/// lavapipe's limiter is one counter per invocation, decremented at the end of every loop
/// iteration of any loop, also where no lane ran the body (a loop entered and left at once), so
/// a loop entry costs an iteration (measured: one ray of 8192 samples runs 16384; a jackknife
/// with --n 4096 at 7 spp per pass lost its later samples on lavapipe).
pub const ITERATIONS_PER_SAMPLE: u64 = 2;

/// Loop iterations of unbiased ray marching's power series besides its estimates: the degree's
/// roulette (<= MAX_DEGREE), then per pivot (<= MAX_DEGREE + 1) the symmetric means (one loop
/// entry and <= MAX_DEGREE iterations per offset) and the terms (P_j's loop each), about 1,600
/// for MAX_DEGREE = 8; rounded up.
const SERIES_ITERATIONS: u64 = 2_000;

/// Iterations outside the loops counted below (the entry point, the box clip).
const FIXED: u64 = 64;

/// Upper bound on the loop iterations one invocation of `params`' integrator (or, without
/// one, one primary ray of its estimator) takes on the grid `desc`.
pub fn loop_iterations_per_ray(params: &RenderParams, desc: &GridDesc) -> u64 {
    // One traversal of the super-voxels or voxels: the builder's bound from the occupied bricks
    // with empty-space skipping, or the stepping bound if smaller (the DDA's own budget), plus
    // the cells of subdivided bricks (adaptive super-voxels).
    let bricks = desc.brick_budget() as u64 + desc.cell_budget() as u64;
    let voxels = desc.voxel_budget() as u64;
    // A tracking loop: two iterations per tentative collision (the collision loop and the
    // sampler's), one sampler iteration per brick segment, and at the cap the completion by a
    // voxel DDA (two for free-flight sampling: the flight, then T up to it).
    let tracking = 2 * params.collision_cap() as u64 + bricks + 2 * voxels;
    let estimate = || {
        let mut e = *params;
        e.integrator = Integrator::Transmittance as u32;
        loop_iterations_per_ray(&e, desc)
    };
    match Integrator::from_u32(params.integrator).family() {
        // One bounce per invocation: a free flight, one shadow ray's estimate, a CDF search.
        Family::Lit(Wavefront::Path) => FIXED + tracking + estimate() + 32,
        // One invocation runs either the camera ray's free flight and two CDF searches, or one
        // transmittance estimate by the chosen estimator (restir: or one candidate's target
        // estimate, of at most as many loops: a jackknife of restir_n <= n samples or ratio
        // tracking under the same cap).
        Family::Lit(Wavefront::Direct | Wavefront::Restir) => {
            FIXED + tracking.max(estimate()) + 2 * 32
        }
        // Free-flight sampling and one ratio tracking (Miller, --t-hat ratio), up to four pairs
        // of estimates on the camera ray and two shadow rays, and two passes over the lights.
        Family::SingleScattering => {
            FIXED
                + 2 * tracking
                + 6 * (3 * bricks + 2 * ITERATIONS_PER_SAMPLE * params.n as u64)
                + 2 * MAX_LIGHTS as u64
        }
        Family::Transmittance => FIXED + estimator_iterations(params, bricks, voxels, tracking),
    }
}

/// The loops of one primary ray's estimate by `params`' estimator, given the iterations of one
/// brick traversal, one voxel traversal and one tracking loop.
fn estimator_iterations(params: &RenderParams, bricks: u64, voxels: u64, tracking: u64) -> u64 {
    use Estimator as E;
    match E::from_u32(params.estimator) {
        E::Jackknife | E::NaiveMean | E::NaiveSingle => {
            3 * bricks + 2 * ITERATIONS_PER_SAMPLE * params.n as u64
        }
        E::JackknifeAdaptive => 3 * bricks + 2 * ITERATIONS_PER_SAMPLE * MAX_ADAPTIVE_STRATA as u64,
        E::RegularTracking => voxels,
        E::BiasedRayMarching => 3 * bricks + ITERATIONS_PER_SAMPLE * MAX_BIASED_SAMPLES as u64,
        E::UnbiasedRayMarching => {
            let estimates = MAX_DEGREE as u64 + 1;
            bricks
                + estimates * (2 * bricks + ITERATIONS_PER_SAMPLE * MAX_UNBIASED_SAMPLES as u64)
                + SERIES_ITERATIONS
        }
        E::TrackLength | E::RatioTracking | E::FirstCollision => bricks + tracking,
        // Alg. 2's traversal, the sample walk and the control variate's rest (as the
        // jackknife's), each sample's level walk (<= MAX_LEVEL), and the series.
        E::Telescoping => {
            3 * bricks
                + (ITERATIONS_PER_SAMPLE + MAX_LEVEL as u64 + 1) * MAX_TELESCOPING_SAMPLES as u64
                + 4 * MAX_LEVEL as u64
        }
        // One traversal; per merged segment (at most one per brick) the order's loop, the
        // sample loop's entry and the loop over the N <= 16 marches; one iteration per sample.
        E::TelescopingCycles => bricks * (1 + 4 + 1 + 16 + 2) + MAX_CYCLES_SAMPLES as u64,
    }
}
