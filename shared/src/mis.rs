//! Jackknife function estimation Re g(X̄ + iS) (Sec. 5.1, Eq. 7) for the MIS weights of distance
//! sampling, g(tau) = (u0 e^-tau + u1) / (v0 e^-tau + v1) (Eq. 11, 12, App. F).

use crate::complex::Complex;
use crate::estimators::transmittance::{s, x_bar};
use crate::math;

/// Coefficients of g(tau) = (u0 e^-tau + u1) / (v0 e^-tau + v1) (Eq. 11).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Mobius {
    pub u0: f32,
    pub u1: f32,
    pub v0: f32,
    pub v1: f32,
}

impl Mobius {
    /// Free-flight MIS weight w1 = mu T / (mu T + p_eq): u0 = v0 = mu, u1 = 0, v1 = p_eq (Eq. 11).
    #[inline]
    pub fn free_flight_weight(mu: f32, p_other: f32) -> Self {
        Mobius {
            u0: mu,
            u1: 0.0,
            v0: mu,
            v1: p_other,
        }
    }

    /// The other strategy's weight 1 - w1 = p_eq / (mu T + p_eq): u0 = 0, u1 = p_eq (App. D).
    #[inline]
    pub fn other_weight(mu: f32, p_other: f32) -> Self {
        Mobius {
            u0: 0.0,
            u1: p_other,
            v0: mu,
            v1: p_other,
        }
    }

    /// g at a complex argument z = X̄ + iS: (u0 e^-z + u1) / (v0 e^-z + v1).
    #[inline]
    pub fn eval_complex(&self, z: Complex) -> Complex {
        let e = (-z).exp();
        let num = e.scale(self.u0) + Complex::real(self.u1);
        let den = e.scale(self.v0) + Complex::real(self.v1);
        num / den
    }

    /// g at a real tau (the exact weight when tau is known; the naive estimate g(X̄)).
    #[inline]
    pub fn eval(&self, tau: f32) -> f32 {
        let e = math::exp(-tau);
        let den = self.v0 * e + self.v1;
        if den == 0.0 {
            return 0.0;
        }
        (self.u0 * e + self.u1) / den
    }

    /// Jackknife estimate Re g(X̄ + iS) from two optical depth estimates (Eq. 12), in the real
    /// arithmetic of App. F: Re(U/V) = (Re U Re V + Im U Im V) / |V|^2. Where V vanishes (a pole
    /// hit exactly), falls back to the naive g(X̄) so the weight stays finite.
    #[inline]
    pub fn jackknife(&self, x0: f32, x1: f32) -> f32 {
        let xb = x_bar(x0, x1);
        let e = math::exp(-xb);
        if e == 0.0 {
            return self.eval(xb);
        }
        let (sn, cs) = math::sin_cos(s(x0, x1));
        let (re_z, im_z) = (cs * e, -sn * e);
        let (re_u, im_u) = (self.u0 * re_z + self.u1, self.u0 * im_z);
        let (re_v, im_v) = (self.v0 * re_z + self.v1, self.v0 * im_z);
        let d = re_v * re_v + im_v * im_v;
        let w = (re_u * re_v + im_u * im_v) / d;
        if d == 0.0 || !math::is_finite(w) {
            return self.eval(xb);
        }
        w
    }

    /// Naive estimate g(X̄) from two optical depth estimates.
    #[inline]
    pub fn naive(&self, x0: f32, x1: f32) -> f32 {
        self.eval(x_bar(x0, x1))
    }
}

/// Estimate of 1/tau from two estimates, (X0 + X1) / (X0^2 + X1^2) (Sec. 7); 0 when both are 0.
#[inline]
pub fn reciprocal(x0: f32, x1: f32) -> f32 {
    let d = x0 * x0 + x1 * x1;
    if d == 0.0 {
        0.0
    } else {
        (x0 + x1) / d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn app_f_equals_complex_evaluation() {
        let g = Mobius {
            u0: 1.0,
            u1: 0.0,
            v0: 1.0,
            v1: 0.5,
        };
        for &(x0, x1) in &[(0.3f32, 1.7f32), (2.0, 2.0), (0.0, 4.0), (5.0, 1.0)] {
            let z = Complex::new(x_bar(x0, x1), s(x0, x1));
            let want = g.eval_complex(z).re;
            assert!((g.jackknife(x0, x1) - want).abs() < 1e-6, "{x0} {x1}");
        }
    }

    #[test]
    fn exp_case_reduces_to_eq_4() {
        // g = e^-tau (u0 = 1, u1 = 0, v0 = 0, v1 = 1) gives the jackknife transmittance.
        let g = Mobius {
            u0: 1.0,
            u1: 0.0,
            v0: 0.0,
            v1: 1.0,
        };
        for &(x0, x1) in &[(0.3f32, 1.7f32), (2.0, 2.5), (0.0, 4.0)] {
            let k = crate::estimators::transmittance::jackknife(x0, x1);
            assert!((g.jackknife(x0, x1) - k).abs() < 1e-7);
        }
    }

    #[test]
    fn weights_of_a_pair_sum_to_one_exactly_for_equal_inputs_and_in_expectation_form() {
        // w1 + w0 = Re((mu z + p) / (mu z + p)) = 1 up to rounding for any (X0, X1) (App. D).
        for &(mu, p, x0, x1) in &[
            (2.0f32, 0.3f32, 0.5f32, 1.5f32),
            (0.1, 5.0, 3.0, 0.2),
            (1.0, 1.0, 0.0, 0.0),
        ] {
            let w1 = Mobius::free_flight_weight(mu, p).jackknife(x0, x1);
            let w0 = Mobius::other_weight(mu, p).jackknife(x0, x1);
            assert!((w0 + w1 - 1.0).abs() < 1e-6, "{w0} + {w1}");
        }
    }

    #[test]
    fn reciprocal_of_equal_estimates_is_exact() {
        assert_eq!(reciprocal(4.0, 4.0), 0.25);
        assert_eq!(reciprocal(0.0, 0.0), 0.0);
    }
}
