//! The named estimator variants of the CLI: each is an [`Estimator`] plus its settings.

use shared::params::Estimator;
use shared::params::RenderParams;
use shared::params::{Importance, Jitter};

/// One selectable transmittance estimator.
#[derive(Clone, Copy, Debug)]
pub struct EstimatorSpec {
    /// CLI and JSON name.
    pub name: &'static str,
    pub estimator: Estimator,
    pub importance: Importance,
    pub jitter: Jitter,
    /// Kettunen ray marching sample-count multiplier.
    pub rm_scale: f32,
    /// Unbiased for the nearest-neighbour (or filtered) volume.
    pub unbiased: bool,
    /// One line for `--help` and reports.
    pub about: &'static str,
}

const fn spec(
    name: &'static str,
    estimator: Estimator,
    importance: Importance,
    jitter: Jitter,
    rm_scale: f32,
    unbiased: bool,
    about: &'static str,
) -> EstimatorSpec {
    EstimatorSpec {
        name,
        estimator,
        importance,
        jitter,
        rm_scale,
        unbiased,
        about,
    }
}

use Estimator as E;
use Importance::{Mean, VarianceAware as Var};
use Jitter::{Stratified as Strat, Uniform as Unif};

/// Every estimator variant, the paper's method first.
pub const ESTIMATORS: &[EstimatorSpec] = &[
    spec(
        "jackknife",
        E::Jackknife,
        Var,
        Strat,
        1.0,
        false,
        "jackknife cos(S) exp(-X̄), m = 2 (Eq. 4; ours)",
    ),
    spec(
        "naive",
        E::NaiveMean,
        Var,
        Strat,
        1.0,
        false,
        "naive exp(-X̄) of the same two estimates",
    ),
    spec(
        "naive-m1",
        E::NaiveSingle,
        Var,
        Strat,
        1.0,
        false,
        "naive exp(-X) of one estimate with all 2N samples (Fig. 8c: same sample count; same importance and stratified jitter)",
    ),
    spec(
        "jackknife-adaptive",
        E::JackknifeAdaptive,
        Var,
        Strat,
        1.0,
        false,
        "jackknife with constant CDF step --f-delta (default 0.6, Fig. 8d)",
    ),
    spec(
        "jackknife-mean",
        E::Jackknife,
        Mean,
        Strat,
        1.0,
        false,
        "jackknife, mean importance, no control variate (Fig. 9 ablation)",
    ),
    spec(
        "jackknife-uniform",
        E::Jackknife,
        Var,
        Unif,
        1.0,
        false,
        "jackknife with uniform instead of stratified jitter",
    ),
    spec(
        "biased-rm",
        E::BiasedRayMarching,
        Mean,
        Unif,
        1.0,
        false,
        "Kettunen et al. biased ray marching, N = round(N_CMF / 1.31945) samples (author's count)",
    ),
    spec(
        "biased-rm2",
        E::BiasedRayMarching,
        Mean,
        Unif,
        2.0,
        false,
        "biased ray marching, N = round(2 N_CMF / 1.31945) (Fig. 8b: doubled)",
    ),
    spec(
        "unbiased-rm",
        E::UnbiasedRayMarching,
        Mean,
        Unif,
        1.0,
        true,
        "Kettunen et al. unbiased ray marching (degree <= 8)",
    ),
    spec(
        "unbiased-rm2",
        E::UnbiasedRayMarching,
        Mean,
        Unif,
        2.0,
        true,
        "unbiased ray marching with doubled sample count",
    ),
    spec(
        "track-length",
        E::TrackLength,
        Var,
        Strat,
        1.0,
        true,
        "track-length estimate (delta tracking, per-brick majorants)",
    ),
    spec(
        "ratio",
        E::RatioTracking,
        Var,
        Strat,
        1.0,
        true,
        "ratio tracking, per-brick majorants, no roulette (--ratio-roulette: pbrt-v4's)",
    ),
    spec(
        "telescoping",
        E::Telescoping,
        Var,
        Strat,
        1.0,
        true,
        "Misso et al. 2022 telescoping series over nested stratified estimates (N, 2N, 4N, ... \
         samples with the jackknife's importance and control variate), unbiased",
    ),
    spec(
        "telescoping-cycles",
        E::TelescopingCycles,
        Mean,
        Unif,
        1.0,
        false,
        "Blender Cycles 5.0's telescoping shadow rays: k = round(range x length) steps per merged \
         segment, order <= 4 (truncated: biased)",
    ),
    spec(
        "regular",
        E::RegularTracking,
        Var,
        Strat,
        1.0,
        true,
        "regular tracking: exact for nearest lookups (the reference)",
    ),
];

/// The variant called `name`.
pub fn by_name(name: &str) -> Option<&'static EstimatorSpec> {
    ESTIMATORS.iter().find(|s| s.name == name)
}

/// All names, comma-separated (for error messages).
pub fn names() -> String {
    ESTIMATORS
        .iter()
        .map(|s| s.name)
        .collect::<Vec<_>>()
        .join(", ")
}

impl EstimatorSpec {
    /// Writes this variant's settings into render parameters.
    pub fn apply(&self, params: &mut RenderParams) {
        params.estimator = self.estimator as u32;
        params.importance = self.importance as u32;
        params.jitter = self.jitter as u32;
        params.rm_scale = self.rm_scale;
    }
}

/// Parses an estimator name (the value parser of `--estimator`).
pub fn parse(name: &str) -> Result<&'static EstimatorSpec, String> {
    by_name(name).ok_or_else(|| format!("unknown estimator {name:?}; choose one of: {}", names()))
}
