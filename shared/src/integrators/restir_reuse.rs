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
    let side = 2 * params.restir_radius + 1;
    let (x, y) = (id % params.width, id / params.width);
    // x + a % side - r in [0, width), written without negative intermediates.
    let (qx, qy) = (x + a % side, y + b % side);
    let r = params.restir_radius;
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
    if params.restir_m_cap > 0 && m > params.restir_m_cap {
        params.restir_m_cap
    } else {
        m
    }
}

/// Reuse pass `pass` of pixel `id`: its new state, whose output reservoir resamples its own
/// reservoir and its neighbours' (GRIS Eq. 5.2 with the weights of Sec. 5.6). `states[j - base]`
/// is pixel j's state; all the pixels' states must be there.
#[allow(clippy::too_many_arguments)]
pub fn reuse(
    vol: &VolumeView,
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
    let k = params.restir_neighbours;
    let balance = RestirMis::from_u32(params.restir_mis) == RestirMis::Balance;
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
    let ctx = Ctx {
        vol,
        cfg,
        params,
        scene,
        sample,
        states,
        base,
        id,
        pass,
        x: st.x,
        wo: st.wo,
    };
    let mut tally = Tally::default();
    let mut rng = HashRng {
        state: st.direct.rng,
    };
    let mut out = Reservoir::default();
    let mut m_own = if k_eff == 0 { 1.0 } else { 0.0 };
    let mut n = 0;
    while n < k {
        let q_id = neighbour(params, id, sample, pass, n);
        n += 1;
        let Some(q) = neighbour_input(states, base, q_id, pass) else {
            continue;
        };
        // Neighbour q's sample shifted here (same light, |J| = 1): p̂(y_q) at this vertex.
        let (p_c, t) = ctx.target_here(q.r);
        tally = tally.merge(t);
        let m_q = if balance {
            let (sum, t) = ctx.balance_sum(q.r.y, c_c * p_c);
            tally = tally.merge(t);
            m_balance(q.r.m as f32 * q.r.p_hat, sum)
        } else {
            m_neighbour(c_c, q.r.m as f32, kf, c_total, p_c, q.r.p_hat)
        };
        let (u, next) = rng.next_f32();
        rng = next;
        out = out.update(q.r.y, m_q * p_c * q.r.contribution_weight(), p_c, u);
        // Pairwise: pair q's term of the canonical sample's weight, p̂_q at the own sample.
        if !balance && own.w_sum > 0.0 {
            let (p_q, t) = p_hat(vol, cfg, params, scene, q_id, sample, q.x, q.wo, own.y);
            tally = tally.merge(t);
            m_own += m_canonical_term(c_c, q.r.m as f32, kf, c_total, own.p_hat, p_q);
        }
    }
    if balance && k_eff > 0 && own.w_sum > 0.0 {
        let (sum, t) = ctx.balance_sum(own.y, c_c * own.p_hat);
        tally = tally.merge(t);
        m_own = m_balance(c_c * own.p_hat, sum);
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

/// What the target evaluations of one pixel's pass share.
struct Ctx<'a> {
    vol: &'a VolumeView<'a>,
    cfg: &'a Config,
    params: &'a RenderParams,
    scene: &'a Scene<'a>,
    sample: u32,
    states: &'a [RestirState],
    base: u32,
    id: u32,
    pass: u32,
    x: V3,
    wo: V3,
}

impl Ctx<'_> {
    /// p̂ of this pixel at reservoir r's light (0 without a sample).
    fn target_here(&self, r: Reservoir) -> (f32, Tally) {
        if !(r.w_sum > 0.0) {
            return (0.0, Tally::default());
        }
        p_hat(
            self.vol,
            self.cfg,
            self.params,
            self.scene,
            self.id,
            self.sample,
            self.x,
            self.wo,
            r.y,
        )
    }

    /// The generalized balance heuristic's denominator at light y: `own` (c p̂ of this pixel)
    /// plus c_q p̂_q(y) over every valid neighbour input q.
    fn balance_sum(&self, y: u32, own: f32) -> (f32, Tally) {
        let mut sum = own;
        let mut tally = Tally::default();
        let mut n = 0;
        while n < self.params.restir_neighbours {
            let q_id = neighbour(self.params, self.id, self.sample, self.pass, n);
            n += 1;
            let Some(q) = neighbour_input(self.states, self.base, q_id, self.pass) else {
                continue;
            };
            let p_q = if q.r.w_sum > 0.0 && q.r.y == y {
                // Its own sample: the target it stored (the same fixed function's value).
                q.r.p_hat
            } else {
                let (p, t) = p_hat(
                    self.vol,
                    self.cfg,
                    self.params,
                    self.scene,
                    q_id,
                    self.sample,
                    q.x,
                    q.wo,
                    y,
                );
                tally = tally.merge(t);
                p
            };
            sum += q.r.m as f32 * p_q;
        }
        (sum, tally)
    }
}
