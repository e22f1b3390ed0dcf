//! Limits of the studies' inputs, shared by the CLI's flag parsers and the studies' own checks.

use anyhow::{bail, Result};

/// Most trials of a study whose estimates are streamed into moments (time is the only cost).
pub const MAX_TRIALS: u64 = 10_000_000_000;
/// Most trials of a histogram, which keeps every estimate (8 bytes each, twice while merging).
pub const MAX_HISTOGRAM_TRIALS: u64 = 20_000_000;
/// Most histogram bins.
pub const MAX_BINS: usize = 10_000;
/// Most ray marching samples per estimate.
pub const MAX_SAMPLES: usize = 1_000_000;
/// Largest sigma of the normal-input studies (e^{sigma^2} of App. A stays finite far beyond).
pub const MAX_SIGMA: f64 = 10.0;
/// Largest optical depth tau of the studies' inputs: their m = 2 estimators run in f32, where
/// T = e^-tau and its spread leave the normal range from tau ~ 60 (e^-87) on.
pub const MAX_TAU: f64 = 20.0;

/// Standard errors need two trials at least.
pub fn check_trials(trials: u64) -> Result<()> {
    if trials < 2 {
        bail!("--trials must be at least 2");
    }
    Ok(())
}
