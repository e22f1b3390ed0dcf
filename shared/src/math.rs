//! Deterministic elementary functions built from `+ - * /` and bit operations only.
//!
//! The GLSL.std.450 `exp`/`cos` that SPIR-V lowers to differ from native libm by up to 17 ulp, so
//! every transcendental used by an estimator lives here, with one body for both targets. Each op
//! is an IEEE-754 single operation; there is no `mul_add`, so native code and lavapipe round
//! identically. NaN results are the canonical quiet NaN so output bytes compare exactly.

/// Canonical quiet NaN returned by every function here (payloads would otherwise differ).
pub const NAN: f32 = f32::from_bits(0x7fc0_0000);
/// ln(2) split so that `n * LN2_HI` is exact for |n| < 2^8 (fdlibm's split).
const LN2_HI: f32 = f32::from_bits(0x3f31_7200);
/// ln(2) - LN2_HI.
const LN2_LO: f32 = f32::from_bits(0x35bf_be8e);
const LOG2_E: f32 = core::f32::consts::LOG2_E;
/// ln(2) split for `ln` (musl logf's split; differs from the one `exp` uses).
const LOG_LN2_HI: f32 = f32::from_bits(0x3f31_7180);
/// ln(2) - LOG_LN2_HI.
const LOG_LN2_LO: f32 = f32::from_bits(0x3717_f7d1);
/// musl logf's minimax coefficients Lg1..Lg4.
const LG: [f32; 4] = [
    f32::from_bits(0x3f2a_aaaa),
    f32::from_bits(0x3ecc_ce13),
    f32::from_bits(0x3e91_e9ee),
    f32::from_bits(0x3e78_9e26),
];
/// Above this, e^x overflows f32.
const EXP_OVERFLOW: f32 = 88.722_83;
/// Below this, e^x rounds to zero even as a subnormal.
const EXP_UNDERFLOW: f32 = -103.972_08;
/// 2/pi rounded to f32.
const TWO_OVER_PI: f32 = f32::from_bits(0x3f22_f983);
/// pi/2 as five parts; the first four have <= 12 significant bits, so `k * PIO2_i` is exact for
/// |k| < 2^12 and the reduction error stays below 2^-72 * |k|.
const PIO2: [f32; 5] = [
    f32::from_bits(0x3fc9_0000),
    f32::from_bits(0x39fd_a000),
    f32::from_bits(0x33a2_2000),
    f32::from_bits(0x2c34_6000),
    f32::from_bits(0x248d_3132),
];
/// Largest |x| for which sin/cos reduce the argument accurately (k < 2^12).
pub const TRIG_ACCURATE_RANGE: f32 = 6433.0;

/// True when `x` is NaN (bit test; `x != x` can be folded away by optimizers).
#[inline]
pub fn is_nan(x: f32) -> bool {
    (x.to_bits() & 0x7fff_ffff) > 0x7f80_0000
}

/// True when `x` is neither NaN nor infinite.
#[inline]
pub fn is_finite(x: f32) -> bool {
    (x.to_bits() & 0x7f80_0000) != 0x7f80_0000
}

/// `x` itself, as a value a compiler cannot see through: its bits and `ones` (all bits set,
/// read from a buffer). A product passed through here is rounded on its own: no shader compiler
/// can fuse it into a following sum (one rounding instead of two), as lavapipe did in the
/// 16-bit shadow-map quantization. Identity on the CPU.
#[inline]
pub fn rounded(x: f32, ones: u32) -> f32 {
    f32::from_bits(x.to_bits() & ones)
}

/// |x| by clearing the sign bit.
#[inline]
pub fn abs(x: f32) -> f32 {
    f32::from_bits(x.to_bits() & 0x7fff_ffff)
}

