//! Flags of `host probe`.

use super::parsers::{f32_in, BackendArg};
use clap::Args;
use lab::probe::ProbeOptions;

/// Flags of `host probe`.
#[derive(Args, Debug, Clone)]
pub struct ProbeArgs {
    /// Where kernels run.
    #[arg(long, value_enum, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// Number of (X0, X1) pairs, 1 to 2^26.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1 << 20, value_parser = clap::value_parser!(u32).range(1..=1 << 26))]
    pub count: u32,
    /// True optical depth tau of the simulated estimates, 0 to 20.
    #[arg(long, default_value_t = 2.0, allow_hyphen_values = true, value_parser = f32_in(0.0, 20.0))]
    pub tau: f32,
    /// Standard deviation sigma of each simulated optical depth estimate, 0 to 10.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = f32_in(0.0, 10.0))]
    pub sigma: f32,
    /// Seed, 0 to 2^32 - 1.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    pub seed: u32,
}

impl ProbeArgs {
    /// The library's probe options.
    pub fn options(&self) -> ProbeOptions {
        ProbeOptions {
            backend: self.backend.into(),
            count: self.count,
            tau: self.tau,
            sigma: self.sigma,
            seed: self.seed,
        }
    }
}
