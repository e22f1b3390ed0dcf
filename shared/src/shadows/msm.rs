//! Moment shadow maps for translucent occluders (Peters, Münstermann, Wetzstein, Klein 2017):
//! the four power moments b = E_Z[(1, z, z^2, z^3, z^4)] of the absorption depth distribution Z
//! along a light ray, and the reconstruction of the shadow intensity Z(z < z_f) at a fragment
//! depth z_f by Algorithm 1 (the sharpest lower bound over all depth distributions with these
//! moments; the upper bound adds the weight of the atom at z_f).
//!
//! Depths are signed, in [-1, 1] from the light's near to its far plane (Sec. "Signed Depth").
//! For a volume, Z holds the fraction of light absorbed at each depth, and the light left at the
//! far plane is an atom at z = 1, so b_0 = 1 (as the paper's opaque far surface); the shadow map's
//! transmittance at depth z_f is T = 1 - Z(z < z_f). Everything is f32, + - * / and our sqrt.

use crate::math::{self, sqrt};

/// Moments of a depth distribution: b_0 .. b_4.
pub type Moments4 = [f32; 5];

/// Moment bias alpha_b for moments stored as f32 (Sec. "Biasing for the Worst Case").
pub const ALPHA_F32: f32 = 3.0e-7;
/// Moment bias alpha_b after the 16-bit quantization transform.
pub const ALPHA_U16: f32 = 6.0e-5;
/// The worst-case-optimal biasing target b* without the quantization transform.
pub const TARGET_F32: Moments4 = [1.0, 0.0, 0.375, 0.0, 0.375];
/// The biasing target b* with the quantization transform.
pub const TARGET_U16: Moments4 = [1.0, 0.0, 0.628, 0.0, 0.628];

/// b + w b(z): adds an atom of weight w at depth z (one absorption event of a light ray).
#[inline]
pub fn add_atom(b: Moments4, z: f32, w: f32) -> Moments4 {
    let z2 = z * z;
    [
        b[0] + w,
        b[1] + w * z,
        b[2] + w * z2,
        b[3] + w * (z2 * z),
        b[4] + w * (z2 * z2),
    ]
}

/// b' = (1 - alpha) b + alpha b* (Sec. "Biasing for the Worst Case").
#[inline]
pub fn bias(b: Moments4, alpha: f32, target: Moments4) -> Moments4 {
    let k = 1.0 - alpha;
    [
        k * b[0] + alpha * target[0],
        k * b[1] + alpha * target[1],
        k * b[2] + alpha * target[2],
        k * b[3] + alpha * target[3],
        k * b[4] + alpha * target[4],
    ]
}

/// Lower and upper bound of Z(z < z_f) from biased moments b (b_0 = 1), Algorithm 1 for m = 4:
/// solve B(b) q = (1, z_f, z_f^2) (B the 3x3 Hankel matrix, by LDL^T), take the roots z_1, z_2
/// of q_0 + q_1 z + q_2 z^2, the weights w of the atoms (z_f, z_1, z_2) from their Vandermonde
/// system, and sum the weights of the roots below z_f; the upper bound adds w_0. Both are
/// clamped to [0, 1]. Where the 3x3 matrix is numerically singular (moments on the boundary of
/// the moment space, which the bias keeps rare), it tries once more with [`RETRY_ALPHA`], then
/// uses the bounds of the first two moments ([`shadow_bounds2`], weaker but valid).
pub fn shadow_bounds(b: Moments4, zf: f32) -> (f32, f32) {
    let (lower, upper, _) = shadow_bounds_flagged(b, zf);
    (lower, upper)
}

