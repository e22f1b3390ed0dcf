//! `host study distributions`: Eq. 4 against exp(-X̄) for m = 2 optical depth estimates that are
//! not normal (Fig. 2). Every distribution has mean tau and standard deviation sigma.
//!
//! As in `normal`, inputs are drawn in f64, rounded to f32 and fed to the renderer's own
//! `shared::estimators::transmittance::{jackknife, naive}`; statistics are accumulated in f64.

use super::files::Output;
use super::limits::check_trials;
use super::plot::{Drawn, Figure, LinePanel, Series, Style, BLUE, FONT, INK, ORANGE};
use super::rng::{sub_seed, Rng};
use super::stats::{progress, run_chunked, Moments, Summary};
use anyhow::{bail, Result};
use indicatif::ProgressBar;
use plotters::coord::Shift;
use plotters::prelude::{DrawingArea, DrawingBackend};
use serde::Serialize;

/// Hypothetical distributions of optical depth estimates, all with mean tau and std sigma.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Distribution {
    /// The assumption of Thm. 1: Eq. 4 is unbiased.
    Normal,
    /// Uniform on tau +- sqrt(3) sigma.
    Uniform,
    /// Laplace (double exponential) with scale sigma / sqrt(2).
    Laplace,
    /// One-sided: tau - sigma + Exp(mean sigma), a long tail towards large depths.
    Exponential,
    /// One-sided the other way: tau + sigma - Exp(mean sigma); exp(-X̄) has infinite variance
    /// from sigma = 1 on and infinite mean from sigma = 2 on.
    ExponentialLeft,
    /// tau - sigma or tau + sigma with probability 1/2 each.
    TwoPoint,
}

impl Distribution {
    pub const ALL: [Distribution; 6] = [
        Distribution::Normal,
        Distribution::Uniform,
        Distribution::Laplace,
        Distribution::Exponential,
        Distribution::ExponentialLeft,
        Distribution::TwoPoint,
    ];

    pub fn label(self) -> &'static str {
        match self {
            Distribution::Normal => "normal",
            Distribution::Uniform => "uniform",
            Distribution::Laplace => "Laplace",
            Distribution::Exponential => "exponential (right tail)",
            Distribution::ExponentialLeft => "exponential (left tail)",
            Distribution::TwoPoint => "two-point",
        }
    }

    /// One draw with mean 0 and standard deviation 1.
    fn standard(self, rng: &mut Rng) -> f64 {
        match self {
            Distribution::Normal => rng.normal_pair().0,
            Distribution::Uniform => 3f64.sqrt() * (2.0 * rng.uniform() - 1.0),
            Distribution::Laplace => {
                let e = -rng.uniform_open0().ln() / std::f64::consts::SQRT_2;
                if rng.next_u32() & 1 == 0 {
                    e
                } else {
                    -e
                }
            }
            Distribution::Exponential => -rng.uniform_open0().ln() - 1.0,
            Distribution::ExponentialLeft => 1.0 + rng.uniform_open0().ln(),
            Distribution::TwoPoint => {
                if rng.next_u32() & 1 == 0 {
                    -1.0
                } else {
                    1.0
                }
            }
        }
    }

    /// Two independent draws with mean tau and standard deviation sigma.
    pub fn pair(self, tau: f64, sigma: f64, rng: &mut Rng) -> (f64, f64) {
        let (z0, z1) = match self {
            Distribution::Normal => rng.normal_pair(),
            _ => (self.standard(rng), self.standard(rng)),
        };
        (tau + sigma * z0, tau + sigma * z1)
    }
}

/// Both estimators for one distribution and sigma.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Point {
    pub distribution: Distribution,
    pub tau: f64,
    pub sigma: f64,
    pub transmittance: f64,
    pub jackknife: Summary,
    pub naive: Summary,
}

