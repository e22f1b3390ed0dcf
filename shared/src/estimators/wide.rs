//! Alg. 2 and Alg. 1, with a fixed N or the adaptive variant's fixed step
//! ([`crate::estimators::optical_depth::prepare`], `estimate_pair`, `estimate_pair_adaptive`),
//! for several rays at once, on the layout
//! of [`crate::volume::wide`]: a loop runs while any lane has work, and a lane's values change
//! only under its mask, in the order the scalar loops change them, so each lane's estimates
//! are the scalar functions' bits for its ray.

use crate::estimators::optical_depth::{Prep, Strata};
use crate::geometry::Ray;
use crate::lanes::{pcg_hash, unit_f32, Lanes};
use crate::params::{Importance, Jitter};
use crate::volume::wide::{WideDda, WideRays, WideVolume, MEAN, MU_MIN, P};

/// [`crate::estimators::optical_depth::Prep`] per lane.
#[derive(Clone, Copy)]
pub struct WidePrep<L: Lanes> {
    pub f: L::F,
    pub t_min: L::F,
    pub t_max: L::F,
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
/// strata per estimate N, and whether targets past F are skipped (the adaptive variant).
#[derive(Clone, Copy)]
pub struct WidePlan<L: Lanes> {
    pub f_delta: L::F,
    pub n: L::U,
    pub adaptive: bool,
}

impl<L: Lanes> WidePlan<L> {
    /// [`Strata::fixed`] with N samples per estimate in every lane.
    #[inline(always)]
    pub fn fixed(prep: &WidePrep<L>, n: u32) -> Self {
        WidePlan {
            f_delta: prep.f / L::f(n as f32),
            n: L::u(n),
            adaptive: false,
        }
    }

