//! Measures the ulp error of the deterministic math functions against f64 `std` references.
//!
//! Default: every 13th f32 bit pattern of each range (about 10^8 arguments in all). With
//! `JK_EXHAUSTIVE=1` every f32 in each range is checked. Target: <= 4 ulp (foundation issue).

use rayon::prelude::*;
use shared::math;

/// Size of one f32 ulp at the magnitude of `r` (subnormal spacing below 2^-126).
fn ulp_of(r: f64) -> f64 {
    let a = r.abs();
    if a < f32::MIN_POSITIVE as f64 {
        return 2f64.powi(-149);
    }
    2f64.powi(a.log2().floor() as i32 - 23)
}

/// Error of `got` against the exact value `want`, in ulps of the f32 result.
fn ulp_error(got: f32, want: f64) -> f64 {
    if want.is_nan() {
        return if got.is_nan() { 0.0 } else { f64::INFINITY };
    }
    if want.abs() > f32::MAX as f64 * (1.0 + 2f64.powi(-25)) {
        // Rounds to +-inf in f32.
        return if got.is_infinite() && got.signum() as f64 == want.signum() {
            0.0
        } else {
            f64::INFINITY
        };
    }
    if got.is_infinite() || got.is_nan() {
        return f64::INFINITY;
    }
    (got as f64 - want).abs() / ulp_of(want)
}

/// All f32 bit patterns of [lo, hi] for both signs as requested, with the chosen stride.
fn args(lo: f32, hi: f32, stride: u32) -> Vec<f32> {
    let mut v = Vec::new();
    let (a, b) = (lo.to_bits(), hi.to_bits());
    let mut bits = a;
    while bits <= b {
        v.push(f32::from_bits(bits));
        bits = match bits.checked_add(stride) {
            Some(n) => n,
            None => break,
        };
    }
    v
}

fn stride() -> u32 {
    if std::env::var("JK_EXHAUSTIVE").is_ok_and(|v| v == "1") {
        1
    } else {
        13
    }
}

/// Largest error over `xs` and where it happened.
fn worst(xs: &[f32], f: fn(f32) -> f32, reference: fn(f64) -> f64) -> (f64, f32) {
    xs.par_iter()
        .map(|&x| (ulp_error(f(x), reference(x as f64)), x))
        .reduce(|| (0.0, 0.0), |a, b| if b.0 > a.0 { b } else { a })
}

fn check(
    name: &str,
    ranges: &[(f32, f32)],
    f: fn(f32) -> f32,
    reference: fn(f64) -> f64,
    limit: f64,
) {
    let s = stride();
    let mut overall = (0.0f64, 0.0f32);
    let mut n = 0usize;
    for &(lo, hi) in ranges {
        // Positive range, then the mirrored negative one where asked (bit order is by magnitude).
        let (xs, neg) = if lo < 0.0 {
            (args(0.0, hi, s), true)
        } else {
            (args(lo, hi, s), false)
        };
        let w = worst(&xs, f, reference);
        n += xs.len();
        if w.0 > overall.0 {
            overall = w;
        }
        if neg {
            let xs: Vec<f32> = xs.iter().map(|x| -x).collect();
            let w = worst(&xs, f, reference);
            n += xs.len();
            if w.0 > overall.0 {
                overall = w;
            }
        }
    }
    println!(
        "{name}: max error {:.3} ulp at x = {:e} ({n} arguments, stride {s})",
        overall.0, overall.1
    );
    assert!(
        overall.0 <= limit,
        "{name}: {:.3} ulp at x = {:e} exceeds {limit} ulp",
        overall.0,
        overall.1
    );
}

#[test]
fn exp_within_4_ulp() {
    // Whole domain where the result is neither 0 nor inf (plus the edges of both).
    check("exp", &[(-104.0, 104.0)], math::exp, f64::exp, 4.0);
}

#[test]
fn ln_within_4_ulp() {
    // Every positive finite float, subnormals included.
    check(
        "ln",
        &[(f32::from_bits(1), f32::MAX)],
        math::ln,
        f64::ln,
        4.0,
    );
}

#[test]
fn sin_within_4_ulp() {
    check(
        "sin",
        &[(-math::TRIG_ACCURATE_RANGE, math::TRIG_ACCURATE_RANGE)],
        math::sin,
        f64::sin,
        4.0,
    );
}

#[test]
fn cos_within_4_ulp() {
    check(
        "cos",
        &[(-math::TRIG_ACCURATE_RANGE, math::TRIG_ACCURATE_RANGE)],
        math::cos,
        f64::cos,
        4.0,
    );
}

#[test]
fn atan_within_4_ulp() {
    check("atan", &[(-1e30, 1e30)], math::atan, f64::atan, 4.0);
}

