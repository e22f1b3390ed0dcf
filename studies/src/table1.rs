//! `host study table1`: Eq. 3 with m estimates of N = total / m stratified jittered samples each,
//! against the naive exp(-X) with all samples in one estimate (Table 1). All in f64 (`umvu`).
//!
//! Every row of a trial reuses the same `total` uniform numbers, and the difference of each row to
//! the first is measured per trial, with its own standard error: that is the comparison Table 1
//! makes. (The rows place their samples on different strata, so they are nearly uncorrelated and
//! the paired standard error is about sqrt(2) times a row's.)

use super::files::Output;
use super::limits::check_trials;
use super::plot::{Figure, Legend, LinePanel, Series, Style, BLUE, INK, ORANGE};
use super::profile::{Profile, ProfileFlag, Sampling};
use super::stats::{progress, run_chunked, Merge, Moments, Summary};
use super::umvu;
use anyhow::{bail, Result};
use indicatif::ProgressBar;
use plotters::coord::Shift;
use plotters::prelude::{DrawingArea, DrawingBackend};
use serde::Serialize;

/// One (m, N) configuration; m = 1 is the naive estimate.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Config {
    pub m: usize,
    pub n: usize,
}

/// The rows of Table 1 for `total` samples: every divisor m >= 2 of `total` with N >= `min_n`
/// (24 and 3 give the paper's m = 2, 3, 4, 6, 8), then m = 1 with N = total.
pub fn configs(total: usize, min_n: usize) -> Vec<Config> {
    let mut rows: Vec<Config> = (2..=total)
        .filter(|m| total.is_multiple_of(*m) && total / m >= min_n)
        .map(|m| Config { m, n: total / m })
        .collect();
    rows.push(Config { m: 1, n: total });
    rows
}

/// One row: the estimator's statistics and its paired difference to the first row (m = 2).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Row {
    pub m: usize,
    pub n: usize,
    #[serde(flatten)]
    pub stats: Summary,
    /// mean(K_row - K_first) and its standard error (0 for the first row itself).
    pub bias_minus_first: f64,
    pub bias_minus_first_se: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct Report {
    pub profile: String,
    pub tau: f64,
    pub transmittance: f64,
    pub sampling: Sampling,
    pub total: usize,
    pub trials: u64,
    pub seed: u64,
    pub rows: Vec<Row>,
}

/// Per-row moments of K and of K - K_first.
#[derive(Clone, Debug)]
struct Acc {
    k: Vec<Moments>,
    diff: Vec<Moments>,
}

impl Merge for Acc {
    fn merge(&mut self, other: &Self) {
        self.k.merge(&other.k);
        self.diff.merge(&other.diff);
    }
}

/// One optical depth estimate from its own slice of the trial's uniform numbers.
fn estimate(profile: &Profile, sampling: Sampling, n: usize, xi: &[f64]) -> f64 {
    match sampling {
        Sampling::Stratified => profile.march(n, &xi[..n]),
        Sampling::Uniform => profile.march(n, &xi[..1]),
        _ => unreachable!("checked in measure"),
    }
}

/// Runs Table 1 for `rows` (the first must have m >= 2) on `profile`.
pub fn measure(
    profile: &Profile,
    rows: &[Config],
    sampling: Sampling,
    trials: u64,
    seed: u64,
    bar: &ProgressBar,
) -> Result<Report> {
    if !matches!(sampling, Sampling::Stratified | Sampling::Uniform) {
        bail!("table1 compares jittered ray marching: --sampling stratified or uniform");
    }
    let total = rows.iter().map(|r| r.m * r.n).max().unwrap_or(0);
    if rows.is_empty() || rows.iter().any(|r| r.m * r.n != total) || rows[0].m < 2 {
        bail!("every row needs m N = {total} and the first row m >= 2");
    }
    let tau = profile.tau();
    let t = (-tau).exp();
    let empty = Acc {
        k: vec![Moments::new(t); rows.len()],
        diff: vec![Moments::new(0.0); rows.len()],
    };
    let acc = run_chunked(trials, seed, bar, &empty, |acc, rng, count| {
        let (mut xi, mut xs, mut k) = (vec![0.0; total], Vec::new(), vec![0.0; rows.len()]);
        for _ in 0..count {
            xi.iter_mut().for_each(|v| *v = rng.uniform());
            for (row, k) in rows.iter().zip(k.iter_mut()) {
                xs.clear();
                xs.extend((0..row.m).map(|j| estimate(profile, sampling, row.n, &xi[j * row.n..])));
                *k = if row.m == 1 {
                    umvu::naive(&xs)
                } else {
                    umvu::jackknife(&xs)
                };
            }
            for (i, &ki) in k.iter().enumerate() {
                acc.k[i].push(ki);
                acc.diff[i].push(ki - k[0]);
            }
        }
    });
    let rows = rows
        .iter()
        .enumerate()
        .map(|(i, r)| Row {
            m: r.m,
            n: r.n,
            stats: acc.k[i].summary(t),
            bias_minus_first: acc.diff[i].mean(),
            bias_minus_first_se: acc.diff[i].mean_se(),
        })
        .collect();
    Ok(Report {
        profile: profile.name.clone(),
        tau,
        transmittance: t,
        sampling,
        total,
        trials,
        seed,
        rows,
    })
}

