//! The `host study` subcommands: run a study, print its table, write its JSON and plot.

use super::distributions::{self, Distribution};
use super::files::Output;
use super::profile::{Profile, Sampling};
use super::stats::progress;
use super::{convergence, histogram, mis_bias, normal, profile_study, rng, table1};
use super::{
    ConvergenceOptions, DistributionsOptions, HistogramOptions, MisBiasOptions, NormalOptions,
    ProfileOptions, Study, StudyOptions, Table1Options,
};
use anyhow::{bail, Context, Result};
use serde::Serialize;
use shared::mis::Mobius;

/// Standard errors need two trials at least.
fn check_trials(trials: u64) -> Result<()> {
    if trials < 2 {
        bail!("--trials must be at least 2");
    }
    Ok(())
}

/// The sigma values of the Fig. 3 dots.
pub const NORMAL_SWEEP: [f64; 10] = [0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5];

pub fn run_normal(a: &NormalOptions) -> Result<()> {
    if !(a.sigma >= 0.0) || !a.tau.is_finite() || a.trials < 2 || a.sweep_trials == 1 {
        bail!(
            "normal needs a finite --tau, --sigma >= 0, --trials >= 2 and --sweep-trials 0 or >= 2"
        );
    }
    let sweep_len = if a.sweep_trials >= 2 {
        NORMAL_SWEEP.len() as u64
    } else {
        0
    };
    let bar = progress(a.trials + sweep_len * a.sweep_trials, "normal", a.out.quiet);
    let point = normal::measure(a.tau, a.sigma, a.trials, a.out.seed, &bar);
    let sweep = if sweep_len > 0 {
        normal::sweep(a.tau, &NORMAL_SWEEP, a.sweep_trials, a.out.seed, &bar)
    } else {
        Vec::new()
    };
    bar.finish_and_clear();
    println!(
        "m = 2 normal estimates: tau = {}, sigma = {}, T = {:.6}, {} trials, seed {}",
        a.tau, a.sigma, point.transmittance, a.trials, a.out.seed
    );
    println!(
        "{:<10} {:<8} {:>24} {:>14}",
        "estimator", "", "measured +- s.e.", "App. A"
    );
    for (name, s, rrmse, c) in [
        (
            "jackknife",
            &point.jackknife,
            point.jackknife_rrmse,
            &point.jackknife_closed,
        ),
        (
            "naive",
            &point.naive,
            point.naive_rrmse,
            &point.naive_closed,
        ),
    ] {
        println!(
            "{name:<10} {:<8} {:>12.6} +- {:<9.6} {:>14.6}",
            "mean", s.mean, s.mean_se, c.mean
        );
        println!(
            "{:<10} {:<8} {:>+12.6} +- {:<9.6} {:>14.6}",
            "", "bias", s.bias, s.mean_se, c.bias
        );
        println!(
            "{:<10} {:<8} {:>12.6} +- {:<9.6} {:>14.6}",
            "", "std", s.std, s.std_se, c.std
        );
        println!(
            "{:<10} {:<8} {:>12.6e} +- {:<9.3e} {:>14.6e}",
            "", "variance", s.variance, s.variance_se, c.variance
        );
        println!(
            "{:<10} {:<8} {:>12.6} {:>12} {:>14.6}",
            "", "rRMSE", rrmse, "", c.rrmse
        );
    }
    #[derive(Serialize)]
    struct Json<'a> {
        point: &'a normal::NormalPoint,
        sweep: &'a [normal::NormalPoint],
    }
    a.out.write(
        "normal",
        &Json {
            point: &point,
            sweep: &sweep,
        },
        &normal::RrmseFigure {
            point,
            sweep: sweep.clone(),
        },
    )
}

