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

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
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

/// A value parser of finite numbers in `[lo, hi]`, for a flag's documented range.
pub fn finite_in(lo: f64, hi: f64) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync {
    move |s: &str| match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && (lo..=hi).contains(&v) => Ok(v),
        Ok(v) => Err(format!("must be a finite number in [{lo}, {hi}] (got {v})")),
        Err(e) => Err(format!("not a number: {e}")),
    }
}

/// A value parser of finite numbers in `(0, hi]`.
pub fn positive_up_to(hi: f64) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync {
    move |s: &str| match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= hi => Ok(v),
        Ok(v) => Err(format!("must be a finite number in (0, {hi}] (got {v})")),
        Err(e) => Err(format!("not a number: {e}")),
    }
}

/// A value parser of counts (usize) in `lo..=hi`.
pub fn count_in(lo: u64, hi: u64) -> clap::builder::RangedU64ValueParser<usize> {
    clap::builder::RangedU64ValueParser::<usize>::new().range(lo..=hi)
}

/// Flags of `host study`.
#[derive(Args, Debug, Clone)]
pub struct StudyArgs {
    #[command(subcommand)]
    pub command: StudyCommand,
    /// Worker threads, 1 to 1024 [default: all cores]; the results do not depend on it.
    #[arg(long, allow_hyphen_values = true, global = true, value_parser = count_in(1, 1024))]
    pub threads: Option<usize>,
}

/// The studies.
#[derive(Subcommand, Debug, Clone)]
pub enum StudyCommand {
    /// Eq. 4 and exp(-X̄) for m = 2 normal estimates next to App. A's closed forms (Fig. 3).
    Normal(NormalArgs),
    /// Eq. 4 and exp(-X̄) for non-normal estimates: uniform, Laplace, exponential, ... (Fig. 2).
    Distributions(DistributionsArgs),
    /// Stratified vs uniform jittered estimates on a profile: depth and Eq. 3 statistics.
    Profile(ProfileArgs),
    /// Eq. 3 with m estimates of N = total / m samples vs exp(-X) with all of them (Table 1).
    Table1(Table1Args),
    /// Histograms of optical depth estimates with fitted normal densities (Fig. 4, 6).
    Histogram(HistogramArgs),
    /// RMSE of optical depth estimates over the sample count, log-log (Fig. 5).
    Convergence(ConvergenceArgs),
    /// Bias of jackknife and naive MIS weight estimates over (tau, sigma) (Fig. 7).
    MisBias(MisBiasArgs),
}

#[derive(Args, Debug, Clone)]
pub struct NormalArgs {
    /// Optical depth tau (the mean of each estimate), 0 to 20.
    #[arg(long, allow_hyphen_values = true, default_value_t = 2.0, value_parser = finite_in(0.0, MAX_TAU))]
    pub tau: f64,
    /// Standard deviation sigma of each of the two estimates, 0 to 10.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1.0, value_parser = finite_in(0.0, MAX_SIGMA))]
    pub sigma: f64,
    /// Trials (independent transmittance estimates), 2 to 10^10.
    #[arg(long, allow_hyphen_values = true, default_value_t = 10_000_000, value_parser = clap::value_parser!(u64).range(2..=MAX_TRIALS))]
    pub trials: u64,
    /// Trials per sigma of the measured rRMSE dots of the plot, 2 to 10^10 (0: none).
    #[arg(long, allow_hyphen_values = true, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(0..=MAX_TRIALS))]
    pub sweep_trials: u64,
    #[command(flatten)]
    pub out: Output,
}

#[derive(Args, Debug, Clone)]
pub struct DistributionsArgs {
    /// Optical depth tau (the mean of every estimate), 0 to 20.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1.0, value_parser = finite_in(0.0, MAX_TAU))]
    pub tau: f64,
    /// Largest sigma of the sweep, in (0, 10]. Heavy tails: exp(-X̄) has infinite variance from
    /// sigma = 1 on for exponential-left and from sqrt(2) on for Laplace.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1.0, value_parser = positive_up_to(MAX_SIGMA))]
    pub sigma_max: f64,
    /// Sigma values from sigma_max / points to sigma_max, 1 to 1000.
    #[arg(long, allow_hyphen_values = true, default_value_t = 20, value_parser = count_in(1, 1000))]
    pub points: usize,
    /// Trials per (distribution, sigma), 2 to 10^10.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(2..=MAX_TRIALS))]
    pub trials: u64,
    /// Distributions [default: all].
    #[arg(long, value_enum, value_delimiter = ',')]
    pub dist: Vec<Distribution>,
    #[command(flatten)]
    pub out: Output,
}