/// [`shadow_bounds`] and whether it fell back (1: the retry with [`RETRY_ALPHA`] or the
/// two-moment bounds gave the result; renders count such lookups).
pub fn shadow_bounds_flagged(b: Moments4, zf: f32) -> (f32, f32, u32) {
    match hamburger4(b, zf) {
        Some((lower, upper)) => (lower, upper, 0),
        // Numerically singular: once more with a stronger bias, then the two-moment bounds.
        None => match hamburger4(bias(b, RETRY_ALPHA, TARGET_F32), zf) {
            Some((lower, upper)) => (lower, upper, 1),
            None => {
                let (lower, upper) = shadow_bounds2(b, zf);
                (lower, upper, 1)
            }
        },
    }
}

/// The bias of [`shadow_bounds`]'s second attempt when f32 rounding left the moments on the
/// boundary of the moment space (two-atom distributions biased by [`ALPHA_F32`] only).
pub const RETRY_ALPHA: f32 = 1.0e-5;

/// Algorithm 1 for m = 4 (see [`shadow_bounds`]); None where B(b) is not numerically positive
/// definite.
fn hamburger4(b: Moments4, zf: f32) -> Option<(f32, f32)> {
    // LDL^T of B = [[b0, b1, b2], [b1, b2, b3], [b2, b3, b4]].
    let d0 = b[0];
    if !(d0 > 0.0) {
        return None;
    }
    let l10 = b[1] / d0;
    let l20 = b[2] / d0;
    let d1 = b[2] - l10 * b[1];
    if !(d1 > 0.0) {
        return None;
    }
    let l21 = (b[3] - l20 * b[1]) / d1;
    let d2 = b[4] - l20 * b[2] - l21 * l21 * d1;
    if !(d2 > 0.0) {
        return None;
    }
    // Forward substitution L y = c, then D, then back substitution L^T q = D^-1 y.
    let c0 = 1.0;
    let c1 = zf - l10 * c0;
    let c2 = zf * zf - l20 * c0 - l21 * c1;
    let q2 = c2 / d2;
    let q1 = c1 / d1 - l21 * q2;
    let q0 = c0 / d0 - l10 * q1 - l20 * q2;
    // Roots of q2 z^2 + q1 z + q0 (q2 > 0: c2 > 0 for zf off the support's moment curve).
    if !(q2 != 0.0) {
        return None;
    }
    let p = q1 / q2;
    let q = q0 / q2;
    let disc = 0.25 * p * p - q;
    let r = sqrt(if disc > 0.0 { disc } else { 0.0 });
    let z1 = -0.5 * p - r;
    let z2 = -0.5 * p + r;
    let w0 = atom_weight(&b, zf, z1, z2);
    let w1 = atom_weight(&b, z1, zf, z2);
    let w2 = atom_weight(&b, z2, zf, z1);
    let mut lower = 0.0f32;
    if z1 < zf {
        lower += w1;
    }
    if z2 < zf {
        lower += w2;
    }
    let upper = lower + w0;
    Some((clamp01(lower), clamp01(upper)))
}

/// Lower and upper bound of Z(z < z_f) from b_0, b_1, b_2 alone (Algorithm 1 for m = 2): the
/// two-atom distribution (z_f, z_1) with these moments, z_1 = (b_2 - z_f b_1) / (b_1 - z_f b_0).
pub fn shadow_bounds2(b: Moments4, zf: f32) -> (f32, f32) {
    let den = b[1] - zf * b[0];
    if !(b[0] > 0.0) || den == 0.0 {
        return (0.0, 1.0);
    }
    let z1 = (b[2] - zf * b[1]) / den;
    // w_1 (z_1 - z_f) = b_1 - z_f b_0.
    let gap = z1 - zf;
    if gap == 0.0 {
        return (0.0, 1.0);
    }
    let w1 = den / gap;
    let w0 = b[0] - w1;
    let lower = if z1 < zf { w1 } else { 0.0 };
    (clamp01(lower), clamp01(lower + w0))
}

/// An estimate of Z(z < z_f) between the bounds: lower + beta (upper - lower) (the paper's
/// weighted combination for single scattering; beta = 1/2 minimizes the worst-case error).
#[inline]
pub fn shadow_estimate(b: Moments4, zf: f32, beta: f32) -> f32 {
    let (lower, upper) = shadow_bounds(b, zf);
    lower + beta * (upper - lower)
}

