//! Alg. 2 and Alg. 1 (two interleaved, stratified, importance-sampled estimates with the
//! mu_min control variate; a fixed N, one estimate, or the adaptive variant's fixed step), Sec. 4:
//! the one body of both, written over lanes ([`Lanes`]) and a volume that reads them
//! ([`LaneVolume`]). One lane over [`crate::estimators::lane_volume::ScalarVolume`] is
//! [`crate::estimators::optical_depth`]'s `prepare` and `estimate_interleaved`, which the GPU's
//! kernels and the CPU's scalar paths run; eight lanes over [`crate::volume::wide::WideVolume`]
//! the CPU's wide pass. A loop runs while any lane has work, and a lane's values change only
//! under its mask, so each lane's estimates are the bits of its ray alone.

use crate::estimators::lane_volume::LaneVolume;
use crate::lanes::Lanes;
use crate::math;
use crate::params::{Importance, Jitter};
use crate::rng::{pcg_hash_lanes, unit_f32_lanes};

/// Output of Alg. 2: the integral of importance F and the tight segment [t'_min, t'_max].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Prep {
    pub f: f32,
    pub t_min: f32,
    pub t_max: f32,
    /// The bricks' mean extinction integrated over the segment: a prediction of its optical
    /// depth (the means are rounded up), for the shadow rays' roulette; 0 unless asked for
    /// ([`crate::estimators::optical_depth::prepare_with_mean`]).
    pub tau_mean: f32,
    /// Whether the traversal's iteration budget ended it early ([`crate::volume::supervoxels::SuperVoxelDda::exhausted`]).
    pub capped: bool,
}

/// Most strata per estimate in the adaptive variant (bounds the work per ray on the GPU).
pub const MAX_ADAPTIVE_STRATA: u32 = 1024;

/// How Alg. 1 divides the importance CDF: step, strata per estimate, and whether targets past
/// F are skipped (adaptive) or clamped into the last brick (fixed count; only rounding).
#[derive(Clone, Copy, Debug)]
pub struct Strata {
    pub f_delta: f32,
    pub n0: u32,
    pub n1: u32,
    pub adaptive: bool,
}

impl Strata {
    /// F_delta = F / N with exactly n0 and n1 samples (Sec. 4.3, fixed sample count).
    #[inline]
    pub fn fixed(prep: &Prep, n0: u32, n1: u32) -> Self {
        let n = if n0 > n1 { n0 } else { n1 };
        Strata {
            f_delta: prep.f / n as f32,
            n0,
            n1,
            adaptive: false,
        }
    }

    /// A constant F_delta; ceil(F / F_delta) strata per estimate, capped.
    #[inline]
    pub fn adaptive(prep: &Prep, f_delta: f32) -> Self {
        let strata = if f_delta > 0.0 {
            let q = prep.f / f_delta;
            if q >= MAX_ADAPTIVE_STRATA as f32 {
                MAX_ADAPTIVE_STRATA
            } else {
                let c = math::floor(q) as u32;
                if (c as f32) < q {
                    c + 1
                } else {
                    c
                }
            }
        } else {
            0
        };
        // With the cap reached, widen the step so the strata still cover [0, F].
        let f_delta = if strata == MAX_ADAPTIVE_STRATA && prep.f > f_delta * strata as f32 {
            prep.f / strata as f32
        } else {
            f_delta
        };
        Strata {
            f_delta,
            n0: strata,
            n1: strata,
            adaptive: true,
        }
    }
}

/// [`Prep`] per lane.
#[derive(Clone, Copy)]
pub struct WidePrep<L: Lanes> {
    pub f: L::F,
    pub t_min: L::F,
    pub t_max: L::F,
    pub tau_mean: L::F,
    pub capped: L::M,
}

/// [`crate::estimators::optical_depth::DepthPairEstimate`] per lane, and each lane's generator
/// state after it ([`crate::rng::HashRng::state`]).
#[derive(Clone, Copy)]
pub struct WidePair<L: Lanes> {
    pub x0: L::F,
    pub x1: L::F,
    pub samples: L::U,
    pub capped: L::M,
    pub rng: L::U,
}

/// How Alg. 1 divides each lane's importance CDF ([`Strata`] per lane): the step F_delta, the
/// strata of each estimate n0 and n1, and whether targets past F are skipped (the adaptive
/// variant).
#[derive(Clone, Copy)]
pub struct WidePlan<L: Lanes> {
    pub f_delta: L::F,
    pub n0: L::U,
    pub n1: L::U,
    pub adaptive: bool,
}

impl<L: Lanes> WidePlan<L> {
    /// [`Strata::fixed`] with n0 and n1 samples in every lane.
    #[inline(always)]
    pub fn fixed(prep: &WidePrep<L>, n0: u32, n1: u32) -> Self {
        let n = if n0 > n1 { n0 } else { n1 };
        WidePlan {
            f_delta: prep.f / L::f(n as f32),
            n0: L::u(n0),
            n1: L::u(n1),
            adaptive: false,
        }
    }

