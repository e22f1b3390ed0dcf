//! `host`: renders and measures the jackknife transmittance estimators on the GPU or the CPU.

use anyhow::Result;
use clap::Parser;
use host::{Backend, BackendChoice};
use shared::probe::{self, DepthPair};
use std::time::Instant;

/// Jackknife transmittance (Peters 2025) on a Vulkan GPU or the CPU, from one Rust source.
///
/// For now this evaluates the jackknife estimate K = cos(S) exp(-X̄) (Eq. 4) and the naive
/// exp(-X̄) for normally distributed optical depth pairs and compares their means to exp(-tau).
#[derive(Parser, Debug)]
#[command(version, about)]
struct Cli {
    /// Where kernels run: auto (GPU if a Vulkan driver exists, else CPU), gpu, or cpu.
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    backend: BackendChoice,
    /// Number of (X0, X1) pairs.
    #[arg(long, default_value_t = 1 << 20, value_parser = clap::value_parser!(u32).range(1..=1 << 26))]
    count: u32,
    /// True optical depth tau of the simulated estimates.
    #[arg(long, default_value_t = 2.0)]
    tau: f32,
    /// Standard deviation sigma of each simulated optical depth estimate.
    #[arg(long, default_value_t = 1.0)]
    sigma: f32,
    /// Seed; the same seed gives the same numbers on every backend.
    #[arg(long, default_value_t = 0)]
    seed: u32,
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

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    anyhow::ensure!(
        cli.tau.is_finite() && cli.sigma.is_finite() && cli.sigma >= 0.0,
        "--tau must be finite and --sigma finite and >= 0 (got --tau {} --sigma {})",
        cli.tau,
        cli.sigma
    );
    let backend = Backend::open(cli.backend)?;
    println!("backend: {} ({})", backend.kind(), backend.device());

    let pairs: Vec<DepthPair> =
        host::cpu::generate(cli.count, |i| normal_pair(i, cli.seed, cli.tau, cli.sigma));
    let start = Instant::now();
    let out = backend.transmittance_pairs(&pairs)?;
    let elapsed = start.elapsed();

    let n = out.len() as f64;
    let mean = |f: &dyn Fn(usize) -> f32| (0..out.len()).map(|i| f(i) as f64).sum::<f64>() / n;
    let jackknife = mean(&|i| out[i].jackknife);
    let naive = mean(&|i| out[i].naive);
    let exact = (-(cli.tau as f64)).exp();
    let var = |m: f64, f: &dyn Fn(usize) -> f32| {
        (0..out.len())
            .map(|i| (f(i) as f64 - m).powi(2))
            .sum::<f64>()
            / (n - 1.0).max(1.0)
    };
    let se_j = (var(jackknife, &|i| out[i].jackknife) / n).sqrt();
    let se_n = (var(naive, &|i| out[i].naive) / n).sqrt();
    println!(
        "{} pairs X0, X1 ~ N(tau = {}, sigma = {}), seed {}: kernel time {:.1} ms",
        cli.count,
        cli.tau,
        cli.sigma,
        cli.seed,
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
