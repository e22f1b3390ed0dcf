//! Resampled point-light sampling at the free-flight vertex (`restir`; GRIS, Lin et al. 2022,
//! with a jackknife-estimated target function, beyond the paper).
//!
//! `direct` estimates the in-scattered light at its vertex x with one light sample drawn by the
//! pmf over the map, the sun and the point lights, plus one phase sample. Point lights are delta
//! lights that phase sampling never reaches, so their integral separates:
//! L_s(x) = L_dir(x) + sum_k f_k(x), f_k = I_k tint_k phase(wo, w_k) T(x, y_k) / d_k^2.
//! `restir` keeps `direct`'s estimate of L_dir (the host gives the point lights no share of the
//! kinds' pmf) and estimates the point-light sum by resampled importance sampling:
//! M candidates X_i from the power pmf p, each with resampling weight w_i = p̂(X_i) / (M p(X_i))
//! (GRIS Eq. 5.2 with m_i = 1 / M), one kept by a streaming weighted reservoir (Sec. 6.2) and
//! contributing f(Y) W with the unbiased contribution weight W = (sum_i w_i) / p̂(Y).
//!
//! The target p̂(k) = I_k phase / d_k^2 * clamp(T̂_k, floor, 1) with T̂_k a jackknife (Eq. 4)
//! of small N, ratio tracking, or 1: p̂ > 0 wherever f_k > 0 (the floor; the jackknife may be
//! <= 0 or > 1), so the estimate is unbiased for any T̂. T̂_k's random numbers are keyed by
//! (pixel, sample, light): p̂ is a fixed function of the light and those numbers, the same each
//! time it is evaluated (spatial reuse re-evaluates it in other pixels' domains). f(Y) takes its
//! transmittance from the render's `--estimator`, independent of the candidates.
//!
//! Between the candidates and the resolve, `restir_passes` spatial reuse passes resample each
//! pixel's reservoir with its neighbours' ([`super::restir_reuse`]).

use super::direct::{
    add_shadowed, shadow_pair_or_ratio, start_at_vertex, DirectState, ShadowQuery,
};
use crate::geometry::{Ray, V3};
use crate::params::{Config, Estimator, Importance, Jitter, RenderParams, RestirTarget};
use crate::rgb::Rgb;
use crate::rng::{pcg_hash, HashRng};
use crate::sampling::lighting::Scene;
use crate::sampling::lights::{sample_power, unshadowed};
use crate::sampling::sampler::SampleDims;
use crate::tally::Tally;
use crate::volume::grid::VolumeView;
use crate::volume::texels::Texels;
use bytemuck::{Pod, Zeroable};

/// Salt of the target's per-light random numbers.
const TARGET_SALT: u32 = 0x2b7e_1516;

/// A streaming weighted reservoir over point lights (GRIS Sec. 6.2): the kept light Y, the sum
/// of the resampling weights, p̂(Y) and the number of candidates seen.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Reservoir {
    pub y: u32,
    pub w_sum: f32,
    pub p_hat: f32,
    pub m: u32,
}

impl Reservoir {
    /// Streams one candidate with resampling weight w (kept with probability w / w_sum, by u).
    #[inline]
    pub fn update(self, k: u32, w: f32, p_hat: f32, u: f32) -> Reservoir {
        let w_sum = self.w_sum + w;
        let keep = w > 0.0 && u * w_sum < w;
        Reservoir {
            y: if keep { k } else { self.y },
            w_sum,
            p_hat: if keep { p_hat } else { self.p_hat },
            m: self.m + 1,
        }
    }

    /// The unbiased contribution weight W = w_sum / p̂(Y) (GRIS Eq. 5.3; 0 if nothing was kept).
    #[inline]
    pub fn contribution_weight(&self) -> f32 {
        if self.p_hat > 0.0 && self.w_sum > 0.0 {
            self.w_sum / self.p_hat
        } else {
            0.0
        }
    }
}

/// One camera sample of `restir` between its stages (260 bytes): `direct`'s state (background,
/// map/sun light sample, phase sample), the vertex, two reservoirs and the resampled light's
/// query. The GPU runs the start, each candidate, each reuse pass, the resolve and each estimate
/// as a dispatch.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RestirState {
    pub direct: DirectState,
    /// The resampled point light's shadow query (weight f(Y) W / T, albedo included).
    pub query: ShadowQuery,
    /// The scattering vertex and the direction toward the camera.
    pub x: V3,
    pub wo: V3,
    /// 1 if the free flight collided (there is a vertex).
    pub found: u32,
    /// The candidates' reservoir (then the output of odd reuse passes).
    pub reservoir: Reservoir,
    /// The output of even reuse passes (0, 2, ...; the input of odd ones).
    pub reused: Reservoir,
}

impl RestirState {
    /// The reservoir that reuse pass `pass` reads: even passes the candidates' reservoir, odd
    /// passes the reused one; after P passes, `input(P)` is the last pass's output (what the
    /// resolve reads).
    #[inline]
    pub fn input(&self, pass: u32) -> Reservoir {
        if pass & 1 == 0 {
            self.reservoir
        } else {
            self.reused
        }
    }
}