    /// [`Strata::adaptive`] with step `f_delta`, lane by lane.
    #[inline(always)]
    pub fn adaptive(prep: &WidePrep<L>, f_delta: f32) -> Self {
        Self::of(|l| Strata::adaptive(&prep.lane(l), f_delta), true)
    }

    /// Lane l divides by `plan(l)`.
    #[inline(always)]
    pub fn of(plan: impl Fn(usize) -> Strata, adaptive: bool) -> Self {
        WidePlan {
            f_delta: L::f_from(|l| plan(l).f_delta),
            n0: L::u_from(|l| plan(l).n0),
            n1: L::u_from(|l| plan(l).n1),
            adaptive,
        }
    }
}

impl<L: Lanes> WidePrep<L> {
    /// Lane `l`'s [`Prep`].
    #[inline(always)]
    pub fn lane(&self, l: usize) -> Prep {
        Prep {
            f: L::f_at(self.f, l),
            t_min: L::f_at(self.t_min, l),
            t_max: L::f_at(self.t_max, l),
            tau_mean: L::f_at(self.tau_mean, l),
            capped: L::m_at(self.capped, l),
        }
    }
}

impl<L: Lanes> WidePrep<L> {
    /// `prep` in every lane.
    #[inline(always)]
    pub fn splat(prep: &Prep) -> Self {
        WidePrep {
            f: L::f(prep.f),
            t_min: L::f(prep.t_min),
            t_max: L::f(prep.t_max),
            tau_mean: L::f(prep.tau_mean),
            capped: L::m(prep.capped),
        }
    }
}

/// Alg. 2 for the rays of the lanes `on` over [t0, t1]: one traversal summing
/// (t_{n+1} - t_n) P into F (and, `with_mean`, the bricks' means into tau_mean; a constant at
/// every call, so the sum folds away where it is not asked for) and recording the entry of the
/// first and the exit of the last segment with P != 0.
#[inline(always)]
pub fn prepare<L: Lanes, V: LaneVolume<L>>(
    vol: &V,
    rays: &V::Rays,
    t0: L::F,
    t1: L::F,
    on: L::M,
    mode: Importance,
    with_mean: bool,
) -> WidePrep<L> {
    let mut f = L::f(0.0);
    let mut tau_mean = L::f(0.0);
    let mut t_min = t1;
    let mut t_max = t0;
    let mut dda = vol.dda(rays, t0, t1, on);
    loop {
        let a = on & !V::done(&dda);
        if !L::any(a) {
            break;
        }
        let (s0, s1, b) = vol.step(&mut dda, a);
        let p = vol.importance(a, &b, mode);
        f = L::f_sel(a, f + (s1 - s0) * p, f);
        if with_mean {
            let mean = vol.importance(a, &b, Importance::Mean);
            tau_mean = L::f_sel(a, tau_mean + (s1 - s0) * mean, tau_mean);
        }
        let nonzero = a & L::f_ne(p, L::f(0.0));
        t_min = L::f_sel(nonzero & L::f_lt(s0, t_min), s0, t_min);
        t_max = L::f_sel(nonzero & L::f_gt(s1, t_max), s1, t_max);
    }
    WidePrep {
        f,
        t_min,
        t_max,
        tau_mean,
        capped: on & V::exhausted(&dda),
    }
}

/// Next uniform in (0, 1] of each lane's generator and the advanced states
/// ([`crate::rng::HashRng::next_f32_open0`]).
#[inline(always)]
fn next_open0<L: Lanes>(state: L::U) -> (L::F, L::U) {
    let s = pcg_hash_lanes::<L>(state);
    (L::f(1.0) - unit_f32_lanes::<L>(s), s)
}