/// Largest integer-valued float <= x (identical on both targets; no `as` overflow).
#[inline]
pub fn floor(x: f32) -> f32 {
    if is_nan(x) || abs(x) >= 8_388_608.0 {
        // |x| >= 2^23 is already an integer (or NaN/inf).
        return x;
    }
    let t = (x as i32) as f32;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

/// Nearest integer to x, halves away from zero, for |x| < 2^31.
#[inline]
fn round_to_i32(x: f32) -> i32 {
    if x >= 0.0 {
        (x + 0.5) as i32
    } else {
        (x - 0.5) as i32
    }
}

/// 2^n as f32 for n in [-126, 127].
#[inline]
fn pow2i(n: i32) -> f32 {
    f32::from_bits(((n + 127) as u32) << 23)
}

/// e^x with <= 1 ulp error (fdlibm's reduction x = n ln2 + r and rational approximation).
pub fn exp(x: f32) -> f32 {
    if is_nan(x) {
        return NAN;
    }
    if x > EXP_OVERFLOW {
        return f32::INFINITY;
    }
    if x < EXP_UNDERFLOW {
        return 0.0;
    }
    if abs(x) < f32::from_bits(0x3200_0000) {
        // |x| < 2^-27: e^x rounds to 1 + x.
        return 1.0 + x;
    }
    let n = round_to_i32(x * LOG2_E);
    let nf = n as f32;
    let hi = x - nf * LN2_HI;
    let lo = nf * LN2_LO;
    let r = hi - lo;
    let z = r * r;
    // c = r - r^2 (P1 + r^2 P2): e^r = 1 + 2r / (2 - c) in Remez form (fdlibm expf).
    let c = r - z * (1.666_662_5e-1 + z * -2.766_733_3e-3);
    let y = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi);
    // Scale in two exact steps so 2^n never overflows and subnormals round once.
    let n1 = n / 2;
    y * pow2i(n1) * pow2i(n - n1)
}

/// Natural logarithm with <= 1 ulp error (musl/fdlibm logf's reduction to [sqrt(2)/2, sqrt(2))).
pub fn ln(x: f32) -> f32 {
    if is_nan(x) || x < 0.0 {
        return NAN;
    }
    if x == 0.0 {
        return f32::NEG_INFINITY;
    }
    if x == f32::INFINITY {
        return x;
    }
    let mut ix = x.to_bits();
    let mut k: i32 = 0;
    if ix < 0x0080_0000 {
        // Subnormal: scale by 2^25 to normalise.
        k -= 25;
        ix = (x * 33_554_432.0).to_bits();
    }
    // Put the mantissa m in [sqrt(2)/2, sqrt(2)) and adjust the exponent k accordingly.
    ix += 0x3f80_0000 - 0x3f35_04f3;
    k += (ix >> 23) as i32 - 0x7f;
    ix = (ix & 0x007f_ffff) + 0x3f35_04f3;
    let f = f32::from_bits(ix) - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    let w = z * z;
    let t1 = w * (LG[1] + w * LG[3]);
    let t2 = z * (LG[0] + w * LG[2]);
    let r = t2 + t1;
    let hfsq = 0.5 * f * f;
    let dk = k as f32;
    s * (hfsq + r) + dk * LOG_LN2_LO - hfsq + f + dk * LOG_LN2_HI
}

/// sin on [-pi/4, pi/4] (Taylor through r^9; truncation < 2^-31 relative).
#[inline]
fn sin_kernel(r: f32) -> f32 {
    let z = r * r;
    let p = -1.666_666_7e-1 + z * (8.333_333e-3 + z * (-1.984_127e-4 + z * 2.755_731_9e-6));
    r + (r * z) * p
}

/// cos on [-pi/4, pi/4] (Taylor through r^10).
#[inline]
fn cos_kernel(r: f32) -> f32 {
    let z = r * r;
    let p = 4.166_666_8e-2 + z * (-1.388_888_9e-3 + z * (2.480_158_7e-5 + z * -2.755_732e-7));
    // Not fdlibm's compensated `w + ((1 - w) - hz)`: Mesa's NIR folds `1 - (1 - hz)` to `hz` in
    // shaders without NoContraction (which rust-gpu cannot emit), so the two targets would differ.
    1.0 - (0.5 * z - (z * z) * p)
}

/// Reduces x to r in about [-pi/4, pi/4] and the quadrant k mod 4 (Cody-Waite, five parts).
#[inline]
fn reduce_pio2(x: f32) -> (f32, u32) {
    let kf = floor(x * TWO_OVER_PI + 0.5);
    let r = (((x - kf * PIO2[0]) - kf * PIO2[1]) - kf * PIO2[2]) - kf * PIO2[3];
    let r = r - kf * PIO2[4];
    // kf mod 4 without an integer conversion that could overflow for huge x.
    let q = kf - 4.0 * floor(kf * 0.25);
    (r, q as u32 & 3)
}

