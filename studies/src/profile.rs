//! A 1-D extinction profile mu(t), piecewise linear between the `t,mu` points of a CSV file, and
//! the ray marching estimates of its optical depth compared in Sec. 4.1 (Fig. 4, 5, 6).

use super::rng::Rng;
use anyhow::{bail, Context, Result};
use serde::Serialize;
use std::path::Path;

/// Built-in profiles, selectable by name: `smooth` (Gaussian lobes, tau = 2, the default),
/// `cloud` (voxel-scale band-limited noise, tau = 2, closest to the paper's Table 1) and `sparse`
/// (thin wisps in empty space, Fig. 6).
pub const BUILTIN: [(&str, &str); 3] = [
    ("smooth", include_str!("profiles/smooth.csv")),
    ("cloud", include_str!("profiles/cloud.csv")),
    ("sparse", include_str!("profiles/sparse.csv")),
];

/// `--profile`: a built-in name or a CSV file of `t,mu` points.
#[derive(Debug, Clone)]
pub struct ProfileFlag {
    /// Extinction profile: `smooth`, `cloud`, `sparse` (built in) or a CSV file of `t,mu` lines.
    pub profile: String,
}

/// mu(t) at increasing knots t, linear in between; the ray segment is [t_first, t_last].
#[derive(Clone, Debug)]
pub struct Profile {
    pub name: String,
    t: Vec<f64>,
    mu: Vec<f64>,
    /// 1 / knot spacing when all knots are equidistant (voxel-like profiles): O(1) lookups.
    inv_step: Option<f64>,
}

/// Largest optical depth a profile may reach (its span times its largest mu): the studies take
/// moments of tau up to the fourth, which must stay finite in f64; the renderer refuses optical
/// depths above 1e35 too.
pub const MAX_OPTICAL_DEPTH: f64 = 1e35;

impl Profile {
    /// Reads `t,mu` lines; blank lines, `#` comments and a non-numeric header line are skipped.
    pub fn parse(name: &str, text: &str) -> Result<Self> {
        let (mut t, mut mu) = (Vec::new(), Vec::new());
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            let parsed = match fields.as_slice() {
                [a, b] => a
                    .parse::<f64>()
                    .and_then(|a| b.parse::<f64>().map(|b| (a, b))),
                _ => bail!("{name}:{}: expected `t,mu`, got {line:?}", i + 1),
            };
            match parsed {
                Ok((a, b)) => {
                    t.push(a);
                    mu.push(b);
                }
                Err(_) if t.is_empty() => continue, // a header line
                Err(e) => bail!("{name}:{}: {e} in {line:?}", i + 1),
            }
        }
        if t.len() < 2 {
            bail!("{name}: a profile needs at least two points");
        }
        if !t.iter().chain(&mu).all(|v| v.is_finite()) {
            bail!("{name}: non-finite value");
        }
        if t.windows(2).any(|w| w[1] <= w[0]) {
            bail!("{name}: t must increase strictly");
        }
        if mu.iter().any(|&m| m < 0.0) {
            bail!("{name}: extinction mu must be non-negative");
        }
        let length = t[t.len() - 1] - t[0];
        let mu_max = mu.iter().copied().fold(0.0, f64::max);
        if !(length * mu_max <= MAX_OPTICAL_DEPTH) {
            bail!(
                "{name}: the optical depth may reach {:e} (t spans {length:e}, mu reaches \
                 {mu_max:e}), above {MAX_OPTICAL_DEPTH:e}, where the studies' moments of tau \
                 overflow; rescale t or mu",
                length * mu_max
            );
        }
        if let Some(w) = t.windows(2).find(|w| !(1.0 / (w[1] - w[0])).is_finite()) {
            bail!(
                "{name}: knots {:e} and {:e} are too close (the reciprocal of their spacing \
                 overflows); rescale t",
                w[0],
                w[1]
            );
        }
        let h = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
        let equidistant = t
            .iter()
            .enumerate()
            .all(|(i, &k)| (k - (t[0] + i as f64 * h)).abs() <= 1e-9 * h);
        Ok(Profile {
            name: name.to_string(),
            t,
            mu,
            inv_step: equidistant.then_some(1.0 / h),
        })
    }

    /// A built-in profile by name (`smooth`, `cloud`, `sparse`) or a CSV file.
    pub fn load(spec: &str) -> Result<Self> {
        if let Some((name, text)) = BUILTIN.iter().find(|(n, _)| *n == spec) {
            return Profile::parse(name, text);
        }
        let text = read_profile_file(Path::new(spec))
            .with_context(|| format!("reading profile {spec} (built-in: smooth, cloud, sparse)"))?;
        Profile::parse(spec, &text)
    }

    /// Like `load`, but a constant profile (no spread to measure) is an error.
    pub fn load_varying(spec: &str) -> Result<Self> {
        let profile = Profile::load(spec)?;
        if let Some(why) = profile.constant() {
            bail!("{why}");
        }
        Ok(profile)
    }

    /// The name without directories and `.csv` (`dir/cloud.csv` -> `cloud`), for file names.
    pub fn stem(&self) -> &str {
        self.name
            .rsplit('/')
            .next()
            .unwrap_or("")
            .trim_end_matches(".csv")
    }

    /// Why ray marching estimates of this profile are all exact (mu constant, e.g. all zero), so
    /// that their spread, histogram or convergence is undefined; `None` if mu varies.
    pub fn constant(&self) -> Option<String> {
        let first = self.mu[0];
        self.mu.iter().all(|&m| m == first).then(|| {
            format!(
                "profile {} is constant (mu = {first} everywhere), so every ray marching estimate \
                 is exact: no spread to histogram or converge; use a profile whose mu varies",
                self.name
            )
        })
    }

    pub fn t_min(&self) -> f64 {
        self.t[0]
    }

    pub fn t_max(&self) -> f64 {
        self.t[self.t.len() - 1]
    }

    pub fn length(&self) -> f64 {
        self.t_max() - self.t_min()
    }

    /// The knots (t, mu).
    pub fn points(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.t.iter().copied().zip(self.mu.iter().copied())
    }

    pub fn mu_max(&self) -> f64 {
        self.mu.iter().copied().fold(0.0, f64::max)
    }

    /// mu(t), linear between knots, constant beyond the ends.
    #[inline]
    pub fn mu(&self, t: f64) -> f64 {
        if let Some(inv_h) = self.inv_step {
            let last = self.mu.len() - 1;
            let u = ((t - self.t[0]) * inv_h).clamp(0.0, last as f64);
            let i = (u as usize).min(last - 1);
            let (m0, m1) = (self.mu[i], self.mu[i + 1]);
            return m0 + (u - i as f64) * (m1 - m0);
        }
        let i = self.t.partition_point(|&k| k <= t);
        if i == 0 {
            return self.mu[0];
        }
        if i == self.t.len() {
            return self.mu[i - 1];
        }
        let (t0, t1) = (self.t[i - 1], self.t[i]);
        let w = (t - t0) / (t1 - t0);
        self.mu[i - 1] + w * (self.mu[i] - self.mu[i - 1])
    }

    /// Exact optical depth tau = integral of mu over the segment (Eq. 1): the trapezoid rule is
    /// exact for a piecewise linear function.
    pub fn tau(&self) -> f64 {
        self.t
            .windows(2)
            .zip(self.mu.windows(2))
            .map(|(t, m)| 0.5 * (t[1] - t[0]) * (m[0] + m[1]))
            .sum()
    }

    /// X = (t_max / N) sum mu(t_j) with t_j = (j + xi_j) t_max / N (Sec. 4.1), one xi per stratum
    /// (stratified jittered: N values) or one shared xi (uniform jittered: a slice of length 1).
    pub fn march(&self, n: usize, xi: &[f64]) -> f64 {
        let (t0, h) = (self.t_min(), self.length() / n as f64);
        let sum: f64 = if xi.len() == 1 {
            (0..n).map(|j| self.mu(t0 + (j as f64 + xi[0]) * h)).sum()
        } else {
            xi[..n]
                .iter()
                .enumerate()
                .map(|(j, &x)| self.mu(t0 + (j as f64 + x) * h))
                .sum()
        };
        h * sum
    }
}

