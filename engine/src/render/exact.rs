//! Exact sums of f32 values: a render adds its sample blocks' f32 sums here without rounding, so
//! the order (one render, or shards merged in any order) cannot change a bit of the result.
//!
//! Every finite f32 is an integer multiple of 2^-149 below 2^128: a two's complement integer of
//! [`LIMBS`] 32-bit limbs with its least bit worth 2^-149 holds each of them, and the sum of up
//! to 2^42 of them, exactly (277 bits of magnitude, 43 bits of headroom and sign). Infinities and
//! NaNs are kept beside it as flags (which of them were added), so they too add up the same in
//! every order.

/// 32-bit limbs of the fixed-point integer (least significant first).
pub const LIMBS: usize = 10;

/// Flag: a +inf was added.
const POS_INF: u8 = 1;
/// Flag: a -inf was added.
const NEG_INF: u8 = 2;
/// Flag: a NaN was added.
const NAN: u8 = 4;

/// The exact sum of f32 values (see the module's comment).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ExactSum {
    /// Two's complement, least significant limb first, bit 0 worth 2^-149.
    limbs: [u32; LIMBS],
    /// Which non-finite values were added (`POS_INF`, `NEG_INF`, `NAN`).
    special: u8,
}

impl ExactSum {
    /// The sum of the single value `x`.
    pub fn of(x: f32) -> ExactSum {
        let mut s = ExactSum::default();
        s.add_f32(x);
        s
    }

    /// Adds `x` exactly.
    pub fn add_f32(&mut self, x: f32) {
        if x.is_nan() {
            self.special |= NAN;
            return;
        }
        if x.is_infinite() {
            self.special |= if x > 0.0 { POS_INF } else { NEG_INF };
            return;
        }
        let bits = x.to_bits();
        let field = (bits >> 23) & 0xff;
        let frac = u64::from(bits & 0x7f_ffff);
        // x = m 2^(offset - 149): subnormals m = frac, offset 0; normals m = 1.frac, offset E - 1.
        let (m, offset) = if field == 0 {
            (frac, 0)
        } else {
            (frac | 1 << 23, field - 1)
        };
        if m == 0 {
            return;
        }
        let (limb, shift) = ((offset / 32) as usize, offset % 32);
        let wide = m << shift; // at most 24 + 31 bits
        let part = [wide as u32, (wide >> 32) as u32];
        if x < 0.0 {
            self.sub_at(limb, part);
        } else {
            self.add_at(limb, part);
        }
    }

    /// Adds `other` exactly (the merge of two partial sums).
    pub fn add(&mut self, other: &ExactSum) {
        let mut carry = 0u64;
        for (a, b) in self.limbs.iter_mut().zip(other.limbs) {
            let t = u64::from(*a) + u64::from(b) + carry;
            *a = t as u32;
            carry = t >> 32;
        }
        self.special |= other.special;
    }

    /// `part` (two limbs) added at limb `at`, the carry carried to the top (two's complement
    /// wraps there, as it must).
    fn add_at(&mut self, at: usize, part: [u32; 2]) {
        let mut carry = 0u64;
        for i in at..LIMBS {
            let add = if i - at < 2 { part[i - at] } else { 0 };
            let t = u64::from(self.limbs[i]) + u64::from(add) + carry;
            self.limbs[i] = t as u32;
            carry = t >> 32;
            if carry == 0 && i - at >= 1 {
                break;
            }
        }
    }

    /// `part` subtracted at limb `at`, the borrow carried to the top.
    fn sub_at(&mut self, at: usize, part: [u32; 2]) {
        let mut borrow = 0u64;
        for i in at..LIMBS {
            let sub = if i - at < 2 { part[i - at] } else { 0 };
            let (t, b1) = self.limbs[i].overflowing_sub(sub);
            let (t, b2) = t.overflowing_sub(borrow as u32);
            self.limbs[i] = t;
            borrow = u64::from(b1 | b2);
            if borrow == 0 && i - at >= 1 {
                break;
            }
        }
    }

    /// Whether the integer is negative (its top bit).
    fn negative(&self) -> bool {
        self.limbs[LIMBS - 1] >> 31 == 1
    }

    /// The magnitude of the integer and its sign (true: negative).
    fn magnitude(&self) -> ([u32; LIMBS], bool) {
        if !self.negative() {
            return (self.limbs, false);
        }
        let mut m = self.limbs.map(|l| !l);
        for l in m.iter_mut() {
            let (t, overflow) = l.overflowing_add(1);
            *l = t;
            if !overflow {
                break;
            }
        }
        (m, true)
    }