pub fn run_distributions(a: &DistributionsOptions) -> Result<()> {
    check_trials(a.trials)?;
    if a.points == 0 || !(a.sigma_max > 0.0) || !a.tau.is_finite() {
        bail!("distributions needs --points >= 1, --sigma-max > 0 and a finite --tau");
    }
    let dists = if a.dist.is_empty() {
        Distribution::ALL.to_vec()
    } else {
        a.dist.clone()
    };
    let sigmas: Vec<f64> = (1..=a.points)
        .map(|i| a.sigma_max * i as f64 / a.points as f64)
        .collect();
    let bar = progress(
        (dists.len() * sigmas.len()) as u64 * a.trials,
        "distributions",
        a.out.quiet,
    );
    let points = distributions::sweep(&dists, a.tau, &sigmas, a.trials, a.out.seed, &bar);
    bar.finish_and_clear();
    println!(
        "m = 2 estimates with mean tau = {}, T = {:.6}; {} trials per point",
        a.tau,
        (-a.tau).exp(),
        a.trials
    );
    println!(
        "{:<26} {:>6} {:>22} {:>10} {:>22} {:>10}",
        "distribution", "sigma", "jackknife bias +- s.e.", "std", "naive bias +- s.e.", "std"
    );
    for p in &points {
        println!(
            "{:<26} {:>6.3} {:>+12.6} +- {:<7.6} {:>10.6} {:>+12.6} +- {:<7.6} {:>10.6}",
            p.distribution.label(),
            p.sigma,
            p.jackknife.bias,
            p.jackknife.mean_se,
            p.jackknife.std,
            p.naive.bias,
            p.naive.mean_se,
            p.naive.std
        );
    }
    a.out.write(
        "distributions",
        &points,
        &distributions::DistributionsFigure {
            tau: a.tau,
            points: points.clone(),
        },
    )
}

pub fn run_profile(a: &ProfileOptions) -> Result<()> {
    check_trials(a.trials)?;
    let profile = Profile::load(&a.profile.profile)?;
    if let Some(why) = profile.constant() {
        bail!("{why}");
    }
    let hist_trials = a.trials.min(1_000_000);
    let schemes = [Sampling::Stratified, Sampling::Uniform];
    let bar = progress(2 * (a.trials + hist_trials), "profile", a.out.quiet);
    let mut stats = Vec::new();
    let mut histograms = Vec::new();
    for (k, &s) in schemes.iter().enumerate() {
        stats.push(profile_study::measure(
            &profile,
            s,
            a.m,
            a.n,
            a.trials,
            rng::sub_seed(a.out.seed, k as u64),
            &bar,
        )?);
        histograms.push(histogram::measure(
            &profile,
            s,
            a.n,
            hist_trials,
            a.bins,
            rng::sub_seed(a.out.seed, 10 + k as u64),
            &bar,
        )?);
    }
    bar.finish_and_clear();
    let tau = profile.tau();
    println!(
        "profile {}: tau = {:.6}, T = {:.6}; m = {}, N = {}, {} trials",
        profile.name,
        tau,
        (-tau).exp(),
        a.m,
        a.n,
        a.trials
    );
    println!(
        "{:<20} {:>10} {:>10} {:>8} {:>8} | {:>22} {:>9} | {:>22} {:>9}",
        "sampling",
        "X mean",
        "X std",
        "skew",
        "kurt",
        "Eq. 3 bias +- s.e.",
        "std",
        "naive bias +- s.e.",
        "std"
    );
    for s in &stats {
        println!(
            "{:<20} {:>10.6} {:>10.6} {:>8.3} {:>8.3} | {:>+12.6} +- {:<7.6} {:>9.6} | {:>+12.6} +- {:<7.6} {:>9.6}",
            s.sampling.label(), s.depth.mean, s.depth.std, s.depth_skewness,
            s.depth_excess_kurtosis, s.jackknife.bias, s.jackknife.mean_se, s.jackknife.std,
            s.naive.bias, s.naive.mean_se, s.naive.std
        );
    }
    #[derive(Serialize)]
    struct Json<'a> {
        profile: &'a str,
        tau: f64,
        m: usize,
        n: usize,
        trials: u64,
        schemes: &'a [profile_study::SchemeStats],
        histograms: &'a [histogram::Histogram],
    }
    let json = Json {
        profile: &profile.name,
        tau,
        m: a.m,
        n: a.n,
        trials: a.trials,
        schemes: &stats,
        histograms: &histograms,
    };
    let name = format!(
        "profile_{}",
        profile
            .name
            .rsplit('/')
            .next()
            .unwrap_or("")
            .trim_end_matches(".csv")
    );
    a.out.write(
        &name,
        &json,
        &profile_study::ProfileFigure {
            profile: profile.clone(),
            histograms: histograms.clone(),
        },
    )
}

