//! Phase functions.

/// Henyey-Greenstein phase function value for cos(theta) between directions (g = 0: isotropic).
#[inline]
pub fn phase_hg(cos_theta: f32, g: f32) -> f32 {
    let inv_4pi = 1.0 / (4.0 * core::f32::consts::PI);
    let denom = hg_denominator(cos_theta, g);
    let d = denom * crate::math::sqrt(denom);
    if !(d > 0.0) {
        return inv_4pi;
    }
    ((1.0 - g) * (1.0 + g)) / d * inv_4pi
}

/// 1 + g^2 + 2 g cos(theta), written without cancellation in the lobe: (1 - g)^2 + 2 g (1 + cos)
/// for g >= 0 and (1 + g)^2 - 2 g (1 - cos) for g < 0 (1 +- cos are exact near the lobe).
#[inline]
fn hg_denominator(cos_theta: f32, g: f32) -> f32 {
    if g >= 0.0 {
        (1.0 - g) * (1.0 - g) + 2.0 * g * (1.0 + cos_theta)
    } else {
        (1.0 + g) * (1.0 + g) - 2.0 * g * (1.0 - cos_theta)
    }
}

/// A direction wi drawn with density phase_hg(wo . wi, g) around wo (pbrt-v4's
/// `SampleHenyeyGreenstein`: wo points away from the scattering point, toward the viewer, so
/// g > 0 draws wi near -wo); returns (wi, its density).
///
/// pbrt-v4's cos(theta) = -(1 + g^2 - q^2) / (2 g), q = (1 - g^2) / (1 + g - 2 g u0), is
/// computed as the distance from the lobe's pole instead, a = 1 + cos = (1 - g) u0 (q + 1 - g) /
/// (1 + g - 2 g u0) for g > 0 and a = 1 - cos = (1 + g) (1 - u0) (1 + g + q) / (1 + g - 2 g u0)
/// for g < 0 (the same function without cancellation), with sin(theta) = sqrt(a (2 - a)): in
/// f32, cos within 3e-8 of -+1 rounds to -+1, which put 6% of the samples of g = -0.999 at
/// wi == wo exactly.
#[inline]
pub fn sample_hg(wo: crate::geometry::V3, g: f32, u0: f32, u1: f32) -> (crate::geometry::V3, f32) {
    let (cos_theta, a) = if crate::math::abs(g) < 1e-3 {
        let c = 1.0 - 2.0 * u0;
        (c, 1.0 - c)
    } else {
        let d = 1.0 + g - 2.0 * g * u0;
        let q = (1.0 - g) * (1.0 + g) / d;
        if g > 0.0 {
            let a = clamp02((1.0 - g) * u0 * (q + 1.0 - g) / d);
            (a - 1.0, a)
        } else {
            let a = clamp02((1.0 + g) * (1.0 - u0) * (1.0 + g + q) / d);
            (1.0 - a, a)
        }
    };
    let s2 = a * (2.0 - a);
    let sin_theta = crate::math::sqrt(if s2 > 0.0 { s2 } else { 0.0 });
    let (t, b) = crate::geometry::frame_from_z(wo);
    let wi = crate::geometry::from_frame(
        t,
        b,
        wo,
        sin_theta,
        cos_theta,
        2.0 * core::f32::consts::PI * u1,
    );
    (wi, phase_hg(cos_theta, g))
}

/// x clamped to [0, 2] (NaN to 0).
#[inline]
fn clamp02(x: f32) -> f32 {
    if x > 2.0 {
        2.0
    } else if x > 0.0 {
        x
    } else {
        0.0
    }
}
