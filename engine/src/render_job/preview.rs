//! How a render's pixels look in its PNG preview, in `host view`'s window and in `host eval`'s
//! images (which `host report` shows): one view transform for all of them, so the window shows
//! what the PNG holds. The EXR stays linear.
//!
//! Radiance (every integrator) is scaled by a gain, `--exposure` times the image's automatic
//! exposure (its log-average luminance to middle grey, Reinhard et al. 2002, "Photographic tone
//! reproduction", Eq. 1-2; `--fixed-exposure` leaves it out), then mapped by a filmic curve
//! (Narkowicz 2015's fit of the ACES reference rendering transform, per channel: highlights
//! roll off to white instead of clipping) and sRGB-encoded. Transmittance images show T in
//! [0, 1] as it is.

use shared::kernels::render::PixelOut;
use shared::params::Integrator;

/// The scene value the automatic exposure maps the image's log-average luminance to.
pub const MIDDLE_GREY: f32 = 0.18;

/// Luminances below this fraction of the image's mean luminance count at it in the
/// log-average, so a few nearly black pixels (a medium's faint edge) cannot brighten the image.
const FLOOR_OF_MEAN: f64 = 1e-3;

/// The name of the view transform in the JSON summary and the docs.
pub const TRANSFORM: &str = "filmic";

/// The preview's view transform of a render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Preview {
    /// Transmittance: T in [0, 1], sRGB, grey.
    Transmittance,
    /// Single-scattering radiance (grey: the luminance channel) times the gain, filmic, sRGB.
    Grey(f32),
    /// RGB radiance (`direct`, `path`, `restir`) times the gain, filmic per channel, sRGB.
    Rgb(f32),
}

impl Preview {
    /// The preview of `pixels`, rendered with `integrator`: the gain is `exposure` times the
    /// automatic exposure of the image's luminance ([`auto_exposure`]), or `exposure` alone
    /// when `auto` is false.
    pub fn of(
        integrator: Option<Integrator>,
        exposure: f32,
        auto: bool,
        pixels: &[PixelOut],
    ) -> Self {
        let lit = integrator.is_some_and(Integrator::is_lit);
        let gain = |lum: &dyn Fn(&PixelOut) -> f32| {
            if auto {
                exposure * auto_exposure(pixels.iter().map(lum))
            } else {
                exposure
            }
        };
        match integrator {
            None => Preview::Transmittance,
            Some(_) if lit => Preview::Rgb(gain(&|p| {
                luminance(p.rgb_mean.r, p.rgb_mean.g, p.rgb_mean.b)
            })),
            Some(_) => Preview::Grey(gain(&|p| p.t_mean)),
        }
    }

    /// The gain applied to radiance (None for transmittance).
    pub fn gain(self) -> Option<f32> {
        match self {
            Preview::Transmittance => None,
            Preview::Grey(g) | Preview::Rgb(g) => Some(g),
        }
    }

    /// The linear display value in [0, 1] of a grey preview's pixel of value `t` (the RGB
    /// preview: of one channel of value `t`).
    pub fn grey(self, t: f32) -> f32 {
        match self {
            Preview::Transmittance => t,
            Preview::Grey(g) | Preview::Rgb(g) => filmic(t * g),
        }
    }

    /// The sRGB bytes of pixel `p`.
    pub fn rgb8(self, p: &PixelOut) -> [u8; 3] {
        match self {
            Preview::Rgb(_) => [p.rgb_mean.r, p.rgb_mean.g, p.rgb_mean.b].map(|v| self.rgb8_of(v)),
            grey => [crate::output::srgb8(grey.grey(p.t_mean)); 3],
        }
    }

    /// The sRGB bytes (RGB, row-major) of `pixels`' preview.
    pub fn rgb_bytes(self, pixels: &[PixelOut]) -> Vec<u8> {
        pixels.iter().flat_map(|p| self.rgb8(p)).collect()
    }

    /// The sRGB byte of one channel of linear value `v`.
    pub fn rgb8_of(self, v: f32) -> u8 {
        crate::output::srgb8(self.grey(v))
    }
}

/// Rec. 709 luminance of linear RGB.
pub fn luminance(r: f32, g: f32, b: f32) -> f32 {
    0.2126 * r + 0.7152 * g + 0.0722 * b
}

/// The automatic exposure gain of an image of luminances `lum`: [`MIDDLE_GREY`] over the
/// log-average (geometric mean, Reinhard et al. 2002, Eq. 1) of its positive luminances, each
/// at least [`FLOOR_OF_MEAN`] times their mean; 1 for an image with none (black, or not finite).
pub fn auto_exposure(lum: impl Iterator<Item = f32> + Clone) -> f32 {
    let positive = lum.filter(|l| l.is_finite() && *l > 0.0);
    let (mut n, mut sum) = (0u64, 0.0f64);
    for l in positive.clone() {
        n += 1;
        sum += f64::from(l);
    }
    if n == 0 {
        return 1.0;
    }
    let floor = FLOOR_OF_MEAN * sum / n as f64;
    let log_sum: f64 = positive.map(|l| f64::from(l).max(floor).ln()).sum();
    let log_average = (log_sum / n as f64).exp();
    let g = f64::from(MIDDLE_GREY) / log_average;
    if g.is_finite() && g > 0.0 {
        g as f32
    } else {
        1.0
    }
}

/// The filmic curve: Narkowicz 2015's fit of the ACES reference rendering transform,
/// x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14), in [0, 1] (NaN and negative values to 0).
pub fn filmic(x: f32) -> f32 {
    let x = if x > 0.0 { x } else { 0.0 };
    let y = x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14);
    if y < 1.0 {
        y
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filmic_is_monotone_from_black_to_white() {
        assert_eq!(filmic(0.0), 0.0);
        assert_eq!(filmic(f32::NAN), 0.0);
        assert_eq!(filmic(-3.0), 0.0);
        assert_eq!(filmic(1e9), 1.0);
        let mut last = 0.0;
        for k in 1..2000 {
            let y = filmic(k as f32 * 0.01);
            assert!(y >= last, "not monotone at {}", k as f32 * 0.01);
            last = y;
        }
        // Middle grey lands mid-way (sRGB about 0.56), and 1.0 well below white.
        let s = crate::output::srgb8(filmic(MIDDLE_GREY));
        assert!((130..=150).contains(&s), "{s}");
        assert!(filmic(1.0) < 0.85);
    }

    #[test]
    fn auto_exposure_maps_the_log_average_to_middle_grey() {
        // Log-average of 0.5 and 2 is 1; black and NaN pixels are left out.
        let g = auto_exposure([0.5f32, 2.0, 0.0, f32::NAN].into_iter());
        assert!((g - MIDDLE_GREY).abs() < 1e-6, "{g}");
        // A scale of the image scales the gain inversely.
        let g4 = auto_exposure([2.0f32, 8.0].into_iter());
        assert!((g4 * 4.0 - MIDDLE_GREY).abs() < 1e-6, "{g4}");
        // Nearly black pixels count at a floor, not at their own log.
        let mut v = vec![1.0f32; 100];
        v.push(1e-30);
        let g = auto_exposure(v.iter().copied());
        assert!(g < 0.2, "{g}");
        assert_eq!(auto_exposure([0.0f32, 0.0].into_iter()), 1.0);
        assert_eq!(auto_exposure(std::iter::empty()), 1.0);
    }
}
