//! Optical depth estimation along a ray: Alg. 2 (preparation) and Alg. 1 (two interleaved,
//! stratified, importance-sampled estimates with the mu_min control variate), Sec. 4.

use crate::estimators::lane_volume::ScalarVolume;
use crate::estimators::wide::{self, WidePlan, WidePrep};
pub use crate::estimators::wide::{Prep, Strata, MAX_ADAPTIVE_STRATA};
use crate::geometry::Ray;
use crate::lanes::One;
use crate::params::{Importance, Jitter};
use crate::rng::HashRng;
use crate::tally::Tally;
use crate::volume::grid::{Lookup, VolumeView};
use crate::volume::texels::Texels;

/// Alg. 2: one DDA over the super-voxels of [t0, t1], summing (t_{n+1} - t_n) P into F and recording
/// the entry of the first and the exit of the last super-voxel with P != 0 (one lane of
/// [`wide::prepare`]).
#[inline]
pub fn prepare(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    mode: Importance,
) -> Prep {
    let lookup = Lookup::from_u32(vol.desc.lookup);
    let scalar = ScalarVolume { view: *vol, lookup };
    wide::prepare::<One, _>(&scalar, ray, t0, t1, true, mode, false).lane(0)
}

/// [`prepare`], also summing the bricks' means into [`Prep::tau_mean`] (the shadow rays'
/// roulette, [`crate::integrators::shadow_roulette`]).
#[inline]
pub fn prepare_with_mean(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    mode: Importance,
) -> Prep {
    let lookup = Lookup::from_u32(vol.desc.lookup);
    let scalar = ScalarVolume { view: *vol, lookup };
    wide::prepare::<One, _>(&scalar, ray, t0, t1, true, mode, true).lane(0)
}

/// Two optical depth estimates of one ray and the number of high-resolution lookups they took.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DepthPairEstimate {
    pub x0: f32,
    pub x1: f32,
    pub samples: u32,
    /// Whether a traversal's iteration budget cut a brick traversal of Alg. 2 or Alg. 1 short.
    pub capped: bool,
}

impl DepthPairEstimate {
    /// The lookups taken, and the capped flag.
    #[inline]
    pub fn tally(&self) -> Tally {
        Tally::lookups(self.samples).capped_if(self.capped)
    }
}

/// Alg. 1: two i.i.d. optical depth estimates with N samples each (CDF step F_delta = F / N),
/// stratified or uniform jitter, over the tight segment of `prep`. Every estimate takes exactly
/// N samples whenever F > 0; with F = 0 both estimates are exactly 0 and no sample is taken.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn estimate_pair(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    prep: &Prep,
    n: u32,
    mode: Importance,
    jitter: Jitter,
    lookup: Lookup,
    rng: HashRng,
) -> (DepthPairEstimate, HashRng) {
    let plan = Strata::fixed(prep, n, n);
    estimate_interleaved(vol, ray, prep, &plan, mode, jitter, lookup, rng)
}

/// One optical depth estimate with N samples (m = 1), as Alg. 1 with a single estimate: x0 (x1
/// is 0).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn estimate_single(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    prep: &Prep,
    n: u32,
    mode: Importance,
    jitter: Jitter,
    lookup: Lookup,
    rng: HashRng,
) -> (DepthPairEstimate, HashRng) {
    let plan = Strata::fixed(prep, n, 0);
    estimate_interleaved(vol, ray, prep, &plan, mode, jitter, lookup, rng)
}

/// Alg. 1 with a constant CDF step F_delta (the paper's adaptive variant, Fig. 8d): the sample
/// count grows with the importance integral F; the last, partial stratum is sampled only when
/// its jittered target falls below F, which keeps the estimate unbiased.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn estimate_pair_adaptive(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    prep: &Prep,
    f_delta: f32,
    mode: Importance,
    jitter: Jitter,
    lookup: Lookup,
    rng: HashRng,
) -> (DepthPairEstimate, HashRng) {
    let plan = Strata::adaptive(prep, f_delta);
    estimate_interleaved(vol, ray, prep, &plan, mode, jitter, lookup, rng)
}

/// True when the adaptive variant reaches [`MAX_ADAPTIVE_STRATA`] strata and widens its step
/// (fewer samples than F / F_delta: the ray is counted as capped).
#[inline]
pub fn adaptive_capped(prep: &Prep, f_delta: f32) -> bool {
    f_delta > 0.0 && prep.f > f_delta * MAX_ADAPTIVE_STRATA as f32
}

/// True when an estimate of the adaptive variant took no sample although the ray has importance:
/// with F <= F_delta each estimate has one partial stratum, sampled with probability F / F_delta,
/// and one without its sample is the control variate alone. The pair's S (Eq. 4) then says
/// nothing of the estimates' spread and the jackknife's normal model does not hold, so the ray
/// counts as outside the regime (`samples`: both estimates' samples).
#[inline]
pub fn adaptive_unsampled(prep: &Prep, f_delta: f32, samples: u32) -> bool {
    (prep.f > 0.0) & (Strata::adaptive(prep, f_delta).n0 == 1) & (samples < 2)
}

/// The shared loop of Alg. 1: up to two interleaved estimates over one DDA (Sec. 4.3): one lane
/// of [`wide::estimate_pair`].
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn estimate_interleaved(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    prep: &Prep,
    plan: &Strata,
    mode: Importance,
    jitter: Jitter,
    lookup: Lookup,
    rng: HashRng,
) -> (DepthPairEstimate, HashRng) {
    let scalar = ScalarVolume { view: *vol, lookup };
    let lanes = WidePlan::<One>::of(|_| *plan, plan.adaptive);
    let prep = WidePrep::<One>::splat(prep);
    let est =
        wide::estimate_pair::<One, _>(&scalar, ray, &prep, true, &lanes, mode, jitter, rng.state);
    let pair = DepthPairEstimate {
        x0: est.x0,
        x1: est.x1,
        samples: est.samples,
        capped: est.capped,
    };
    (pair, HashRng { state: est.rng })
}