/// Alg. 1 by `plan` for the rays of the lanes `on`, over `prep`'s tight segments, each lane's
/// generator at `rng` ([`crate::rng::HashRng::state`]). Every estimate takes exactly its n
/// samples where F > 0 (the adaptive variant: fewer where a jittered target of the partial last
/// stratum falls past F); with F = 0 both estimates are exactly 0 and no sample is taken.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn estimate_pair<L: Lanes, V: LaneVolume<L>>(
    vol: &V,
    rays: &V::Rays,
    prep: &WidePrep<L>,
    on: L::M,
    plan: &WidePlan<L>,
    mode: Importance,
    jitter: Jitter,
    rng: L::U,
) -> WidePair<L> {
    let (f_delta, n0, n1) = (plan.f_delta, plan.n0, plan.n1);
    let zero = L::f(0.0);
    // Lanes with samples to take (the others are done at once).
    let none = L::u_eq(n0, L::u(0)) & L::u_eq(n1, L::u(0));
    let go = on & L::f_gt(prep.f, zero) & !none & L::f_gt(f_delta, zero);
    let (xi0, s) = next_open0::<L>(rng);
    let (xi1, s) = next_open0::<L>(s);
    let mut rng = L::u_sel(go, s, rng);
    // Per estimate: samples taken k_j, current offset xi_j, running sum of (mu - mu_min) / P.
    let (mut k0, mut k1) = (L::u(0), L::u(0));
    let (mut o0, mut o1) = (xi0, xi1);
    let (mut sum0, mut sum1) = (zero, zero);
    let mut f = zero;
    let mut tau_c = zero;
    // The last segment with P > 0 reached: t0, t1, CDF at its end, P, mu_min (P = 0 until
    // there is one).
    let (mut l_t0, mut l_t1, mut l_f, mut l_p, mut l_m) = (zero, zero, zero, zero, zero);
    let mut dda = vol.dda(rays, prep.t_min, prep.t_max, go);
    let mut samples = L::u(0);
    // Lanes still in the sample loop (a lane leaves it where its sample has no brick).
    let mut live = go;
    // Each pass takes one high-resolution sample per lane (coherent on SIMD hardware).
    loop {
        let left0 = L::u_lt(k0, n0);
        let left1 = L::u_lt(k1, n1);
        let a = live & (left0 | left1);
        if !L::any(a) {
            break;
        }
        let c0 = f_delta * (L::u_to_f(k0) + o0);
        let c1 = f_delta * (L::u_to_f(k1) + o1);
        let j0 = left0 & (!left1 | L::f_le(c0, c1));
        let target = L::f_sel(j0, c0, c1);
        // The adaptive variant: a jittered target of a partial last stratum past F takes no
        // sample, and that estimate is done.
        let past = a & L::m(plan.adaptive) & L::f_ge(target, prep.f);
        k0 = L::u_sel(past & j0, n0, k0);
        k1 = L::u_sel(past & !j0, n1, k1);
        let a = a & !past;
        // Advance over segments until the CDF passes the target.
        loop {
            let v = a & L::f_ge(target, f) & !V::done(&dda);
            if !L::any(v) {
                break;
            }
            let (s0, s1, b) = vol.step(&mut dda, v);
            let p = vol.importance(v, &b, mode);
            let m = vol.mu_min(v, &b, mode);
            let len = s1 - s0;
            f = L::f_sel(v, f + len * p, f);
            tau_c = L::f_sel(v, tau_c + len * m, tau_c);
            let nonzero = v & L::f_gt(p, zero);
            l_t0 = L::f_sel(nonzero, s0, l_t0);
            l_t1 = L::f_sel(nonzero, s1, l_t1);
            l_f = L::f_sel(nonzero, f, l_f);
            l_p = L::f_sel(nonzero, p, l_p);
            l_m = L::f_sel(nonzero, m, l_m);
        }
        // The sample's segment: the one whose CDF passed the target (it has P > 0), or, where
        // rounding left the last target a hair beyond the final CDF, the last one with P > 0
        // (the sample then goes to its end), so the count stays exactly n per estimate. A lane
        // without one leaves the loop.
        let stop = a & !L::f_gt(l_p, zero);
        live = live & !stop;
        let a = a & !stop;
        // Rewind to the sample location within the segment (Alg. 1), clamped against rounding.
        let t = l_t1 - (l_f - target) / l_p;
        let t = L::f_sel(L::f_lt(t, l_t0), l_t0, t);
        let t = L::f_sel(L::f_gt(t, l_t1), l_t1, t);
        let key = [rng, samples, L::u(0x9e37_79b9)];
        let contribution = (vol.mu_at(a, rays, t, key) - l_m) / l_p;
        samples = L::u_sel(a, L::u_add(samples, L::u(1)), samples);
        let (a0, a1) = (a & j0, a & !j0);
        sum0 = L::f_sel(a0, sum0 + contribution, sum0);
        sum1 = L::f_sel(a1, sum1 + contribution, sum1);
        k0 = L::u_sel(a0, L::u_add(k0, L::u(1)), k0);
        k1 = L::u_sel(a1, L::u_add(k1, L::u(1)), k1);
        if jitter == Jitter::Stratified {
            let (xi, s) = next_open0::<L>(rng);
            o0 = L::f_sel(a0, xi, o0);
            o1 = L::f_sel(a1, xi, o1);
            rng = L::u_sel(a, s, rng);
        }
    }
    // The control variate needs the rest of the segment.
    loop {
        let v = go & !V::done(&dda);
        if !L::any(v) {
            break;
        }
        let (s0, s1, b) = vol.step(&mut dda, v);
        let m = vol.mu_min(v, &b, mode);
        tau_c = L::f_sel(v, tau_c + (s1 - s0) * m, tau_c);
    }
    WidePair {
        x0: L::f_sel(go, f_delta * sum0 + tau_c, zero),
        x1: L::f_sel(go, f_delta * sum1 + tau_c, zero),
        samples,
        capped: prep.capped | (go & V::exhausted(&dda)),
        rng,
    }
}
