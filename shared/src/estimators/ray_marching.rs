//! Kettunen et al. 2021 baselines: biased ray marching exp(-X) and unbiased ray marching (power
//! series with aggressive Russian roulette and U-statistics), over mean-based importance sampling
//! with tight segments and uniform jitter, as the paper compares them (Sec. 6; REFERENCE.md).

use crate::estimators::optical_depth::{estimate_single, prepare, DepthPairEstimate};
use crate::estimators::wide::Prep;
use crate::geometry::Ray;
use crate::math;
use crate::params::{Importance, Jitter};
use crate::rng::HashRng;
use crate::tally::Tally;
use crate::volume::grid::{Lookup, VolumeView};
use crate::volume::texels::Texels;

/// Highest power-series degree (the author's cap; a tiny truncation bias, stated in the paper).
pub const MAX_DEGREE: usize = 8;
/// Probability of stopping at degree 0 (aggressive Russian roulette, p_Z).
const P_ZERO: f32 = 0.9;
/// Degrees evaluated in full once the series does not stop at 0 (K).
const K_FULL: usize = 2;
/// Continuation constant c: beyond K, degree k is reached with probability min(1, c / k).
const C_CONT: f32 = 2.0;
/// Most samples per estimate of biased ray marching (keeps a ray's work bounded on the GPU); a
/// ray that reaches it is counted as capped.
pub const MAX_BIASED_SAMPLES: u32 = 8192;
/// Most samples per estimate of unbiased ray marching (up to MAX_DEGREE + 1 estimates per ray);
/// fewer samples keep the estimate unbiased but raise its variance, so a ray that reaches it is
/// counted as capped. 9 estimates of 2048 samples keep one ray within a GPU invocation's loop
/// budget (two loop iterations per sample on lavapipe: 4096 took a ray past its 65535).
pub const MAX_UNBIASED_SAMPLES: u32 = 2048;
/// Expected evaluation order beyond the pivot, 0.31945 for c = 2, p_Z = 0.9 (Kettunen Eq. 22).
const EXPECTED_ORDER: f32 = 0.319_45;

/// cbrt(v) for v > 0 from the deterministic exp and ln.
#[inline]
fn cbrt(v: f32) -> f32 {
    math::exp(math::ln(v) * (1.0 / 3.0))
}

/// Smallest integer >= v, for 0 <= v < 2^31.
#[inline]
fn ceil_u32(v: f32) -> u32 {
    let f = math::floor(v);
    if f < v {
        f as u32 + 1
    } else {
        f as u32
    }
}

/// N_CMF = ceil(cbrt((x + 0.015)(x + 0.65)(x + 60.3))), x = integral of the mean extinction
/// along the ray (Kettunen et al.'s sample-count heuristic), as f32 (infinite for huge x).
#[inline]
pub fn n_cmf(x: f32) -> f32 {
    let v = cbrt((x + 0.015) * (x + 0.65) * (x + 60.3));
    if v < 16_777_216.0 {
        ceil_u32(v) as f32
    } else {
        v
    }
}

/// Samples per estimate N = max(1, round(scale * N_CMF / (1 + 0.31945))) (the author's tuple
/// size, used by both ray marching baselines; the paper's Fig. 8b/10e double it), capped at
/// `cap`. Returns (N, whether the cap was hit).
#[inline]
pub fn tuple_size(x: f32, scale: f32, cap: u32) -> (u32, bool) {
    let tuple = scale * n_cmf(x) / (1.0 + EXPECTED_ORDER);
    if !(tuple < cap as f32) {
        (cap, true)
    } else if tuple < 1.5 {
        (1, false)
    } else {
        (math::floor(tuple + 0.5) as u32, false)
    }
}

/// Probability P_j of evaluating degree j of the series under the Russian roulette above.
#[inline]
pub fn p_degree(j: usize) -> f32 {
    if j == 0 {
        return 1.0;
    }
    let mut p = 1.0 - P_ZERO;
    let mut k = K_FULL + 1;
    while k <= j {
        let c = C_CONT / k as f32;
        if c < 1.0 {
            p *= c;
        }
        k += 1;
    }
    p
}

/// Samples the degree M of the series (number of estimates beyond the pivot).
#[inline]
fn sample_degree(rng: HashRng) -> (usize, HashRng) {
    let (u, mut rng) = rng.next_f32();
    if u < P_ZERO {
        return (0, rng);
    }
    let mut m = K_FULL;
    let mut going = true;
    while going && m < MAX_DEGREE {
        let (u, r) = rng.next_f32();
        rng = r;
        let c = C_CONT / (m + 1) as f32;
        if u < c {
            m += 1;
        } else {
            going = false;
        }
    }
    (m, rng)
}

/// One optical depth estimate of the ray marching baselines: N mean-importance samples with
/// one uniform jitter offset (Alg. 1 with m = 1). Returns (X in `x0`, rng).
#[inline]
fn marching_estimate(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    prep: &Prep,
    n: u32,
    lookup: Lookup,
    rng: HashRng,
) -> (DepthPairEstimate, HashRng) {
    estimate_single(
        vol,
        ray,
        prep,
        n,
        Importance::Mean,
        Jitter::Uniform,
        lookup,
        rng,
    )
}

/// Biased ray marching: exp(-X), X from [`tuple_size`] mean-importance samples (the same count
/// as one estimate of unbiased ray marching, as in the author's code). Returns (T, tally, rng).
pub fn biased_ray_marching(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    scale: f32,
    lookup: Lookup,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let prep = prepare(vol, ray, t0, t1, Importance::Mean);
    if !(prep.f > 0.0) {
        return (1.0, Tally::default().capped_if(prep.capped), rng);
    }
    let (n, capped) = tuple_size(prep.f, scale, MAX_BIASED_SAMPLES);
    let (est, rng) = marching_estimate(vol, ray, &prep, n, lookup, rng);
    (math::exp(-est.x0), est.tally().capped_if(capped), rng)
}