/// `--profile`: a built-in name or a CSV file of `t,mu` points.
#[derive(Args, Debug, Clone)]
pub struct ProfileFlag {
    /// Extinction profile: `smooth`, `cloud`, `sparse` (built in) or a CSV file of `t,mu` lines.
    #[arg(long, default_value = "smooth")]
    pub profile: String,
}

#[derive(Args, Debug, Clone)]
pub struct ProfileArgs {
    #[command(flatten)]
    pub profile: ProfileFlag,
    /// Estimates per transmittance estimate (m, Eq. 3), 2 to 64.
    #[arg(long, allow_hyphen_values = true, default_value_t = 2, value_parser = count_in(2, 64))]
    pub m: usize,
    /// Ray marching samples per estimate, 1 to 10^6.
    #[arg(long, allow_hyphen_values = true, default_value_t = 12, value_parser = count_in(1, MAX_SAMPLES as u64))]
    pub n: usize,
    /// Trials (independent transmittance estimates), 2 to 10^10.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(2..=MAX_TRIALS))]
    pub trials: u64,
    /// Histogram bins of the plot, 1 to 10000.
    #[arg(long, allow_hyphen_values = true, default_value_t = 80, value_parser = count_in(1, MAX_BINS as u64))]
    pub bins: usize,
    #[command(flatten)]
    pub out: Output,
}

#[derive(Args, Debug, Clone)]
pub struct Table1Args {
    #[command(flatten)]
    pub profile: ProfileFlag,
    /// Samples per transmittance estimate, m N, 2 to 1024.
    #[arg(long, allow_hyphen_values = true, default_value_t = 24, value_parser = count_in(2, 1024))]
    pub total: usize,
    /// Smallest N of a row, 1 to --total / 2 (3 gives the paper's rows m = 2, 3, 4, 6, 8 for 24).
    #[arg(long, allow_hyphen_values = true, default_value_t = 3, value_parser = count_in(1, 512))]
    pub min_n: usize,
    /// Ray marching of every row: stratified or uniform.
    #[arg(long, value_enum, default_value = "stratified")]
    pub sampling: Sampling,
    /// Trials (independent transmittance estimates), 2 to 10^10.
    #[arg(long, allow_hyphen_values = true, default_value_t = 10_000_000, value_parser = clap::value_parser!(u64).range(2..=MAX_TRIALS))]
    pub trials: u64,
    #[command(flatten)]
    pub out: Output,
}

#[derive(Args, Debug, Clone)]
pub struct HistogramArgs {
    #[command(flatten)]
    pub profile: ProfileFlag,
    /// Sample counts N (columns), each 1 to 10^6, at most 16 of them.
    #[arg(long, allow_hyphen_values = true, value_delimiter = ',', default_values_t = [2usize, 5, 10, 20], value_parser = count_in(1, MAX_SAMPLES as u64))]
    pub n: Vec<usize>,
    /// Sampling schemes (rows): uniform, stratified or iid (midpoint is deterministic).
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [Sampling::Stratified, Sampling::Uniform])]
    pub sampling: Vec<Sampling>,
    /// Estimates per histogram, 2 to 2 x 10^7 (each is kept in memory).
    #[arg(long, allow_hyphen_values = true, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(2..=MAX_HISTOGRAM_TRIALS))]
    pub trials: u64,
    /// Histogram bins, 1 to 10000.
    #[arg(long, allow_hyphen_values = true, default_value_t = 80, value_parser = count_in(1, MAX_BINS as u64))]
    pub bins: usize,
    #[command(flatten)]
    pub out: Output,
}

