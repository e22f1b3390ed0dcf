//! Spatial reuse of `restir`'s reservoirs (GRIS, Lin et al. 2022, Secs. 5-6): each pass, every
//! pixel resamples one light from its own reservoir (the canonical input) and those of k random
//! neighbours within r pixels, with pairwise or generalized balance MIS weights
//! ([`super::resampling_mis`]) and the reservoirs' M as confidence weights (capped: Sec. 6.4).
//!
//! The sample is the light index at this pixel's own vertex: the shift from neighbour j keeps
//! the light (identity on the discrete light set, Jacobian 1) and re-evaluates the target at the
//! canonical vertex; p̂_←j(y) = p̂_j(y) evaluates j's target (j's vertex, direction and keyed
//! random numbers: a fixed function, [`super::restir::p_hat`]) from this pixel. Conditioned on
//! every pixel's vertex and target, each input reservoir carries an unbiased contribution weight
//! and the weights sum to one wherever p̂ > 0, so the resampled estimate stays unbiased; inputs
//! may share samples after the first pass, which changes the variance, not the expectation.
//!
//! Pass p reads the reservoir of parity p ([`RestirState::input`]) of every pixel and writes
//! the other ([`store_reuse`]): a dispatch reads neighbours' vertices and input reservoirs only,
//! and writes only its own output reservoir and generator, so pixels never race.

use super::resampling_mis::{m_balance, m_canonical_term, m_neighbour};
use super::restir::{p_hat, Reservoir, RestirState};
use crate::geometry::V3;
use crate::params::{Config, RenderParams, RestirMis};
use crate::rng::{pcg_hash, HashRng};
use crate::sampling::lighting::Scene;
use crate::tally::Tally;
use crate::volume::grid::VolumeView;
use crate::volume::texels::Texels;

/// Salt of the neighbour choice's random numbers.
const NEIGHBOUR_SALT: u32 = 0x3c6e_f372;

/// No neighbour (outside the image, or the pixel itself).
pub const NO_NEIGHBOUR: u32 = u32::MAX;

/// Stores what reuse pass `pass` of one pixel changed: its generator and tally, and the output
/// reservoir (the other parity). Its vertex and input reservoir, which neighbours read during
/// the pass, are left alone.
#[inline]
pub fn store_reuse(dst: &mut RestirState, src: &RestirState, pass: u32) {
    dst.direct = src.direct;
    if pass & 1 == 0 {
        dst.reused = src.reused;
    } else {
        dst.reservoir = src.reservoir;
    }
}

/// Neighbour n of pixel `id` in reuse pass `pass` of sample `sample`: uniform over the
/// (2r + 1)^2 window around it, by integer arithmetic on hashed bits (the same pixel on every
/// backend); [`NO_NEIGHBOUR`] outside the image or on the pixel itself.
#[inline]
pub fn neighbour(params: &RenderParams, id: u32, sample: u32, pass: u32, n: u32) -> u32 {
    let key = params.seed ^ pcg_hash(((pass << 16) | n) ^ NEIGHBOUR_SALT);
    let rng = HashRng::for_sample(id, sample, key);
    let (a, rng) = rng.next_u32();
    let (b, _) = rng.next_u32();
    let side = 2 * params.restir.radius + 1;
    let (y, x) = crate::math::div_rem_small(id, params.width);
    // x + a % side - r in [0, width), written without negative intermediates.
    let (qx, qy) = (x + a % side, y + b % side);
    let r = params.restir.radius;
    if qx < r || qy < r || qx - r >= params.width || qy - r >= params.height {
        return NO_NEIGHBOUR;
    }
    let q = (qy - r) * params.width + (qx - r);
    if q == id {
        NO_NEIGHBOUR
    } else {
        q
    }
}

/// What a pass reads of a neighbour: its vertex, direction to the camera and input reservoir
/// (field by field, never the fields it writes in the same pass).
#[derive(Clone, Copy)]
struct Input {
    x: V3,
    wo: V3,
    r: Reservoir,
}

impl Input {
    /// No input (its fields unused).
    const NONE: Input = Input {
        x: V3::new(0.0, 0.0, 0.0),
        wo: V3::new(0.0, 0.0, 0.0),
        r: Reservoir {
            y: 0,
            w_sum: 0.0,
            p_hat: 0.0,
            m: 0,
        },
    };
}

/// Neighbour q's input if it has a vertex (else None): states[q - base].
#[inline]
fn neighbour_input(states: &[RestirState], base: u32, q: u32, pass: u32) -> Option<Input> {
    if q == NO_NEIGHBOUR {
        return None;
    }
    let s = &states[(q - base) as usize];
    if s.found == 0 {
        return None;
    }
    Some(Input {
        x: s.x,
        wo: s.wo,
        r: s.input(pass),
    })
}

/// The reservoir's confidence M after a reuse, capped at `restir_m_cap` (0: no cap).
#[inline]
pub fn capped_m(params: &RenderParams, m: u32) -> u32 {
    if params.restir.m_cap > 0 && m > params.restir.m_cap {
        params.restir.m_cap
    } else {
        m
    }
}

