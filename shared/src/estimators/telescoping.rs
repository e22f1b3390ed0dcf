//! Telescoping transmittance (Misso et al. 2022, "Unbiased and consistent rendering using biased
//! estimators"): ray-marching estimates exp(-X_l) at doubling sample counts, debiased by a
//! telescoping series over the levels l. Two forms:
//!
//! - [`telescoping`] (`telescoping`), unbiased: the levels nest (each level's stratified samples
//!   are a subset of the next level's, so all levels share one set of lookups), they run over
//!   Alg. 2's importance with the mu_min control variate as the jackknife does, and the series is
//!   a Russian roulette over the levels with P(L >= l) = r^l, without a truncation short of the
//!   loop bounds (counted as capped where reached).
//! - [`telescoping_cycles`] (`telescoping-cycles`), the form Blender Cycles 5.0 ships for shadow
//!   rays: bricks merged until their majorant-minorant optical depth reaches 1, k steps of one
//!   jittered comb per merged segment, a single-term primary estimator of order n <= 4 with
//!   P(n) = 0.9 x 0.1^n: the truncation makes it converge to a 16k-step march, so it is biased.

use crate::estimators::lane_volume::{importance, mu_at, mu_min};
use crate::estimators::optical_depth::prepare;
use crate::geometry::Ray;
use crate::math;
use crate::params::Importance;
use crate::rng::{pcg_hash, unit_f32, HashRng};
use crate::tally::Tally;
use crate::volume::grid::{Lookup, VolumeView};
use crate::volume::supervoxels::SuperVoxelDda;
use crate::volume::texels::Texels;

/// Probability r of the series going on past each level: P(L >= l) = r^l, r = 2^(-3/2), the
/// geometric mean of 1/2 (at and above it the expected sample count n E[2^L] diverges) and 1/4
/// (at and below it the variance of the corrections, which falls as 4^-l for stratified samples
/// of a density with jumps, divided by r^l, diverges). Expected samples: n (1 + sum_l 2^(l-1)
/// r^l) = 2.21 n.
pub const R_CONTINUE: f32 = 0.353_553_38;

/// Highest level of the series; a ray that draws a higher one is truncated to it and counted as
/// capped (probability r^11 = 1e-5).
pub const MAX_LEVEL: u32 = 10;

/// Most samples of one [`telescoping`] estimate, n 2^L: the level (and, past it, n) is lowered to
/// fit and the ray counted as capped. Each sample costs its level walk besides the sample loop,
/// so one estimate stays within a GPU invocation's loop budget.
pub const MAX_TELESCOPING_SAMPLES: u32 = 2048;

/// Salt of the stochastic-lookup jitter keys of the telescoping estimators.
const SALT: u32 = 0x27d4_eb2f;

/// P(L >= l) = r^l: the probability that the series reaches level l.
#[inline]
pub fn p_reach(l: u32) -> f32 {
    let mut p = 1.0f32;
    let mut k = 0;
    while k < l {
        p *= R_CONTINUE;
        k += 1;
    }
    p
}

/// The level L of the series from a uniform u in [0, 1): the largest l <= MAX_LEVEL + 1 with
/// u < r^l (MAX_LEVEL + 1: past the cap).
#[inline]
pub fn sample_level(u: f32) -> u32 {
    let mut l = 0;
    let mut p = R_CONTINUE;
    while l <= MAX_LEVEL && u < p {
        l += 1;
        p *= R_CONTINUE;
    }
    l
}

/// The uniform in [0, 1) that stratum `i` of level `l` draws from the estimate's `seed`.
#[inline]
fn level_uniform(seed: u32, l: u32, i: u32) -> f32 {
    unit_f32(pcg_hash(pcg_hash(seed ^ l.wrapping_mul(0x9e37_79b9)) ^ i))
}

