//! BC4-style block compression of the super-voxel statistics, as in the paper's figures (the
//! author's code compresses each statistic's grid to `VK_FORMAT_BC4_UNORM_BLOCK`): per statistic
//! one transform of the whole grid to [0, 1] (linear, or exponential where that spreads the
//! values more evenly: the author's `get_quantization_coeffs`), then per block of 4 x 4 bricks
//! of one z slice two 8-bit endpoints and a 3-bit index per brick into the 8 levels between
//! them. Rounding is conservative (min down, everything else up: endpoints and indices rounded
//! with floor or ceil as the author's `ROUND_OP`), so mu_min stays a lower bound, mu_max a
//! majorant and P positive wherever the extinction is.
//!
//! The builder stores the decoded values (f32) in the brick table: the estimators see exactly
//! what a BC4 decoder in the kernels would return (decoded in f64 here, then rounded to f32 in
//! the statistic's direction), so the bias of the format is measured; the memory it saves is
//! reported ([`bc4_table_bytes`]) but not taken.

use shared::volume::grid::Brick;

/// Which way a statistic rounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Round {
    /// Towards smaller values (mu_min, the control variate).
    Down,
    /// Towards larger values (mu_max, mean, P).
    Up,
}

/// Bricks per block side (BC4 blocks are 4 x 4 texels of one slice).
const BLOCK: usize = 4;
/// Levels between a block's endpoints (3-bit indices).
const LEVELS: f64 = 7.0;
/// Levels of an endpoint (8 bits).
const ENDPOINT: f64 = 255.0;
/// How aggressively the exponential transform compresses large values (the author's 0.6).
const LERP: f64 = 0.6;

/// The global transform of one statistic to [0, 1]: y = factor * m(x) + summand with
/// m(x) = exp(k x), or m(x) = x where k = 0 (the author's quantization coefficients).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    k: f64,
    factor: f64,
    summand: f64,
    min: f64,
    max: f64,
}

impl Transform {
    /// The transform of `values` (finite, any order): linear, or exponential with the factor
    /// that the author's `optimize_exponent_factor` picks from the values' first two moments.
    pub fn fit(values: &[f32]) -> Self {
        let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
        let (mut b1, mut b2) = (0.0f64, 0.0f64);
        for &v in values {
            let v = v as f64;
            min = min.min(v);
            max = max.max(v);
            b1 += v;
            b2 += v * v;
        }
        if values.is_empty() || !(max > min) {
            // One value (or none): every statistic decodes exactly.
            let v = if values.is_empty() { 0.0 } else { min };
            return Transform {
                k: 0.0,
                factor: 0.0,
                summand: 0.0,
                min: v,
                max: v,
            };
        }
        let k = exponent_factor(min, max, values.len() as f64, b1, b2);
        let m = |x: f64| if k == 0.0 { x } else { (k * x).exp() };
        let factor = 1.0 / (m(max) - m(min));
        Transform {
            k,
            factor,
            summand: -m(min) * factor,
            min,
            max,
        }
    }

    /// y of x, exactly 0 at the minimum and 1 at the maximum.
    pub fn y(&self, x: f64) -> f64 {
        if x <= self.min {
            0.0
        } else if x >= self.max {
            1.0
        } else {
            let m = if self.k == 0.0 { x } else { (self.k * x).exp() };
            (self.factor * m + self.summand).clamp(0.0, 1.0)
        }
    }

    /// x of y (the dequantization), exactly the minimum at 0 and the maximum at 1.
    pub fn x(&self, y: f64) -> f64 {
        if y <= 0.0 || !(self.max > self.min) {
            self.min
        } else if y >= 1.0 {
            self.max
        } else {
            let m = (y - self.summand) / self.factor;
            let x = if self.k == 0.0 { m } else { m.ln() / self.k };
            x.clamp(self.min, self.max)
        }
    }
}

/// The author's `optimize_exponent_factor`: the factor k < 0 of exp(k x) that balances the
/// quantization error over the values (count b0, sum b1, sum of squares b2) in [min, max], or
/// 0 where linear quantization is better (or the optimum is too weak to be worth the
/// cancellation).
fn exponent_factor(min: f64, max: f64, b0: f64, b1: f64, b2: f64) -> f64 {
    let center = (b1 * min - b2) / (b0 * min - b1);
    let range = max - min;
    let offset = center - min;
    let critical = (LERP * range / offset).ln() / (center - max);
    if !critical.is_finite() || critical >= 0.0 || !(offset > 0.0) {
        return 0.0;
    }
    let (mut left, mut right) = ((1.0 - LERP).ln() / offset, critical);
    // Bisection to a relative 1e-6 (at most 200 halvings).
    let mut halvings = 0;
    while right - left > left.abs() * 1e-6 && halvings < 200 {
        let fac = 0.5 * (right + left);
        if (fac * offset).exp() - LERP * (fac * range).exp() < 1.0 - LERP {
            left = fac;
        } else {
            right = fac;
        }
        halvings += 1;
    }
    let fac = 0.5 * (right + left);
    if !fac.is_finite() || fac * range > -1e-2 {
        0.0
    } else {
        fac
    }
}