/// A row of Table 1 as printed: (m, N, mean, bias, std).
pub type PaperRow = (usize, usize, f64, f64, f64);

/// Table 1 as printed in the paper (profile of its Fig. 4a, 10^8 trials).
pub const PAPER: [PaperRow; 6] = [
    (2, 12, 0.13411, 0.00000, 0.0405),
    (3, 8, 0.13425, 0.00014, 0.0440),
    (4, 6, 0.13421, 0.00010, 0.0528),
    (6, 4, 0.13433, 0.00022, 0.0490),
    (8, 3, 0.13485, 0.00074, 0.0694),
    (1, 24, 0.13797, 0.00386, 0.0331),
];

/// Table 1 as two bar charts: bias (with +-2 standard errors) and std per row, next to the
/// paper's numbers for its own profile.
pub struct Table1Figure {
    pub report: Report,
}

impl Figure for Table1Figure {
    fn size(&self) -> (u32, u32) {
        (1000, 400)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let areas = root.split_evenly((1, 2));
        let rows = &self.report.rows;
        let ticks: Vec<String> = rows
            .iter()
            .map(|r| format!("m={} N={}", r.m, r.n))
            .collect();
        let x = (-0.5, rows.len() as f64 - 0.5);
        let paper = |f: &dyn Fn(&PaperRow) -> f64| {
            rows.iter()
                .enumerate()
                .filter_map(|(i, r)| {
                    PAPER
                        .iter()
                        .find(|p| p.0 == r.m && p.1 == r.n)
                        .map(|p| (i as f64, f(p)))
                })
                .collect::<Vec<_>>()
        };
        let ours = |f: &dyn Fn(&Row) -> f64| {
            rows.iter()
                .enumerate()
                .map(|(i, r)| (i as f64, f(r)))
                .collect::<Vec<_>>()
        };

        let top = rows
            .iter()
            .map(|r| r.stats.bias + 2.0 * r.stats.mean_se)
            .chain(PAPER.iter().map(|p| p.3))
            .fold(0.0, f64::max);
        let bottom = rows
            .iter()
            .map(|r| r.stats.bias - 2.0 * r.stats.mean_se)
            .fold(0.0, f64::min);
        let mut bias = LinePanel::new(
            &format!(
                "bias, {} samples per estimate, profile {}",
                self.report.total, self.report.profile
            ),
            "",
            "bias of transmittance",
            x,
            (bottom * 1.1, top * 1.15),
        );
        bias.x_ticks = ticks.clone();
        bias.legend = Legend::UpperLeft;
        bias.series.push(Series::new(
            "this profile",
            BLUE,
            Style::Bars(0.6),
            ours(&|r| r.stats.bias),
        ));
        for sign in [-2.0, 2.0] {
            let label = if sign > 0.0 { "±2 s.e." } else { "" };
            bias.series.push(Series::new(
                label,
                INK,
                Style::Markers(2),
                ours(&|r| r.stats.bias + sign * r.stats.mean_se),
            ));
        }
        bias.series.push(Series::new(
            "paper (its Fig. 4a profile)",
            ORANGE,
            Style::Markers(5),
            paper(&|p| p.3),
        ));
        bias.draw(&areas[0])?;

        let top = rows
            .iter()
            .map(|r| r.stats.std)
            .chain(PAPER.iter().map(|p| p.4))
            .fold(0.0, f64::max);
        let mut std = LinePanel::new(
            "standard deviation",
            "",
            "std of transmittance",
            x,
            (0.0, top * 1.2),
        );
        std.x_ticks = ticks;
        std.series.push(Series::new(
            "this profile",
            BLUE,
            Style::Bars(0.6),
            ours(&|r| r.stats.std),
        ));
        std.series.push(Series::new(
            "paper",
            ORANGE,
            Style::Markers(5),
            paper(&|p| p.4),
        ));
        std.draw(&areas[1])
    }
}

/// Options of `host study table1` (the CLI's flags, checked by `run`).
#[derive(Debug, Clone)]
pub struct Table1Options {
    /// The extinction profile.
    pub profile: ProfileFlag,
    /// Samples per transmittance estimate, m N, 2 to 1024.
    pub total: usize,
    /// Smallest N of a row, 1 to --total / 2 (3 gives the paper's rows m = 2, 3, 4, 6, 8 for 24).
    pub min_n: usize,
    /// Ray marching of every row: stratified or uniform.
    pub sampling: Sampling,
    /// Trials (independent transmittance estimates), 2 to 10^10.
    pub trials: u64,
    /// Seed, JSON and plot files, progress bar.
    pub out: Output,
}

/// Runs `host study table1`: measures, prints the table, writes the JSON and the plot.
pub fn run(a: &Table1Options) -> Result<()> {
    check_trials(a.trials)?;
    let profile = Profile::load(&a.profile.profile)?;
    let rows = configs(a.total, a.min_n);
    if rows.len() < 2 {
        bail!(
            "--total {} with --min-n {} leaves no m >= 2 row",
            a.total,
            a.min_n
        );
    }
    let bar = progress(a.trials, "table1", a.out.quiet);
    let report = measure(&profile, &rows, a.sampling, a.trials, a.out.seed, &bar)?;
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
        let paper = PAPER.iter().find(|p| p.0 == r.m && p.1 == r.n);
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
        &Table1Figure {
            report: report.clone(),
        },
    )
}