/// Reuse pass `pass` of pixel `id`: its new state, whose output reservoir resamples its own
/// reservoir and its neighbours' (GRIS Eq. 5.2 with the weights of Sec. 5.6). `states[j - base]`
/// is pixel j's state; all the pixels' states must be there.
#[allow(clippy::too_many_arguments)]
pub fn reuse(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    id: u32,
    sample: u32,
    pass: u32,
    states: &[RestirState],
    base: u32,
) -> RestirState {
    let mut st = states[(id - base) as usize];
    let own = st.input(pass);
    if st.found == 0 || scene.point_count == 0 {
        return with_output(st, pass, own);
    }
    let k = params.restir.neighbours;
    let balance = RestirMis::from_u32(params.restir.mis) == RestirMis::Balance;
    // The valid inputs' count and confidences.
    let c_c = own.m as f32;
    let (mut k_eff, mut c_total, mut m_total) = (0u32, c_c, own.m);
    let mut n = 0;
    while n < k {
        if let Some(q) = neighbour_input(states, base, neighbour(params, id, sample, pass, n), pass)
        {
            k_eff += 1;
            c_total += q.r.m as f32;
            m_total += q.r.m;
        }
        n += 1;
    }
    let kf = k_eff as f32;
    let mut tally = Tally::default();
    let mut rng = HashRng {
        state: st.direct.rng,
    };
    let mut out = Reservoir::default();
    let mut m_own = if k_eff == 0 { 1.0 } else { 0.0 };
    // Input i < k is neighbour i, i = k the canonical sample (its balance weight only). Every
    // target evaluation of the pass goes through the one call of `p_hat` below (a kernel
    // inlines each call site: one copy, not four), in the order of the MIS weights' sums:
    // evaluation e = 0 is p̂ here at neighbour i's light (its shift here), then pairwise e = 1
    // is p̂_i at the canonical light, balance e = 1..=k is p̂_{e-1} at the input's light.
    let canonical_balance = balance && k_eff > 0 && own.w_sum > 0.0;
    let evaluations = if balance { k + 1 } else { 2 };
    let mut i = 0;
    while i <= k {
        let canonical = i == k;
        let q_id = if canonical {
            NO_NEIGHBOUR
        } else {
            neighbour(params, id, sample, pass, i)
        };
        i += 1;
        let q = neighbour_input(states, base, q_id, pass);
        if (!canonical && q.is_none()) || (canonical && !canonical_balance) {
            continue;
        }
        // The input's light y and reservoir (the canonical's own).
        let r = match q {
            Some(q) => q.r,
            None => own,
        };
        let (mut p_c, mut p_pair) = (own.p_hat, 0.0);
        // The balance heuristic's sum: c p̂ here first, then c_j p̂_j in neighbour order.
        let mut sum = if canonical { c_c * own.p_hat } else { 0.0 };
        let mut e = if canonical { 1 } else { 0 };
        while e < evaluations {
            // Who evaluates which light (pixel, its vertex and direction, the light) with what
            // factor, or the value when it is known without evaluating.
            let (who, x, wo, light, scale, known) = if e == 0 {
                // Neighbour i's sample shifted here (same light, |J| = 1).
                let known = if r.w_sum > 0.0 { None } else { Some(0.0) };
                (id, st.x, st.wo, r.y, 1.0, known)
            } else if !balance {
                // Pair i's term of the canonical weight: p̂_i at the canonical light.
                let known = if own.w_sum > 0.0 { None } else { Some(0.0) };
                let q = q.unwrap_or(Input::NONE);
                (q_id, q.x, q.wo, own.y, 1.0, known)
            } else {
                // The sum's term of neighbour e - 1 at y: c_j p̂_j(y), with the target j stored
                // where y is its own sample (the same fixed function's value); none (0) where
                // there is no neighbour.
                let j_id = neighbour(params, id, sample, pass, e - 1);
                match neighbour_input(states, base, j_id, pass) {
                    None => (j_id, st.x, st.wo, r.y, 0.0, Some(0.0)),
                    Some(j) => {
                        let c_j = j.r.m as f32;
                        let known = if j.r.w_sum > 0.0 && j.r.y == r.y {
                            Some(c_j * j.r.p_hat)
                        } else {
                            None
                        };
                        (j_id, j.x, j.wo, r.y, c_j, known)
                    }
                }
            };
            let value = match known {
                Some(v) => v,
                None => {
                    let (p, t) = p_hat(vol, cfg, params, scene, who, sample, x, wo, light);
                    tally = tally.merge(t);
                    scale * p
                }
            };
            if e == 0 {
                p_c = value;
                sum = c_c * p_c;
            } else if !balance {
                p_pair = value;
            } else {
                sum += value;
            }
            e += 1;
        }
        if canonical {
            m_own = m_balance(c_c * own.p_hat, sum);
            continue;
        }
        let m_q = if balance {
            m_balance(r.m as f32 * r.p_hat, sum)
        } else {
            m_neighbour(c_c, r.m as f32, kf, c_total, p_c, r.p_hat)
        };
        let (u, next) = rng.next_f32();
        rng = next;
        out = out.update(r.y, m_q * p_c * r.contribution_weight(), p_c, u);
        if !balance && own.w_sum > 0.0 {
            m_own += m_canonical_term(c_c, r.m as f32, kf, c_total, own.p_hat, p_pair);
        }
    }
    let (u, next) = rng.next_f32();
    rng = next;
    out = out.update(
        own.y,
        m_own * own.p_hat * own.contribution_weight(),
        own.p_hat,
        u,
    );
    out.m = capped_m(params, m_total);
    st.direct.rng = rng.state;
    // The targets' lookups are cost; their flags shape the variance only (as the candidates').
    st.direct
        .set_tally(st.direct.tally().merge(Tally::lookups(tally.lookups)));
    with_output(st, pass, out)
}

/// `st` with `r` as the output reservoir of pass `pass`.
#[inline]
fn with_output(st: RestirState, pass: u32, r: Reservoir) -> RestirState {
    let mut st = st;
    if pass & 1 == 0 {
        st.reused = r;
    } else {
        st.reservoir = r;
    }
    st
}
