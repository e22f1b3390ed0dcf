//! `host study histogram`: the distribution of optical depth estimates of one sampling scheme and
//! sample count, with the fitted normal density (Fig. 4, 6), skewness, kurtosis and the
//! Kolmogorov-Smirnov distance to that normal.

use super::files::Output;
use super::limits::check_trials;
use super::plot::{Figure, LinePanel, Series, Style, BLUE, INK, ORANGE};
use super::profile::{Profile, ProfileFlag, Sampling};
use super::rng;
use super::stats::{progress, run_chunked, Merge, Moments};
use anyhow::{bail, Result};
use indicatif::ProgressBar;
use plotters::coord::Shift;
use plotters::prelude::{DrawingArea, DrawingBackend};
use serde::Serialize;

/// All estimates of a run, in chunk order.
#[derive(Clone, Debug, Default)]
struct Samples(Vec<f64>);

impl Merge for Samples {
    fn merge(&mut self, other: &Self) {
        self.0.extend_from_slice(&other.0);
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct Histogram {
    pub sampling: Sampling,
    pub n: usize,
    pub trials: u64,
    pub tau: f64,
    pub mean: f64,
    pub mean_se: f64,
    pub std: f64,
    pub skewness: f64,
    pub excess_kurtosis: f64,
    /// sup |F_empirical - F_normal| against the fitted normal (0 for an exact normal sample up to
    /// ~1/sqrt(trials) noise).
    pub ks_distance: f64,
    /// Bin edges lo + i (hi - lo) / bins, and the counts.
    pub lo: f64,
    pub hi: f64,
    pub counts: Vec<u64>,
}

/// Normal CDF.
fn normal_cdf(x: f64, mean: f64, std: f64) -> f64 {
    0.5 * puruspe::erfc(-(x - mean) / (std * std::f64::consts::SQRT_2))
}

/// `trials` estimates of tau with `sampling` and N = `n`, binned into `bins` bins over their range.
pub fn measure(
    profile: &Profile,
    sampling: Sampling,
    n: usize,
    trials: u64,
    bins: usize,
    seed: u64,
    bar: &ProgressBar,
) -> Result<Histogram> {
    if sampling == Sampling::Midpoint {
        bail!("the midpoint rule is deterministic: no histogram");
    }
    if trials < 2 || bins == 0 {
        bail!("a histogram needs trials >= 2 and bins >= 1");
    }
    let tau = profile.tau();
    let Samples(mut xs) = run_chunked(trials, seed, bar, &Samples::default(), |acc, rng, count| {
        let mut scratch = Vec::new();
        acc.0
            .extend((0..count).map(|_| sampling.estimate(profile, n, rng, &mut scratch)));
    });
    let mut m = Moments::new(tau);
    xs.iter().for_each(|&x| m.push(x));
    xs.sort_by(f64::total_cmp);
    let (mean, std) = (m.mean(), m.std());
    let (lo, hi) = (xs[0], xs[xs.len() - 1]);
    if !(hi - lo > 1e-12 * mean.abs()) || !(std > 0.0) || !std.is_finite() {
        bail!(
            "profile {}: every {} estimate with N = {n} is {lo} (to 12 digits); a histogram and \
             a normal fit (KS test) of a constant are undefined: use a profile whose mu varies",
            profile.name,
            sampling.label()
        );
    }
    let count = xs.len() as f64;
    let ks_distance = xs
        .iter()
        .enumerate()
        .map(|(i, &x)| {
            let f = normal_cdf(x, mean, std);
            (f - i as f64 / count)
                .abs()
                .max(((i + 1) as f64 / count - f).abs())
        })
        .fold(0.0, f64::max);
    let mut counts = vec![0u64; bins];
    for &x in &xs {
        let b = (((x - lo) / (hi - lo)) * bins as f64) as usize;
        counts[b.min(bins - 1)] += 1;
    }
    Ok(Histogram {
        sampling,
        n,
        trials,
        tau,
        mean,
        mean_se: m.mean_se(),
        std,
        skewness: m.skewness(),
        excess_kurtosis: m.excess_kurtosis(),
        ks_distance,
        lo,
        hi,
        counts,
    })
}

impl Histogram {
    /// The histogram as a density next to the fitted normal density, as one plot panel.
    pub fn panel(&self) -> LinePanel {
        let bins = self.counts.len();
        let w = (self.hi - self.lo) / bins as f64;
        let bars: Vec<(f64, f64)> = self
            .counts
            .iter()
            .enumerate()
            .map(|(i, &c)| {
                (
                    self.lo + (i as f64 + 0.5) * w,
                    c as f64 / (self.trials as f64 * w),
                )
            })
            .collect();
        let density = |x: f64| {
            let z = (x - self.mean) / self.std;
            (-0.5 * z * z).exp() / (self.std * (2.0 * std::f64::consts::PI).sqrt())
        };
        let curve: Vec<(f64, f64)> = (0..=200)
            .map(|i| self.lo + (self.hi - self.lo) * i as f64 / 200.0)
            .map(|x| (x, density(x)))
            .collect();
        let y_max = bars.iter().chain(&curve).map(|p| p.1).fold(0.0, f64::max) * 1.08;
        let color = if self.sampling == Sampling::Stratified {
            BLUE
        } else {
            ORANGE
        };
        let mut panel = LinePanel::new(
            &format!(
                "{}, N = {} (KS {:.3})",
                self.sampling.label(),
                self.n,
                self.ks_distance
            ),
            "optical depth estimate X",
            "density",
            (self.lo, self.hi),
            (0.0, y_max),
        );
        panel
            .series
            .push(Series::new("", color, Style::Bars(w), bars));
        panel.series.push(Series::new("", INK, Style::Line, curve));
        panel
    }
}

/// A grid of histograms: one row per sampling scheme, one column per N.
pub struct HistogramFigure {
    pub columns: usize,
    pub histograms: Vec<Histogram>,
}

impl Figure for HistogramFigure {
    fn size(&self) -> (u32, u32) {
        let rows = self.histograms.len().div_ceil(self.columns);
        (300 * self.columns as u32, 250 * rows as u32)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let rows = self.histograms.len().div_ceil(self.columns);
        let areas = root.split_evenly((rows, self.columns));
        for (h, area) in self.histograms.iter().zip(&areas) {
            h.panel().draw(area)?;
        }
        Ok(())
    }
}

/// Options of `host study histogram` (the CLI's flags, checked by `run`).
#[derive(Debug, Clone)]
pub struct HistogramOptions {
    /// The extinction profile.
    pub profile: ProfileFlag,
    /// Sample counts N (columns), each 1 to 10^6, at most 16 of them.
    pub n: Vec<usize>,
    /// Sampling schemes (rows): uniform, stratified or iid (midpoint is deterministic).
    pub sampling: Vec<Sampling>,
    /// Estimates per histogram, 2 to 2 x 10^7 (each is kept in memory).
    pub trials: u64,
    /// Histogram bins, 1 to 10000.
    pub bins: usize,
    /// Seed, JSON and plot files, progress bar.
    pub out: Output,
}

/// Runs `host study histogram`: measures, prints the table, writes the JSON and the plot.
pub fn run(a: &HistogramOptions) -> Result<()> {
    check_trials(a.trials)?;
    if a.n.len() > 16 || a.sampling.len() > 8 {
        bail!("--n takes at most 16 values and --sampling at most 8");
    }
    if a.sampling.contains(&Sampling::Midpoint) {
        bail!("--sampling midpoint is deterministic: no histogram; use uniform, stratified or iid");
    }
    let profile = Profile::load_varying(&a.profile.profile)?;
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
            measure(
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
    let name = format!("histogram_{}", profile.stem());
    a.out.write(
        &name,
        &histograms,
        &HistogramFigure {
            columns: a.n.len(),
            histograms: histograms.clone(),
        },
    )
}