/// Unbiased ray marching: with M + 1 i.i.d. estimates X_i (M from the roulette), each X_p as
/// pivot in turn: exp(-X_p) sum_j e_j / (j! P_j), e_j the elementary symmetric mean of degree j
/// of the offsets (X_p - X_i), i != p; averaged over the pivots.
pub fn unbiased_ray_marching(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    scale: f32,
    lookup: Lookup,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let prep = prepare(vol, ray, t0, t1, Importance::Mean);
    if !(prep.f > 0.0) {
        return (1.0, Tally::default().capped_if(prep.capped), rng);
    }
    let (n, capped) = tuple_size(prep.f, scale, MAX_UNBIASED_SAMPLES);
    let (m, mut rng) = sample_degree(rng);
    let mut xs = [0.0f32; MAX_DEGREE + 1];
    let mut samples = 0u32;
    let mut cut = false;
    let mut i = 0;
    while i <= m {
        let (est, r) = marching_estimate(vol, ray, &prep, n, lookup, rng);
        xs[i] = est.x0;
        samples += est.samples;
        cut |= est.capped;
        rng = r;
        i += 1;
    }
    let mut total = 0.0f32;
    let mut pivot = 0;
    while pivot <= m {
        total += pivot_estimate(&xs, m, pivot);
        pivot += 1;
    }
    let t = total / (m + 1) as f32;
    // Offsets of optical depths near f32's range overflow the series (inf - inf = NaN): such an
    // estimate is beyond f32, so it becomes 0 and the ray is counted like a capped one.
    let finite = math::is_finite(t);
    (
        if finite { t } else { 0.0 },
        Tally::lookups(samples).capped_if(capped || cut || !finite),
        rng,
    )
}

/// exp(-X_p) sum_{j=0}^{M} e_j / (j! P_j) for pivot p (U-statistics over the other estimates).
#[inline]
fn pivot_estimate(xs: &[f32; MAX_DEGREE + 1], m: usize, p: usize) -> f32 {
    // e[k]: mean of the products of all k-subsets of the offsets seen so far.
    let mut e = [0.0f32; MAX_DEGREE + 1];
    e[0] = 1.0;
    let mut seen = 0usize;
    let mut i = 0;
    while i <= m {
        if i != p {
            let x = xs[p] - xs[i];
            seen += 1;
            let mut k = seen;
            while k >= 1 {
                e[k] += k as f32 / seen as f32 * (e[k - 1] * x - e[k]);
                k -= 1;
            }
        }
        i += 1;
    }
    let mut sum = 0.0f32;
    let mut factorial = 1.0f32;
    let mut j = 0;
    while j <= m {
        if j > 0 {
            factorial *= j as f32;
        }
        sum += e[j] / (factorial * p_degree(j));
        j += 1;
    }
    let e = math::exp(-xs[p]);
    if e == 0.0 {
        // exp(-X_p) underflowed (X_p > 104): the term is 0 whatever the series says.
        return 0.0;
    }
    e * sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expected_order_matches_the_roulette() {
        // sum_{j >= 1} P_j (untruncated) = 0.31945 (Kettunen et al. 2021).
        let s: f32 = (1..=30).map(p_degree).sum();
        assert!((s - EXPECTED_ORDER).abs() < 2e-4, "{s}");
    }

    #[test]
    fn n_cmf_grows_with_depth() {
        assert_eq!(n_cmf(0.0), 1.0); // cbrt(0.015 * 0.65 * 60.3) = 0.84
        assert!(n_cmf(1.0) >= 4.0 && n_cmf(10.0) > n_cmf(1.0));
    }

    #[test]
    fn tuple_size_is_the_authors_and_capped() {
        // N_CMF(0) = 1: round(1 / 1.31945) = 1.
        assert_eq!(tuple_size(0.0, 1.0, 4096), (1, false));
        // N_CMF(10) = ceil(cbrt(10.015 * 10.65 * 70.3)) = 20: round(20 / 1.31945) = 15.
        assert_eq!(n_cmf(10.0), 20.0);
        assert_eq!(tuple_size(10.0, 1.0, 4096), (15, false));
        assert_eq!(tuple_size(10.0, 2.0, 4096), (30, false));
        assert_eq!(tuple_size(1e30, 1.0, 4096), (4096, true));
        assert_eq!(tuple_size(f32::INFINITY, 1.0, 4096), (4096, true));
    }

    #[test]
    fn symmetric_means_match_brute_force() {
        let xs = [0.3f32, 1.1, 0.7, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        // Pivot 0, offsets (0.3 - 1.1, 0.3 - 0.7, 0.3 - 2.0); degree 2 mean of pairwise products.
        let o = [-0.8f32, -0.4, -1.7];
        let e1 = (o[0] + o[1] + o[2]) / 3.0;
        let e2 = (o[0] * o[1] + o[0] * o[2] + o[1] * o[2]) / 3.0;
        let e3 = o[0] * o[1] * o[2];
        let want = (-0.3f32).exp()
            * (1.0 + e1 / p_degree(1) + e2 / (2.0 * p_degree(2)) + e3 / (6.0 * p_degree(3)));
        let got = pivot_estimate(&xs, 3, 0);
        assert!((got - want).abs() < 1e-5, "{got} vs {want}");
    }
}