    /// The sum rounded to the nearest f32 (ties to even; beyond f32's range, the infinity of its
    /// sign); NaN if a NaN or both infinities were added, an infinity if one was.
    pub fn to_f32(&self) -> f32 {
        if self.special & NAN != 0 || self.special & (POS_INF | NEG_INF) == POS_INF | NEG_INF {
            return f32::NAN;
        }
        if self.special & POS_INF != 0 {
            return f32::INFINITY;
        }
        if self.special & NEG_INF != 0 {
            return f32::NEG_INFINITY;
        }
        let (mag, negative) = self.magnitude();
        let Some(top) = (0..LIMBS).rev().find(|&i| mag[i] != 0) else {
            return 0.0;
        };
        let h = top as u32 * 32 + 31 - mag[top].leading_zeros(); // the highest set bit
        let bits = if h <= 23 {
            // Below 2^-125 every multiple of 2^-149 is an f32: its bits are the integer.
            mag[0]
        } else {
            // Keep 24 bits from h down; round half to even on the bits below.
            let shift = h - 23;
            let mut mant = bits_at(&mag, shift, 24);
            let round = bits_at(&mag, shift - 1, 1) == 1;
            let sticky = any_below(&mag, shift - 1);
            let mut shift = shift;
            if round && (sticky || mant & 1 == 1) {
                mant += 1;
                if mant == 1 << 24 {
                    mant >>= 1;
                    shift += 1;
                }
            }
            // mant 2^(shift - 149) = 1.f 2^(shift - 126): biased exponent shift + 1.
            let field = shift + 1;
            if field >= 255 {
                0xff << 23
            } else {
                field << 23 | (mant & 0x7f_ffff)
            }
        };
        let v = f32::from_bits(bits);
        if negative {
            -v
        } else {
            v
        }
    }

    /// Appends the sum to `out`: the flags, the sign, then the magnitude's non-zero limbs (first
    /// index, count, limbs little-endian): 4 + 4 k bytes for k limbs.
    pub fn write(&self, out: &mut Vec<u8>) {
        let (mag, negative) = self.magnitude();
        let lo = mag.iter().position(|&l| l != 0).unwrap_or(0);
        let hi = mag.iter().rposition(|&l| l != 0).map_or(lo, |i| i + 1);
        out.extend_from_slice(&[self.special, u8::from(negative), lo as u8, (hi - lo) as u8]);
        for l in &mag[lo..hi] {
            out.extend_from_slice(&l.to_le_bytes());
        }
    }

    /// Reads a sum written by [`ExactSum::write`] from the front of `bytes`, advancing it; None
    /// if the bytes are not one.
    pub fn read(bytes: &mut &[u8]) -> Option<ExactSum> {
        let (head, rest) = bytes.split_first_chunk::<4>()?;
        let [special, negative, lo, count] = *head;
        let (lo, count) = (usize::from(lo), usize::from(count));
        if special > (POS_INF | NEG_INF | NAN) || negative > 1 || lo + count > LIMBS {
            return None;
        }
        let (body, rest) = rest.split_at_checked(4 * count)?;
        let mut mag = [0u32; LIMBS];
        for (i, word) in body.as_chunks::<4>().0.iter().enumerate() {
            mag[lo + i] = u32::from_le_bytes(*word);
        }
        if mag[LIMBS - 1] >> 31 == 1 {
            return None; // beyond the range of any sum of f32s
        }
        let mut s = ExactSum {
            limbs: mag,
            special,
        };
        if negative == 1 {
            // Two's complement: invert, add one.
            s.limbs = mag.map(|l| !l);
            s.add_at(0, [1, 0]);
        }
        *bytes = rest;
        Some(s)
    }
}

/// `count` (<= 32) bits of `mag` from bit `at` up.
fn bits_at(mag: &[u32; LIMBS], at: u32, count: u32) -> u32 {
    let (limb, shift) = ((at / 32) as usize, at % 32);
    let lo = u64::from(mag[limb]);
    let hi = mag.get(limb + 1).map_or(0, |&l| u64::from(l));
    let wide = (hi << 32 | lo) >> shift;
    (wide & ((1u64 << count) - 1)) as u32
}

