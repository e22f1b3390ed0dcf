//! [`Lanes`] over 8-lane vectors (`std::simd`) for the CPU's wide transmittance pass
//! ([`shared::kernels::wide`]): every operation is the lane-wise form of the scalar one (IEEE
//! f32 arithmetic and comparisons, wrapping u32), so each lane computes the scalar bits.

use shared::kernels::render::PixelSums;
use shared::kernels::wide;
use shared::lanes::Lanes;
use shared::params::RenderParams;
use shared::volume::grid::VolumeView;
use shared::volume::texels::Texels;
use std::simd::prelude::*;

/// Eight lanes.
#[derive(Clone, Copy, Debug, Default)]
pub struct X8;

type F = f32x8;
type U = u32x8;
type I = i32x8;
type M = mask32x8;

impl Lanes for X8 {
    const N: usize = 8;
    type F = F;
    type U = U;
    type I = I;
    type M = M;

    #[inline(always)]
    fn f(v: f32) -> F {
        F::splat(v)
    }
    #[inline(always)]
    fn u(v: u32) -> U {
        U::splat(v)
    }
    #[inline(always)]
    fn i(v: i32) -> I {
        I::splat(v)
    }
    #[inline(always)]
    fn m(v: bool) -> M {
        M::splat(v)
    }
    #[inline(always)]
    fn f_from(f: impl Fn(usize) -> f32) -> F {
        F::from_array(std::array::from_fn(f))
    }
    #[inline(always)]
    fn u_from(f: impl Fn(usize) -> u32) -> U {
        U::from_array(std::array::from_fn(f))
    }
    #[inline(always)]
    fn i_from(f: impl Fn(usize) -> i32) -> I {
        I::from_array(std::array::from_fn(f))
    }
    #[inline(always)]
    fn m_from(f: impl Fn(usize) -> bool) -> M {
        M::from_array(std::array::from_fn(f))
    }
    #[inline(always)]
    fn f_at(v: F, l: usize) -> f32 {
        v[l]
    }
    #[inline(always)]
    fn u_at(v: U, l: usize) -> u32 {
        v[l]
    }
    #[inline(always)]
    fn m_at(v: M, l: usize) -> bool {
        v.test(l)
    }
    #[inline(always)]
    fn any(m: M) -> bool {
        m.any()
    }
    #[inline(always)]
    fn f_lt(a: F, b: F) -> M {
        a.simd_lt(b)
    }
    #[inline(always)]
    fn f_le(a: F, b: F) -> M {
        a.simd_le(b)
    }
    #[inline(always)]
    fn f_gt(a: F, b: F) -> M {
        a.simd_gt(b)
    }
    #[inline(always)]
    fn f_ge(a: F, b: F) -> M {
        a.simd_ge(b)
    }
    #[inline(always)]
    fn f_ne(a: F, b: F) -> M {
        a.simd_ne(b)
    }
    #[inline(always)]
    fn f_sel(m: M, a: F, b: F) -> F {
        m.select(a, b)
    }
    #[inline(always)]
    fn f_bits(v: F) -> U {
        v.to_bits()
    }
    #[inline(always)]
    fn f_from_bits(v: U) -> F {
        F::from_bits(v)
    }
    #[inline(always)]
    fn f_to_u(v: F) -> U {
        v.cast::<u32>()
    }
    #[inline(always)]
    fn u_add(a: U, b: U) -> U {
        a + b
    }
    #[inline(always)]
    fn u_sub(a: U, b: U) -> U {
        a - b
    }
    #[inline(always)]
    fn u_div(a: U, b: U) -> U {
        a / b
    }
    #[inline(always)]
    fn u_mul(a: U, b: U) -> U {
        a * b
    }
    #[inline(always)]
    fn u_and(a: U, b: U) -> U {
        a & b
    }
    #[inline(always)]
    fn u_or(a: U, b: U) -> U {
        a | b
    }
    #[inline(always)]
    fn u_xor(a: U, b: U) -> U {
        a ^ b
    }
    #[inline(always)]
    fn u_shr(a: U, b: U) -> U {
        a >> (b & U::splat(31))
    }
    #[inline(always)]
    fn u_shl(a: U, b: U) -> U {
        a << (b & U::splat(31))
    }
    #[inline(always)]
    fn u_lt(a: U, b: U) -> M {
        a.simd_lt(b)
    }
    #[inline(always)]
    fn u_eq(a: U, b: U) -> M {
        a.simd_eq(b)
    }
    #[inline(always)]
    fn u_sel(m: M, a: U, b: U) -> U {
        m.select(a, b)
    }
    #[inline(always)]
    fn u_to_f(v: U) -> F {
        v.cast::<f32>()
    }
    #[inline(always)]
    fn gather(words: &[u32], m: M, idx: U) -> U {
        U::gather_select(words, m.cast(), idx.cast::<usize>(), U::splat(0))
    }
    #[inline(always)]
    fn i_add(a: I, b: I) -> I {
        a + b
    }
    #[inline(always)]
    fn i_lt(a: I, b: I) -> M {
        a.simd_lt(b)
    }
    #[inline(always)]
    fn i_gt(a: I, b: I) -> M {
        a.simd_gt(b)
    }
    #[inline(always)]
    fn i_ge(a: I, b: I) -> M {
        a.simd_ge(b)
    }
    #[inline(always)]
    fn i_eq(a: I, b: I) -> M {
        a.simd_eq(b)
    }
    #[inline(always)]
    fn i_sel(m: M, a: I, b: I) -> I {
        m.select(a, b)
    }
    #[inline(always)]
    fn i_to_f(v: I) -> F {
        v.cast::<f32>()
    }
    #[inline(always)]
    fn i_to_u(v: I) -> U {
        v.cast::<u32>()
    }
}

