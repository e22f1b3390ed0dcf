//! `host study convergence`: RMSE of optical depth estimates against the sample count N for the
//! midpoint rule, uniform jittered, stratified jittered and i.i.d. sampling (Fig. 5).

use super::files::Output;
use super::limits::check_trials;
use super::plot::{Figure, Legend, LinePanel, Series, Style, BLUE, GREEN, GREY, ORANGE, PURPLE};
use super::profile::{Profile, ProfileFlag, Sampling};
use super::rng::sub_seed;
use super::stats::{log_log_slope, progress, run_chunked, Moments};
use anyhow::{bail, Result};
use indicatif::ProgressBar;
use plotters::coord::Shift;
use plotters::prelude::{DrawingArea, DrawingBackend};
use serde::Serialize;

/// About `points` sample counts from 1 to `max_n`, evenly spaced in log N, rounded, distinct.
pub fn sample_counts(max_n: usize, points: usize) -> Vec<usize> {
    let mut ns: Vec<usize> = (0..points)
        .map(|i| {
            (max_n as f64)
                .powf(i as f64 / (points - 1).max(1) as f64)
                .round() as usize
        })
        .collect();
    ns.dedup();
    ns
}

/// RMSE over N for one sampling scheme, and the fitted log-log slopes below and above N = 100.
#[derive(Clone, Debug, Serialize)]
pub struct Curve {
    pub sampling: Sampling,
    /// (N, RMSE): for the midpoint rule the absolute error of its single deterministic estimate.
    pub rmse: Vec<(usize, f64)>,
    /// None (JSON null) where fewer than two points with a nonzero error lie in the range.
    pub slope_up_to_100: Option<f64>,
    pub slope_from_100: Option<f64>,
}

/// A fitted slope for tables and legends: `n/a` where there is none.
fn slope_text(slope: Option<f64>, precision: usize) -> String {
    slope.map_or("n/a".into(), |s| format!("{s:.precision$}"))
}

/// Runs `trials` estimates per (sampling, N) and measures the RMSE about the exact tau.
pub fn measure(
    profile: &Profile,
    samplings: &[Sampling],
    ns: &[usize],
    trials: u64,
    seed: u64,
    bar: &ProgressBar,
) -> Vec<Curve> {
    let tau = profile.tau();
    samplings
        .iter()
        .enumerate()
        .map(|(k, &sampling)| {
            let rmse: Vec<(usize, f64)> = ns
                .iter()
                .map(|&n| {
                    let trials = if sampling == Sampling::Midpoint {
                        1
                    } else {
                        trials
                    };
                    let key = (k as u64) << 32 | n as u64;
                    let m = run_chunked(
                        trials,
                        sub_seed(seed, key),
                        bar,
                        &Moments::new(tau),
                        |acc, rng, count| {
                            let mut scratch = Vec::new();
                            for _ in 0..count {
                                acc.push(sampling.estimate(profile, n, rng, &mut scratch));
                            }
                        },
                    );
                    (n, m.rms_about_centre())
                })
                .collect();
            let fit = |keep: &dyn Fn(usize) -> bool| {
                let pts: Vec<(f64, f64)> = rmse
                    .iter()
                    .filter(|&&(n, e)| keep(n) && e > 0.0)
                    .map(|&(n, e)| (n as f64, e))
                    .collect();
                (pts.len() >= 2).then(|| log_log_slope(&pts))
            };
            Curve {
                sampling,
                slope_up_to_100: fit(&|n| n <= 100),
                slope_from_100: fit(&|n| n >= 100),
                rmse,
            }
        })
        .collect()
}

/// Fig. 5: log-log RMSE over N with N^-1/2 and N^-1 guides.
pub struct ConvergenceFigure {
    pub profile: String,
    pub tau: f64,
    pub curves: Vec<Curve>,
}

