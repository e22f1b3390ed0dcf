//! IEEE half-precision decoding with integer operations only (no f16 type on SPIR-V needed).

/// The f32 value of the binary16 number with bits `h` (exact; every f16 is an f32).
#[inline]
pub fn f16_to_f32(h: u32) -> f32 {
    let sign = (h & 0x8000) << 16;
    let exp = (h >> 10) & 0x1f;
    let mant = h & 0x03ff;
    if exp == 0 {
        // Zero or subnormal: mant * 2^-24, exact in f32.
        let v = mant as f32 * (1.0 / 16_777_216.0);
        return f32::from_bits(v.to_bits() | sign);
    }
    if exp == 31 {
        // Inf or NaN.
        return f32::from_bits(sign | 0x7f80_0000 | (mant << 13));
    }
    f32::from_bits(sign | ((exp + 112) << 23) | (mant << 13))
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
