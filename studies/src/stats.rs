//! Moments accumulated in f64, merged in a fixed order, and the chunked parallel trial runner that
//! makes every study independent of the thread count.

use super::rng::Rng;
use indicatif::ProgressBar;
use rayon::prelude::*;
use serde::Serialize;

/// Trials per chunk: one generator, one accumulator, one progress tick.
pub const CHUNK: u64 = 1 << 15;

/// Accumulators that combine per-chunk results (in chunk order, so the sum is reproducible).
pub trait Merge {
    fn merge(&mut self, other: &Self);
}

/// Power sums of d = x - centre up to d^4. The centre is a value known in advance near the mean
/// (usually the exact answer), so the central moments below lose no precision to cancellation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Moments {
    pub n: u64,
    pub centre: f64,
    sums: [f64; 4],
}

impl Moments {
    pub fn new(centre: f64) -> Self {
        Moments {
            n: 0,
            centre,
            sums: [0.0; 4],
        }
    }

    #[inline]
    pub fn push(&mut self, x: f64) {
        let d = x - self.centre;
        let d2 = d * d;
        self.n += 1;
        self.sums[0] += d;
        self.sums[1] += d2;
        self.sums[2] += d2 * d;
        self.sums[3] += d2 * d2;
    }

    fn raw(&self, k: usize) -> f64 {
        self.sums[k] / self.n as f64
    }

    /// Sample mean.
    pub fn mean(&self) -> f64 {
        self.centre + self.raw(0)
    }

    /// k-th central moment with divisor n (k = 2, 3, 4).
    pub fn central(&self, k: usize) -> f64 {
        let (a, b, c, d) = (self.raw(0), self.raw(1), self.raw(2), self.raw(3));
        match k {
            2 => b - a * a,
            3 => c - 3.0 * a * b + 2.0 * a * a * a,
            4 => d - 4.0 * a * c + 6.0 * a * a * b - 3.0 * a * a * a * a,
            _ => panic!("central moment {k} is not tracked"),
        }
    }

    /// Unbiased sample variance s^2 (divisor n - 1).
    pub fn variance(&self) -> f64 {
        let n = self.n as f64;
        self.central(2) * n / (n - 1.0)
    }

    pub fn std(&self) -> f64 {
        self.variance().max(0.0).sqrt()
    }

    /// Standard error of the mean, s / sqrt(n).
    pub fn mean_se(&self) -> f64 {
        (self.variance() / self.n as f64).sqrt()
    }

    /// Standard error of s^2 by the delta method: V(s^2) ~ (mu4 - sigma^4) / n for large n
    /// (needs a finite 8th moment; all estimators studied here have one for normal inputs).
    pub fn variance_se(&self) -> f64 {
        let m2 = self.central(2);
        ((self.central(4) - m2 * m2).max(0.0) / self.n as f64).sqrt()
    }

    /// Standard error of s, from that of s^2: d sqrt(v) = dv / (2 sqrt(v)).
    pub fn std_se(&self) -> f64 {
        self.variance_se() / (2.0 * self.std())
    }

    /// Root mean square of x - centre: the RMSE when the centre is the exact answer.
    pub fn rms_about_centre(&self) -> f64 {
        self.raw(1).sqrt()
    }

    pub fn skewness(&self) -> f64 {
        self.central(3) / self.central(2).powf(1.5)
    }

    pub fn excess_kurtosis(&self) -> f64 {
        let m2 = self.central(2);
        self.central(4) / (m2 * m2) - 3.0
    }

    /// The numbers a report shows for an estimator of `exact`.
    pub fn summary(&self, exact: f64) -> Summary {
        Summary {
            mean: self.mean(),
            mean_se: self.mean_se(),
            bias: self.mean() - exact,
            std: self.std(),
            std_se: self.std_se(),
            variance: self.variance(),
            variance_se: self.variance_se(),
            rmse: self.rms_about_centre(),
        }
    }
}

impl Merge for Moments {
    fn merge(&mut self, other: &Self) {
        assert_eq!(
            self.centre, other.centre,
            "merging moments about different centres"
        );
        self.n += other.n;
        for (a, b) in self.sums.iter_mut().zip(other.sums) {
            *a += b;
        }
    }
}

impl<T: Merge> Merge for Vec<T> {
    fn merge(&mut self, other: &Self) {
        assert_eq!(self.len(), other.len());
        for (a, b) in self.iter_mut().zip(other) {
            a.merge(b);
        }
    }
}

/// Mean, bias, std and RMSE of an estimator, with standard errors; the RMSE is about the centre
/// its moments were accumulated around (the exact value).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Summary {
    pub mean: f64,
    pub mean_se: f64,
    pub bias: f64,
    pub std: f64,
    pub std_se: f64,
    pub variance: f64,
    pub variance_se: f64,
    pub rmse: f64,
}

/// Runs `trials` trials in chunks of [`CHUNK`]: chunk c gets `Rng::for_chunk(seed, c)`, a copy of
/// `empty` and its trial count; the chunk results are merged in increasing c. Rayon decides only
/// which thread runs which chunk, so the result is the same for any thread count.
pub fn run_chunked<A, F>(trials: u64, seed: u64, bar: &ProgressBar, empty: &A, chunk: F) -> A
where
    A: Merge + Clone + Send + Sync,
    F: Fn(&mut A, &mut Rng, u64) + Sync,
{
    let chunks = trials.div_ceil(CHUNK);
    let parts: Vec<A> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let count = CHUNK.min(trials - c * CHUNK);
            let mut acc = empty.clone();
            chunk(&mut acc, &mut Rng::for_chunk(seed, c), count);
            bar.inc(count);
            acc
        })
        .collect();
    let mut total = empty.clone();
    for part in &parts {
        total.merge(part);
    }
    total
}

pub use output::progress;

/// Least-squares slope of log y over log x: the convergence order of a log-log plot.
pub fn log_log_slope(points: &[(f64, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points.iter().map(|&(x, y)| (x.ln(), y.ln())).collect();
    let n = logs.len() as f64;
    let (mx, my) = logs
        .iter()
        .fold((0.0, 0.0), |(a, b), &(x, y)| (a + x / n, b + y / n));
    let (sxy, sxx) = logs.iter().fold((0.0, 0.0), |(a, b), &(x, y)| {
        (a + (x - mx) * (y - my), b + (x - mx) * (x - mx))
    });
    sxy / sxx
}
