//! `host study profile`: for one extinction profile, m estimates of N samples each with stratified
//! and with uniform jittered sampling: optical depth statistics and the transmittance estimates
//! Eq. 3 (m >= 2) and exp(-X̄), all in f64 (`umvu`).

use super::files::Output;
use super::histogram::{self, Histogram};
use super::limits::check_trials;
use super::plot::{Figure, LinePanel, Series, Style, INK};
use super::profile::{Profile, ProfileFlag, Sampling};
use super::rng;
use super::stats::{progress, run_chunked, Moments, Summary};
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

/// Options of `host study profile` (the CLI's flags, checked by `run`).
#[derive(Debug, Clone)]
pub struct ProfileOptions {
    /// The extinction profile.
    pub profile: ProfileFlag,
    /// Estimates per transmittance estimate (m, Eq. 3), 2 to 64.
    pub m: usize,
    /// Ray marching samples per estimate, 1 to 10^6.
    pub n: usize,
    /// Trials (independent transmittance estimates), 2 to 10^10.
    pub trials: u64,
    /// Histogram bins of the plot, 1 to 10000.
    pub bins: usize,
    /// Seed, JSON and plot files, progress bar.
    pub out: Output,
}

/// Runs `host study profile`: measures, prints the table, writes the JSON and the plot.
pub fn run(a: &ProfileOptions) -> Result<()> {
    check_trials(a.trials)?;
    let profile = Profile::load_varying(&a.profile.profile)?;
    let hist_trials = a.trials.min(1_000_000);
    let schemes = [Sampling::Stratified, Sampling::Uniform];
    let bar = progress(2 * (a.trials + hist_trials), "profile", a.out.quiet);
    let mut stats = Vec::new();
    let mut histograms = Vec::new();
    for (k, &s) in schemes.iter().enumerate() {
        stats.push(measure(
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
        schemes: &'a [SchemeStats],
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
    let name = format!("profile_{}", profile.stem());
    a.out.write(
        &name,
        &json,
        &ProfileFigure {
            profile: profile.clone(),
            histograms: histograms.clone(),
        },
    )
}
