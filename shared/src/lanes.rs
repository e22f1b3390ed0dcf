//! Several rays per instruction: the lane types that Alg. 1/2 ([`crate::estimators::wide`]), the
//! traversal step ([`crate::volume::walk`]), the hashes ([`crate::rng`]) and the f16 decode
//! ([`crate::half`]) are written over, once. [`One`] is one lane of plain scalars (no_std,
//! SPIR-V): the scalar functions are those bodies over it. The CPU backend implements the trait
//! over 8-lane vectors. Every operation is the lane-wise IEEE (or wrapping integer) operation,
//! so each lane computes the bits one lane computes for its ray.

use core::ops::{Add, BitAnd, BitOr, Div, Mul, Not, Sub};

/// A width and its lane types: `F` (f32), `U` (u32, wrapping), `I` (i32) and the mask `M`.
pub trait Lanes: Copy {
    /// Lanes per value.
    const N: usize;
    type F: Copy
        + Add<Output = Self::F>
        + Sub<Output = Self::F>
        + Mul<Output = Self::F>
        + Div<Output = Self::F>;
    type U: Copy;
    type I: Copy;
    type M: Copy + BitAnd<Output = Self::M> + BitOr<Output = Self::M> + Not<Output = Self::M>;

    fn f(v: f32) -> Self::F;
    fn u(v: u32) -> Self::U;
    fn i(v: i32) -> Self::I;
    fn m(v: bool) -> Self::M;
    /// Lane by lane from a function of the lane index.
    fn f_from(f: impl Fn(usize) -> f32) -> Self::F;
    fn u_from(f: impl Fn(usize) -> u32) -> Self::U;
    fn i_from(f: impl Fn(usize) -> i32) -> Self::I;
    fn m_from(f: impl Fn(usize) -> bool) -> Self::M;
    /// Lane `l`.
    fn f_at(v: Self::F, l: usize) -> f32;
    fn u_at(v: Self::U, l: usize) -> u32;
    fn m_at(v: Self::M, l: usize) -> bool;
    /// Whether any lane is set.
    fn any(m: Self::M) -> bool;

    fn f_lt(a: Self::F, b: Self::F) -> Self::M;
    fn f_le(a: Self::F, b: Self::F) -> Self::M;
    fn f_gt(a: Self::F, b: Self::F) -> Self::M;
    fn f_ge(a: Self::F, b: Self::F) -> Self::M;
    fn f_ne(a: Self::F, b: Self::F) -> Self::M;
    fn f_sel(m: Self::M, a: Self::F, b: Self::F) -> Self::F;
    fn f_bits(v: Self::F) -> Self::U;
    fn f_from_bits(v: Self::U) -> Self::F;
    /// `v as u32` (v in [0, 2^32)).
    fn f_to_u(v: Self::F) -> Self::U;

    fn u_add(a: Self::U, b: Self::U) -> Self::U;
    fn u_sub(a: Self::U, b: Self::U) -> Self::U;
    fn u_mul(a: Self::U, b: Self::U) -> Self::U;
    /// `a / b` (b nonzero in every lane).
    fn u_div(a: Self::U, b: Self::U) -> Self::U;
    fn u_and(a: Self::U, b: Self::U) -> Self::U;
    fn u_or(a: Self::U, b: Self::U) -> Self::U;
    fn u_xor(a: Self::U, b: Self::U) -> Self::U;
    /// Shifts by amounts below 32.
    fn u_shr(a: Self::U, b: Self::U) -> Self::U;
    fn u_shl(a: Self::U, b: Self::U) -> Self::U;
    fn u_lt(a: Self::U, b: Self::U) -> Self::M;
    fn u_eq(a: Self::U, b: Self::U) -> Self::M;
    fn u_sel(m: Self::M, a: Self::U, b: Self::U) -> Self::U;
    /// `v as f32`.
    fn u_to_f(v: Self::U) -> Self::F;
    /// `words[idx]` where `m`, 0 elsewhere (`idx` in bounds where `m`).
    fn gather(words: &[u32], m: Self::M, idx: Self::U) -> Self::U;

    fn i_add(a: Self::I, b: Self::I) -> Self::I;
    fn i_lt(a: Self::I, b: Self::I) -> Self::M;
    fn i_gt(a: Self::I, b: Self::I) -> Self::M;
    fn i_ge(a: Self::I, b: Self::I) -> Self::M;
    fn i_eq(a: Self::I, b: Self::I) -> Self::M;
    fn i_sel(m: Self::M, a: Self::I, b: Self::I) -> Self::I;
    /// `v as f32`.
    fn i_to_f(v: Self::I) -> Self::F;
    /// `v as u32`.
    fn i_to_u(v: Self::I) -> Self::U;
}