/// The stages of one sample: start, M candidates, P reuse passes, resolve, four estimates.
#[inline]
pub fn stage_count(params: &RenderParams) -> u32 {
    params.restir.candidates + params.restir.passes + 6
}

/// Whether stage `stage` is a reuse pass (stages M + 1 ..= M + P), which reads the other
/// pixels' states ([`super::restir_reuse::reuse`]; [`restir_stage`] leaves it alone).
#[inline]
pub fn is_reuse_stage(params: &RenderParams, stage: u32) -> bool {
    stage > params.restir.candidates && stage <= params.restir.candidates + params.restir.passes
}

/// Stage kinds of a sample, in stage order (the value of the wavefront kernel's stage
/// specialization constant, so that one pipeline compiles one kind's code).
pub const KIND_START: u32 = 0;
/// Streams one light candidate (stages 1..=M).
pub const KIND_CANDIDATE: u32 = 1;
/// Spatial reuse (stages M + 1 ..= M + P).
pub const KIND_REUSE: u32 = 2;
/// Resolves the reservoir (stage M + P + 1).
pub const KIND_RESOLVE: u32 = 3;
/// Estimates one transmittance query (the last four stages).
pub const KIND_QUERY: u32 = 4;

/// The kind of stage `stage` (one of the `KIND_*` constants).
#[inline]
pub fn stage_kind(params: &RenderParams, stage: u32) -> u32 {
    let m = params.restir.candidates;
    let p = params.restir.passes;
    if stage == 0 {
        KIND_START
    } else if stage <= m {
        KIND_CANDIDATE
    } else if stage <= m + p {
        KIND_REUSE
    } else if stage == m + p + 1 {
        KIND_RESOLVE
    } else {
        KIND_QUERY
    }
}

/// The reuse pass of reuse stage `stage` (0-based).
#[inline]
pub fn reuse_pass(params: &RenderParams, stage: u32) -> u32 {
    stage - params.restir.candidates - 1
}

/// Radiance along one camera ray (RGB), its tally and the generator: every stage in one call
/// (the CPU backend without reuse; reuse passes need the other pixels and are skipped here).
#[allow(clippy::too_many_arguments)]
pub fn restir_radiance(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    id: u32,
    sample: u32,
    world: &Ray,
    rng: HashRng,
) -> (Rgb, Tally, HashRng) {
    let dims = SampleDims::new(params, id, sample);
    let mut st = restir_start(vol, cfg, params, scene, world, dims, rng);
    // The M candidate stages at once: the same numbers, without moving the whole state through
    // each.
    st = stream_candidates(
        vol,
        cfg,
        params,
        scene,
        id,
        sample,
        st,
        params.restir.candidates,
    );
    let mut stage = params.restir.candidates + 1;
    while stage < stage_count(params) {
        st = restir_stage(vol, cfg, params, scene, id, sample, st, stage);
        stage += 1;
    }
    let d = &st.direct;
    (d.total, d.tally(), HashRng { state: d.rng })
}

/// Stage 0: `direct`'s start (free flight, map/sun light sample, phase sample, leading with
/// `dims`' patterns) and the vertex.
pub fn restir_start(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    world: &Ray,
    dims: SampleDims,
    rng: HashRng,
) -> RestirState {
    let (direct, found, x) = start_at_vertex(vol, cfg, params, scene, world, dims, rng);
    RestirState {
        direct,
        query: ShadowQuery::NONE,
        x,
        wo: world.d * -1.0,
        found: found as u32,
        ..Default::default()
    }
}

/// Stage `stage` >= 1: candidate stage - 1 (stages 1..=M), the resolve (M + P + 1), or the
/// transmittance of query stage - M - P - 2 (0..2 `direct`'s, 3 the resampled light's); a
/// reuse stage (M + 1 ..= M + P) returns `st` (it needs the image: [`is_reuse_stage`]).
#[allow(clippy::too_many_arguments)]
pub fn restir_stage(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    id: u32,
    sample: u32,
    st: RestirState,
    stage: u32,
) -> RestirState {
    let kind = stage_kind(params, stage);
    restir_stage_of_kind(vol, cfg, params, scene, id, sample, st, stage, kind)
}

/// [`restir_stage`] with its kind ([`stage_kind`]) given: branching on the kind, so that a
/// kernel specialized to one kind holds only that kind's code.
#[allow(clippy::too_many_arguments)]
pub fn restir_stage_of_kind(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    id: u32,
    sample: u32,
    st: RestirState,
    stage: u32,
    kind: u32,
) -> RestirState {
    if kind == KIND_CANDIDATE {
        candidate_stage(vol, cfg, params, scene, id, sample, st)
    } else if kind == KIND_RESOLVE {
        resolve_stage(scene, params, st)
    } else if kind == KIND_QUERY {
        query_stage(vol, cfg, params, scene, st, stage)
    } else {
        st
    }
}

/// A [`KIND_QUERY`] stage `stage`: transmittance query stage - M - P - 2.
#[inline]
pub fn query_stage(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    st: RestirState,
    stage: u32,
) -> RestirState {
    let first = params.restir.candidates + params.restir.passes + 2;
    estimate_query(vol, cfg, params, scene, st, stage - first)
}