/// The weight of atom z_l of the three-atom distribution (z_l, z_a, z_b) with the moments b_0,
/// b_1, b_2: E[(z - z_a)(z - z_b)] / ((z_l - z_a)(z_l - z_b)) (its Vandermonde system solved by
/// Lagrange); 0 where atoms coincide.
#[inline]
fn atom_weight(b: &Moments4, zl: f32, za: f32, zb: f32) -> f32 {
    let den = (zl - za) * (zl - zb);
    let num = b[2] - (za + zb) * b[1] + za * zb * b[0];
    if den != 0.0 {
        num / den
    } else {
        0.0
    }
}

/// Clamps to [0, 1] (NaN to 0).
#[inline]
#[allow(clippy::manual_clamp)]
fn clamp01(v: f32) -> f32 {
    if !(v > 0.0) {
        0.0
    } else if v > 1.0 {
        1.0
    } else {
        v
    }
}

/// sqrt(3) in f32.
const SQRT3: f32 = 1.732_050_8;
/// 1 / det of the transform's (b_1, b_3) block: 3 / (2 sqrt(3)).
const INV_DET: f32 = 3.0 / (2.0 * SQRT3);

/// The sparse quantization transform Theta_4^* (Eq. 3): moments b_1..b_4 of depths in [-1, 1] to
/// four values in about [0, 1] for 16-bit storage.
#[inline]
pub fn quantize_transform(b: Moments4) -> [f32; 4] {
    [
        1.5 * b[1] - 2.0 * b[3] + 0.5,
        4.0 * b[2] - 4.0 * b[4],
        (0.5 * SQRT3) * b[1] - (2.0 * SQRT3 / 9.0) * b[3] + 0.5,
        0.5 * b[2] + 0.5 * b[4],
    ]
}

/// The inverse of [`quantize_transform`] (b_0 = 1): b_1 and b_3 from the 2x2 block
/// [1.5, -2; sqrt3/2, -2 sqrt3/9] [b1; b3] = [u_0 - 1/2; u_2 - 1/2] (determinant 2 sqrt3 / 3),
/// multiplied out into input x constant + constant. Written as (u - 1/2) k, shader compilers
/// distribute the constant factor over the offset, which rounds differently from the CPU; in
/// this form there is nothing left to rewrite.
#[inline]
pub fn dequantize_transform(u: [f32; 4]) -> Moments4 {
    let b1 = u[0] * DQ_B1[0] + u[2] * DQ_B1[1] + DQ_B1[2];
    let b3 = u[0] * DQ_B3[0] + u[2] * DQ_B3[1] + DQ_B3[2];
    let b2 = u[3] + 0.125 * u[1];
    let b4 = u[3] - 0.125 * u[1];
    [1.0, b1, b2, b3, b4]
}

/// b_1 = u_0 c_0 + u_2 c_1 + c_2: the first row of the block's inverse (-2 sqrt3/9, 2) / det and
/// the offsets.
const DQ_B1: [f32; 3] = [
    -2.0 * SQRT3 / 9.0 * INV_DET,
    2.0 * INV_DET,
    (-0.5 * (-2.0 * SQRT3 / 9.0) - 0.5 * 2.0) * INV_DET,
];
/// b_3 = u_0 c_0 + u_2 c_1 + c_2: the second row (-sqrt3/2, 3/2) / det and the offsets.
const DQ_B3: [f32; 3] = [
    -0.5 * SQRT3 * INV_DET,
    1.5 * INV_DET,
    (0.5 * 0.5 * SQRT3 - 0.5 * 1.5) * INV_DET,
];