/// Where the sample of finest stratum `i` (of `level` levels) lies in its stratum, r in [0, 1),
/// and the level c that drew it: level 0's stratum i >> level holds one uniform point; each
/// level halves the strata, the half that holds its parent's point keeps it, and the other half
/// draws a new uniform point. Every level's points are thus stratified and uniform, and level
/// l's points are those of the finest level drawn at levels c <= l.
#[inline]
pub fn nested_offset(seed: u32, i: u32, level: u32) -> (f32, u32) {
    let mut r = level_uniform(seed, 0, i >> level);
    let mut c = 0;
    let mut l = 1;
    while l <= level {
        let il = i >> (level - l);
        let upper = r >= 0.5;
        if upper == ((il & 1) == 1) {
            // Exact: 2r and 2r - 1 for r in [1/2, 1) are representable.
            r = if upper { 2.0 * r - 1.0 } else { 2.0 * r };
        } else {
            r = level_uniform(seed, l, il);
            c = l;
        }
        l += 1;
    }
    (r, c)
}

/// Telescoping transmittance of [t0, t1] (Misso et al. 2022, Sec. 4; unbiased): with L drawn so
/// that P(L >= l) = r^l and X_l the optical depth estimate of n 2^l nested stratified samples
/// over Alg. 2's importance with the mu_min control variate (`mode`),
/// T = exp(-X_0) + sum_{l=1}^{L} (exp(-X_l) - exp(-X_{l-1})) / r^l. Since X_l tends to the
/// optical depth, E[T] = lim_l E[exp(-X_l)] = exp(-tau). Returns (T, tally, rng).
#[allow(clippy::too_many_arguments)]
pub fn telescoping(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    n: u32,
    mode: Importance,
    lookup: Lookup,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let prep = prepare(vol, ray, t0, t1, mode);
    if !(prep.f > 0.0) {
        return (1.0, Tally::default().capped_if(prep.capped), rng);
    }
    let (u, rng) = rng.next_f32();
    let (seed, rng) = rng.next_u32();
    let drawn = sample_level(u);
    let base_capped = n > MAX_TELESCOPING_SAMPLES;
    let base = if base_capped {
        MAX_TELESCOPING_SAMPLES
    } else if n == 0 {
        1
    } else {
        n
    };
    // The highest level whose n 2^l samples fit.
    let mut fit = 0;
    while fit < MAX_LEVEL && (base << (fit + 1)) <= MAX_TELESCOPING_SAMPLES {
        fit += 1;
    }
    let level = if drawn < fit { drawn } else { fit };
    let strata = base << level;
    // The CDF width of a finest stratum.
    let step = prep.f / strata as f32;
    // Per level c: the sum of (mu - mu_min) / P over the samples level c drew.
    let mut sums = [0.0f32; MAX_LEVEL as usize + 1];
    let mut dda = SuperVoxelDda::new(&vol.desc, ray, prep.t_min, prep.t_max);
    let (mut f, mut tau_c) = (0.0f32, 0.0f32);
    // The last segment with P > 0 reached: t0, t1, CDF at its end, P, mu_min.
    let (mut l_t0, mut l_t1, mut l_f, mut l_p, mut l_m) = (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
    let mut samples = 0u32;
    let mut i = 0u32;
    while i < strata {
        let (r, c) = nested_offset(seed, i, level);
        let target = step * (i as f32 + r);
        while target >= f && !dda.done() {
            let (seg, b) = dda.step(vol);
            let p = importance(&b, mode);
            let m = mu_min(&b, mode);
            let len = seg.t1 - seg.t0;
            f += len * p;
            tau_c += len * m;
            if p > 0.0 {
                l_t0 = seg.t0;
                l_t1 = seg.t1;
                l_f = f;
                l_p = p;
                l_m = m;
            }
        }
        if !(l_p > 0.0) {
            // No segment with importance (only where rounding left F > 0 without one).
            break;
        }
        // Rewind to the sample location within the segment (Alg. 1), clamped against rounding.
        let mut t = l_t1 - (l_f - target) / l_p;
        if t < l_t0 {
            t = l_t0;
        }
        if t > l_t1 {
            t = l_t1;
        }
        let g = (mu_at(vol, ray.at(t), lookup, [seed, i, SALT]) - l_m) / l_p;
        sums[c as usize] += g;
        samples += 1;
        i += 1;
    }
    // The control variate needs the rest of the segment.
    while !dda.done() {
        let (seg, b) = dda.step(vol);
        tau_c += (seg.t1 - seg.t0) * mu_min(&b, mode);
    }
    let t = series(&sums, level, step, tau_c);
    // Estimates near f32's range overflow the corrections: such a ray's T is 0 and counted.
    let finite = math::is_finite(t);
    let capped = prep.capped | dda.exhausted() | base_capped | (drawn > level) | !finite;
    (
        if finite { t } else { 0.0 },
        Tally::lookups(samples).capped_if(capped),
        rng,
    )
}

/// The telescoping series of [`telescoping`]: X_l = (F / (n 2^l)) sum_{c <= l} sums[c] + tau_c
/// (`step` = F / (n 2^level)), T = exp(-X_0) + sum_{l=1}^{level} (exp(-X_l) - exp(-X_{l-1})) / r^l.
#[inline]
pub fn series(sums: &[f32; MAX_LEVEL as usize + 1], level: u32, step: f32, tau_c: f32) -> f32 {
    let mut t = 0.0f32;
    let mut acc = 0.0f32;
    let mut prev = 0.0f32;
    let mut l = 0;
    while l <= level {
        acc += sums[l as usize];
        let width = step * (1u32 << (level - l)) as f32;
        let e = math::exp(-(width * acc + tau_c));
        if l == 0 {
            t = e;
        } else {
            t += (e - prev) / p_reach(l);
        }
        prev = e;
        l += 1;
    }
    t
}

/// Probability that Cycles' series stops at each order (its `r`; P(n) = 0.9 x 0.1^n).
pub const CYCLES_STOP: f32 = 0.9;
/// Cycles' highest order n (N = 2^n <= 16 marches); the rest of the series is dropped (biased).
pub const CYCLES_MAX_ORDER: u32 = 4;
/// Cycles' most steps k of one merged segment (VOLUME_MAX_STEPS).
pub const CYCLES_MAX_STEPS: u32 = 1024;
/// Most lookups of one [`telescoping_cycles`] estimate: where a segment's N k would pass it, k is
/// lowered to fit (at least one step) and the ray counted as capped (Cycles has no such bound
/// per ray; ours keeps a GPU invocation within its loop budget).
pub const MAX_CYCLES_SAMPLES: u32 = 8192;

/// Cycles' order n from a uniform u in [0, 1): the number of l in 1..=4 with u < 0.1^l, and its
/// probability P(n) = 0.9 x 0.1^n (n < 4) or 0.1^4 (the tail, n = 4).
#[inline]
pub fn cycles_order(u: f32) -> (u32, f32) {
    let go = 1.0 - CYCLES_STOP;
    let mut n = 0;
    let mut reach = go;
    while n < CYCLES_MAX_ORDER && u < reach {
        n += 1;
        reach *= go;
    }
    let tail = reach / go;
    (
        n,
        if n == CYCLES_MAX_ORDER {
            tail
        } else {
            CYCLES_STOP * tail
        },
    )
}

/// Cycles 5.0's telescoping transmittance of [t0, t1] (biased: the order is truncated at 4):
/// bricks are merged until (mu_max - mu_min) x length >= 1; each merged segment of length D
/// takes k = clamp(round((mu_max - mu_min) D), 1, 1024) steps and an order n (N = 2^n, n = 0
/// where mu_max = mu_min), N k lookups on one comb with offset u, and gives
/// T_k + (T_fine - T_coarse) / P(n), T_k the mean of the N interleaved k-step marches'
/// exp(-tau), T_fine the N k-step march's, T_coarse the mean of its even and odd halves'
/// (T_k alone for N = 1). No control variate. Returns (T, tally, rng).
pub fn telescoping_cycles(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    lookup: Lookup,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let mut rng = rng;
    let mut t = 1.0f32;
    let mut samples = 0u32;
    let mut capped = false;
    let mut dda = SuperVoxelDda::new(&vol.desc, ray, t0, t1);
    let mut start = t0;
    let mut end = t0;
    let (mut lo, mut hi) = (f32::MAX, 0.0f32);
    let mut open = false;
    loop {
        let more = !dda.done();
        if more {
            let (seg, b) = dda.step(vol);
            lo = if b.mu_min < lo { b.mu_min } else { lo };
            hi = if b.mu_max > hi { b.mu_max } else { hi };
            end = seg.t1;
            open = true;
        }
        if open && (!more || (hi - lo) * (end - start) >= 1.0) {
            let seg = CyclesSegment {
                start,
                end,
                range: if hi > lo { hi - lo } else { 0.0 },
            };
            let spent = if samples < MAX_CYCLES_SAMPLES {
                samples
            } else {
                MAX_CYCLES_SAMPLES
            };
            let budget = MAX_CYCLES_SAMPLES - spent;
            let (ts, used, cut, r) = cycles_segment(vol, ray, &seg, lookup, budget, rng);
            t *= ts;
            samples += used;
            capped |= cut;
            rng = r;
            start = end;
            lo = f32::MAX;
            hi = 0.0;
            open = false;
        }
        if !more {
            break;
        }
    }
    // The correction can make a segment's T negative or above 1 (Cycles keeps it); a product
    // past f32's range is 0 and counted.
    let finite = math::is_finite(t);
    (
        if finite { t } else { 0.0 },
        Tally::lookups(samples).capped_if(capped | dda.exhausted() | !finite),
        rng,
    )
}

/// A merged segment of [`telescoping_cycles`]: [start, end] and its majorant minus minorant.
#[derive(Clone, Copy)]
struct CyclesSegment {
    start: f32,
    end: f32,
    range: f32,
}

/// One merged segment of [`telescoping_cycles`] with at most `budget` lookups. Returns (its T,
/// lookups, whether k was lowered to fit, rng).
fn cycles_segment(
    vol: &VolumeView<impl Texels>,
    ray: &Ray,
    seg: &CyclesSegment,
    lookup: Lookup,
    budget: u32,
    rng: HashRng,
) -> (f32, u32, bool, HashRng) {
    let d = seg.end - seg.start;
    let (xi, rng) = rng.next_f32();
    let (u, rng) = rng.next_f32();
    let (order, pmf) = if seg.range > 0.0 {
        cycles_order(xi)
    } else {
        (0, 1.0)
    };
    let big_n = 1u32 << order;
    let wanted = math::floor(seg.range * d + 0.5);
    let mut k = if wanted < 1.0 {
        1
    } else if wanted > CYCLES_MAX_STEPS as f32 {
        CYCLES_MAX_STEPS
    } else {
        wanted as u32
    };
    let mut cut = false;
    if big_n * k > budget {
        k = budget / big_n;
        if k == 0 {
            k = 1;
        }
        cut = true;
    }
    let count = big_n * k;
    let dt = d / count as f32;
    // Per interleaved march m (s mod N): the sum of the extinction at its steps.
    let mut sums = [0.0f32; 1 << CYCLES_MAX_ORDER];
    let mut s = 0u32;
    while s < count {
        let mut x = seg.start + (u + s as f32) * dt;
        if x > seg.end {
            x = seg.end;
        }
        sums[(s & (big_n - 1)) as usize] += mu_at(vol, ray.at(x), lookup, [rng.state, s, SALT]);
        s += 1;
    }
    // T_k, and the sums of the even and odd steps of the fine march.
    let coarse_dt = d / k as f32;
    let (mut t_k, mut even, mut odd) = (0.0f32, 0.0f32, 0.0f32);
    let mut m = 0u32;
    while m < big_n {
        t_k += math::exp(-coarse_dt * sums[m as usize]);
        if m & 1 == 0 {
            even += sums[m as usize];
        } else {
            odd += sums[m as usize];
        }
        m += 1;
    }
    t_k /= big_n as f32;
    let t = if big_n == 1 {
        t_k
    } else {
        let fine = math::exp(-dt * (even + odd));
        let coarse = 0.5 * (math::exp(-2.0 * dt * even) + math::exp(-2.0 * dt * odd));
        t_k + (fine - coarse) / pmf
    };
    (t, count, cut, rng)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_are_geometric() {
        // P(L >= l) = r^l: the fraction of a fine uniform grid of u that reaches each level.
        let m = 1_000_000u32;
        let mut reach = [0u32; MAX_LEVEL as usize + 2];
        for j in 0..m {
            let l = sample_level((j as f32 + 0.5) / m as f32);
            for r in reach.iter_mut().take(l as usize + 1) {
                *r += 1;
            }
        }
        for (l, &count) in reach.iter().enumerate().take(6) {
            let want = p_reach(l as u32) as f64;
            let got = count as f64 / m as f64;
            assert!(
                (got - want).abs() < 2e-6 + 1e-4 * want,
                "level {l}: {got} vs {want}"
            );
        }
    }

    #[test]
    fn nested_points_are_stratified_at_every_level_and_shared_with_the_finer_ones() {
        for seed in [1u32, 7, 12345, 0xdead_beef] {
            let level = 5;
            let strata = 3u32 << level;
            let pts: Vec<(f32, u32)> = (0..strata)
                .map(|i| {
                    let (r, c) = nested_offset(seed, i, level);
                    ((i as f32 + r) / strata as f32, c)
                })
                .collect();
            for l in 0..=level {
                // Level l's points: one in each of its 3 2^l strata.
                let kl = 3u32 << l;
                let mut hits = vec![0u32; kl as usize];
                for &(x, c) in &pts {
                    if c <= l {
                        let s = (x * kl as f32) as usize;
                        hits[s.min(kl as usize - 1)] += 1;
                    }
                }
                assert!(
                    hits.iter().all(|&h| h == 1),
                    "seed {seed} level {l}: {hits:?}"
                );
            }
        }
    }

    #[test]
    fn nested_offsets_are_uniform_at_every_level() {
        // Chi-square of the position of the level-l point within its level-l stratum over many
        // seeds (16 bins; 99.9 % quantile of chi2(15) = 37.7).
        let level = 4;
        for l in 0..=level {
            let mut bins = [0u32; 16];
            let seeds = 20_000u32;
            for seed in 0..seeds {
                // The point of level-l stratum 0 is the first finest point drawn at c <= l.
                let strata = 1u32 << level;
                let x = (0..strata)
                    .map(|i| {
                        let (r, c) = nested_offset(seed, i, level);
                        ((i as f32 + r) / strata as f32, c)
                    })
                    .find(|&(x, c)| c <= l && x < 1.0 / (1u32 << l) as f32)
                    .unwrap()
                    .0;
                let within = x * (1u32 << l) as f32;
                bins[((within * 16.0) as usize).min(15)] += 1;
            }
            let e = seeds as f64 / 16.0;
            let chi2: f64 = bins.iter().map(|&b| (b as f64 - e).powi(2) / e).sum();
            assert!(chi2 < 37.7, "level {l}: chi2 {chi2}, {bins:?}");
        }
    }

    #[test]
    fn the_series_matches_its_formula_in_f64() {
        // Sums drawn at levels 0, 1 and 3 of a level-3 estimate: X_l weighs the samples of
        // levels c <= l by the CDF width of a level-l stratum.
        let mut sums = [0.0f32; MAX_LEVEL as usize + 1];
        (sums[0], sums[1], sums[3]) = (8.0, 5.0, 2.5);
        let level = 3;
        let step = 0.25 / 8.0;
        let t = series(&sums, level, step, 0.1);
        let acc = |l: u32| sums[..=l as usize].iter().sum::<f32>();
        let x = |l: u32| step * (1u32 << (level - l)) as f32 * acc(l) + 0.1;
        let mut want = (-x(0) as f64).exp();
        for l in 1..=level {
            want += ((-x(l) as f64).exp() - (-x(l - 1) as f64).exp()) / p_reach(l) as f64;
        }
        assert!((t as f64 - want).abs() < 1e-6, "{t} vs {want}");
    }

    #[test]
    fn cycles_orders_follow_their_probabilities() {
        let m = 1_000_000u32;
        let mut count = [0u32; 5];
        let mut pmf = [0.0f32; 5];
        for j in 0..m {
            let (n, p) = cycles_order((j as f32 + 0.5) / m as f32);
            count[n as usize] += 1;
            pmf[n as usize] = p;
        }
        for n in 0..5 {
            let got = count[n] as f64 / m as f64;
            assert!(
                (got - pmf[n] as f64).abs() < 2e-6 + 1e-4 * pmf[n] as f64,
                "order {n}: {got} vs {}",
                pmf[n]
            );
        }
        assert!((pmf.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    }
}