    /// [`Strata::adaptive`] with step `f_delta`, lane by lane.
    #[inline(always)]
    pub fn adaptive(prep: &WidePrep<L>, f_delta: f32) -> Self {
        let plan = |l: usize| Strata::adaptive(&prep.lane(l), f_delta);
        WidePlan {
            f_delta: L::f_from(|l| plan(l).f_delta),
            n: L::u_from(|l| plan(l).n0),
            adaptive: true,
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
            capped: L::m_at(self.capped, l),
        }
    }
}

/// The importance word of a brick record (see [`crate::estimators::optical_depth::importance`]).
#[inline(always)]
fn importance_word(mode: Importance) -> u32 {
    match mode {
        Importance::VarianceAware => P,
        Importance::Mean => MEAN,
    }
}

/// The control variate of a brick's record words (see
/// [`crate::estimators::optical_depth::mu_min`]).
#[inline(always)]
fn mu_min<L: Lanes>(vol: &WideVolume, m: L::M, cell: [L::U; 3], mode: Importance) -> L::F {
    match mode {
        Importance::VarianceAware => L::f_from_bits(vol.brick_word::<L>(m, cell, MU_MIN)),
        Importance::Mean => L::f(0.0),
    }
}

/// Alg. 2 for the rays of the lanes `on` over [t0, t1].
#[inline(always)]
pub fn prepare<L: Lanes>(
    vol: &WideVolume,
    rays: &[Ray],
    t0: L::F,
    t1: L::F,
    on: L::M,
    mode: Importance,
) -> WidePrep<L> {
    let word = importance_word(mode);
    let mut f = L::f(0.0);
    let mut t_min = t1;
    let mut t_max = t0;
    let mut dda = WideDda::<L>::new(vol, rays, t0, t1, on);
    loop {
        let a = !dda.done;
        if !L::any(a) {
            break;
        }
        let seg = dda.step(vol, a);
        let p = L::f_from_bits(vol.brick_word::<L>(a, seg.cell, word));
        f = L::f_sel(a, f + (seg.t1 - seg.t0) * p, f);
        let nonzero = a & L::f_ne(p, L::f(0.0));
        t_min = L::f_sel(nonzero & L::f_lt(seg.t0, t_min), seg.t0, t_min);
        t_max = L::f_sel(nonzero & L::f_gt(seg.t1, t_max), seg.t1, t_max);
    }
    WidePrep {
        f,
        t_min,
        t_max,
        capped: dda.exhausted(),
    }
}

/// Next uniform in (0, 1] of each lane's generator and the advanced states
/// ([`crate::rng::HashRng::next_f32_open0`]).
#[inline(always)]
fn next_open0<L: Lanes>(state: L::U) -> (L::F, L::U) {
    let s = pcg_hash::<L>(state);
    (L::f(1.0) - unit_f32::<L>(s), s)
}

/// Alg. 1 by `plan` for the rays of the lanes `on`, over `prep`'s tight segments, each lane's
/// generator at `rng` ([`crate::rng::HashRng::state`]).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn estimate_pair<L: Lanes>(
    vol: &WideVolume,
    rays: &[Ray],
    prep: &WidePrep<L>,
    on: L::M,
    plan: &WidePlan<L>,
    mode: Importance,
    jitter: Jitter,
    rng: L::U,
) -> WidePair<L> {
    let word = importance_word(mode);
    let wide = WideRays::<L>::of(rays);
    let (f_delta, nu) = (plan.f_delta, plan.n);
    // Lanes with samples to take (the scalar function returns at once for the others).
    let go = on & L::f_gt(prep.f, L::f(0.0)) & !L::u_eq(nu, L::u(0)) & L::f_gt(f_delta, L::f(0.0));
    let (xi0, s) = next_open0::<L>(rng);
    let (xi1, s) = next_open0::<L>(s);
    let mut rng = L::u_sel(go, s, rng);
    let (mut k0, mut k1) = (L::u(0), L::u(0));
    let (mut o0, mut o1) = (xi0, xi1);
    let (mut sum0, mut sum1) = (L::f(0.0), L::f(0.0));
    let mut f = L::f(0.0);
    let mut tau_c = L::f(0.0);
    // The last brick segment with P > 0 reached: t0, t1, CDF at its end, P, mu_min.
    let zero = L::f(0.0);
    let (mut l_t0, mut l_t1, mut l_f, mut l_p, mut l_m) = (zero, zero, zero, zero, zero);
    let mut dda = WideDda::<L>::new(vol, rays, prep.t_min, prep.t_max, go);
    let mut samples = L::u(0);
    // Lanes still in the sample loop (a lane leaves it where the scalar loop breaks).
    let mut live = go;
    loop {
        let left0 = L::u_lt(k0, nu);
        let left1 = L::u_lt(k1, nu);
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
        k0 = L::u_sel(past & j0, nu, k0);
        k1 = L::u_sel(past & !j0, nu, k1);
        let a = a & !past;
        // Advance over bricks until the CDF passes the target.
        loop {
            let v = a & L::f_ge(target, f) & !dda.done;
            if !L::any(v) {
                break;
            }
            let seg = dda.step(vol, v);
            let p = L::f_from_bits(vol.brick_word::<L>(v, seg.cell, word));
            let m = mu_min::<L>(vol, v, seg.cell, mode);
            let len = seg.t1 - seg.t0;
            f = L::f_sel(v, f + len * p, f);
            tau_c = L::f_sel(v, tau_c + len * m, tau_c);
            let nonzero = v & L::f_gt(p, zero);
            l_t0 = L::f_sel(nonzero, seg.t0, l_t0);
            l_t1 = L::f_sel(nonzero, seg.t1, l_t1);
            l_f = L::f_sel(nonzero, f, l_f);
            l_p = L::f_sel(nonzero, p, l_p);
            l_m = L::f_sel(nonzero, m, l_m);
        }
        let stop = a & !L::f_gt(l_p, zero);
        live = live & !stop;
        let a = a & !stop;
        // The sample's location within its brick, clamped against rounding.
        let t = l_t1 - (l_f - target) / l_p;
        let t = L::f_sel(L::f_lt(t, l_t0), l_t0, t);
        let t = L::f_sel(L::f_gt(t, l_t1), l_t1, t);
        let key = [rng, samples, L::u(0x9e37_79b9)];
        let mu = vol.mu_at::<L>(a, wide.at(t), key);
        let contribution = (mu - l_m) / l_p;
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
        let v = go & !dda.done;
        if !L::any(v) {
            break;
        }
        let seg = dda.step(vol, v);
        let m = mu_min::<L>(vol, v, seg.cell, mode);
        tau_c = L::f_sel(v, tau_c + (seg.t1 - seg.t0) * m, tau_c);
    }
    WidePair {
        x0: L::f_sel(go, f_delta * sum0 + tau_c, zero),
        x1: L::f_sel(go, f_delta * sum1 + tau_c, zero),
        samples,
        capped: prep.capped | (go & dda.exhausted()),
        rng,
    }
}
