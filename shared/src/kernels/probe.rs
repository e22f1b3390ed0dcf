//! Bodies of the foundation kernels: transmittance of optical-depth pairs, the math functions and
//! the RNG streams, one pure function per id, so the GPU and the CPU run exactly this code.

use crate::estimators::transmittance;
use crate::{math, rng};
use bytemuck::{Pod, Zeroable};

/// Two optical depth estimates (X0, X1) of one ray.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DepthPair {
    pub x0: f32,
    pub x1: f32,
}

/// Jackknife K (Eq. 4) and naive exp(-X̄) for one pair.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TransmittancePair {
    pub jackknife: f32,
    pub naive: f32,
}

/// Transmittance estimates of one (X0, X1) pair.
#[inline]
pub fn transmittance_pair(p: DepthPair) -> TransmittancePair {
    TransmittancePair {
        jackknife: transmittance::jackknife(p.x0, p.x1),
        naive: transmittance::naive(p.x0, p.x1),
    }
}

/// Every deterministic math function at one argument.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MathValues {
    pub exp: f32,
    pub ln: f32,
    pub sin: f32,
    pub cos: f32,
    pub atan: f32,
    pub tan: f32,
    pub sqrt: f32,
    pub _pad: f32,
}

/// exp, ln, sin, cos, atan, tan and sqrt of x.
#[inline]
pub fn math_values(x: f32) -> MathValues {
    let (sin, cos) = math::sin_cos(x);
    MathValues {
        exp: math::exp(x),
        ln: math::ln(x),
        sin,
        cos,
        atan: math::atan(x),
        tan: math::tan(x),
        sqrt: crate::math::sqrt(x),
        _pad: 0.0,
    }
}

/// Draws of every generator for one id.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct RngDraws {
    /// First four outputs of `Pcg32::new(state, stream)` for this id.
    pub pcg32: [u32; 4],
    /// `pcg_hash(id ^ seed)`.
    pub hash: u32,
    /// `pcg3d([id, seed, hash])`.
    pub pcg3d: [u32; 3],
}

/// The PCG32 seed used for one id: state from the hash of the id, stream from the user seed.
#[inline]
pub fn pcg32_for(id: u32, seed: u32) -> rng::Pcg32 {
    let state = ((id as u64) << 32) | rng::pcg_hash(id) as u64;
    rng::Pcg32::new(state, seed as u64)
}

/// All generator outputs for one id.
#[inline]
pub fn rng_draws(id: u32, seed: u32) -> RngDraws {
    let mut g = pcg32_for(id, seed);
    let mut pcg32 = [0u32; 4];
    let mut i = 0;
    while i < 4 {
        let (v, next) = g.next_u32();
        pcg32[i] = v;
        g = next;
        i += 1;
    }
    let hash = rng::pcg_hash(id ^ seed);
    RngDraws {
        pcg32,
        hash,
        pcg3d: rng::pcg3d([id, seed, hash]),
    }
}

/// Inputs of the equiangular-sampling probe kernel.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct EquiangularIn {
    pub o: crate::geometry::V3,
    pub dir: crate::geometry::V3,
    pub light: crate::geometry::V3,
    pub ta: f32,
    pub tb: f32,
    pub u: f32,
}

/// Outputs of the equiangular-sampling probe kernel.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct EquiangularOut {
    pub tc: f32,
    pub d: f32,
    pub theta_a: f32,
    pub angle: f32,
    pub t: f32,
    pub pdf: f32,
    pub _pad: [f32; 2],
}

/// Equiangular setup, sample and pdf for one configuration.
#[inline]
pub fn equiangular(p: EquiangularIn) -> EquiangularOut {
    let eq = crate::sampling::equiangular::Equiangular::new(p.o, p.dir, p.light, p.ta, p.tb);
    let (t, pdf) = eq.sample(p.u);
    EquiangularOut {
        tc: eq.tc,
        d: eq.d,
        theta_a: eq.theta_a,
        angle: eq.angle,
        t,
        pdf,
        _pad: [eq.pdf(p.ta + p.u), 0.0],
    }
}

/// Inputs of the phase-function probe kernel.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PhaseIn {
    pub wo: crate::geometry::V3,
    pub g: f32,
    pub u0: f32,
    pub u1: f32,
    pub cos_theta: f32,
    pub _pad: f32,
}

/// Outputs of the phase-function probe kernel.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PhaseOut {
    pub wi: crate::geometry::V3,
    pub pdf: f32,
    pub phase: f32,
    pub _pad: [f32; 3],
}

/// A Henyey-Greenstein sample (direction and density) and the phase function at `cos_theta`.
#[inline]
pub fn phase(p: PhaseIn) -> PhaseOut {
    let (wi, pdf) = crate::sampling::phase::sample_hg(p.wo, p.g, p.u0, p.u1);
    PhaseOut {
        wi,
        pdf,
        phase: crate::sampling::phase::phase_hg(p.cos_theta, p.g),
        _pad: [0.0; 3],
    }
}

/// Inputs of the moment-shadow-map lookup probe: a 2 x 2 map (`desc.width` = `desc.height` =
/// 2) in the layout of `mode`, and a point.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MsmLookupIn {
    pub desc: crate::shadows::map::MsmDesc,
    pub x: crate::geometry::V3,
    pub mode: u32,
    pub words: [u32; 24],
}

/// Outputs of the moment-shadow-map lookup probe.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MsmLookupOut {
    pub t: f32,
    pub fallback: u32,
    pub _pad: [u32; 2],
}

/// [`crate::shadows::map::map_transmittance`] of one configuration.
#[inline]
pub fn msm_lookup(p: MsmLookupIn) -> MsmLookupOut {
    let mode = crate::shadows::map::Shadows::from_u32(p.mode);
    let (t, fallback) = crate::shadows::map::map_transmittance(&p.desc, mode, &p.words, p.x);
    MsmLookupOut {
        t,
        fallback,
        _pad: [0; 2],
    }
}
