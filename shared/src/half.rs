//! IEEE half-precision decoding with integer operations only (no f16 type on SPIR-V needed).

use crate::lanes::{Lanes, One};

/// The f32 value of the binary16 number with bits `h` (exact; every f16 is an f32).
#[inline]
pub fn f16_to_f32(h: u32) -> f32 {
    f16_to_f32_lanes::<One>(h)
}

/// [`f16_to_f32`] lane by lane (its one body): zero or subnormal (exponent 0) is mant * 2^-24,
/// exact in f32; exponent 31 is inf or NaN.
#[inline(always)]
pub fn f16_to_f32_lanes<L: Lanes>(h: L::U) -> L::F {
    let sign = L::u_shl(L::u_and(h, L::u(0x8000)), L::u(16));
    let exp = L::u_and(L::u_shr(h, L::u(10)), L::u(0x1f));
    let mant = L::u_and(h, L::u(0x03ff));
    let mant13 = L::u_shl(mant, L::u(13));
    let tiny = L::u_to_f(mant) * L::f(1.0 / 16_777_216.0);
    let tiny = L::f_from_bits(L::u_or(L::f_bits(tiny), sign));
    let special = L::f_from_bits(L::u_or(L::u_or(sign, L::u(0x7f80_0000)), mant13));
    let exp112 = L::u_shl(L::u_add(exp, L::u(112)), L::u(23));
    let normal = L::f_from_bits(L::u_or(L::u_or(sign, exp112), mant13));
    let v = L::f_sel(L::u_eq(exp, L::u(31)), special, normal);
    L::f_sel(L::u_eq(exp, L::u(0)), tiny, v)
}

/// The half at `index` of an array packed two per u32 (low half first).
#[inline]
pub fn packed_f16(words: &[u32], index: usize) -> f32 {
    let word = words[index >> 1];
    f16_to_f32((word >> ((index as u32 & 1) * 16)) & 0xffff)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_every_finite_half_like_the_half_crate_would() {
        // Independent model: value = (-1)^s * 2^(e-15) * (1 + m/1024), subnormals 2^-14 * m/1024.
        for h in 0u32..=0xffff {
            let (s, e, m) = ((h >> 15) & 1, (h >> 10) & 0x1f, h & 0x3ff);
            if e == 31 {
                continue;
            }
            let mag = if e == 0 {
                m as f64 * 2f64.powi(-24)
            } else {
                (1.0 + m as f64 / 1024.0) * 2f64.powi(e as i32 - 15)
            };
            let want = if s == 1 { -mag } else { mag };
            assert_eq!(f16_to_f32(h) as f64, want, "half bits {h:#06x}");
            assert_eq!(f16_to_f32(h).is_sign_negative(), s == 1);
        }
        assert_eq!(f16_to_f32(0x7c00), f32::INFINITY);
        assert!(f16_to_f32(0x7e00).is_nan());
    }
}
