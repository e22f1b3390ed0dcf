//! Transmittance from two optical depth estimates X0, X1 (paper Sec. 3.3).

use crate::math;

/// Sample mean X̄ = (X0 + X1) / 2 (Eq. 4).
#[inline]
pub fn x_bar(x0: f32, x1: f32) -> f32 {
    0.5 * (x0 + x1)
}

/// Biased sample standard deviation S = |X0 - X1| / 2 (Eq. 4).
#[inline]
pub fn s(x0: f32, x1: f32) -> f32 {
    0.5 * math::abs(x0 - x1)
}

/// Jackknife transmittance K = cos(S) exp(-X̄) (Eq. 4); not clamped (clamping adds bias).
#[inline]
pub fn jackknife(x0: f32, x1: f32) -> f32 {
    let e = math::exp(-x_bar(x0, x1));
    if e == 0.0 {
        // exp(-X̄) underflowed: K = 0 exactly, whatever cos(S) of a huge S would say.
        return 0.0;
    }
    math::cos(s(x0, x1)) * e
}

/// Largest S (Eq. 4) of the regime where the jackknife's analysis holds: [`outside_regime`].
pub const S_REGIME: f32 = 1.0;

/// True when a pair of optical depth estimates lies outside the regime where the jackknife
/// holds (Sec. 3.3, 6.3): S > [`S_REGIME`], i.e. an optical-depth standard deviation of about
/// sqrt(2) S > 1.4, where K's relative standard deviation sqrt((e^(sigma^2) - 1) / 2) exceeds 1.9
/// and the estimates are far from normal (cos(S) changes sign at S = pi / 2).
#[inline]
pub fn outside_regime(x0: f32, x1: f32) -> bool {
    !(s(x0, x1) <= S_REGIME)
}

/// Naive transmittance exp(-X̄), biased upwards by Jensen's inequality (Sec. 1).
#[inline]
pub fn naive(x0: f32, x1: f32) -> f32 {
    math::exp(-x_bar(x0, x1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_estimates_give_exp() {
        for x in [0.0f32, 0.1, 1.0, 3.5, 20.0] {
            assert_eq!(jackknife(x, x), math::exp(-x));
            assert_eq!(naive(x, x), math::exp(-x));
        }
    }

    #[test]
    fn stays_in_unit_interval_for_nonnegative_depths() {
        for i in 0..200 {
            for j in 0..200 {
                let (x0, x1) = (i as f32 * 0.37, j as f32 * 0.91);
                let k = jackknife(x0, x1);
                assert!((-1.0..=1.0).contains(&k), "K({x0}, {x1}) = {k}");
            }
        }
    }

    #[test]
    fn matches_f64_formula() {
        let (x0, x1) = (0.8f32, 2.1f32);
        let reference =
            ((x0 as f64 - x1 as f64).abs() / 2.0).cos() * (-(x0 as f64 + x1 as f64) / 2.0).exp();
        assert!((jackknife(x0, x1) as f64 - reference).abs() < 1e-7);
    }

    #[test]
    fn huge_depths_give_zero_not_nan() {
        assert_eq!(jackknife(3.0e38, 0.0), 0.0);
        assert_eq!(jackknife(f32::MAX, f32::MAX), 0.0);
        assert_eq!(naive(f32::MAX, f32::MAX), 0.0);
    }
}