impl Figure for ConvergenceFigure {
    fn size(&self) -> (u32, u32) {
        (720, 520)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let has_error = self.curves.iter().flat_map(|c| &c.rmse).any(|p| p.1 > 0.0);
        anyhow::ensure!(
            has_error,
            "profile {}: every estimate is exact (RMSE 0 for every N), so there is no \
             convergence to plot on log axes: use a profile whose mu varies",
            self.profile
        );
        let positive = || {
            self.curves
                .iter()
                .flat_map(|c| c.rmse.iter().map(|p| p.1))
                .filter(|&e| e > 0.0)
        };
        let y_min = positive().fold(f64::INFINITY, f64::min) * 0.5;
        let y_max = positive().fold(0.0, f64::max) * 2.0;
        let n_max = self
            .curves
            .iter()
            .flat_map(|c| c.rmse.iter().map(|p| p.0))
            .max()
            .unwrap_or(1) as f64;
        let mut panel = LinePanel::new(
            &format!(
                "RMSE of optical depth estimates, profile {} (τ = {:.3})",
                self.profile, self.tau
            ),
            "sample count N",
            "RMSE",
            (1.0, n_max),
            (y_min, y_max),
        );
        panel.log_x = true;
        panel.log_y = true;
        panel.legend = Legend::LowerLeft;
        for c in &self.curves {
            let color = match c.sampling {
                Sampling::Midpoint => PURPLE,
                Sampling::Uniform => ORANGE,
                Sampling::Stratified => BLUE,
                Sampling::Iid => GREEN,
            };
            let pts: Vec<(f64, f64)> = c
                .rmse
                .iter()
                .filter(|p| p.1 > 0.0)
                .map(|&(n, e)| (n as f64, e))
                .collect();
            let label = format!(
                "{} (slope {} / {})",
                c.sampling.label(),
                slope_text(c.slope_up_to_100, 2),
                slope_text(c.slope_from_100, 2)
            );
            panel
                .series
                .push(Series::new(&label, color, Style::Line, pts.clone()));
            panel
                .series
                .push(Series::new("", color, Style::Markers(3), pts));
        }
        // Guides through the i.i.d. curve's first point: N^-1/2 and N^-1.
        if let Some(&(_, e1)) = self
            .curves
            .iter()
            .find(|c| c.sampling == Sampling::Iid)
            .and_then(|c| c.rmse.first())
        {
            let guide = |p: f64| vec![(1.0, e1), (n_max, e1 * n_max.powf(-p))];
            panel
                .series
                .push(Series::new("N^-1/2, N^-1", GREY, Style::Dashed, guide(0.5)));
            panel
                .series
                .push(Series::new("", GREY, Style::Dashed, guide(1.0)));
        }
        panel.draw(root)
    }
}

/// Options of `host study convergence` (the CLI's flags, checked by `run`).
#[derive(Debug, Clone)]
pub struct ConvergenceOptions {
    /// The extinction profile.
    pub profile: ProfileFlag,
    /// Largest sample count N, 1 to 10^6.
    pub max_n: usize,
    /// Sample counts, log-spaced from 1 to max-n, 2 to 1000.
    pub points: usize,
    /// Estimates per (sampling, N), 2 to 10^8 (the paper uses 10^4).
    pub trials: u64,
    /// Sampling schemes (curves).
    pub sampling: Vec<Sampling>,
    /// Seed, JSON and plot files, progress bar.
    pub out: Output,
}

/// Runs `host study convergence`: measures, prints the table, writes the JSON and the plot.
pub fn run(a: &ConvergenceOptions) -> Result<()> {
    check_trials(a.trials)?;
    if a.max_n < 1 || a.points < 2 || a.sampling.is_empty() || a.sampling.len() > 8 {
        bail!("convergence needs --max-n >= 1, --points >= 2 and 1 to 8 --sampling schemes");
    }
    let profile = Profile::load_varying(&a.profile.profile)?;
    let ns = sample_counts(a.max_n, a.points);
    let per_n: u64 = a
        .sampling
        .iter()
        .map(|&s| if s == Sampling::Midpoint { 1 } else { a.trials })
        .sum();
    let bar = progress(per_n * ns.len() as u64, "convergence", a.out.quiet);
    let curves = measure(&profile, &a.sampling, &ns, a.trials, a.out.seed, &bar);
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
    curves.iter().for_each(|c| {
        print!(
            " {:>9} / {:<8}",
            slope_text(c.slope_up_to_100, 3),
            slope_text(c.slope_from_100, 3)
        )
    });
    println!("   (N <= 100 / N >= 100)");
    let figure = ConvergenceFigure {
        profile: profile.name.clone(),
        tau: profile.tau(),
        curves: curves.clone(),
    };
    a.out.write("convergence", &curves, &figure)
}
