//! `host study normal`: Eq. 4 and exp(-X̄) for m = 2 normal optical depth estimates, measured
//! next to the closed forms of App. A (Fig. 3).
//!
//! Inputs are drawn in f64 (Box-Muller), rounded to f32 and fed to the renderer's own estimators
//! `shared::estimators::transmittance::{jackknife, naive}`; statistics are accumulated in f64.

use super::files::Output;
use super::plot::{Figure, Legend, LinePanel, Series, Style, BLUE, GREY, INK, ORANGE};
use super::rng::{sub_seed, Rng};
use super::stats::{progress, run_chunked, Moments, Summary};
use anyhow::{bail, Result};
use indicatif::ProgressBar;
use plotters::coord::Shift;
use plotters::prelude::{DrawingArea, DrawingBackend};
use serde::Serialize;

/// Mean, bias, std, variance and rRMSE of a transmittance estimator, exact or measured.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ClosedForm {
    pub mean: f64,
    pub bias: f64,
    pub std: f64,
    pub variance: f64,
    pub rrmse: f64,
}

/// App. A.2: K = cos(S) exp(-X̄) is unbiased with V(K) = (e^{sigma^2} - 1) T^2 / 2.
pub fn jackknife_closed_form(tau: f64, sigma: f64) -> ClosedForm {
    let t = (-tau).exp();
    let e = (sigma * sigma).exp();
    let variance = 0.5 * (e - 1.0) * t * t;
    ClosedForm {
        mean: t,
        bias: 0.0,
        std: variance.sqrt(),
        variance,
        rrmse: (0.5 * (e - 1.0)).sqrt(),
    }
}

/// App. A.1 with the variance of X̄ = (X0 + X1) / 2 halved to sigma^2 / 2:
/// E = e^{sigma^2/4} T, V = (e^{sigma^2} - e^{sigma^2/2}) T^2 and
/// rRMSE^2 = e^{sigma^2} - 2 e^{sigma^2/4} + 1.
pub fn naive_closed_form(tau: f64, sigma: f64) -> ClosedForm {
    let t = (-tau).exp();
    let s2 = sigma * sigma;
    let mean = (0.25 * s2).exp() * t;
    let variance = (s2.exp() - (0.5 * s2).exp()) * t * t;
    let rrmse = (s2.exp() - 2.0 * (0.25 * s2).exp() + 1.0).sqrt();
    ClosedForm {
        mean,
        bias: mean - t,
        std: variance.sqrt(),
        variance,
        rrmse,
    }
}

/// Measured statistics of both estimators for one (tau, sigma).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct NormalPoint {
    pub tau: f64,
    pub sigma: f64,
    pub trials: u64,
    pub transmittance: f64,
    pub jackknife: Summary,
    pub naive: Summary,
    pub jackknife_rrmse: f64,
    pub naive_rrmse: f64,
    pub jackknife_closed: ClosedForm,
    pub naive_closed: ClosedForm,
}

/// Runs `trials` pairs X0, X1 ~ N(tau, sigma^2) through Eq. 4 and exp(-X̄).
pub fn measure(tau: f64, sigma: f64, trials: u64, seed: u64, bar: &ProgressBar) -> NormalPoint {
    let t = (-tau).exp();
    let empty = vec![Moments::new(t); 2];
    let m = run_chunked(trials, seed, bar, &empty, |acc, rng: &mut Rng, count| {
        for _ in 0..count {
            let (z0, z1) = rng.normal_pair();
            let x0 = (tau + sigma * z0) as f32;
            let x1 = (tau + sigma * z1) as f32;
            acc[0].push(shared::estimators::transmittance::jackknife(x0, x1) as f64);
            acc[1].push(shared::estimators::transmittance::naive(x0, x1) as f64);
        }
    });
    NormalPoint {
        tau,
        sigma,
        trials,
        transmittance: t,
        jackknife: m[0].summary(t),
        naive: m[1].summary(t),
        jackknife_rrmse: m[0].rms_about_centre() / t,
        naive_rrmse: m[1].rms_about_centre() / t,
        jackknife_closed: jackknife_closed_form(tau, sigma),
        naive_closed: naive_closed_form(tau, sigma),
    }
}

/// Measured rRMSE of both estimators at several sigma (the markers of the Fig. 3 plot).
pub fn sweep(
    tau: f64,
    sigmas: &[f64],
    trials: u64,
    seed: u64,
    bar: &ProgressBar,
) -> Vec<NormalPoint> {
    sigmas
        .iter()
        .enumerate()
        .map(|(i, &sigma)| measure(tau, sigma, trials, sub_seed(seed, 1000 + i as u64), bar))
        .collect()
}