/// Moments b_1 .. b_4 of one texel's stored 16-bit integers `q` (as f32) of
/// [`quantize_transform`]'s outputs: the unorm scale and [`dequantize_transform`] in one affine
/// map, b = C q + c, with the coefficients `k` = [`U16_DEQUANT`] passed in at run time.
/// Written with constants, shader compilers re-associate scales of scales and distribute
/// constant factors over offsets, which rounds differently from the CPU; renders read the
/// coefficients from the map's descriptor instead, where no compiler can fold them.
#[inline]
pub fn dequantize_u16(q: [f32; 4], k: &[f32; 12]) -> [f32; 4] {
    [
        q[2] * k[1] + (q[0] * k[0] + k[2]),
        q[3] * k[3] + q[1] * k[4],
        q[2] * k[6] + (q[0] * k[5] + k[7]),
        q[3] * k[8] + q[1] * k[9],
    ]
}

/// 1 / 65535, the unorm16 scale.
const UNORM16: f32 = 1.0 / 65535.0;
/// The coefficients of [`dequantize_u16`]: b_1 = q_0 k_0 + q_2 k_1 + k_2, b_2 = q_3 k_3 + q_1
/// k_4, b_3 = q_0 k_5 + q_2 k_6 + k_7, b_4 = q_3 k_8 + q_1 k_9 (k_10, k_11 unused).
pub const U16_DEQUANT: [f32; 12] = [
    DQ_B1[0] * UNORM16,
    DQ_B1[1] * UNORM16,
    DQ_B1[2],
    UNORM16,
    0.125 * UNORM16,
    DQ_B3[0] * UNORM16,
    DQ_B3[1] * UNORM16,
    DQ_B3[2],
    UNORM16,
    -0.125 * UNORM16,
    0.0,
    0.0,
];

/// The four 16-bit unorm integers a texel of moments `b` stores: [`to_unorm16`] of
/// [`quantize_transform`], with every inexact product rounded on its own ([`math::rounded`],
/// `ones` = `u32::MAX` from the map's descriptor). lavapipe fused b_1 sqrt3/2 into the sum
/// after it (one rounding instead of two) and stored 20 of 131,072 words one unit off the CPU.
#[inline]
pub fn quantize_u16(b: Moments4, ones: u32) -> [u32; 4] {
    let r = |x: f32| math::rounded(x, ones);
    let u = [
        r(1.5 * b[1]) - 2.0 * b[3] + 0.5,
        4.0 * b[2] - 4.0 * b[4],
        r((0.5 * SQRT3) * b[1]) - r((2.0 * SQRT3 / 9.0) * b[3]) + 0.5,
        0.5 * b[2] + 0.5 * b[4],
    ];
    let unorm = |x: f32| (r(clamp01(x) * 65535.0) + 0.5) as u32;
    [unorm(u[0]), unorm(u[1]), unorm(u[2]), unorm(u[3])]
}

/// x in [0, 1] as a 16-bit unsigned normalized integer (rounded to nearest, clamped).
#[inline]
pub fn to_unorm16(x: f32) -> u32 {
    let v = clamp01(x) * 65535.0 + 0.5;
    v as u32
}

/// A 16-bit unsigned normalized integer as f32.
#[inline]
pub fn from_unorm16(v: u32) -> f32 {
    v as f32 * (1.0 / 65535.0)
}

/// Moments of a depth distribution: b_0 .. b_6.
pub type Moments6 = [f32; 7];

/// The biasing target of six moments: the moments of the uniform distribution on [-1, 1] (an
/// interior point of the moment space; our choice, the paper gives no six-moment target).
pub const TARGET6: Moments6 = [1.0, 0.0, 1.0 / 3.0, 0.0, 0.2, 0.0, 1.0 / 7.0];
/// Moment bias of six f32 moments (measured in `tests/tests/msm.rs`: 1e-6 keeps three-atom
/// distributions within 1.1e-3 and random ones within their bounds; 1e-5 gave errors of 9e-3
/// and one bound violation of 0.016 in 20500 cases, 1e-4 errors of 0.07).
pub const ALPHA6_F32: f32 = 1.0e-6;

