//! `host probe`: Eq. 4 on simulated normal pairs of optical depth estimates.

use anyhow::{Context, Result};
use engine::backend::{Backend, BackendChoice};
use shared::kernels::probe::{self, DepthPair};
use std::time::Instant;

/// What `host probe` simulates.
#[derive(Debug, Clone)]
pub struct ProbeOptions {
    pub backend: BackendChoice,
    /// Number of (X0, X1) pairs.
    pub count: u32,
    /// True optical depth.
    pub tau: f32,
    /// Standard deviation of each estimate.
    pub sigma: f32,
    pub seed: u32,
}

/// Two normal optical depth estimates N(tau, sigma^2) for one id (Box-Muller on PCG32 draws).
fn normal_pair(id: u32, seed: u32, tau: f32, sigma: f32) -> DepthPair {
    let rng = probe::pcg32_for(id, seed);
    let (u1, rng) = rng.next_f32();
    let (u2, _) = rng.next_f32();
    let radius = (-2.0 * shared::math::ln(1.0 - u1)).sqrt();
    let (s, c) = shared::math::sin_cos(std::f32::consts::TAU * u2);
    DepthPair {
        x0: tau + sigma * radius * c,
        x1: tau + sigma * radius * s,
    }
}

/// `host probe`: Eq. 4 and exp(-X̄) on simulated normal pairs, next to exp(-tau).
pub fn run_probe(args: &ProbeOptions) -> Result<()> {
    anyhow::ensure!(
        args.tau.is_finite() && args.sigma.is_finite() && args.sigma >= 0.0,
        "--tau must be finite and --sigma finite and >= 0 (got --tau {} --sigma {})",
        args.tau,
        args.sigma
    );
    let backend = Backend::open(args.backend)?;
    println!("backend: {} ({})", backend.kind(), backend.device());
    let pairs: Vec<DepthPair> = engine::backend::cpu::generate(args.count, |i| {
        normal_pair(i, args.seed, args.tau, args.sigma)
    });
    let start = Instant::now();
    let out = backend
        .transmittance_pairs(&pairs)
        .context("evaluating Eq. 4")?;
    let elapsed = start.elapsed();
    let n = out.len() as f64;
    let stats = |f: &dyn Fn(usize) -> f32| {
        let mean = (0..out.len()).map(|i| f(i) as f64).sum::<f64>() / n;
        let var = (0..out.len())
            .map(|i| (f(i) as f64 - mean).powi(2))
            .sum::<f64>()
            / (n - 1.0).max(1.0);
        (mean, (var / n).sqrt())
    };
    let (jackknife, se_j) = stats(&|i| out[i].jackknife);
    let (naive, se_n) = stats(&|i| out[i].naive);
    let exact = (-(args.tau as f64)).exp();
    println!(
        "{} pairs X0, X1 ~ N(tau = {}, sigma = {}), seed {}: kernel time {:.1} ms",
        args.count,
        args.tau,
        args.sigma,
        args.seed,
        elapsed.as_secs_f64() * 1e3
    );
    println!("  exact exp(-tau)        {exact:.6}");
    println!(
        "  jackknife K (Eq. 4)    {jackknife:.6} ± {se_j:.6}  bias {:+.6}",
        jackknife - exact
    );
    println!(
        "  naive exp(-X̄)         {naive:.6} ± {se_n:.6}  bias {:+.6}",
        naive - exact
    );
    Ok(())
}
