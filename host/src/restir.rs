//! `--integrator restir`: its options, their checks, and what it records in the JSON.

use anyhow::{ensure, Result};
use shared::params::{RenderParams, RestirTarget};

/// Most candidates per sample (each is a dispatch on the GPU).
pub const MAX_CANDIDATES: u32 = 1024;
/// Most samples per optical depth estimate of the target (as `--n`).
pub const MAX_TARGET_N: u32 = 4096;

/// The options of `restir` (`--restir-*`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestirOptions {
    /// Light candidates per camera sample, M.
    pub candidates: u32,
    /// The transmittance factor of the target p̂.
    pub target: RestirTarget,
    /// Samples per optical depth estimate of the target's jackknife.
    pub n: u32,
    /// Floor on the target's T̂.
    pub floor: f32,
}

impl Default for RestirOptions {
    fn default() -> Self {
        RestirOptions {
            candidates: 32,
            target: RestirTarget::Jackknife,
            n: 4,
            floor: 0.05,
        }
    }
}

/// Target names of `--restir-target`.
pub const TARGETS: &[(&str, RestirTarget)] = &[
    ("jackknife", RestirTarget::Jackknife),
    ("unshadowed", RestirTarget::Unshadowed),
    ("ratio", RestirTarget::Ratio),
];

/// Parses a `--restir-target` name.
pub fn parse_target(s: &str) -> Result<RestirTarget, String> {
    TARGETS
        .iter()
        .find(|(n, _)| *n == s)
        .map(|(_, t)| *t)
        .ok_or_else(|| {
            format!("unknown --restir-target {s:?}; choose one of: jackknife, unshadowed, ratio")
        })
}

/// The name of a target.
pub fn target_name(t: RestirTarget) -> &'static str {
    TARGETS
        .iter()
        .find(|(_, x)| *x == t)
        .map(|(n, _)| *n)
        .unwrap_or("jackknife")
}

impl RestirOptions {
    /// Refuses values the integrator cannot use, naming the flag.
    pub fn check(&self) -> Result<()> {
        ensure!(
            (1..=MAX_CANDIDATES).contains(&self.candidates),
            "--restir-candidates must be in 1..={MAX_CANDIDATES} (got {})",
            self.candidates
        );
        ensure!(
            (1..=MAX_TARGET_N).contains(&self.n),
            "--restir-n must be in 1..={MAX_TARGET_N} (got {})",
            self.n
        );
        ensure!(
            self.floor.is_finite() && self.floor > 0.0 && self.floor <= 1.0,
            "--restir-floor must be in (0, 1] (got {}): the target must stay positive wherever \
             the integrand is, or the estimate would be biased",
            self.floor
        );
        Ok(())
    }

    /// Writes the options into the render parameters.
    pub fn apply(&self, params: &mut RenderParams) {
        params.restir_candidates = self.candidates;
        params.restir_target = self.target as u32;
        params.restir_n = self.n;
        params.restir_floor = self.floor;
    }

    /// The JSON record.
    pub fn settings(&self) -> RestirSettings {
        RestirSettings {
            candidates: self.candidates,
            target: target_name(self.target).into(),
            target_n: self.n,
            target_floor: self.floor,
        }
    }
}

/// `restir`'s settings in the render JSON.
#[derive(serde::Serialize, Clone, Debug)]
pub struct RestirSettings {
    /// Light candidates per camera sample (M), drawn by power.
    pub candidates: u32,
    /// The target's transmittance factor: `jackknife`, `unshadowed` or `ratio`.
    pub target: String,
    /// Samples per optical depth estimate of the target's jackknife.
    pub target_n: u32,
    /// Floor on the target's T̂ (clamped to [floor, 1]).
    pub target_floor: f32,
}