/// `v` rounded to an integer in the direction `round`.
fn directed(v: f64, round: Round) -> f64 {
    match round {
        Round::Down => v.floor(),
        Round::Up => v.ceil(),
    }
}

/// The decoded values of one block (`ys`: up to 16 transformed values in [0, 1]): endpoints
/// 8-bit, each value's index into the 8 levels between them, both rounded in the direction
/// `round` (a value past an endpoint takes that endpoint, as the author's index mapping).
pub fn block(ys: &[f64], round: Round) -> Vec<f64> {
    let (lo, hi) = ys
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &y| {
            (a.min(y), b.max(y))
        });
    let e0 = directed(ENDPOINT * lo.clamp(0.0, 1.0), round) / ENDPOINT;
    let e1 = directed(ENDPOINT * hi.clamp(0.0, 1.0), round) / ENDPOINT;
    ys.iter()
        .map(|&y| {
            if !(e1 > e0) {
                // Equal endpoints: one level.
                return e0;
            }
            let q = directed((y - e0) * (LEVELS / (e1 - e0)), round).clamp(0.0, LEVELS);
            e0 + q * ((e1 - e0) / LEVELS)
        })
        .collect()
}

/// `v` as f32 rounded in the direction `round`, and never on the wrong side of `original`
/// (the transform's own rounding can cross it by a few ulps).
fn to_f32(v: f64, original: f32, round: Round) -> f32 {
    let mut f = v as f32;
    match round {
        Round::Down => {
            if f as f64 > v {
                f = f.next_down();
            }
            f.min(original)
        }
        Round::Up => {
            if (f as f64) < v {
                f = f.next_up();
            }
            f.max(original)
        }
    }
}

/// One statistic of every brick (x fastest over `dims` bricks) compressed and decoded.
pub fn compress(values: &[f32], dims: [u32; 3], round: Round) -> Vec<f32> {
    let t = Transform::fit(values);
    let [dx, dy, dz] = dims.map(|d| d as usize);
    let mut out = values.to_vec();
    let mut ys = Vec::with_capacity(BLOCK * BLOCK);
    let mut at = Vec::with_capacity(BLOCK * BLOCK);
    for z in 0..dz {
        for by in (0..dy).step_by(BLOCK) {
            for bx in (0..dx).step_by(BLOCK) {
                ys.clear();
                at.clear();
                for y in by..(by + BLOCK).min(dy) {
                    for x in bx..(bx + BLOCK).min(dx) {
                        let i = x + dx * (y + dy * z);
                        at.push(i);
                        ys.push(t.y(values[i] as f64));
                    }
                }
                for (&i, y) in at.iter().zip(block(&ys, round)) {
                    out[i] = to_f32(t.x(y), values[i], round);
                }
            }
        }
    }
    out
}

/// The bricks (or the cell records of subdivided bricks, as `dims` = [s, s, s x count]) with
/// their four statistics BC4-compressed and decoded (mu_min down, mu_max, mean and P up); slots
/// and cell indices unchanged. A statistic that is 0 stays exactly 0 where the grid's minimum of
/// it is 0 (the transform maps the minimum to 0, a block holding it has endpoint 0).
pub fn compress_bricks(bricks: &[Brick], dims: [u32; 3]) -> Vec<Brick> {
    let stat = |f: fn(&Brick) -> f32, round| {
        compress(&bricks.iter().map(f).collect::<Vec<_>>(), dims, round)
    };
    let mu_min = stat(|b| b.mu_min, Round::Down);
    let mu_max = stat(|b| b.mu_max, Round::Up);
    let mean = stat(|b| b.mean, Round::Up);
    let p = stat(|b| b.p, Round::Up);
    bricks
        .iter()
        .enumerate()
        .map(|(i, b)| Brick {
            mu_min: mu_min[i],
            mu_max: mu_max[i],
            mean: mean[i],
            p: p[i],
            slot: b.slot,
            cells: b.cells,
        })
        .collect()
}