/// A [`KIND_CANDIDATE`] stage: one candidate, a light by power, its target p̂ and resampling
/// weight p̂ / (M p), streamed into the reservoir.
pub fn candidate_stage(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    id: u32,
    sample: u32,
    st: RestirState,
) -> RestirState {
    stream_candidates(vol, cfg, params, scene, id, sample, st, 1)
}

/// `count` candidates streamed into the state's reservoir, on the reservoir and generator alone
/// (the CPU streams all M at once, the GPU one per stage: the same numbers). Each draws a light
/// by power, evaluates its target p̂ and streams it with resampling weight p̂ / (M p); the
/// targets' lookups are cost, their regime and cap flags are not (p̂ only shapes the variance,
/// never the estimate's expectation).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn stream_candidates(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    id: u32,
    sample: u32,
    st: RestirState,
    count: u32,
) -> RestirState {
    if st.found == 0 || scene.point_count == 0 {
        return st;
    }
    let mut r = st.reservoir;
    let mut rng = HashRng {
        state: st.direct.rng,
    };
    let mut lookups = 0;
    let mut i = 0;
    while i < count {
        let (u0, next) = rng.next_f32();
        let (u1, next) = next.next_f32();
        let (u2, next) = next.next_f32();
        rng = next;
        let (k, inv_pmf) = sample_power(scene.points, scene.point_count, u0, u1);
        let (p_hat, tally) = p_hat(vol, cfg, params, scene, id, sample, st.x, st.wo, k);
        let w = p_hat * inv_pmf / params.restir.candidates as f32;
        r = r.update(k, w, p_hat, u2);
        lookups += tally.lookups;
        i += 1;
    }
    let mut st = st;
    st.reservoir = r;
    st.direct.rng = rng.state;
    st.direct
        .set_tally(st.direct.tally().merge(Tally::lookups(lookups)));
    st
}

/// The target p̂ of light k at vertex x (luminance): I phase / d^2 times the clamped T̂, whose
/// random numbers depend on (pixel, sample, light) only. Returns (p̂, the tally of T̂).
#[allow(clippy::too_many_arguments)]
pub fn p_hat(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    id: u32,
    sample: u32,
    x: V3,
    wo: V3,
    k: u32,
) -> (f32, Tally) {
    let (w, dist, f) = unshadowed(&scene.points[k as usize], x, wo, params.hg_g);
    let target = RestirTarget::from_u32(params.restir.target);
    if target == RestirTarget::Unshadowed || !(dist > 0.0) {
        return (f, Tally::default());
    }
    let est = Config {
        estimator: if target == RestirTarget::Ratio {
            Estimator::RatioTracking
        } else {
            Estimator::Jackknife
        },
        importance: Importance::VarianceAware,
        jitter: Jitter::Stratified,
        roulette: false,
        ..*cfg
    };
    let small = RenderParams {
        n: params.restir.n,
        ..*params
    };
    let toward = ShadowQuery {
        o: x,
        w,
        dist,
        weight: Rgb::ZERO,
    };
    let rng = HashRng::for_sample(id, sample, params.seed ^ pcg_hash(k ^ TARGET_SALT));
    let (t_hat, tally, _) = shadow_pair_or_ratio(vol, &est, &small, &toward, rng);
    let clamped = if t_hat > 1.0 {
        1.0
    } else if t_hat > params.restir.floor {
        t_hat
    } else {
        params.restir.floor
    };
    (f * clamped, tally)
}

/// A [`KIND_RESOLVE`] stage (M + P + 1): the kept light's unshadowed contribution and its shadow
/// query, with weight albedo tint I phase / d^2 W (its T to come), from the reservoir of the last
/// reuse pass.
pub fn resolve_stage(scene: &Scene, params: &RenderParams, st: RestirState) -> RestirState {
    let kept = st.input(params.restir.passes);
    let big_w = kept.contribution_weight();
    if st.found == 0 || !(big_w > 0.0) {
        return st;
    }
    let light = scene.points[kept.y as usize];
    let (w, dist, f) = unshadowed(&light, st.x, st.wo, params.hg_g);
    if !(dist > 0.0) {
        return st;
    }
    let v = f * big_w;
    let mut st = st;
    st.query = ShadowQuery {
        o: st.x,
        w,
        dist,
        weight: (light.tint * v).mul_rgb(scene.lighting.albedo),
    };
    st
}

/// Stages M + P + 2 .. M + P + 5: the transmittance of query q (0..2 `direct`'s, 3 the resampled
/// light's) added to the radiance, through one call of [`add_shadowed`] (one inlined copy of the
/// estimators in `restir_query_cs`).
fn estimate_query(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    st: RestirState,
    q: u32,
) -> RestirState {
    let (query, map) = if q < 3 {
        let d = &st.direct;
        (d.queries[q as usize], q == 1 && d.map_query != 0)
    } else {
        (st.query, false)
    };
    let mut st = st;
    st.direct = add_shadowed(vol, cfg, params, scene, st.direct, &query, map);
    st
}
