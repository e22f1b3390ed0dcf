//! `host study histogram`: the distribution of optical depth estimates of one sampling scheme and
//! sample count, with the fitted normal density (Fig. 4, 6), skewness, kurtosis and the
//! Kolmogorov-Smirnov distance to that normal.

use super::plot::{Figure, LinePanel, Series, Style, BLUE, INK, ORANGE};
use super::profile::{Profile, Sampling};
use super::stats::{run_chunked, Merge, Moments};
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
