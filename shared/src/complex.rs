//! A minimal complex number for jackknife function estimation, Re g(X̄ + iS) (paper Sec. 5.1).

use crate::math;
use core::ops::{Add, Div, Mul, Neg, Sub};

/// z = re + i im in f32.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Complex {
    pub re: f32,
    pub im: f32,
}

impl Complex {
    /// re + i im.
    #[inline]
    pub const fn new(re: f32, im: f32) -> Self {
        Complex { re, im }
    }

    /// A real number as a complex one.
    #[inline]
    pub const fn real(re: f32) -> Self {
        Complex { re, im: 0.0 }
    }

    /// Complex conjugate re - i im.
    #[inline]
    pub fn conj(self) -> Self {
        Complex::new(self.re, -self.im)
    }

    /// |z|^2.
    #[inline]
    pub fn norm_sqr(self) -> f32 {
        self.re * self.re + self.im * self.im
    }

    /// Scales both parts by a real factor.
    #[inline]
    pub fn scale(self, k: f32) -> Self {
        Complex::new(self.re * k, self.im * k)
    }

    /// e^z = e^re (cos im + i sin im), with the deterministic `math` functions.
    #[inline]
    pub fn exp(self) -> Self {
        let e = math::exp(self.re);
        let (s, c) = math::sin_cos(self.im);
        Complex::new(e * c, e * s)
    }
}

impl Add for Complex {
    type Output = Complex;
    #[inline]
    fn add(self, o: Complex) -> Complex {
        Complex::new(self.re + o.re, self.im + o.im)
    }
}

impl Sub for Complex {
    type Output = Complex;
    #[inline]
    fn sub(self, o: Complex) -> Complex {
        Complex::new(self.re - o.re, self.im - o.im)
    }
}

impl Neg for Complex {
    type Output = Complex;
    #[inline]
    fn neg(self) -> Complex {
        Complex::new(-self.re, -self.im)
    }
}

impl Mul for Complex {
    type Output = Complex;
    #[inline]
    fn mul(self, o: Complex) -> Complex {
        Complex::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
}

impl Div for Complex {
    type Output = Complex;
    /// a / b = a conj(b) / |b|^2 (the real-arithmetic form of the paper's App. F).
    #[inline]
    fn div(self, o: Complex) -> Complex {
        let d = o.norm_sqr();
        let n = self * o.conj();
        Complex::new(n.re / d, n.im / d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_of_imaginary_is_on_the_unit_circle() {
        for k in 0..100 {
            let z = Complex::new(0.0, k as f32 * 0.1).exp();
            assert!((z.norm_sqr() - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn division_inverts_multiplication() {
        let a = Complex::new(1.5, -2.0);
        let b = Complex::new(0.25, 3.0);
        let q = (a * b) / b;
        assert!((q.re - a.re).abs() < 1e-6 && (q.im - a.im).abs() < 1e-6);
    }

    #[test]
    fn exp_matches_std_reference() {
        let z = Complex::new(-0.7, 1.3).exp();
        let (re, im) = (
            (-0.7f64).exp() * 1.3f64.cos(),
            (-0.7f64).exp() * 1.3f64.sin(),
        );
        assert!((z.re as f64 - re).abs() < 1e-7 && (z.im as f64 - im).abs() < 1e-7);
    }
}