/// [`shared::kernels::wide::transmittance_pass`] over [`X8`], compiled for AVX2 (real gathers,
/// 8-lane integer multiplies) where the CPU has it, else for the baseline instruction set:
/// the same bytes either way (no fused operations are formed without being asked for).
pub fn transmittance_pass<T: Texels>(
    vol: &VolumeView<T>,
    params: &RenderParams,
    pixels: &[u32],
    s_begin: u32,
    s_end: u32,
    acc: &mut [PixelSums],
) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2, the only feature `pass_avx2` is compiled for.
        unsafe { pass_avx2(vol, params, pixels, s_begin, s_end, acc) };
        return;
    }
    wide::transmittance_pass::<X8, T>(vol, params, pixels, s_begin, s_end, acc);
}

/// The pass inlined into a function compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn pass_avx2<T: Texels>(
    vol: &VolumeView<T>,
    params: &RenderParams,
    pixels: &[u32],
    s_begin: u32,
    s_end: u32,
    acc: &mut [PixelSums],
) {
    wide::transmittance_pass::<X8, T>(vol, params, pixels, s_begin, s_end, acc);
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::half::f16_to_f32_lanes;
    use shared::rng::{pcg3d_lanes, pcg_hash_lanes, unit_f32_lanes};

    /// Eight values of `f` over lane indices as an [`X8`] lane value.
    fn lanes(f: impl Fn(usize) -> u32) -> U {
        X8::u_from(f)
    }

    /// The 8-lane forms of the hashes, `unit_f32` and the f16 decode give each lane the bits of
    /// the one-lane form (the scalar functions): every f16 value, and 2^16 hash inputs spread
    /// over the u32 range (a PCG-hash chain from 1), eight per call.
    #[test]
    fn eight_lanes_are_eight_scalar_calls() {
        for base in (0..=0xffffu32).step_by(8) {
            let f = f16_to_f32_lanes::<X8>(lanes(|l| base + l as u32));
            for l in 0..8 {
                let want = shared::half::f16_to_f32(base + l as u32).to_bits();
                assert_eq!(
                    X8::f_at(f, l).to_bits(),
                    want,
                    "f16 {:#06x}",
                    base + l as u32
                );
            }
        }
        let mut v = [1u32; 8];
        for (l, x) in v.iter_mut().enumerate() {
            *x = shared::rng::pcg_hash(l as u32 + 1);
        }
        for _ in 0..1 << 13 {
            let x = lanes(|l| v[l]);
            let hashed = pcg_hash_lanes::<X8>(x);
            let key = [
                x,
                lanes(|l| v[l].rotate_left(11)),
                lanes(|l| v[l] ^ 0x9e37_79b9),
            ];
            let h3 = pcg3d_lanes::<X8>(key);
            let unit = unit_f32_lanes::<X8>(x);
            for (l, &vl) in v.iter().enumerate() {
                let k = [vl, vl.rotate_left(11), vl ^ 0x9e37_79b9];
                assert_eq!(X8::u_at(hashed, l), shared::rng::pcg_hash(vl));
                let want = shared::rng::pcg3d(k);
                assert_eq!([0, 1, 2].map(|i| X8::u_at(h3[i], l)), want);
                assert_eq!(
                    X8::f_at(unit, l).to_bits(),
                    shared::rng::unit_f32(vl).to_bits()
                );
            }
            for x in v.iter_mut() {
                *x = shared::rng::pcg_hash(*x);
            }
        }
    }
}