/// Fig. 3: rRMSE of both estimators over sigma (closed forms as lines, measurements as dots),
/// and their ratio.
pub struct RrmseFigure {
    pub point: NormalPoint,
    pub sweep: Vec<NormalPoint>,
}

impl Figure for RrmseFigure {
    fn size(&self) -> (u32, u32) {
        (1000, 420)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let areas = root.split_evenly((1, 2));
        let mut measured: Vec<NormalPoint> = self.sweep.clone();
        measured.push(self.point);
        let sigma_max = measured.iter().map(|p| p.sigma).fold(2.5, f64::max);
        let sigmas: Vec<f64> = (1..=250).map(|i| sigma_max * i as f64 / 250.0).collect();
        let curve = |f: &dyn Fn(f64) -> f64| sigmas.iter().map(|&s| (s, f(s))).collect::<Vec<_>>();
        let jk = |s: f64| jackknife_closed_form(0.0, s).rrmse;
        let nv = |s: f64| naive_closed_form(0.0, s).rrmse;
        let dots = |f: &dyn Fn(&NormalPoint) -> f64| {
            measured.iter().map(|p| (p.sigma, f(p))).collect::<Vec<_>>()
        };

        let mut left = LinePanel::new(
            "rRMSE, m = 2 normal estimates (App. A)",
            "σ of each estimate",
            "rRMSE",
            (sigmas[0], sigma_max),
            (jk(sigmas[0]) * 0.8, nv(sigma_max) * 1.3),
        );
        left.log_y = true;
        left.series.push(Series::new(
            "naive exp(-(X0+X1)/2), closed form",
            ORANGE,
            Style::Line,
            curve(&nv),
        ));
        left.series.push(Series::new(
            "jackknife (Eq. 4), closed form",
            BLUE,
            Style::Line,
            curve(&jk),
        ));
        left.series.push(Series::new(
            "measured",
            INK,
            Style::Markers(4),
            dots(&|p| p.naive_rrmse),
        ));
        left.series.push(Series::new(
            "",
            INK,
            Style::Markers(4),
            dots(&|p| p.jackknife_rrmse),
        ));
        left.draw(&areas[0])?;

        let mut right = LinePanel::new(
            "rRMSE ratio jackknife / naive",
            "σ of each estimate",
            "ratio",
            (0.0, sigma_max),
            (0.65, 1.02),
        );
        right.legend = Legend::UpperRight;
        right.series.push(Series::new(
            "closed form",
            BLUE,
            Style::Line,
            curve(&|s| jk(s) / nv(s)),
        ));
        right.series.push(Series::new(
            "1/√2",
            GREY,
            Style::Dashed,
            vec![(0.0, 0.5f64.sqrt()), (sigma_max, 0.5f64.sqrt())],
        ));
        right.series.push(Series::new(
            "measured",
            INK,
            Style::Markers(4),
            dots(&|p| p.jackknife_rrmse / p.naive_rrmse),
        ));
        right.draw(&areas[1])
    }
}

/// The sigma values of the Fig. 3 dots.
pub const NORMAL_SWEEP: [f64; 10] = [0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5];

/// Options of `host study normal` (the CLI's flags, checked by `run`).
#[derive(Debug, Clone)]
pub struct NormalOptions {
    /// Optical depth tau (the mean of each estimate), 0 to 20.
    pub tau: f64,
    /// Standard deviation sigma of each of the two estimates, 0 to 10.
    pub sigma: f64,
    /// Trials (independent transmittance estimates), 2 to 10^10.
    pub trials: u64,
    /// Trials per sigma of the measured rRMSE dots of the plot, 2 to 10^10 (0: none).
    pub sweep_trials: u64,
    /// Seed, JSON and plot files, progress bar.
    pub out: Output,
}

/// Runs `host study normal`: measures, prints the table, writes the JSON and the plot.
pub fn run(a: &NormalOptions) -> Result<()> {
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
    let point = measure(a.tau, a.sigma, a.trials, a.out.seed, &bar);
    let sweep = if sweep_len > 0 {
        sweep(a.tau, &NORMAL_SWEEP, a.sweep_trials, a.out.seed, &bar)
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
        point: &'a NormalPoint,
        sweep: &'a [NormalPoint],
    }
    a.out.write(
        "normal",
        &Json {
            point: &point,
            sweep: &sweep,
        },
        &RrmseFigure {
            point,
            sweep: sweep.clone(),
        },
    )
}