/// (sin x, cos x), <= 2 ulp for |x| <= TRIG_ACCURATE_RANGE; beyond it finite, in [-1, 1], but
/// inaccurate (estimators never get there: exp(-X̄) underflows first). NaN/inf give NaN.
pub fn sin_cos(x: f32) -> (f32, f32) {
    if !is_finite(x) {
        return (NAN, NAN);
    }
    if abs(x) < 2.441_406_3e-4 {
        // 2^-12: sin x = x and cos x = 1 - x^2/2 to within rounding.
        return (x, 1.0 - 0.5 * x * x);
    }
    let (r, q) = reduce_pio2(x);
    let s = sin_kernel(r);
    let c = cos_kernel(r);
    let (sn, cs) = match q {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    };
    (clamp_unit(sn), clamp_unit(cs))
}

/// sin x; see [`sin_cos`].
pub fn sin(x: f32) -> f32 {
    sin_cos(x).0
}

/// cos x; see [`sin_cos`].
pub fn cos(x: f32) -> f32 {
    sin_cos(x).1
}

/// Clamps to [-1, 1] (NaN to 0; hence no `f32::clamp`); only active for inaccurate reductions of huge arguments, where
/// `k * pi/2` itself can overflow.
#[inline]
#[allow(clippy::manual_clamp)]
fn clamp_unit(v: f32) -> f32 {
    if is_nan(v) {
        0.0
    } else if v > 1.0 {
        1.0
    } else if v < -1.0 {
        -1.0
    } else {
        v
    }
}

/// atan on [-tan(pi/8), tan(pi/8)]: odd Taylor series through x^21 (truncation < 2^-26).
#[inline]
fn atan_kernel(x: f32) -> f32 {
    let z = x * x;
    // atan x = x - x z q, q = 1/3 - z (1/5 - z (1/7 - ...)), Horner from the inside.
    let mut p = 1.0 / 21.0;
    p = 1.0 / 19.0 - z * p;
    p = 1.0 / 17.0 - z * p;
    p = 1.0 / 15.0 - z * p;
    p = 1.0 / 13.0 - z * p;
    p = 1.0 / 11.0 - z * p;
    p = 1.0 / 9.0 - z * p;
    p = 1.0 / 7.0 - z * p;
    p = 1.0 / 5.0 - z * p;
    p = 1.0 / 3.0 - z * p;
    x - (x * z) * p
}

/// atan(x), built from + - * / and sqrt (reductions atan(x) = pi/2 - atan(1/x) and the half
/// angle formula); NaN gives NaN.
pub fn atan(x: f32) -> f32 {
    if is_nan(x) {
        return NAN;
    }
    let a = abs(x);
    let (r, offset) = if a > 1.0 { (1.0 / a, 1) } else { (a, 0) };
    // Half-angle reduction atan r = 2 atan(r / (1 + sqrt(1 + r^2))) for r > tan(pi/8): doubling is
    // exact. (The textbook pi/4 + atan((r - 1)/(r + 1)) gave different bits on lavapipe: Mesa's
    // NIR reassociates the constant addition in shaders without NoContraction.)
    let mut v = if r > 0.414_213_57 {
        2.0 * atan_kernel(r / (1.0 + sqrt(1.0 + r * r)))
    } else {
        atan_kernel(r)
    };
    if offset == 1 {
        v = core::f32::consts::FRAC_PI_2 - v;
    }
    if x < 0.0 {
        -v
    } else {
        v
    }
}

/// atan2(y, x): the angle of (x, y) in (-pi, pi], from [`atan`] (quadrant by the signs; (0, 0)
/// gives 0, NaN gives NaN, two infinities the quadrant's diagonal).
pub fn atan2(y: f32, x: f32) -> f32 {
    if is_nan(x) || is_nan(y) {
        return NAN;
    }
    if abs(x) == f32::INFINITY && abs(y) == f32::INFINITY {
        // y / x would be NaN: the diagonal of the quadrant, as IEEE atan2.
        let a = if x > 0.0 {
            core::f32::consts::FRAC_PI_4
        } else {
            3.0 * core::f32::consts::FRAC_PI_4
        };
        return if y > 0.0 { a } else { -a };
    }
    if x == 0.0 {
        return if y > 0.0 {
            core::f32::consts::FRAC_PI_2
        } else if y < 0.0 {
            -core::f32::consts::FRAC_PI_2
        } else {
            0.0
        };
    }
    let a = atan(y / x);
    if x > 0.0 {
        a
    } else if y < 0.0 {
        a - core::f32::consts::PI
    } else {
        a + core::f32::consts::PI
    }
}

