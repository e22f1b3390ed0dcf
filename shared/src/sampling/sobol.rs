//! Owen-scrambled Sobol points (Burley 2020, "Practical Hash-based Owen Scrambling", JCGT 9(4)):
//! the first two Sobol dimensions, a nested uniform scramble of the sample index per pattern
//! (a random permutation of the sequence that keeps every power-of-two prefix a (0, m, 2)-net)
//! and an Owen scramble of each coordinate. Every quantity of a path (the pixel jitter, each
//! vertex's free flight, light and phase samples) is its own pattern with its own seed
//! (Burley's padding, as Cycles' Sobol-Burley sampler), so no dimension count runs out and
//! only two Sobol dimensions are needed.
//!
//! Integer arithmetic only: the CPU and every GPU invocation compute the same bits.

use crate::rng::{pcg_hash, unit_f32};

/// Reverses the 32 bits of `x` (five swaps; no intrinsic, so every target runs the same code).
#[inline]
#[allow(clippy::manual_rotate)]
pub fn reverse_bits(x: u32) -> u32 {
    let x = ((x >> 1) & 0x5555_5555) | ((x & 0x5555_5555) << 1);
    let x = ((x >> 2) & 0x3333_3333) | ((x & 0x3333_3333) << 2);
    let x = ((x >> 4) & 0x0f0f_0f0f) | ((x & 0x0f0f_0f0f) << 4);
    let x = ((x >> 8) & 0x00ff_00ff) | ((x & 0x00ff_00ff) << 8);
    (x >> 16) | (x << 16)
}

/// Owen scramble of a bit-reversed value (Burley 2020, Listing 2: the Laine-Karras style hash
/// with his improved constants): bit k of the result flips by a hash of the bits below it.
#[inline]
pub fn reversed_bit_owen(n: u32, seed: u32) -> u32 {
    let mut n = n;
    n ^= n.wrapping_mul(0x3d20_adea);
    n = n.wrapping_add(seed);
    n = n.wrapping_mul((seed >> 16) | 1);
    n ^= n.wrapping_mul(0x0552_6c56);
    n ^= n.wrapping_mul(0x53a2_2864);
    n
}

/// Nested uniform (Owen) scramble of `x` in base 2 (Burley 2020, Listing 3): each bit flips
/// by a hash of the bits above it.
#[inline]
pub fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    reverse_bits(reversed_bit_owen(reverse_bits(x), seed))
}

/// Sobol dimension 0 of index i (van der Corput in base 2), 32 bits.
#[inline]
pub fn sobol_0(i: u32) -> u32 {
    reverse_bits(i)
}