/// Largest profile CSV file read (about 3 million `t,mu` lines).
pub const MAX_PROFILE_BYTES: u64 = 64 << 20;

/// Reads a profile CSV: a regular file of at most [`MAX_PROFILE_BYTES`], never more than its size.
fn read_profile_file(path: &Path) -> Result<String> {
    use std::io::Read;
    let kind = std::fs::metadata(path)?.file_type();
    if !kind.is_file() {
        bail!("not a regular file (a directory, FIFO or device); pass a CSV file of `t,mu` lines");
    }
    let file = std::fs::File::open(path)?;
    let len = file.metadata()?.len();
    if len > MAX_PROFILE_BYTES {
        bail!("{len} bytes is more than a profile may have ({MAX_PROFILE_BYTES} bytes)");
    }
    let mut text = String::new();
    file.take(len).read_to_string(&mut text)?;
    Ok(text)
}

/// How ray marching places its N samples along the segment (Sec. 4.1, Fig. 5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Sampling {
    /// Deterministic midpoint rule, t_j = (j + 1/2) t_max / N.
    Midpoint,
    /// Uniform jittered: one xi shifts all N equidistant samples.
    Uniform,
    /// Stratified jittered: an independent xi_j in every stratum (the paper's choice).
    Stratified,
    /// N i.i.d. uniform positions in [0, t_max].
    Iid,
}

impl Sampling {
    pub fn label(self) -> &'static str {
        match self {
            Sampling::Midpoint => "midpoint",
            Sampling::Uniform => "uniform jittered",
            Sampling::Stratified => "stratified jittered",
            Sampling::Iid => "i.i.d. uniform",
        }
    }

    /// One unbiased (midpoint: deterministic) estimate of tau with N samples.
    pub fn estimate(
        self,
        profile: &Profile,
        n: usize,
        rng: &mut Rng,
        scratch: &mut Vec<f64>,
    ) -> f64 {
        match self {
            Sampling::Midpoint => profile.march(n, &[0.5]),
            Sampling::Uniform => profile.march(n, &[rng.uniform()]),
            Sampling::Stratified => {
                scratch.clear();
                scratch.extend((0..n).map(|_| rng.uniform()));
                profile.march(n, scratch)
            }
            Sampling::Iid => {
                let sum: f64 = (0..n)
                    .map(|_| profile.mu(profile.t_min() + rng.uniform() * profile.length()))
                    .sum();
                sum * profile.length() / n as f64
            }
        }
    }
}
