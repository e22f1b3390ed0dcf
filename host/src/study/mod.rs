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

/// Flags of `host study`.
#[derive(Args, Debug, Clone)]
pub struct StudyArgs {
    #[command(subcommand)]
    pub command: StudyCommand,
    /// Worker threads [default: all cores]; the results do not depend on it.
    #[arg(long, global = true)]
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
    /// Optical depth tau (the mean of each estimate).
    #[arg(long, default_value_t = 2.0)]
    pub tau: f64,
    /// Standard deviation sigma of each of the two estimates.
    #[arg(long, default_value_t = 1.0)]
    pub sigma: f64,
    /// Trials (independent transmittance or optical depth estimates).
    #[arg(long, default_value_t = 10_000_000)]
    pub trials: u64,
    /// Trials per sigma of the measured rRMSE dots of the plot (0: none).
    #[arg(long, default_value_t = 1_000_000)]
    pub sweep_trials: u64,
    #[command(flatten)]
    pub out: Output,
}

#[derive(Args, Debug, Clone)]
pub struct DistributionsArgs {
    /// Optical depth tau (the mean of every estimate).
    #[arg(long, default_value_t = 1.0)]
    pub tau: f64,
    /// Largest sigma of the sweep. Heavy tails: exp(-X̄) has infinite variance from sigma = 1 on
    /// for exponential-left and from sqrt(2) on for Laplace.
    #[arg(long, default_value_t = 1.0)]
    pub sigma_max: f64,
    /// Sigma values from sigma_max / points to sigma_max.
    #[arg(long, default_value_t = 20)]
    pub points: usize,
    /// Trials per (distribution, sigma).
    #[arg(long, default_value_t = 1_000_000)]
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
    /// Estimates per transmittance estimate (m >= 2, Eq. 3).
    #[arg(long, default_value_t = 2)]
    pub m: usize,
    /// Ray marching samples per estimate.
    #[arg(long, default_value_t = 12)]
    pub n: usize,
    /// Trials (independent transmittance or optical depth estimates).
    #[arg(long, default_value_t = 1_000_000)]
    pub trials: u64,
    /// Histogram bins of the plot.
    #[arg(long, default_value_t = 80)]
    pub bins: usize,
    #[command(flatten)]
    pub out: Output,
}

#[derive(Args, Debug, Clone)]
pub struct Table1Args {
    #[command(flatten)]
    pub profile: ProfileFlag,
    /// Samples per transmittance estimate, m N.
    #[arg(long, default_value_t = 24)]
    pub total: usize,
    /// Smallest N of a row (3 gives the paper's rows m = 2, 3, 4, 6, 8 for 24).
    #[arg(long, default_value_t = 3)]
    pub min_n: usize,
    #[arg(long, value_enum, default_value = "stratified")]
    pub sampling: Sampling,
    /// Trials (independent transmittance or optical depth estimates).
    #[arg(long, default_value_t = 10_000_000)]
    pub trials: u64,
    #[command(flatten)]
    pub out: Output,
}

#[derive(Args, Debug, Clone)]
pub struct HistogramArgs {
    #[command(flatten)]
    pub profile: ProfileFlag,
    /// Sample counts N (columns).
    #[arg(long, value_delimiter = ',', default_values_t = [2usize, 5, 10, 20])]
    pub n: Vec<usize>,
    /// Sampling schemes (rows).
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [Sampling::Stratified, Sampling::Uniform])]
    pub sampling: Vec<Sampling>,
    /// Trials (independent transmittance or optical depth estimates).
    #[arg(long, default_value_t = 1_000_000)]
    pub trials: u64,
    #[arg(long, default_value_t = 80)]
    pub bins: usize,
    #[command(flatten)]
    pub out: Output,
}

#[derive(Args, Debug, Clone)]
pub struct ConvergenceArgs {
    #[command(flatten)]
    pub profile: ProfileFlag,
    /// Largest sample count N.
    #[arg(long, default_value_t = 1000)]
    pub max_n: usize,
    /// Sample counts, log-spaced from 1 to max-n.
    #[arg(long, default_value_t = 25)]
    pub points: usize,
    /// Estimates per (sampling, N) (the paper uses 10^4).
    #[arg(long, default_value_t = 10_000)]
    pub trials: u64,
    #[arg(long, value_enum, value_delimiter = ',',
          default_values_t = [Sampling::Midpoint, Sampling::Uniform, Sampling::Stratified, Sampling::Iid])]
    pub sampling: Vec<Sampling>,
    #[command(flatten)]
    pub out: Output,
}

#[derive(Args, Debug, Clone)]
pub struct MisBiasArgs {
    /// u0,u1,v0,v1 of g(tau) = (u0 e^-tau + u1) / (v0 e^-tau + v1) (Eq. 11).
    #[arg(long, value_delimiter = ',', default_values_t = [1.0f32, 0.0, 1.0, 0.5])]
    pub g: Vec<f32>,
    /// Largest tau of the grid.
    #[arg(long, default_value_t = 4.0)]
    pub tau_max: f64,
    /// Largest sigma of the grid.
    #[arg(long, default_value_t = 4.0)]
    pub sigma_max: f64,
    /// Grid cells along tau and sigma.
    #[arg(long, default_value_t = 64)]
    pub nx: usize,
    #[arg(long, default_value_t = 64)]
    pub ny: usize,
    /// Trials per cell.
    #[arg(long, default_value_t = 20_000)]
    pub trials: u64,
    /// Bias at which the colour saturates.
    #[arg(long, default_value_t = 0.1)]
    pub limit: f64,
    #[command(flatten)]
    pub out: Output,
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