pub fn run_table1(a: &Table1Options) -> Result<()> {
    check_trials(a.trials)?;
    let profile = Profile::load(&a.profile.profile)?;
    let rows = table1::configs(a.total, a.min_n);
    if rows.len() < 2 {
        bail!(
            "--total {} with --min-n {} leaves no m >= 2 row",
            a.total,
            a.min_n
        );
    }
    let bar = progress(a.trials, "table1", a.out.quiet);
    let report = table1::measure(&profile, &rows, a.sampling, a.trials, a.out.seed, &bar)?;
    bar.finish_and_clear();
    println!(
        "Table 1, profile {}: tau = {:.6}, T = {:.6}, {} sampling, m N = {}, {} trials",
        report.profile,
        report.tau,
        report.transmittance,
        a.sampling.label(),
        report.total,
        report.trials
    );
    println!(
        "{:>3} {:>3} {:>10} {:>22} {:>9} {:>24} | paper: {:>8} {:>8} {:>7}",
        "m", "N", "mean", "bias +- s.e.", "std", "bias - bias(m=2) +- s.e.", "mean", "bias", "std"
    );
    for r in &report.rows {
        let paper = table1::PAPER.iter().find(|p| p.0 == r.m && p.1 == r.n);
        let paper = paper.map_or(String::new(), |p| {
            format!("{:>8.5} {:>8.5} {:>7.4}", p.2, p.3, p.4)
        });
        println!(
            "{:>3} {:>3} {:>10.5} {:>+12.5} +- {:<7.5} {:>9.4} {:>+12.5} +- {:<9.5} | paper: {paper}",
            r.m, r.n, r.stats.mean, r.stats.bias, r.stats.mean_se, r.stats.std,
            r.bias_minus_first, r.bias_minus_first_se
        );
    }
    a.out.write(
        "table1",
        &report,
        &table1::Table1Figure {
            report: report.clone(),
        },
    )
}

pub fn run_histogram(a: &HistogramOptions) -> Result<()> {
    check_trials(a.trials)?;
    if a.n.len() > 16 || a.sampling.len() > 8 {
        bail!("--n takes at most 16 values and --sampling at most 8");
    }
    if a.sampling.contains(&Sampling::Midpoint) {
        bail!("--sampling midpoint is deterministic: no histogram; use uniform, stratified or iid");
    }
    let profile = Profile::load(&a.profile.profile)?;
    if let Some(why) = profile.constant() {
        bail!("{why}");
    }
    let combos: Vec<(Sampling, usize)> = a
        .sampling
        .iter()
        .flat_map(|&s| a.n.iter().map(move |&n| (s, n)))
        .collect();
    let bar = progress(combos.len() as u64 * a.trials, "histogram", a.out.quiet);
    let histograms = combos
        .iter()
        .enumerate()
        .map(|(k, &(s, n))| {
            histogram::measure(
                &profile,
                s,
                n,
                a.trials,
                a.bins,
                rng::sub_seed(a.out.seed, k as u64),
                &bar,
            )
        })
        .collect::<Result<Vec<_>>>()?;
    bar.finish_and_clear();
    println!(
        "profile {}: tau = {:.6}; {} estimates per histogram",
        profile.name,
        profile.tau(),
        a.trials
    );
    println!(
        "{:<20} {:>4} {:>10} {:>10} {:>9} {:>9} {:>8}",
        "sampling", "N", "mean", "std", "skewness", "ex.kurt", "KS"
    );
    for h in &histograms {
        println!(
            "{:<20} {:>4} {:>10.6} {:>10.6} {:>9.4} {:>9.4} {:>8.4}",
            h.sampling.label(),
            h.n,
            h.mean,
            h.std,
            h.skewness,
            h.excess_kurtosis,
            h.ks_distance
        );
    }
    let name = format!(
        "histogram_{}",
        profile
            .name
            .rsplit('/')
            .next()
            .unwrap_or("")
            .trim_end_matches(".csv")
    );
    a.out.write(
        &name,
        &histograms,
        &histogram::HistogramFigure {
            columns: a.n.len(),
            histograms: histograms.clone(),
        },
    )
}

pub fn run_convergence(a: &ConvergenceOptions) -> Result<()> {
    check_trials(a.trials)?;
    if a.max_n < 1 || a.points < 2 || a.sampling.is_empty() || a.sampling.len() > 8 {
        bail!("convergence needs --max-n >= 1, --points >= 2 and 1 to 8 --sampling schemes");
    }
    let profile = Profile::load(&a.profile.profile)?;
    if let Some(why) = profile.constant() {
        bail!("{why}");
    }
    let ns = convergence::sample_counts(a.max_n, a.points);
    let per_n: u64 = a
        .sampling
        .iter()
        .map(|&s| if s == Sampling::Midpoint { 1 } else { a.trials })
        .sum();
    let bar = progress(per_n * ns.len() as u64, "convergence", a.out.quiet);
    let curves = convergence::measure(&profile, &a.sampling, &ns, a.trials, a.out.seed, &bar);
    bar.finish_and_clear();
    println!(
        "profile {}: tau = {:.6}; RMSE from {} estimates per N",
        profile.name,
        profile.tau(),
        a.trials
    );
    print!("{:>6}", "N");
    curves
        .iter()
        .for_each(|c| print!(" {:>20}", c.sampling.label()));
    println!();
    for (i, n) in ns.iter().enumerate() {
        print!("{n:>6}");
        curves
            .iter()
            .for_each(|c| print!(" {:>20.4e}", c.rmse[i].1));
        println!();
    }
    print!("{:>6}", "slope");
    curves
        .iter()
        .for_each(|c| print!(" {:>9.3} / {:<8.3}", c.slope_up_to_100, c.slope_from_100));
    println!("   (N <= 100 / N >= 100)");
    let figure = convergence::ConvergenceFigure {
        profile: profile.name.clone(),
        tau: profile.tau(),
        curves: curves.clone(),
    };
    a.out.write("convergence", &curves, &figure)
}

