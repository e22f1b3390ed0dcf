//! Flags of `host study` and its studies.

use super::parsers::{
    count_in, finite_in, parse_g_coefficient, positive_up_to, DistributionArg, SamplingArg,
};
use clap::{Args, Subcommand};
use std::path::PathBuf;
use studies::convergence::ConvergenceOptions;
use studies::distributions::DistributionsOptions;
use studies::files::Output;
use studies::histogram::HistogramOptions;
use studies::limits::{
    MAX_BINS, MAX_HISTOGRAM_TRIALS, MAX_SAMPLES, MAX_SIGMA, MAX_TAU, MAX_TRIALS,
};
use studies::mis_bias::MisBiasOptions;
use studies::normal::NormalOptions;
use studies::profile_study::ProfileOptions;
use studies::table1::Table1Options;
use studies::{Study, StudyOptions};

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
    pub out: OutputArgs,
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
    pub dist: Vec<DistributionArg>,
    #[command(flatten)]
    pub out: OutputArgs,
}

/// `--profile`: a built-in name or a CSV file of `t,mu` points.
#[derive(Args, Debug, Clone)]
pub struct ProfileFlag {
    /// Extinction profile: `smooth`, `cloud`, `sparse` (built in) or a CSV file of `t,mu` lines.
    #[arg(long, default_value = "smooth", value_parser = super::parsers::Utf8Text)]
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
    pub out: OutputArgs,
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
    pub sampling: SamplingArg,
    /// Trials (independent transmittance estimates), 2 to 10^10.
    #[arg(long, allow_hyphen_values = true, default_value_t = 10_000_000, value_parser = clap::value_parser!(u64).range(2..=MAX_TRIALS))]
    pub trials: u64,
    #[command(flatten)]
    pub out: OutputArgs,
}

#[derive(Args, Debug, Clone)]
pub struct HistogramArgs {
    #[command(flatten)]
    pub profile: ProfileFlag,
    /// Sample counts N (columns), each 1 to 10^6, at most 16 of them.
    #[arg(long, allow_hyphen_values = true, value_delimiter = ',', default_value = "2,5,10,20", value_parser = count_in(1, MAX_SAMPLES as u64))]
    pub n: Vec<usize>,
    /// Sampling schemes (rows): uniform, stratified or iid (midpoint is deterministic).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "stratified,uniform"
    )]
    pub sampling: Vec<SamplingArg>,
    /// Estimates per histogram, 2 to 2 x 10^7 (each is kept in memory).
    #[arg(long, allow_hyphen_values = true, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(2..=MAX_HISTOGRAM_TRIALS))]
    pub trials: u64,
    /// Histogram bins, 1 to 10000.
    #[arg(long, allow_hyphen_values = true, default_value_t = 80, value_parser = count_in(1, MAX_BINS as u64))]
    pub bins: usize,
    #[command(flatten)]
    pub out: OutputArgs,
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
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "midpoint,uniform,stratified,iid"
    )]
    pub sampling: Vec<SamplingArg>,
    #[command(flatten)]
    pub out: OutputArgs,
}

#[derive(Args, Debug, Clone)]
pub struct MisBiasArgs {
    /// u0,u1,v0,v1 of g(tau) = (u0 e^-tau + u1) / (v0 e^-tau + v1) (Eq. 11): four finite
    /// numbers in [-10^6, 10^6]; v0 and v1 not both 0.
    #[arg(long, value_delimiter = ',', default_value = "1,0,1,0.5", allow_hyphen_values = true, value_parser = parse_g_coefficient)]
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
    pub out: OutputArgs,
}

/// `--seed`, `--json`, `--plot`, `--quiet` of every study.
#[derive(Args, Debug, Clone)]
pub struct OutputArgs {
    /// Seed of the random numbers, 0 to 2^64 - 1; results are bit-identical for any thread count.
    #[arg(long, default_value_t = 1, allow_hyphen_values = true)]
    pub seed: u64,
    /// Also write the numbers as JSON to this file.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Plot file, `.png` or `.svg` [default: out/study_<name>.png].
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Hide the progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

impl OutputArgs {
    /// The library's output options.
    fn options(&self) -> Output {
        Output {
            seed: self.seed,
            json: self.json.clone(),
            plot: self.plot.clone(),
            quiet: self.quiet,
        }
    }
}

impl ProfileFlag {
    /// The library's profile choice.
    fn options(&self) -> studies::profile::ProfileFlag {
        studies::profile::ProfileFlag {
            profile: self.profile.clone(),
        }
    }
}

/// Converts each enum value into its library type.
fn convert<A: Copy + Into<B>, B>(values: &[A]) -> Vec<B> {
    values.iter().map(|&v| v.into()).collect()
}

impl StudyArgs {
    /// The library's study options.
    pub fn options(&self) -> StudyOptions {
        StudyOptions {
            command: self.command.options(),
            threads: self.threads,
        }
    }
}

impl StudyCommand {
    /// The library's study with its options.
    fn options(&self) -> Study {
        match self {
            StudyCommand::Normal(a) => Study::Normal(NormalOptions {
                tau: a.tau,
                sigma: a.sigma,
                trials: a.trials,
                sweep_trials: a.sweep_trials,
                out: a.out.options(),
            }),
            StudyCommand::Distributions(a) => Study::Distributions(DistributionsOptions {
                tau: a.tau,
                sigma_max: a.sigma_max,
                points: a.points,
                trials: a.trials,
                dist: convert(&a.dist),
                out: a.out.options(),
            }),
            StudyCommand::Profile(a) => Study::Profile(ProfileOptions {
                profile: a.profile.options(),
                m: a.m,
                n: a.n,
                trials: a.trials,
                bins: a.bins,
                out: a.out.options(),
            }),
            StudyCommand::Table1(a) => Study::Table1(Table1Options {
                profile: a.profile.options(),
                total: a.total,
                min_n: a.min_n,
                sampling: a.sampling.into(),
                trials: a.trials,
                out: a.out.options(),
            }),
            StudyCommand::Histogram(a) => Study::Histogram(HistogramOptions {
                profile: a.profile.options(),
                n: a.n.clone(),
                sampling: convert(&a.sampling),
                trials: a.trials,
                bins: a.bins,
                out: a.out.options(),
            }),
            StudyCommand::Convergence(a) => Study::Convergence(ConvergenceOptions {
                profile: a.profile.options(),
                max_n: a.max_n,
                points: a.points,
                trials: a.trials,
                sampling: convert(&a.sampling),
                out: a.out.options(),
            }),
            StudyCommand::MisBias(a) => Study::MisBias(MisBiasOptions {
                g: a.g.clone(),
                tau_max: a.tau_max,
                sigma_max: a.sigma_max,
                nx: a.nx,
                ny: a.ny,
                trials: a.trials,
                limit: a.limit,
                out: a.out.options(),
            }),
        }
    }
}
