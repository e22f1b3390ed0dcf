//! Phase functions.

/// Henyey-Greenstein phase function value for cos(theta) between directions (g = 0: isotropic).
#[inline]
pub fn phase_hg(cos_theta: f32, g: f32) -> f32 {
    let inv_4pi = 1.0 / (4.0 * core::f32::consts::PI);
    let denom = 1.0 + g * g + 2.0 * g * cos_theta;
    let d = denom * crate::math::sqrt(denom);
    if !(d > 0.0) {
        return inv_4pi;
    }
    inv_4pi * (1.0 - g * g) / d
}

/// A direction wi drawn with density phase_hg(wo . wi, g) around wo (pbrt-v4's
/// `SampleHenyeyGreenstein`: wo points away from the scattering point, toward the viewer);
/// returns (wi, its density).
#[inline]
pub fn sample_hg(wo: crate::geometry::V3, g: f32, u0: f32, u1: f32) -> (crate::geometry::V3, f32) {
    let cos_theta = if crate::math::abs(g) < 1e-3 {
        1.0 - 2.0 * u0
    } else {
        let q = (1.0 - g * g) / (1.0 + g - 2.0 * g * u0);
        -1.0 / (2.0 * g) * (1.0 + g * g - q * q)
    };
    // Not f32::clamp: NaN must not reach an assertion in a shader.
    #[allow(clippy::manual_clamp)]
    let cos_theta = if cos_theta > 1.0 {
        1.0
    } else if cos_theta < -1.0 {
        -1.0
    } else {
        cos_theta
    };
    let s2 = 1.0 - cos_theta * cos_theta;
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