/// b + w b(z) for six moments.
#[inline]
pub fn add_atom6(b: Moments6, z: f32, w: f32) -> Moments6 {
    let z2 = z * z;
    let z3 = z2 * z;
    [
        b[0] + w,
        b[1] + w * z,
        b[2] + w * z2,
        b[3] + w * z3,
        b[4] + w * (z2 * z2),
        b[5] + w * (z2 * z3),
        b[6] + w * (z3 * z3),
    ]
}

/// b' = (1 - alpha) b + alpha b* for six moments.
#[inline]
pub fn bias6(b: Moments6, alpha: f32, target: Moments6) -> Moments6 {
    let k = 1.0 - alpha;
    let mut out = [0.0f32; 7];
    let mut j = 0;
    while j < 7 {
        out[j] = k * b[j] + alpha * target[j];
        j += 1;
    }
    out
}

/// Lower and upper bound of Z(z < z_f) from six biased moments (Algorithm 1 for m = 6: the 4x4
/// Hankel system by LDL^T, the three real roots of the cubic by the trigonometric method, the
/// weights of the four atoms by Lagrange). Where it fails numerically: once more with a stronger
/// bias, then the four-moment bounds of b_0 .. b_4.
pub fn shadow_bounds6(b: Moments6, zf: f32) -> (f32, f32) {
    let (lower, upper, _) = shadow_bounds6_flagged(b, zf);
    (lower, upper)
}

/// [`shadow_bounds6`] and whether it fell back (1: the stronger bias or the four-moment
/// bounds gave the result).
pub fn shadow_bounds6_flagged(b: Moments6, zf: f32) -> (f32, f32, u32) {
    match hausdorff6(b, zf) {
        Some((lower, upper)) => (lower, upper, 0),
        None => match hausdorff6(bias6(b, 10.0 * ALPHA6_F32, TARGET6), zf) {
            Some((lower, upper)) => (lower, upper, 1),
            None => {
                let (lower, upper, _) = shadow_bounds_flagged([b[0], b[1], b[2], b[3], b[4]], zf);
                (lower, upper, 1)
            }
        },
    }
}

/// Algorithm 1 for m = 6 (see [`shadow_bounds6`]); None where it fails numerically.
fn hausdorff6(b: Moments6, zf: f32) -> Option<(f32, f32)> {
    // LDL^T of B = (b_{i+j}), 4x4, column by column.
    let mut l = [[0.0f32; 4]; 4];
    let mut d = [0.0f32; 4];
    let mut j = 0;
    while j < 4 {
        let mut dj = b[2 * j];
        let mut k = 0;
        while k < j {
            dj -= l[j][k] * l[j][k] * d[k];
            k += 1;
        }
        if !(dj > 0.0) {
            return None;
        }
        d[j] = dj;
        let mut i = j + 1;
        while i < 4 {
            let mut s = b[i + j];
            let mut k = 0;
            while k < j {
                s -= l[i][k] * l[j][k] * d[k];
                k += 1;
            }
            l[i][j] = s / dj;
            i += 1;
        }
        l[j][j] = 1.0;
        j += 1;
    }
    // L y = (1, zf, zf^2, zf^3); D; L^T q = D^-1 y.
    let rhs = [1.0, zf, zf * zf, zf * zf * zf];
    let mut y = [0.0f32; 4];
    let mut i = 0;
    while i < 4 {
        let mut s = rhs[i];
        let mut k = 0;
        while k < i {
            s -= l[i][k] * y[k];
            k += 1;
        }
        y[i] = s;
        i += 1;
    }
    let mut q = [0.0f32; 4];
    let mut i = 4;
    while i > 0 {
        i -= 1;
        let mut s = y[i] / d[i];
        let mut k = i + 1;
        while k < 4 {
            s -= l[k][i] * q[k];
            k += 1;
        }
        q[i] = s;
    }
    let roots = cubic_roots(q[3], q[2], q[1], q[0])?;
    let z = [zf, roots[0], roots[1], roots[2]];
    let mut w = [0.0f32; 4];
    let mut m = 0;
    while m < 4 {
        // The other three nodes.
        let (a, c, e) = match m {
            0 => (z[1], z[2], z[3]),
            1 => (z[0], z[2], z[3]),
            2 => (z[0], z[1], z[3]),
            _ => (z[0], z[1], z[2]),
        };
        let den = (z[m] - a) * (z[m] - c) * (z[m] - e);
        let num = cubic_moment(&b, a, c, e);
        if den == 0.0 {
            return None;
        }
        w[m] = num / den;
        m += 1;
    }
    let mut lower = 0.0f32;
    let mut k = 1;
    while k < 4 {
        if z[k] < zf {
            lower += w[k];
        }
        k += 1;
    }
    let upper = lower + w[0];
    if !crate::math::is_finite(lower) || !crate::math::is_finite(upper) {
        return None;
    }
    Some((clamp01(lower), clamp01(upper)))
}