/// tan x = sin x / cos x with the deterministic sin_cos.
#[inline]
pub fn tan(x: f32) -> f32 {
    let (s, c) = sin_cos(x);
    s / c
}

/// 2^k as f32 for -126 <= k <= 127 (exact).
#[inline]
fn pow2(k: i32) -> f32 {
    f32::from_bits(((k + 127) as u32) << 23)
}

/// sqrt(x), correctly rounded (IEEE 754), from integer and + - * / arithmetic only, so it is the
/// same function on every target and builds without `core::f32::math` (stable Rust). For
/// x = m 2^(E - 23) with E even and m in [2^23, 2^25), sqrt(x) = sqrt(m 2^23) 2^(E/2 - 23); the
/// 24-bit root r = round(sqrt(N)), N = m 2^23 < 2^48, comes from an f32 Newton estimate made
/// exact by integer corrections (N > r^2 + r rounds up; ties cannot occur).
#[inline]
pub fn sqrt(x: f32) -> f32 {
    if !(x > 0.0) || x == f32::INFINITY {
        // NaN and negative: NaN; +-0: itself; +inf: itself.
        return if x == 0.0 || x == f32::INFINITY {
            x
        } else {
            f32::NAN
        };
    }
    // Subnormals: scale by 2^64 (exact), take the root, scale by 2^-32.
    let tiny = x < f32::MIN_POSITIVE;
    let v = if tiny { x * pow2(64) } else { x };
    let bits = v.to_bits();
    let mut e = ((bits >> 23) & 0xff) as i32 - 127;
    let mut m = ((bits & 0x7f_ffff) | 0x80_0000) as u64;
    if e & 1 != 0 {
        m <<= 1;
        e -= 1;
    }
    let n = m << 23;
    // f32 estimate of sqrt(a), a = m 2^-23 in [1, 4): the reciprocal root by the bit trick and
    // two Newton steps, then one Newton step of the root itself, all by multiplications (a
    // division costs several multiplications' latency, and these steps depend on each other).
    let a = (m as f32) * pow2(-23);
    let mut y = f32::from_bits(0x5f37_5a86 - (a.to_bits() >> 1));
    y *= 1.5 - 0.5 * a * y * y;
    y *= 1.5 - 0.5 * a * y * y;
    let s = a * y;
    let s = s + 0.5 * y * (a - s * s);
    let r0 = (s * pow2(23)) as u64;
    // The rounded root r = round(sqrt(n)), the least k with n <= k^2 + k (sqrt(n) < k + 1/2
    // exactly then), is within 1 of the estimate r0 for every m and parity of E (every pair is
    // checked by the test `sqrt_is_correctly_rounded_in_1_to_4`), so r is r0 - 1 plus the
    // number of k in {r0 - 1, r0} below it: two products independent of each other.
    let r = r0 - 1 + below_root(r0 - 1, n) + below_root(r0, n);
    let root = (r as f32) * pow2(e / 2 - 23);
    if tiny {
        root * pow2(-32)
    } else {
        root
    }
}

/// 1 if k is below the rounded square root of n (k^2 + k < n), else 0: [`sqrt`]'s correction.
#[inline]
fn below_root(k: u64, n: u64) -> u64 {
    (k * (k + 1) < n) as u64
}

/// (n / d, n % d) for 1 <= d < 2^31 and a quotient below 2^22 (a pixel id's row and column:
/// the command line allows at most 16384 rows), from an f32 estimate corrected once. The
/// estimate is within 1 of n / d there, so the result is exact; a SIMD device (lavapipe) runs
/// it on its vector lanes, where an integer division is a scalar loop over the lanes.
#[inline]
pub fn div_rem_small(n: u32, d: u32) -> (u32, u32) {
    let q0 = (n as f32 / d as f32) as u32;
    // n - q0 d lies in [-d, 2d): exact in wrapping arithmetic, read as i32.
    let r0 = n.wrapping_sub(q0.wrapping_mul(d)) as i32;
    let low = r0 < 0;
    let high = !low & (r0 as u32 >= d);
    let q = if low {
        q0.wrapping_sub(1)
    } else if high {
        q0 + 1
    } else {
        q0
    };
    let r = if low {
        (r0 + d as i32) as u32
    } else if high {
        r0 as u32 - d
    } else {
        r0 as u32
    };
    (q, r)
}