#[derive(Args, Debug, Clone)]
pub struct ConvergenceArgs {
    #[command(flatten)]
    pub profile: ProfileFlag,
    /// Largest sample count N, 1 to 10^6.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1000, value_parser = count_in(1, MAX_SAMPLES as u64))]
    pub max_n: usize,
    /// Sample counts, log-spaced from 1 to max-n, 2 to 1000.
    #[arg(long, allow_hyphen_values = true, default_value_t = 25, value_parser = count_in(2, 1000))]
    pub points: usize,
    /// Estimates per (sampling, N), 2 to 10^8 (the paper uses 10^4).
    #[arg(long, allow_hyphen_values = true, default_value_t = 10_000, value_parser = clap::value_parser!(u64).range(2..=100_000_000))]
    pub trials: u64,
    /// Sampling schemes (curves).
    #[arg(long, value_enum, value_delimiter = ',',
          default_values_t = [Sampling::Midpoint, Sampling::Uniform, Sampling::Stratified, Sampling::Iid])]
    pub sampling: Vec<Sampling>,
    #[command(flatten)]
    pub out: Output,
}

#[derive(Args, Debug, Clone)]
pub struct MisBiasArgs {
    /// u0,u1,v0,v1 of g(tau) = (u0 e^-tau + u1) / (v0 e^-tau + v1) (Eq. 11): four finite
    /// numbers in [-10^6, 10^6]; v0 and v1 not both 0.
    #[arg(long, value_delimiter = ',', default_values_t = [1.0f32, 0.0, 1.0, 0.5], allow_hyphen_values = true, value_parser = parse_g_coefficient)]
    pub g: Vec<f32>,
    /// Largest tau of the grid, in (0, 20].
    #[arg(long, allow_hyphen_values = true, default_value_t = 4.0, value_parser = positive_up_to(MAX_TAU))]
    pub tau_max: f64,
    /// Largest sigma of the grid, in (0, 10].
    #[arg(long, allow_hyphen_values = true, default_value_t = 4.0, value_parser = positive_up_to(MAX_SIGMA))]
    pub sigma_max: f64,
    /// Grid cells along tau, 1 to 1024.
    #[arg(long, allow_hyphen_values = true, default_value_t = 64, value_parser = count_in(1, 1024))]
    pub nx: usize,
    /// Grid cells along sigma, 1 to 1024.
    #[arg(long, allow_hyphen_values = true, default_value_t = 64, value_parser = count_in(1, 1024))]
    pub ny: usize,
    /// Trials per cell, 2 to 10^9.
    #[arg(long, allow_hyphen_values = true, default_value_t = 20_000, value_parser = clap::value_parser!(u64).range(2..=1_000_000_000))]
    pub trials: u64,
    /// Bias at which the colour saturates, in (0, 10^6].
    #[arg(long, allow_hyphen_values = true, default_value_t = 0.1, value_parser = positive_up_to(1e6))]
    pub limit: f64,
    #[command(flatten)]
    pub out: Output,
}

/// One coefficient of `--g`: a finite number in [-10^6, 10^6].
pub fn parse_g_coefficient(s: &str) -> Result<f32, String> {
    let v = finite_in(-1e6, 1e6)(s)?;
    Ok(v as f32)
}

/// Runs one study, on `--threads` threads if given.
pub fn run(args: &StudyArgs) -> Result<()> {
    match args.threads {
        Some(threads) => rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .context("building the thread pool")?
            .install(|| run_study(&args.command)),
        None => run_study(&args.command),
    }
}

/// The output flags of a study.
fn output_of(command: &StudyCommand) -> &Output {
    match command {
        StudyCommand::Normal(a) => &a.out,
        StudyCommand::Distributions(a) => &a.out,
        StudyCommand::Profile(a) => &a.out,
        StudyCommand::Table1(a) => &a.out,
        StudyCommand::Histogram(a) => &a.out,
        StudyCommand::Convergence(a) => &a.out,
        StudyCommand::MisBias(a) => &a.out,
    }
}

fn run_study(command: &StudyCommand) -> Result<()> {
    output_of(command).check()?;
    match command {
        StudyCommand::Normal(a) => commands::run_normal(a),
        StudyCommand::Distributions(a) => commands::run_distributions(a),
        StudyCommand::Profile(a) => commands::run_profile(a),
        StudyCommand::Table1(a) => commands::run_table1(a),
        StudyCommand::Histogram(a) => commands::run_histogram(a),
        StudyCommand::Convergence(a) => commands::run_convergence(a),
        StudyCommand::MisBias(a) => commands::run_mis_bias(a),
    }
}
