//! `host study`: the paper's statistical experiments (Table 1, Fig. 2-7, App. A) on the CPU.
//!
//! Every study splits its trials into chunks with their own seeded generator and merges the chunk
//! results in chunk order, so `--seed` fixes the numbers whatever `--threads` is. Studies of the
//! m = 2 estimators the renderer runs (`normal`, `distributions`, `mis-bias`) call the `shared` f32
//! code on f32-rounded inputs; the ray marching studies (`profile`, `table1`, `histogram`,
//! `convergence`) need Eq. 3 for any m and work in f64 throughout (`umvu`). Statistics are f64.

pub mod commands;
pub mod convergence;
pub mod distributions;
pub mod files;
pub mod histogram;
pub mod mis_bias;
pub mod normal;
pub mod plot;
pub mod profile;
pub mod profile_study;
pub mod rng;
pub mod stats;
pub mod table1;
pub mod umvu;

use distributions::Distribution;
use files::Output;
use profile::Sampling;

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

/// One study and its thread count.
#[derive(Debug, Clone)]
pub struct StudyOptions {
    pub command: Study,
    /// Worker threads (None: all cores); the results do not depend on it.
    pub threads: Option<usize>,
}

/// The studies.
#[derive(Debug, Clone)]
pub enum Study {
    /// Eq. 4 and exp(-X̄) for m = 2 normal estimates next to App. A's closed forms (Fig. 3).
    Normal(NormalOptions),
    /// Eq. 4 and exp(-X̄) for non-normal estimates: uniform, Laplace, exponential, ... (Fig. 2).
    Distributions(DistributionsOptions),
    /// Stratified vs uniform jittered estimates on a profile: depth and Eq. 3 statistics.
    Profile(ProfileOptions),
    /// Eq. 3 with m estimates of N = total / m samples vs exp(-X) with all of them (Table 1).
    Table1(Table1Options),
    /// Histograms of optical depth estimates with fitted normal densities (Fig. 4, 6).
    Histogram(HistogramOptions),
    /// RMSE of optical depth estimates over the sample count, log-log (Fig. 5).
    Convergence(ConvergenceOptions),
    /// Bias of jackknife and naive MIS weight estimates over (tau, sigma) (Fig. 7).
    MisBias(MisBiasOptions),
}

#[derive(Debug, Clone)]
pub struct NormalOptions {
    /// Optical depth tau (the mean of each estimate), 0 to 20.
    pub tau: f64,
    /// Standard deviation sigma of each of the two estimates, 0 to 10.
    pub sigma: f64,
    /// Trials (independent transmittance estimates), 2 to 10^10.
    pub trials: u64,
    /// Trials per sigma of the measured rRMSE dots of the plot, 2 to 10^10 (0: none).
    pub sweep_trials: u64,
    pub out: Output,
}

#[derive(Debug, Clone)]
pub struct DistributionsOptions {
    /// Optical depth tau (the mean of every estimate), 0 to 20.
    pub tau: f64,
    /// Largest sigma of the sweep, in (0, 10]. Heavy tails: exp(-X̄) has infinite variance from
    /// sigma = 1 on for exponential-left and from sqrt(2) on for Laplace.
    pub sigma_max: f64,
    /// Sigma values from sigma_max / points to sigma_max, 1 to 1000.
    pub points: usize,
    /// Trials per (distribution, sigma), 2 to 10^10.
    pub trials: u64,
    /// Distributions [default: all].
    pub dist: Vec<Distribution>,
    pub out: Output,
}

/// `--profile`: a built-in name or a CSV file of `t,mu` points.
#[derive(Debug, Clone)]
pub struct ProfileFlag {
    /// Extinction profile: `smooth`, `cloud`, `sparse` (built in) or a CSV file of `t,mu` lines.
    pub profile: String,
}

#[derive(Debug, Clone)]
pub struct ProfileOptions {
    pub profile: ProfileFlag,
    /// Estimates per transmittance estimate (m, Eq. 3), 2 to 64.
    pub m: usize,
    /// Ray marching samples per estimate, 1 to 10^6.
    pub n: usize,
    /// Trials (independent transmittance estimates), 2 to 10^10.
    pub trials: u64,
    /// Histogram bins of the plot, 1 to 10000.
    pub bins: usize,
    pub out: Output,
}

#[derive(Debug, Clone)]
pub struct Table1Options {
    pub profile: ProfileFlag,
    /// Samples per transmittance estimate, m N, 2 to 1024.
    pub total: usize,
    /// Smallest N of a row, 1 to --total / 2 (3 gives the paper's rows m = 2, 3, 4, 6, 8 for 24).
    pub min_n: usize,
    /// Ray marching of every row: stratified or uniform.
    pub sampling: Sampling,
    /// Trials (independent transmittance estimates), 2 to 10^10.
    pub trials: u64,
    pub out: Output,
}

#[derive(Debug, Clone)]
pub struct HistogramOptions {
    pub profile: ProfileFlag,
    /// Sample counts N (columns), each 1 to 10^6, at most 16 of them.
    pub n: Vec<usize>,
    /// Sampling schemes (rows): uniform, stratified or iid (midpoint is deterministic).
    pub sampling: Vec<Sampling>,
    /// Estimates per histogram, 2 to 2 x 10^7 (each is kept in memory).
    pub trials: u64,
    /// Histogram bins, 1 to 10000.
    pub bins: usize,
    pub out: Output,
}

#[derive(Debug, Clone)]
pub struct ConvergenceOptions {
    pub profile: ProfileFlag,
    /// Largest sample count N, 1 to 10^6.
    pub max_n: usize,
    /// Sample counts, log-spaced from 1 to max-n, 2 to 1000.
    pub points: usize,
    /// Estimates per (sampling, N), 2 to 10^8 (the paper uses 10^4).
    pub trials: u64,
    /// Sampling schemes (curves).
    pub sampling: Vec<Sampling>,
    pub out: Output,
}

#[derive(Debug, Clone)]
pub struct MisBiasOptions {
    /// u0,u1,v0,v1 of g(tau) = (u0 e^-tau + u1) / (v0 e^-tau + v1) (Eq. 11): four finite
    /// numbers in [-10^6, 10^6]; v0 and v1 not both 0.
    pub g: Vec<f32>,
    /// Largest tau of the grid, in (0, 20].
    pub tau_max: f64,
    /// Largest sigma of the grid, in (0, 10].
    pub sigma_max: f64,
    /// Grid cells along tau, 1 to 1024.
    pub nx: usize,
    /// Grid cells along sigma, 1 to 1024.
    pub ny: usize,
    /// Trials per cell, 2 to 10^9.
    pub trials: u64,
    /// Bias at which the colour saturates, in (0, 10^6].
    pub limit: f64,
    pub out: Output,
}
