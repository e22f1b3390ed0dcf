//! `host study profile`: for one extinction profile, m estimates of N samples each with stratified
//! and with uniform jittered sampling: optical depth statistics and the transmittance estimates
//! Eq. 3 (m >= 2) and exp(-X̄), all in f64 (`umvu`).

use super::histogram::Histogram;
use super::plot::{Figure, LinePanel, Series, Style, INK};
use super::profile::{Profile, Sampling};
use super::stats::{run_chunked, Moments, Summary};
use super::umvu;
use anyhow::{bail, Result};
use indicatif::ProgressBar;
use plotters::coord::Shift;
use plotters::prelude::{DrawingArea, DrawingBackend};
use serde::Serialize;

/// One sampling scheme: statistics of a single estimate X and of both transmittance estimates.
#[derive(Clone, Debug, Serialize)]
pub struct SchemeStats {
    pub sampling: Sampling,
    pub depth: Summary,
    pub depth_skewness: f64,
    pub depth_excess_kurtosis: f64,
    /// Eq. 3 with m estimates (Eq. 4 for m = 2).
    pub jackknife: Summary,
    /// exp(-X̄) of the same m estimates.
    pub naive: Summary,
}

pub fn measure(
    profile: &Profile,
    sampling: Sampling,
    m: usize,
    n: usize,
    trials: u64,
    seed: u64,
    bar: &ProgressBar,
) -> Result<SchemeStats> {
    if m < 2 || n < 1 {
        bail!("profile needs --m >= 2 and --n >= 1");
    }
    let tau = profile.tau();
    let t = (-tau).exp();
    let empty = vec![Moments::new(tau), Moments::new(t), Moments::new(t)];
    let acc = run_chunked(trials, seed, bar, &empty, |acc, rng, count| {
        let (mut xs, mut scratch) = (vec![0.0; m], Vec::new());
        for _ in 0..count {
            xs.iter_mut()
                .for_each(|x| *x = sampling.estimate(profile, n, rng, &mut scratch));
            xs.iter().for_each(|&x| acc[0].push(x));
            acc[1].push(umvu::jackknife(&xs));
            acc[2].push(umvu::naive(&xs));
        }
    });
    Ok(SchemeStats {
        sampling,
        depth: acc[0].summary(tau),
        depth_skewness: acc[0].skewness(),
        depth_excess_kurtosis: acc[0].excess_kurtosis(),
        jackknife: acc[1].summary(t),
        naive: acc[2].summary(t),
    })
}

/// The profile mu(t) as a plot panel.
pub fn profile_panel(profile: &Profile) -> LinePanel {
    let pts: Vec<(f64, f64)> = profile.points().collect();
    let mut panel = LinePanel::new(
        &format!(
            "extinction profile {} (τ = {:.4})",
            profile.name,
            profile.tau()
        ),
        "ray parameter t",
        "extinction μ(t)",
        (profile.t_min(), profile.t_max()),
        (0.0, profile.mu_max() * 1.08),
    );
    panel.series.push(Series::new("", INK, Style::Line, pts));
    panel
}

/// mu(t) next to the histograms of one estimate X for each sampling scheme.
pub struct ProfileFigure {
    pub profile: Profile,
    pub histograms: Vec<Histogram>,
}

impl Figure for ProfileFigure {
    fn size(&self) -> (u32, u32) {
        (360 * (1 + self.histograms.len() as u32), 300)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let areas = root.split_evenly((1, 1 + self.histograms.len()));
        profile_panel(&self.profile).draw(&areas[0])?;
        for (h, area) in self.histograms.iter().zip(&areas[1..]) {
            h.panel().draw(area)?;
        }
        Ok(())
    }
}
