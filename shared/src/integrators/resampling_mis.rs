//! Resampling MIS weights m_i(y) of spatial reuse (GRIS, Lin et al. 2022, Sec. 5.6), with
//! confidence weights c_i (the reservoirs' M, Sec. 6.2).
//!
//! Inputs: the canonical reservoir c (this pixel's own candidates, target p̂ = p̂_c) and k
//! neighbours' reservoirs j, each with its own target p̂_j. Every sample is a point light; the
//! shift between pixels keeps the light (identity on the light index, |J| = 1), so
//! p̂_←j(y) = p̂_j(y) (Eq. 35). For every y with p̂(y) > 0 the weights of all inputs sum to one:
//! that, and the canonical input covering supp p̂, keeps the reuse unbiased.

/// The two-strategy balance heuristic a / (a + b), 0 where both vanish.
#[inline]
pub fn balance2(a: f32, b: f32) -> f32 {
    if a + b > 0.0 {
        a / (a + b)
    } else {
        0.0
    }
}

/// Pair j's share of the unity in pairwise MIS: (c_c / k + c_j) / C with C = c_c + sum_j c_j
/// (the canonical's confidence split evenly over the k pairs; 1 / k when all confidences agree).
#[inline]
pub fn pair_share(c_c: f32, c_j: f32, k: f32, c_total: f32) -> f32 {
    (c_c / k + c_j) / c_total
}

/// Pairwise MIS weight of neighbour j's sample y (Eq. 37 with confidence weights):
/// share_j c_j p̂_j(y) / (c_j p̂_j(y) + c_c / k p̂(y)).
#[inline]
pub fn m_neighbour(c_c: f32, c_j: f32, k: f32, c_total: f32, p_c: f32, p_j: f32) -> f32 {
    pair_share(c_c, c_j, k, c_total) * balance2(c_j * p_j, c_c / k * p_c)
}

/// Pair j's term of the canonical sample's pairwise weight (Eq. 37, i in R):
/// share_j c_c / k p̂(y) / (c_j p̂_j(y) + c_c / k p̂(y)); the canonical weight is their sum.
#[inline]
pub fn m_canonical_term(c_c: f32, c_j: f32, k: f32, c_total: f32, p_c: f32, p_j: f32) -> f32 {
    pair_share(c_c, c_j, k, c_total) * balance2(c_c / k * p_c, c_j * p_j)
}

/// Generalized balance heuristic weight (Talbot, Eq. 36 with confidence weights) of an input
/// with c_i p̂_i(y) = `own` when the sum over all inputs of c_l p̂_l(y) is `sum`.
#[inline]
pub fn m_balance(own: f32, sum: f32) -> f32 {
    if sum > 0.0 {
        own / sum
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::RngCore;
    use rand_pcg::Pcg32;

    fn uniform(r: &mut Pcg32) -> f32 {
        (r.next_u32() >> 8) as f32 / (1u32 << 24) as f32
    }

    /// Random confidences (1..64) and targets (0 with probability 1/4, else up to 1e3) for one
    /// canonical input and k neighbours.
    fn inputs(r: &mut Pcg32, k: usize) -> (Vec<f32>, Vec<f32>) {
        let c = (0..=k).map(|_| (1 + r.next_u32() % 64) as f32).collect();
        let p = (0..=k)
            .map(|_| {
                if r.next_u32().is_multiple_of(4) {
                    0.0
                } else {
                    1e3 * uniform(r) + 1e-6
                }
            })
            .collect();
        (c, p)
    }

    /// Pairwise weights of all inputs at one y sum to one wherever p̂(y) > 0, and every weight is
    /// in [0, 1]: 10^5 random draws of k = 1..8 neighbours (Pcg32 seed 7); tolerance 1e-5
    /// (f32 rounding of at most 9 terms).
    #[test]
    fn pairwise_weights_sum_to_one() {
        let mut r = Pcg32::new(7, 11);
        for t in 0..100_000 {
            let k = 1 + t % 8;
            let (c, mut p) = inputs(&mut r, k);
            p[0] = p[0].max(1e-3);
            let c_total: f32 = c.iter().sum();
            let kf = k as f32;
            let mut sum = 0.0f32;
            for j in 1..=k {
                let m = m_neighbour(c[0], c[j], kf, c_total, p[0], p[j]);
                let mc = m_canonical_term(c[0], c[j], kf, c_total, p[0], p[j]);
                assert!((0.0..=1.0).contains(&m) && (0.0..=1.0).contains(&mc));
                sum += m + mc;
            }
            assert!((sum - 1.0).abs() < 1e-5, "draw {t}: sum {sum}");
        }
    }

    /// With all confidences 1 the pairwise weights are Eq. 37 as printed (|R| = 1, M - |R| = k).
    #[test]
    fn pairwise_weights_are_eq_37_at_equal_confidence() {
        let mut r = Pcg32::new(8, 11);
        for t in 0..10_000 {
            let k = 1 + t % 8;
            let (_, mut p) = inputs(&mut r, k);
            p[0] = p[0].max(1e-3);
            let kf = k as f32;
            let c_total = kf + 1.0;
            let mut canonical = 0.0f32;
            let mut eq37_canonical = 0.0f32;
            for j in 1..=k {
                let m = m_neighbour(1.0, 1.0, kf, c_total, p[0], p[j]);
                let eq37 = p[j] / (p[0] + kf * p[j]);
                assert!((m - eq37).abs() <= 1e-6 * eq37.max(1e-3), "{m} vs {eq37}");
                canonical += m_canonical_term(1.0, 1.0, kf, c_total, p[0], p[j]);
                eq37_canonical += p[0] / (p[0] + kf * p[j]) / kf;
            }
            assert!((canonical - eq37_canonical).abs() < 1e-5);
        }
    }

    /// Generalized balance weights of all inputs at one y sum to one wherever some target is
    /// positive (10^5 draws, Pcg32 seed 9, tolerance 1e-5), and are 0 for an input whose
    /// target vanishes there.
    #[test]
    fn balance_weights_sum_to_one() {
        let mut r = Pcg32::new(9, 11);
        for t in 0..100_000 {
            let k = 1 + t % 8;
            let (c, mut p) = inputs(&mut r, k);
            p[0] = p[0].max(1e-3);
            let total: f32 = c.iter().zip(&p).map(|(c, p)| c * p).sum();
            let sum: f32 = c.iter().zip(&p).map(|(c, p)| m_balance(c * p, total)).sum();
            assert!((sum - 1.0).abs() < 1e-5, "draw {t}: sum {sum}");
            for (c, p) in c.iter().zip(&p) {
                if *p == 0.0 {
                    assert_eq!(m_balance(c * p, total), 0.0);
                }
            }
        }
    }
}