/// Sobol dimension 1 of index i (primitive polynomial x + 1: direction numbers
/// v_0 = 2^31, v_k = v_(k-1) xor (v_(k-1) >> 1), Joe & Kuo's m = 1, 3, 5, 15, 17, 51, ...).
#[inline]
pub fn sobol_1(i: u32) -> u32 {
    let mut x = 0u32;
    let mut v = 0x8000_0000u32;
    let mut i = i;
    while i != 0 {
        if i & 1 != 0 {
            x ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    x
}

/// The seed of pattern `pattern` of a sample whose pixel seed is `seed`.
#[inline]
pub fn pattern_seed(seed: u32, pattern: u32) -> u32 {
    pcg_hash(seed ^ pcg_hash(pattern.wrapping_add(0x9e37_79b9)))
}

/// Point `index` of the 2D Owen-scrambled Sobol pattern with seed `seed` (Burley 2020, Listing
/// 4 in two dimensions): the index shuffled, then each coordinate scrambled with its own seed.
#[inline]
pub fn sobol_2d(index: u32, seed: u32) -> [f32; 2] {
    let i = nested_uniform_scramble(index, seed);
    let x = nested_uniform_scramble(sobol_0(i), pcg_hash(seed ^ 0xa511_e9b3));
    let y = nested_uniform_scramble(sobol_1(i), pcg_hash(seed ^ 0x63d8_3595));
    [unit_f32(x), unit_f32(y)]
}

/// Point `index` of the 1D Owen-scrambled Sobol pattern with seed `seed` (dimension 0 of
/// [`sobol_2d`]).
#[inline]
pub fn sobol_1d(index: u32, seed: u32) -> f32 {
    let i = nested_uniform_scramble(index, seed);
    unit_f32(nested_uniform_scramble(
        sobol_0(i),
        pcg_hash(seed ^ 0xa511_e9b3),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reverse_bits_matches_core() {
        for x in [0u32, 1, 2, 0x8000_0000, 0xdead_beef, u32::MAX, 12_345] {
            assert_eq!(reverse_bits(x), x.reverse_bits());
        }
    }

    #[test]
    fn sobol_1_matches_joe_kuo_direction_numbers() {
        // m_k of dimension 2 in Joe & Kuo's table: 1, 3, 5, 15, 17, 51, 85, 255.
        let m = [1u32, 3, 5, 15, 17, 51, 85, 255];
        for (k, mk) in m.iter().enumerate() {
            assert_eq!(sobol_1(1 << k), mk << (31 - k), "direction number {k}");
        }
        // Unscrambled, in index order (not Gray-code order): 0, 1/2, 3/4, 1/4, 5/8.
        let first: Vec<f64> = (0..5)
            .map(|i| sobol_1(i) as f64 / 4_294_967_296.0)
            .collect();
        assert_eq!(first, [0.0, 0.5, 0.75, 0.25, 0.625]);
    }

    /// Each of the 2^m points of an aligned block falls into its own elementary interval of
    /// every shape 2^a x 2^(m-a): a (0, m, 2)-net.
    fn is_net(points: &[[f32; 2]], m: u32) {
        for a in 0..=m {
            let (nx, ny) = (1u32 << a, 1u32 << (m - a));
            let mut seen = vec![false; 1 << m];
            for p in points {
                let cx = (p[0] * nx as f32) as u32;
                let cy = (p[1] * ny as f32) as u32;
                let cell = (cy * nx + cx) as usize;
                assert!(
                    !seen[cell],
                    "two points in one 2^{a} x 2^{} interval",
                    m - a
                );
                seen[cell] = true;
            }
        }
    }

    #[test]
    fn scrambled_prefixes_are_nets() {
        for seed in [0u32, 1, 0xdead_beef, pattern_seed(7, 3)] {
            for m in 0..=10u32 {
                let pts: Vec<[f32; 2]> = (0..1u32 << m).map(|i| sobol_2d(i, seed)).collect();
                is_net(&pts, m);
                // The 1D pattern is the 2D pattern's first coordinate.
                for (i, p) in pts.iter().enumerate() {
                    assert_eq!(sobol_1d(i as u32, seed), p[0]);
                }
            }
        }
    }

    #[test]
    fn scrambles_are_uniform_over_seeds() {
        // One point (index 5) over 2^16 seeds: its coordinates are uniform, tested by the
        // counts in 16 bins (chi-square with 15 degrees of freedom; 99.9 % quantile 37.7).
        let n = 1u32 << 16;
        for c in 0..2 {
            let mut bins = [0u32; 16];
            for s in 0..n {
                let p = sobol_2d(5, pcg_hash(s));
                bins[(p[c] * 16.0) as usize] += 1;
            }
            let e = n as f64 / 16.0;
            let chi2: f64 = bins.iter().map(|&b| (b as f64 - e).powi(2) / e).sum();
            assert!(chi2 < 37.7, "coordinate {c}: chi2 {chi2}");
        }
    }

    #[test]
    fn patterns_are_decorrelated() {
        // Two patterns of one pixel: the correlation of their first coordinates over 4096
        // samples is within 4 standard errors (1/64) of 0.
        let (a, b) = (pattern_seed(11, 1), pattern_seed(11, 2));
        let n = 4096;
        let mut sum = 0.0f64;
        for i in 0..n {
            let (x, y) = (sobol_1d(i, a) as f64 - 0.5, sobol_1d(i, b) as f64 - 0.5);
            sum += x * y * 12.0;
        }
        let r = sum / n as f64;
        assert!(r.abs() < 4.0 / 64.0, "correlation {r}");
    }
}
