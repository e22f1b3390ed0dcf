//! The embedded daylight sky (`--env sky`): Preetham, Shirley and Smits 1999, "A Practical
//! Analytic Model for Daylight" (Perez distribution of luminance and chromaticity for a
//! turbidity and a sun position), rendered into an equirectangular map on the host, with a grey
//! ground below the horizon lit by the sky and the sun.

use super::env::EnvMap;

/// Atmospheric turbidity of the embedded sky (2: very clear, 3: clear, 6: hazy).
pub const TURBIDITY: f64 = 3.0;
/// Texels of the generated map.
pub const WIDTH: u32 = 512;
pub const HEIGHT: u32 = 256;
/// Albedo of the ground below the horizon.
pub const GROUND_ALBEDO: f64 = 0.3;
/// Luminance units: the zenith's luminance (Preetham's kcd/m^2) maps to this radiance.
pub const ZENITH_RADIANCE: f64 = 1.0;

/// Perez et al.'s five coefficients A..E of one quantity at turbidity t.
type Perez = [f64; 5];

/// The coefficients of Y, x and y (Preetham et al. 1999, Appendix A.2).
fn coefficients(t: f64) -> [Perez; 3] {
    [
        [
            0.1787 * t - 1.4630,
            -0.3554 * t + 0.4275,
            -0.0227 * t + 5.3251,
            0.1206 * t - 2.5771,
            -0.0670 * t + 0.3703,
        ],
        [
            -0.0193 * t - 0.2592,
            -0.0665 * t + 0.0008,
            -0.0004 * t + 0.2125,
            -0.0641 * t - 0.8989,
            -0.0033 * t + 0.0452,
        ],
        [
            -0.0167 * t - 0.2608,
            -0.0950 * t + 0.0092,
            -0.0079 * t + 0.2102,
            -0.0441 * t - 1.6537,
            -0.0109 * t + 0.0529,
        ],
    ]
}

/// F(theta, gamma) = (1 + A e^(B / cos theta)) (1 + C e^(D gamma) + E cos^2 gamma).
fn perez(c: &Perez, theta: f64, gamma: f64) -> f64 {
    let cos_t = theta.cos().max(1e-3);
    (1.0 + c[0] * (c[1] / cos_t).exp())
        * (1.0 + c[2] * (c[3] * gamma).exp() + c[4] * gamma.cos().powi(2))
}

/// Zenith luminance (kcd/m^2) and chromaticity (x, y) for turbidity t and sun zenith angle ts.
fn zenith(t: f64, ts: f64) -> [f64; 3] {
    let chi = (4.0 / 9.0 - t / 120.0) * (std::f64::consts::PI - 2.0 * ts);
    let y_lum = (4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192;
    let (t2, s, s2, s3) = (t * t, ts, ts * ts, ts * ts * ts);
    let x = t2 * (0.00166 * s3 - 0.00375 * s2 + 0.00209 * s)
        + t * (-0.02903 * s3 + 0.06377 * s2 - 0.03202 * s + 0.00394)
        + (0.11693 * s3 - 0.21196 * s2 + 0.06052 * s + 0.25886);
    let y = t2 * (0.00275 * s3 - 0.00610 * s2 + 0.00317 * s)
        + t * (-0.04214 * s3 + 0.08970 * s2 - 0.04153 * s + 0.00516)
        + (0.15346 * s3 - 0.26756 * s2 + 0.06670 * s + 0.26688);
    [y_lum, x, y]
}

/// Linear Rec. 709 RGB of luminance Y and chromaticity (x, y), negatives clipped.
fn xy_to_rgb(y_lum: f64, x: f64, y: f64) -> [f64; 3] {
    let big_x = x / y * y_lum;
    let big_z = (1.0 - x - y) / y * y_lum;
    [
        3.2406 * big_x - 1.5372 * y_lum - 0.4986 * big_z,
        -0.9689 * big_x + 1.8758 * y_lum + 0.0415 * big_z,
        0.0557 * big_x - 0.2040 * y_lum + 1.0570 * big_z,
    ]
    .map(|v| v.max(0.0))
}

/// The direction of texel centre (i, j) of a w x h equirectangular map (theta from +y).
pub fn texel_dir(i: u32, j: u32, w: u32, h: u32) -> [f64; 3] {
    let theta = std::f64::consts::PI * (j as f64 + 0.5) / h as f64;
    let phi = 2.0 * std::f64::consts::PI * (i as f64 + 0.5) / w as f64;
    [
        theta.sin() * phi.cos(),
        theta.cos(),
        theta.sin() * phi.sin(),
    ]
}

/// Ratio of the sun's irradiance (perpendicular to it) to the sky's horizontal irradiance when
/// `--sun` gives no intensity (a clear day: about 80 klx direct, 20 klx diffuse).
pub const SUN_TO_SKY: f64 = 4.0;

/// The sky for unit sun direction `sun` (y up; a sun below the horizon is treated as 89 degrees
/// from the zenith), and the ground below the horizon lit by it and by the sun's irradiance
/// `sun_irradiance` (luminance, perpendicular to the sun; None: [`SUN_TO_SKY`] x the sky's).
/// Returns the map and the sun irradiance used.
pub fn preetham(sun: [f64; 3], sun_irradiance: Option<f64>) -> (EnvMap, f64) {
    let ts = sun[1].clamp(-1.0, 1.0).acos().min(89.0f64.to_radians());
    let coef = coefficients(TURBIDITY);
    let z = zenith(TURBIDITY, ts);
    let (w, h) = (WIDTH, HEIGHT);
    let mut texels = vec![[0.0f32; 3]; (w * h) as usize];
    let mut sky_irradiance = 0.0f64;
    for j in 0..h / 2 {
        for i in 0..w {
            let d = texel_dir(i, j, w, h);
            let theta = d[1].clamp(-1.0, 1.0).acos();
            let gamma = (d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2])
                .clamp(-1.0, 1.0)
                .acos();
            let q = |k: usize| z[k] * perez(&coef[k], theta, gamma) / perez(&coef[k], 0.0, ts);
            let y_lum = q(0) / z[0] * ZENITH_RADIANCE;
            let rgb = xy_to_rgb(y_lum, q(1), q(2));
            texels[(j * w + i) as usize] = rgb.map(|v| v as f32);
            // Horizontal irradiance: Y cos(theta) dOmega, dOmega = sin(theta) dtheta dphi.
            let d_omega = theta.sin()
                * (std::f64::consts::PI / h as f64)
                * (2.0 * std::f64::consts::PI / w as f64);
            sky_irradiance += y_lum * theta.cos().max(0.0) * d_omega;
        }
    }
    let sun_irradiance = sun_irradiance.unwrap_or(SUN_TO_SKY * sky_irradiance);
    let ground =
        GROUND_ALBEDO * (sky_irradiance + sun_irradiance * sun[1].max(0.0)) / std::f64::consts::PI;
    for t in texels[((h / 2) * w) as usize..].iter_mut() {
        *t = [ground as f32; 3];
    }
    let map = EnvMap {
        width: w,
        height: h,
        texels,
    };
    (map, sun_irradiance)
}