/// One lane: the scalar types themselves.
#[derive(Clone, Copy, Debug, Default)]
pub struct One;

impl Lanes for One {
    const N: usize = 1;
    type F = f32;
    type U = u32;
    type I = i32;
    type M = bool;

    #[inline]
    fn f(v: f32) -> f32 {
        v
    }
    #[inline]
    fn u(v: u32) -> u32 {
        v
    }
    #[inline]
    fn i(v: i32) -> i32 {
        v
    }
    #[inline]
    fn m(v: bool) -> bool {
        v
    }
    #[inline]
    fn f_from(f: impl Fn(usize) -> f32) -> f32 {
        f(0)
    }
    #[inline]
    fn u_from(f: impl Fn(usize) -> u32) -> u32 {
        f(0)
    }
    #[inline]
    fn i_from(f: impl Fn(usize) -> i32) -> i32 {
        f(0)
    }
    #[inline]
    fn m_from(f: impl Fn(usize) -> bool) -> bool {
        f(0)
    }
    #[inline]
    fn f_at(v: f32, _l: usize) -> f32 {
        v
    }
    #[inline]
    fn u_at(v: u32, _l: usize) -> u32 {
        v
    }
    #[inline]
    fn m_at(v: bool, _l: usize) -> bool {
        v
    }
    #[inline]
    fn any(m: bool) -> bool {
        m
    }
    #[inline]
    fn f_lt(a: f32, b: f32) -> bool {
        a < b
    }
    #[inline]
    fn f_le(a: f32, b: f32) -> bool {
        a <= b
    }
    #[inline]
    fn f_gt(a: f32, b: f32) -> bool {
        a > b
    }
    #[inline]
    fn f_ge(a: f32, b: f32) -> bool {
        a >= b
    }
    #[inline]
    fn f_ne(a: f32, b: f32) -> bool {
        a != b
    }
    #[inline]
    fn f_sel(m: bool, a: f32, b: f32) -> f32 {
        if m {
            a
        } else {
            b
        }
    }
    #[inline]
    fn f_bits(v: f32) -> u32 {
        v.to_bits()
    }
    #[inline]
    fn f_from_bits(v: u32) -> f32 {
        f32::from_bits(v)
    }
    #[inline]
    fn f_to_u(v: f32) -> u32 {
        v as u32
    }
    #[inline]
    fn u_add(a: u32, b: u32) -> u32 {
        a.wrapping_add(b)
    }
    #[inline]
    fn u_sub(a: u32, b: u32) -> u32 {
        a.wrapping_sub(b)
    }
    #[inline]
    fn u_div(a: u32, b: u32) -> u32 {
        a / b
    }
    #[inline]
    fn u_mul(a: u32, b: u32) -> u32 {
        a.wrapping_mul(b)
    }
    #[inline]
    fn u_and(a: u32, b: u32) -> u32 {
        a & b
    }
    #[inline]
    fn u_or(a: u32, b: u32) -> u32 {
        a | b
    }
    #[inline]
    fn u_xor(a: u32, b: u32) -> u32 {
        a ^ b
    }
    #[inline]
    fn u_shr(a: u32, b: u32) -> u32 {
        a >> (b & 31)
    }
    #[inline]
    fn u_shl(a: u32, b: u32) -> u32 {
        a << (b & 31)
    }
    #[inline]
    fn u_lt(a: u32, b: u32) -> bool {
        a < b
    }
    #[inline]
    fn u_eq(a: u32, b: u32) -> bool {
        a == b
    }
    #[inline]
    fn u_sel(m: bool, a: u32, b: u32) -> u32 {
        if m {
            a
        } else {
            b
        }
    }
    #[inline]
    fn u_to_f(v: u32) -> f32 {
        v as f32
    }
    #[inline]
    fn gather(words: &[u32], m: bool, idx: u32) -> u32 {
        if m {
            words[idx as usize]
        } else {
            0
        }
    }
    #[inline]
    fn i_add(a: i32, b: i32) -> i32 {
        a.wrapping_add(b)
    }
    #[inline]
    fn i_lt(a: i32, b: i32) -> bool {
        a < b
    }
    #[inline]
    fn i_gt(a: i32, b: i32) -> bool {
        a > b
    }
    #[inline]
    fn i_ge(a: i32, b: i32) -> bool {
        a >= b
    }
    #[inline]
    fn i_eq(a: i32, b: i32) -> bool {
        a == b
    }
    #[inline]
    fn i_sel(m: bool, a: i32, b: i32) -> i32 {
        if m {
            a
        } else {
            b
        }
    }
    #[inline]
    fn i_to_f(v: i32) -> f32 {
        v as f32
    }
    #[inline]
    fn i_to_u(v: i32) -> u32 {
        v as u32
    }
}