/// E[(z - a)(z - c)(z - e)] from the moments b_0 .. b_3, one factor at a time (moments of
/// (z - a) z^k, then of (z - a)(z - c) z^k): only two-term sums, which shader compilers leave in
/// order (they re-associate longer chains, which rounds differently from the CPU).
#[inline]
fn cubic_moment(b: &Moments6, a: f32, c: f32, e: f32) -> f32 {
    let y0 = b[1] - a * b[0];
    let y1 = b[2] - a * b[1];
    let y2 = b[3] - a * b[2];
    let z0 = y1 - c * y0;
    let z1 = y2 - c * y1;
    z1 - e * z0
}

/// The three real roots of c3 z^3 + c2 z^2 + c1 z + c0 by the trigonometric method (depressed
/// cubic t^3 + p t + q, t_0 = 2 sqrt(-p/3) cos(phi/3) and t_1,2 from cos(phi/3 -+ 2 pi/3) =
/// -cos(phi/3)/2 +- sqrt(3)/2 sin(phi/3)); None unless all three are real. Written with
/// two-term sums and one sine/cosine of phi/3, so that shader compilers round as the CPU does.
fn cubic_roots(c3: f32, c2: f32, c1: f32, c0: f32) -> Option<[f32; 3]> {
    if !(c3 != 0.0) {
        return None;
    }
    let (a, bb, c) = (c2 / c3, c1 / c3, c0 / c3);
    let p = bb - a * a * (1.0 / 3.0);
    // q = 2 a^3 / 27 - a bb / 3 + c, nested.
    let q = a * (a * a * (2.0 / 27.0) - bb * (1.0 / 3.0)) + c;
    if !(p < 0.0) {
        return None;
    }
    let r = sqrt(-p * (1.0 / 3.0));
    // cos(phi) = (3 q / (2 p)) sqrt(-3 / p) = -q / (2 r^3).
    let cos_phi = -q / (2.0 * r * r * r);
    // Plain comparisons (NaN fails both), as everywhere in shader code.
    #[allow(clippy::manual_range_contains)]
    let real = cos_phi >= -1.0 && cos_phi <= 1.0;
    if !real {
        return None;
    }
    let sin_phi = sqrt(1.0 - cos_phi * cos_phi);
    let phi = crate::math::atan2(sin_phi, cos_phi);
    let (s3, c3) = crate::math::sin_cos(phi * (1.0 / 3.0));
    let shift = -a * (1.0 / 3.0);
    let half_sqrt3_s = (0.5 * SQRT3) * s3;
    let half_c = 0.5 * c3;
    Some([
        shift + 2.0 * r * c3,
        shift + 2.0 * r * (half_sqrt3_s - half_c),
        shift - 2.0 * r * (half_sqrt3_s + half_c),
    ])
}
