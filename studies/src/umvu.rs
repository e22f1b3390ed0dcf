//! The UMVU estimate of exp(-tau) from m >= 2 i.i.d. normal estimates (Thm. 1, Eq. 3), in f64:
//! K = Gamma((m-1)/2) (2/S)^nu J_nu(S) exp(-X̄) with nu = (m-3)/2 and the biased sample standard
//! deviation S. Bessel J comes from `puruspe`; two independent evaluations of the same factor
//! (its power series and, for even m, spherical Bessel closed forms) check it.

use std::f64::consts::PI;

/// S above which the Bessel function is evaluated by its large-argument expansion (puruspe's
/// continued fraction needs about S iterations and gives up at 10^4).
const ASYMPTOTIC_S: f64 = 1000.0;
/// S below which the power series is used: two terms are exact in f64 there, and (2/S)^nu J_nu
/// would otherwise divide tiny numbers.
const SERIES_S: f64 = 1e-3;

/// Order nu = (m - 3) / 2 of the Bessel function in Eq. 3.
pub fn order(m: u32) -> f64 {
    (m as f64 - 3.0) / 2.0
}

/// J_nu(x) for real order nu and x > 0: puruspe for nu >= 0; for non-integer nu < 0 (m = 2 needs
/// nu = -1/2) DLMF 10.4.7, J_{-mu} = cos(mu pi) J_mu - sin(mu pi) Y_mu, from puruspe's J and Y.
pub fn bessel_j(nu: f64, x: f64) -> f64 {
    assert!(x > 0.0, "bessel_j needs x > 0, got {x}");
    if x > ASYMPTOTIC_S {
        return bessel_j_asymptotic(nu, x);
    }
    if nu >= 0.0 {
        return puruspe::Jnu_Ynu(nu, x).0;
    }
    let mu = -nu;
    assert!(
        mu.fract() != 0.0,
        "negative integer orders are not needed by Eq. 3"
    );
    let (j, y) = puruspe::Jnu_Ynu(mu, x);
    (mu * PI).cos() * j - (mu * PI).sin() * y
}

/// Hankel's expansion of J_nu(x) for large x (DLMF 10.17.3), three terms of P and two of Q.
fn bessel_j_asymptotic(nu: f64, x: f64) -> f64 {
    let mu = 4.0 * nu * nu;
    let a1 = (mu - 1.0) / 8.0;
    let a2 = (mu - 1.0) * (mu - 9.0) / 128.0;
    let a3 = (mu - 1.0) * (mu - 9.0) * (mu - 25.0) / 3072.0;
    let p = 1.0 - a2 / (x * x);
    let q = a1 / x - a3 / (x * x * x);
    let omega = x - 0.5 * nu * PI - 0.25 * PI;
    (2.0 / (PI * x)).sqrt() * (omega.cos() * p - omega.sin() * q)
}

/// The factor Gamma((m-1)/2) (2/S)^nu J_nu(S) of Eq. 3 that corrects exp(-X̄); 1 at S = 0.
pub fn correction(m: u32, s: f64) -> f64 {
    assert!(m >= 2, "Eq. 3 needs m >= 2");
    if s < SERIES_S {
        return correction_series(m, s);
    }
    let nu = order(m);
    puruspe::gamma(nu + 1.0) * (2.0 / s).powf(nu) * bessel_j(nu, s)
}

/// The same factor as the power series 0F1(; (m-1)/2; -S^2/4) = sum_k (-S^2/4)^k / ((m-1)/2)_k k!
/// (DLMF 10.2.2 divided by its leading term). Accurate for S up to ~10; an independent check.
pub fn correction_series(m: u32, s: f64) -> f64 {
    let b = (m as f64 - 1.0) / 2.0;
    let z = -0.25 * s * s;
    let (mut term, mut sum) = (1.0f64, 1.0f64);
    for k in 0..200 {
        let k = k as f64;
        term *= z / ((b + k) * (k + 1.0));
        sum += term;
        if term.abs() < 1e-18 * sum.abs().max(1e-300) {
            break;
        }
    }
    sum
}

/// Spherical Bessel j_n(x) for n = 0..=3 in closed form (DLMF 10.49.3).
pub fn spherical_j(n: u32, x: f64) -> f64 {
    let (s, c) = x.sin_cos();
    match n {
        0 => s / x,
        1 => s / (x * x) - c / x,
        2 => (3.0 / (x * x * x) - 1.0 / x) * s - 3.0 * c / (x * x),
        3 => (15.0 / x.powi(4) - 6.0 / (x * x)) * s - (15.0 / (x * x * x) - 1.0 / x) * c,
        _ => panic!("spherical_j: n = {n} not tabulated"),
    }
}

/// The factor for even m in closed form: half-integer orders nu = n + 1/2 give
/// Gamma(n + 3/2) (2/S)^{n+1/2} J_{n+1/2}(S) = (2n+1)!! j_n(S) / S^n with n = (m - 4) / 2, and
/// m = 2 (nu = -1/2) gives cos(S), Eq. 4. None for odd m (integer order) or m > 10.
pub fn correction_spherical(m: u32, s: f64) -> Option<f64> {
    match m {
        2 => Some(s.cos()),
        4 | 6 | 8 | 10 => {
            let n = (m - 4) / 2;
            let double_factorial = (1..=2 * n + 1).step_by(2).product::<u32>() as f64;
            Some(double_factorial * spherical_j(n, s) / s.powi(n as i32))
        }
        _ => None,
    }
}

/// Sample mean X̄ and biased sample standard deviation S of Thm. 1 (S^2 computed as the mean
/// squared deviation, which equals mean(X^2) - X̄^2 without its cancellation).
pub fn mean_and_s(xs: &[f64]) -> (f64, f64) {
    let m = xs.len() as f64;
    let x_bar = xs.iter().sum::<f64>() / m;
    let s2 = xs.iter().map(|x| (x - x_bar) * (x - x_bar)).sum::<f64>() / m;
    (x_bar, s2.sqrt())
}

/// Eq. 3: the UMVU estimate of exp(-tau) from m = xs.len() >= 2 estimates.
pub fn jackknife(xs: &[f64]) -> f64 {
    let (x_bar, s) = mean_and_s(xs);
    let e = (-x_bar).exp();
    if e == 0.0 {
        return 0.0;
    }
    correction(xs.len() as u32, s) * e
}

/// The naive estimate exp(-X̄) (for m = 1 simply exp(-X)).
pub fn naive(xs: &[f64]) -> f64 {
    (-(xs.iter().sum::<f64>() / xs.len() as f64)).exp()
}