pub fn run_mis_bias(a: &MisBiasOptions) -> Result<()> {
    check_trials(a.trials)?;
    let [u0, u1, v0, v1] = a.g[..] else {
        bail!("--g takes four numbers u0,u1,v0,v1")
    };
    if v0 == 0.0 && v1 == 0.0 {
        bail!("--g: v0 and v1 are both 0, so g(tau) has no finite value anywhere");
    }
    if a.nx == 0 || a.ny == 0 {
        bail!("mis-bias needs --nx >= 1 and --ny >= 1");
    }
    let g = Mobius { u0, u1, v0, v1 };
    let grid = mis_bias::Grid {
        tau_max: a.tau_max,
        sigma_max: a.sigma_max,
        nx: a.nx,
        ny: a.ny,
    };
    let bar = progress((a.nx * a.ny) as u64, "mis-bias", a.out.quiet);
    let cells = mis_bias::measure(&g, &grid, a.trials, a.out.seed, &bar);
    bar.finish_and_clear();
    let below: Vec<mis_bias::BelowLine> = [1.0, 2.0, f64::INFINITY]
        .iter()
        .map(|&cap| mis_bias::below_line(&cells, cap))
        .collect();
    println!(
        "g = ({u0} e^-tau + {u1}) / ({v0} e^-tau + {v1}); {}x{} cells, {} trials each",
        a.nx, a.ny, a.trials
    );
    println!(
        "cells below sigma = 1.645 tau: |bias| max and mean (each cell has Monte Carlo noise)"
    );
    for b in &below {
        println!(
            "  sigma <= {:>4}: {:>4} cells, jackknife {:.5} / {:.5}, naive {:.5} / {:.5}",
            b.sigma_cap,
            b.cells,
            b.jackknife_max_abs_bias,
            b.jackknife_mean_abs_bias,
            b.naive_max_abs_bias,
            b.naive_mean_abs_bias
        );
    }
    println!(
        "{:>6} {:>6} {:>9} {:>22} {:>22}",
        "tau", "sigma", "g(tau)", "jackknife bias +- s.e.", "naive bias +- s.e."
    );
    for &(tau, sigma) in &[(0.5, 0.25), (1.0, 0.5), (2.0, 1.0), (3.0, 1.0), (1.0, 2.0)] {
        let c = mis_bias::cell(&g, tau, sigma, a.trials.max(100_000), a.out.seed);
        println!(
            "{:>6.2} {:>6.2} {:>9.5} {:>+12.6} +- {:<7.6} {:>+12.6} +- {:<7.6}",
            tau, sigma, c.exact, c.jackknife_bias, c.jackknife_se, c.naive_bias, c.naive_se
        );
    }
    #[derive(Serialize)]
    struct Json<'a> {
        g: [f32; 4],
        grid: mis_bias::Grid,
        trials: u64,
        below_line: &'a [mis_bias::BelowLine],
        cells: &'a [mis_bias::Cell],
    }
    let json = Json {
        g: [u0, u1, v0, v1],
        grid,
        trials: a.trials,
        below_line: &below,
        cells: &cells,
    };
    a.out.write(
        "mis_bias",
        &json,
        &mis_bias::MisBiasFigure {
            g,
            grid,
            cells: cells.clone(),
            limit: a.limit,
        },
    )
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

fn run_study(command: &Study) -> Result<()> {
    output_of(command).check()?;
    match command {
        Study::Normal(a) => run_normal(a),
        Study::Distributions(a) => run_distributions(a),
        Study::Profile(a) => run_profile(a),
        Study::Table1(a) => run_table1(a),
        Study::Histogram(a) => run_histogram(a),
        Study::Convergence(a) => run_convergence(a),
        Study::MisBias(a) => run_mis_bias(a),
    }
}