#[test]
fn special_values() {
    assert!(math::exp(f32::NAN).is_nan());
    assert_eq!(math::exp(f32::INFINITY), f32::INFINITY);
    assert_eq!(math::exp(f32::NEG_INFINITY), 0.0);
    assert_eq!(math::exp(0.0), 1.0);
    assert_eq!(math::exp(89.0), f32::INFINITY);
    assert_eq!(math::exp(-105.0), 0.0);
    assert_eq!(math::ln(1.0), 0.0);
    assert_eq!(math::ln(0.0), f32::NEG_INFINITY);
    assert_eq!(math::ln(f32::INFINITY), f32::INFINITY);
    assert!(math::ln(-1.0).is_nan());
    assert!(math::ln(f32::NAN).is_nan());
    assert_eq!(math::cos(0.0), 1.0);
    assert_eq!(math::sin(0.0), 0.0);
    assert!(math::sin(f32::INFINITY).is_nan() && math::cos(f32::NEG_INFINITY).is_nan());
    // Canonical NaN bits, so GPU and CPU outputs compare byte for byte.
    for v in [
        math::exp(f32::NAN),
        math::ln(-2.0),
        math::sin(f32::NAN),
        math::cos(f32::INFINITY),
    ] {
        assert_eq!(v.to_bits(), math::NAN.to_bits());
    }
}

#[test]
fn huge_trig_arguments_stay_bounded() {
    // Beyond TRIG_ACCURATE_RANGE accuracy is not promised, but results are finite and in [-1, 1].
    for x in [1e4f32, 1e6, 3e7, 1e10, 1e20, f32::MAX, -f32::MAX] {
        let (s, c) = math::sin_cos(x);
        assert!(
            (-1.0..=1.0).contains(&s) && (-1.0..=1.0).contains(&c),
            "sin_cos({x}) = ({s}, {c})"
        );
    }
}

#[test]
fn floor_matches_std() {
    for x in [
        -2.5f32,
        -1.0,
        -0.5,
        -0.0,
        0.0,
        0.5,
        1.0,
        1.5,
        8_388_607.5,
        -8_388_607.5,
        1e20,
        -1e20,
    ] {
        assert_eq!(math::floor(x), x.floor(), "floor({x})");
    }
}

/// Every f32 in [1, 4): all 2^24 pairs of mantissa and exponent parity, which alone decide
/// `math::sqrt`'s integer root (an exponent only scales it, a subnormal is scaled into a normal),
/// so this proves the correction's range for every input; a wrong correction fails here.
#[test]
fn sqrt_is_correctly_rounded_in_1_to_4() {
    let (lo, hi) = (1.0f32.to_bits(), 4.0f32.to_bits());
    let bad: Vec<u32> = (lo..hi)
        .into_par_iter()
        .filter(|&b| {
            let x = f32::from_bits(b);
            math::sqrt(x).to_bits() != x.sqrt().to_bits()
        })
        .take_any(10)
        .collect();
    assert!(bad.is_empty(), "sqrt differs from IEEE at {bad:x?}");
}

#[test]
fn sqrt_is_correctly_rounded_for_every_f32() {
    // math::sqrt is built from integer and + - * / arithmetic (stable Rust, same on every target);
    // it must equal IEEE sqrt bit for bit (NaN: any NaN). Default: every 7th bit pattern plus the
    // first and last 2^20 (subnormals, +-0, inf, NaN); `JK_EXHAUSTIVE=1`: all 2^32 (measured: 0
    // differences).
    let step: u32 = if std::env::var_os("JK_EXHAUSTIVE").is_some() {
        1
    } else {
        7
    };
    let edges = (0..1u32 << 20).chain(u32::MAX - (1 << 20)..=u32::MAX);
    let strided = (0..=u32::MAX / step).map(move |k| k * step);
    let all: Vec<u32> = if step == 1 {
        Vec::new()
    } else {
        edges.chain(strided).collect()
    };
    let check = |&bits: &u32| {
        let x = f32::from_bits(bits);
        let (got, want) = (math::sqrt(x), x.sqrt());
        !(got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()))
    };
    let bad: Vec<u32> = if step == 1 {
        (0..=u32::MAX)
            .into_par_iter()
            .filter(|b| check(b))
            .take_any(10)
            .collect()
    } else {
        all.par_iter()
            .copied()
            .filter(|b| check(b))
            .take_any(10)
            .collect()
    };
    assert!(
        bad.is_empty(),
        "sqrt differs from IEEE at bit patterns {bad:x?}"
    );
}

/// `div_rem_small` equals integer division for every divisor of an image width (1 to 16384) at
/// the quotients of every row (0 to 16383) and a pixel's first, middle and last column, and for
/// small divisors up to its quotient bound (2^22); with `JK_EXHAUSTIVE=1` at every column of
/// every 7th row.
#[test]
fn div_rem_small_is_integer_division() {
    let exhaustive = std::env::var("JK_EXHAUSTIVE").is_ok_and(|v| v == "1");
    (1u32..=16384).into_par_iter().for_each(|d| {
        for q in 0..16384u32 {
            let cols: Vec<u32> = if exhaustive && q % 7 == 0 {
                (0..d).collect()
            } else {
                vec![0, d / 2, d - 1]
            };
            for r in cols {
                let n = q * d + r;
                assert_eq!(math::div_rem_small(n, d), (n / d, n % d), "{n} / {d}");
            }
        }
    });
    for d in 1u32..=256 {
        for q in [(1 << 22) - 2, (1 << 22) - 1] {
            for r in [0, d / 2, d - 1] {
                let n = q * d + r;
                assert_eq!(math::div_rem_small(n, d), (n / d, n % d), "{n} / {d}");
            }
        }
    }
}
