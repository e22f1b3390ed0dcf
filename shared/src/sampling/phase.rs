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