/// Bytes of a BC4 brick table of `dims` bricks: four statistics of 8 bytes per 4 x 4 block of
/// each z slice, and the 4-byte slot of every brick.
pub fn bc4_table_bytes(dims: [u32; 3]) -> u64 {
    let [x, y, z] = dims.map(|d| d as u64);
    4 * 8 * x.div_ceil(BLOCK as u64) * y.div_ceil(BLOCK as u64) * z + 4 * x * y * z
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::rng::{pcg_hash, unit_f32};

    /// Random statistics: mostly zeros, some small, a few large (like a sparse cloud's).
    fn values(n: usize, salt: u32) -> Vec<f32> {
        (0..n as u32)
            .map(|i| {
                let u = unit_f32(pcg_hash(i ^ salt));
                let w = unit_f32(pcg_hash(i.wrapping_mul(7) ^ salt ^ 0x9e37));
                if u < 0.4 {
                    0.0
                } else if u < 0.9 {
                    0.01 + w
                } else {
                    20.0 * w * w + 1.0
                }
            })
            .collect()
    }

    #[test]
    fn decoding_is_conservative_and_keeps_zeros_and_extremes() {
        for (salt, dims) in [(1u32, [9u32, 7, 5]), (2, [16, 16, 3]), (3, [1, 1, 40])] {
            let n = (dims[0] * dims[1] * dims[2]) as usize;
            let v = values(n, salt);
            for round in [Round::Down, Round::Up] {
                let d = compress(&v, dims, round);
                for (i, (&a, &b)) in v.iter().zip(&d).enumerate() {
                    match round {
                        Round::Down => assert!(b <= a && b >= 0.0, "{i}: {a} -> {b}"),
                        Round::Up => assert!(b >= a, "{i}: {a} -> {b}"),
                    }
                    if a == 0.0 {
                        assert_eq!(b.to_bits(), 0, "{round:?} {i}: 0 -> {b}");
                    }
                }
                let max = v.iter().cloned().fold(0.0f32, f32::max);
                assert!(d.iter().all(|&x| x <= max), "{round:?}: beyond the maximum");
                // The format loses information: some value changes.
                assert!(
                    v.iter().zip(&d).any(|(a, b)| a != b),
                    "{round:?}: lossless?"
                );
            }
        }
    }

    #[test]
    fn a_block_decodes_to_its_palette() {
        // Endpoints 0 and 1 exactly: the levels are i / 7.
        let ys = [0.0, 1.0, 0.5, 0.2, 0.99, 1.0 / 7.0];
        let up = block(&ys, Round::Up);
        let down = block(&ys, Round::Down);
        assert_eq!(up[0], 0.0);
        assert_eq!(up[1], 1.0);
        assert_eq!(up[2], 4.0 / 7.0);
        assert_eq!(down[2], 3.0 / 7.0);
        assert_eq!(up[3], 2.0 / 7.0);
        assert_eq!(down[3], 1.0 / 7.0);
        assert_eq!(down[4], 6.0 / 7.0);
        for (i, (&y, (&u, &d))) in ys.iter().zip(up.iter().zip(&down)).enumerate() {
            assert!(d <= y && y <= u, "{i}: {d} {y} {u}");
            assert!(
                ((u * 7.0).round() - u * 7.0).abs() < 1e-12,
                "{i}: {u} off the palette"
            );
        }
        // Equal endpoints: one level, on the safe side.
        assert_eq!(block(&[0.5, 0.5], Round::Up), vec![128.0 / 255.0; 2]);
        assert_eq!(block(&[0.5, 0.5], Round::Down), vec![127.0 / 255.0; 2]);
    }

    #[test]
    fn the_transform_inverts_and_goes_exponential_for_skewed_values() {
        // x = 100 u^3: E[x^2] / E[x] = 57 < 0.6 x 100, where the author's objective prefers the
        // exponential transform.
        let skewed: Vec<f32> = (0..1000)
            .map(|i| 100.0 * (i as f32 / 999.0).powi(3))
            .collect();
        let t = Transform::fit(&skewed);
        assert!(t.k < 0.0, "{t:?}");
        for x in [0.0, 1e-7, 0.01, 0.05, 1.0, 50.0, 100.0] {
            let back = t.x(t.y(x));
            assert!((back - x).abs() <= 1e-9 * (1.0 + x), "{x} -> {back}");
        }
        assert_eq!(t.y(0.0), 0.0);
        assert_eq!(t.y(100.0), 1.0);
        let even: Vec<f32> = (0..1000).map(|i| i as f32).collect();
        assert_eq!(Transform::fit(&even).k, 0.0);
        let constant = Transform::fit(&[3.0; 10]);
        assert_eq!(constant.x(constant.y(3.0)), 3.0);
    }

    #[test]
    fn the_table_bytes_count_blocks_and_slots() {
        assert_eq!(bc4_table_bytes([4, 4, 1]), 32 + 64);
        assert_eq!(bc4_table_bytes([5, 4, 2]), 4 * 8 * 2 * 2 + 4 * 40);
    }
}
