//! The paper's statistical experiments (Table 1, Fig. 2-7, App. A) on the CPU, run by
//! `host study`.
//!
//! Every study splits its trials into chunks with their own seeded generator and merges the chunk
//! results in chunk order, so `--seed` fixes the numbers whatever `--threads` is. Studies of the
//! m = 2 estimators the renderer runs (`normal`, `distributions`, `mis-bias`) call the `shared` f32
//! code on f32-rounded inputs; the ray marching studies (`profile`, `table1`, `histogram`,
//! `convergence`) need Eq. 3 for any m and work in f64 throughout (`umvu`). Statistics are f64.

pub mod convergence;
pub mod distributions;
pub mod files;
pub mod histogram;
pub mod limits;
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
use convergence::ConvergenceOptions;
use distributions::DistributionsOptions;
use files::Output;
use histogram::HistogramOptions;
use mis_bias::MisBiasOptions;
use normal::NormalOptions;
use profile_study::ProfileOptions;
use table1::Table1Options;

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

/// Runs one study, on `--threads` threads if given.
pub fn run(args: &StudyOptions) -> Result<()> {
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
fn output_of(command: &Study) -> &Output {
    match command {
        Study::Normal(a) => &a.out,
        Study::Distributions(a) => &a.out,
        Study::Profile(a) => &a.out,
        Study::Table1(a) => &a.out,
        Study::Histogram(a) => &a.out,
        Study::Convergence(a) => &a.out,
        Study::MisBias(a) => &a.out,
    }
}

/// The `--profile` of a study that reads one (a built-in name or a CSV file).
fn profile_of(command: &Study) -> Option<&str> {
    match command {
        Study::Profile(a) => Some(&a.profile.profile),
        Study::Table1(a) => Some(&a.profile.profile),
        Study::Histogram(a) => Some(&a.profile.profile),
        Study::Convergence(a) => Some(&a.profile.profile),
        Study::Normal(_) | Study::Distributions(_) | Study::MisBias(_) => None,
    }
}

/// Checks the output flags, then runs the study on the current thread pool.
fn run_study(command: &Study) -> Result<()> {
    output_of(command).check(profile_of(command).map(std::path::Path::new))?;
    match command {
        Study::Normal(a) => normal::run(a),
        Study::Distributions(a) => distributions::run(a),
        Study::Profile(a) => profile_study::run(a),
        Study::Table1(a) => table1::run(a),
        Study::Histogram(a) => histogram::run(a),
        Study::Convergence(a) => convergence::run(a),
        Study::MisBias(a) => mis_bias::run(a),
    }
}