pub fn measure(
    dist: Distribution,
    tau: f64,
    sigma: f64,
    trials: u64,
    seed: u64,
    bar: &ProgressBar,
) -> Point {
    let t = (-tau).exp();
    let m = run_chunked(
        trials,
        seed,
        bar,
        &vec![Moments::new(t); 2],
        |acc, rng, count| {
            for _ in 0..count {
                let (x0, x1) = dist.pair(tau, sigma, rng);
                let (x0, x1) = (x0 as f32, x1 as f32);
                acc[0].push(shared::estimators::transmittance::jackknife(x0, x1) as f64);
                acc[1].push(shared::estimators::transmittance::naive(x0, x1) as f64);
            }
        },
    );
    Point {
        distribution: dist,
        tau,
        sigma,
        transmittance: t,
        jackknife: m[0].summary(t),
        naive: m[1].summary(t),
    }
}

/// Every distribution at every sigma; seeds per (distribution, sigma index).
pub fn sweep(
    dists: &[Distribution],
    tau: f64,
    sigmas: &[f64],
    trials: u64,
    seed: u64,
    bar: &ProgressBar,
) -> Vec<Point> {
    dists
        .iter()
        .enumerate()
        .flat_map(|(d, &dist)| {
            sigmas.iter().enumerate().map(move |(i, &sigma)| {
                measure(
                    dist,
                    tau,
                    sigma,
                    trials,
                    sub_seed(seed, (d as u64) << 32 | i as u64),
                    bar,
                )
            })
        })
        .collect()
}

/// Fig. 2: per distribution, mean (solid) and std (dashed) of both estimators over sigma.
pub struct DistributionsFigure {
    pub tau: f64,
    pub points: Vec<Point>,
}

impl Figure for DistributionsFigure {
    fn size(&self) -> (u32, u32) {
        (1050, 640)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let mut dists: Vec<Distribution> = self.points.iter().map(|p| p.distribution).collect();
        dists.dedup();
        let root = root
            .titled(
                "m = 2 estimates: naive exp(-(X0+X1)/2) orange, jackknife (Eq. 4) blue; \
                 mean solid, std dashed; exact T black",
                (FONT, 17),
            )
            .drawn()?;
        let columns = dists.len().min(3);
        let areas = root.split_evenly((dists.len().div_ceil(columns), columns));
        let sigma_max = self.points.iter().map(|p| p.sigma).fold(0.0, f64::max);
        let y_max = self
            .points
            .iter()
            .flat_map(|p| [p.jackknife.mean, p.naive.mean, p.jackknife.std, p.naive.std])
            .fold(0.0, f64::max)
            .min(0.75)
            * 1.05;
        let t = (-self.tau).exp();
        for (&dist, area) in dists.iter().zip(&areas) {
            let pts: Vec<&Point> = self
                .points
                .iter()
                .filter(|p| p.distribution == dist)
                .collect();
            let line =
                |f: &dyn Fn(&Point) -> f64| pts.iter().map(|p| (p.sigma, f(p))).collect::<Vec<_>>();
            let mut panel = LinePanel::new(
                dist.label(),
                "σ of each estimate",
                "transmittance",
                (0.0, sigma_max),
                (0.0, y_max),
            );
            panel.series.push(Series::new(
                "",
                INK,
                Style::Line,
                vec![(0.0, t), (sigma_max, t)],
            ));
            panel.series.push(Series::new(
                "",
                ORANGE,
                Style::Line,
                line(&|p| p.naive.mean),
            ));
            panel.series.push(Series::new(
                "",
                BLUE,
                Style::Line,
                line(&|p| p.jackknife.mean),
            ));
            panel.series.push(Series::new(
                "",
                ORANGE,
                Style::Dashed,
                line(&|p| p.naive.std),
            ));
            panel.series.push(Series::new(
                "",
                BLUE,
                Style::Dashed,
                line(&|p| p.jackknife.std),
            ));
            panel.draw(area)?;
        }
        Ok(())
    }
}

/// Options of `host study distributions` (the CLI's flags, checked by `run`).
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
    /// Seed, JSON and plot files, progress bar.
    pub out: Output,
}

/// Runs `host study distributions`: measures, prints the table, writes the JSON and the plot.
pub fn run(a: &DistributionsOptions) -> Result<()> {
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
    let points = sweep(&dists, a.tau, &sigmas, a.trials, a.out.seed, &bar);
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
        &DistributionsFigure {
            tau: a.tau,
            points: points.clone(),
        },
    )
}