/// Whether any bit of `mag` below bit `at` is set.
fn any_below(mag: &[u32; LIMBS], at: u32) -> bool {
    let (limb, shift) = ((at / 32) as usize, at % 32);
    mag[..limb].iter().any(|&l| l != 0) || mag[limb] & ((1u32 << shift) - 1) != 0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact sum of `xs` as an f64 when the f64 sum is exact (values within 2^29 of each
    /// other's scale): the reference for small cases.
    fn f64_sum(xs: &[f32]) -> f64 {
        xs.iter().map(|&x| f64::from(x)).sum()
    }

    fn exact(xs: &[f32]) -> ExactSum {
        let mut s = ExactSum::default();
        for &x in xs {
            s.add_f32(x);
        }
        s
    }

    /// A single value comes back as itself, every kind of f32 (zeros, subnormals, the largest).
    #[test]
    fn one_value_is_itself() {
        // -0 adds nothing: its sum is +0 (as 0.0 + -0.0 in f32).
        assert_eq!(ExactSum::of(-0.0).to_f32().to_bits(), 0);
        let cases = [
            0.0f32,
            1.0,
            -1.0,
            0.1,
            -3.5e-41,
            f32::from_bits(1),
            -f32::from_bits(1),
            f32::MIN_POSITIVE,
            f32::MAX,
            f32::MIN,
            123456.79,
            1e-30,
        ];
        for x in cases {
            assert_eq!(ExactSum::of(x).to_f32().to_bits(), x.to_bits(), "{x:e}");
        }
        let mut rng = 0x1234_5678_9abc_def0u64;
        for _ in 0..200_000 {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let x = f32::from_bits((rng >> 32) as u32);
            if x.is_finite() && x != 0.0 {
                assert_eq!(ExactSum::of(x).to_f32().to_bits(), x.to_bits(), "{x:e}");
            }
        }
    }

    /// Sums whose f64 sum is exact equal its rounding to f32, in every order.
    #[test]
    fn matches_exact_f64_sums_in_any_order() {
        let mut rng = 0x9e37_79b9_7f4a_7c15u64;
        for trial in 0..20_000 {
            let n = 1 + trial % 17;
            let scale = ((trial % 40) as i32 - 20) as f32;
            let xs: Vec<f32> = (0..n)
                .map(|_| {
                    rng = rng
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    let u = (rng >> 40) as f32 / (1u64 << 24) as f32 - 0.5;
                    u * scale.exp2()
                })
                .collect();
            let want = f64_sum(&xs) as f32;
            let forward = exact(&xs).to_f32();
            let mut rev = xs.clone();
            rev.reverse();
            assert_eq!(forward.to_bits(), want.to_bits(), "{xs:?}");
            assert_eq!(exact(&rev).to_f32().to_bits(), want.to_bits(), "{xs:?}");
            // Split in two and merged: the same sum.
            let (a, b) = xs.split_at(n / 2);
            let mut m = exact(b);
            m.add(&exact(a));
            assert_eq!(m, exact(&xs));
        }
    }

    /// Cancellation far beyond f64's precision: 2^100 + 2^-100 - 2^100 is 2^-100 exactly.
    #[test]
    fn wide_cancellation_is_exact() {
        let big = 2f32.powi(100);
        let tiny = 2f32.powi(-100);
        assert_eq!(exact(&[big, tiny, -big]).to_f32(), tiny);
        assert_eq!(exact(&[f32::MAX, f32::MAX, -f32::MAX]).to_f32(), f32::MAX);
        assert_eq!(exact(&[f32::MAX, f32::MAX]).to_f32(), f32::INFINITY);
        assert_eq!(exact(&[f32::MIN, f32::MIN]).to_f32(), f32::NEG_INFINITY);
        let sub = f32::from_bits(1);
        assert_eq!(exact(&[1.0, sub, -1.0]).to_f32(), sub);
    }

    /// Ties round to even: 1 + 2^-24 is 1, 1 + 3 2^-24 is 1 + 2^-22; just above a tie rounds up.
    #[test]
    fn rounds_ties_to_even() {
        let e = 2f32.powi(-24);
        assert_eq!(exact(&[1.0, e]).to_f32(), 1.0);
        assert_eq!(exact(&[1.0, e, e, e]).to_f32(), 1.0 + 4.0 * e);
        assert_eq!(exact(&[1.0, e, f32::from_bits(1)]).to_f32(), 1.0 + 2.0 * e);
        assert_eq!(
            exact(&[-1.0, -e, -f32::from_bits(1)]).to_f32(),
            -1.0 - 2.0 * e
        );
        // Rounding up across a power of two.
        let below = f32::from_bits(2f32.to_bits() - 1);
        assert_eq!(exact(&[below, e]).to_f32(), 2.0);
    }

    /// Infinities and NaN add up the same in any order.
    #[test]
    fn specials() {
        let inf = f32::INFINITY;
        assert_eq!(exact(&[1.0, inf]).to_f32(), inf);
        assert_eq!(exact(&[-inf, 1.0]).to_f32(), -inf);
        assert!(exact(&[inf, -inf]).to_f32().is_nan());
        assert!(exact(&[f32::NAN, 1.0]).to_f32().is_nan());
        let mut a = exact(&[inf]);
        a.add(&exact(&[-inf]));
        assert!(a.to_f32().is_nan());
    }

    /// The stored form reads back to the same sum, and garbage is refused.
    #[test]
    fn write_read_round_trip() {
        for xs in [
            vec![],
            vec![1.0f32],
            vec![-2.5, 1e-40],
            vec![f32::MAX, f32::MAX, -1e-45],
            vec![f32::NAN],
            vec![-f32::INFINITY, 3.0],
        ] {
            let s = exact(&xs);
            let mut bytes = Vec::new();
            s.write(&mut bytes);
            bytes.push(0xAB);
            let mut view = bytes.as_slice();
            assert_eq!(ExactSum::read(&mut view), Some(s), "{xs:?}");
            assert_eq!(view, [0xAB]);
        }
        assert_eq!(ExactSum::read(&mut [9u8, 0, 0, 0].as_slice()), None);
        assert_eq!(ExactSum::read(&mut [0u8, 0, 8, 3].as_slice()), None);
        assert_eq!(ExactSum::read(&mut [0u8, 0, 0, 1, 1].as_slice()), None);
    }
}
