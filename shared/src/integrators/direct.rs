//! Direct illumination in a volume (the paper's Fig. 1; Sec. 2: transmittance of shadow rays in a
//! renderer): a free-flight vertex on the camera ray, light sampling of the map, the sun and the
//! point lights combined with phase sampling by the balance heuristic, and every shadow ray's
//! transmittance from the chosen estimator. The background seen through the volume is
//! attenuated by the same estimator.
//!
//! Camera ray x(t) = o + t d over [ta, tb] in the grid:
//! L = T̂(ta, tb) L_bg(d) + 1[collision at t] albedo L_s(x(t)), where delta tracking draws t with
//! density mu(t) T(t), so the second term estimates the in-scattered integral. L_s(x) is one
//! light sample plus one phase sample, each weighted by p / (p_light + p_phase) (T is common to
//! both strategies and cancels from the weights).
//!
//! The three transmittance estimates (background, light sample, phase sample) go through one
//! call site of [`estimate::transmittance`] ([`add_shadowed`], which `restir`'s resampled light
//! shares), so the kernel holds the estimators once; on the GPU each runs in its own dispatch ([`DirectState`]). With
//! `--shadows msm4|msm6` a light sample of the sun takes its transmittance from the sun's moment
//! shadow map instead (`map_shadow`); every other query keeps its shadow ray.

use crate::estimators::estimate;
use crate::estimators::inverted_tracking::vertex_flight;
use crate::geometry::{to_index_space, Ray, V3};
use crate::params::{Config, Estimator, RenderParams};
use crate::rgb::Rgb;
use crate::rng::HashRng;
use crate::sampling::lighting::{LightKind, Scene};
use crate::sampling::lights::{sample_power, unshadowed};
use crate::sampling::phase::{phase_hg, sample_hg};
use crate::sampling::sampler::{Lead, SampleDims, VertexPattern};
use crate::shadows::map::{map_transmittance, Shadows};
use crate::tally::Tally;
use crate::volume::dda::clip_to_box;
use crate::volume::grid::VolumeView;
use crate::volume::texels::Texels;
use bytemuck::{Pod, Zeroable};

/// Salt of the stochastic-lookup jitter key of the camera ray's free flight.
const FLIGHT_SALT: u32 = 0x6c8e_9cf5;

/// A transmittance still to be estimated: the world ray from `o` along unit `w` up to `dist`,
/// and what its transmittance multiplies.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ShadowQuery {
    pub o: V3,
    pub w: V3,
    pub dist: f32,
    pub weight: Rgb,
}

/// One camera sample of `direct` between its stages (160 bytes): the three transmittance
/// queries (background, light sample, phase sample), the radiance so far, the generator and the
/// tally. The GPU runs [`direct_start`] and each [`direct_estimate`] as its own dispatch, so one
/// invocation holds at most one tracking loop or one estimate.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DirectState {
    pub queries: [ShadowQuery; 3],
    pub total: Rgb,
    pub rng: u32,
    pub lookups: u32,
    pub capped: u32,
    pub outside: u32,
    /// 1 if a moment-shadow-map lookup fell back ([`Tally::fallback`]).
    pub fallback: u32,
    /// 1 if query 1 (the light sample) went to the sun and takes its transmittance from the
    /// moment shadow map.
    pub map_query: u32,
    pub _pad: u32,
}

impl DirectState {
    /// The tally so far.
    #[inline]
    pub fn tally(&self) -> Tally {
        Tally {
            lookups: self.lookups,
            capped: self.capped,
            outside: self.outside,
            fallback: self.fallback,
        }
    }

    /// Stores a tally.
    #[inline]
    pub(super) fn set_tally(&mut self, t: Tally) {
        self.lookups = t.lookups;
        self.capped = t.capped;
        self.outside = t.outside;
        self.fallback = t.fallback;
    }
}

impl ShadowQuery {
    /// A query that contributes nothing (no ray is traced for it).
    pub const NONE: ShadowQuery = ShadowQuery {
        o: V3::new(0.0, 0.0, 0.0),
        w: V3::new(0.0, 0.0, 1.0),
        dist: 0.0,
        weight: Rgb::ZERO,
    };
}

/// Radiance along one world-space camera ray (RGB), its tally and the generator: the start and
/// the three estimates of [`DirectState`] in one call (the CPU backend).
pub fn direct_radiance(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    world: &Ray,
    dims: SampleDims,
    rng: HashRng,
) -> (Rgb, Tally, HashRng) {
    let mut st = direct_start(vol, cfg, params, scene, world, dims, rng);
    let mut k = 0;
    while k < 3 {
        st = direct_estimate(vol, cfg, params, scene, st, k);
        k += 1;
    }
    (st.total, st.tally(), HashRng { state: st.rng })
}

/// Stage 1 of a camera sample: the free flight, the light and phase samples at its vertex, and
/// the three queries (the background's weight is the radiance behind the volume). The free
/// flight, light and phase samples lead with `dims`' patterns of vertex 0.
pub fn direct_start(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    world: &Ray,
    dims: SampleDims,
    rng: HashRng,
) -> DirectState {
    start_at_vertex(vol, cfg, params, scene, world, dims, rng).0
}

/// [`direct_start`], and whether the free flight collided and where (the scattering vertex).
pub(super) fn start_at_vertex(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    world: &Ray,
    dims: SampleDims,
    rng: HashRng,
) -> (DirectState, bool, V3) {
    let background = scene.directional_radiance(world.d);
    let ray = to_index_space(world, &params.world_to_index);
    let (ta, tb) = clip_to_box(&ray, grid_hi(vol), 0.0, f32::INFINITY);
    let mut st = DirectState {
        rng: rng.state,
        ..Default::default()
    };
    if !(ta < tb) {
        st.total = background;
        return (st, false, V3::new(0.0, 0.0, 0.0));
    }
    let (ff, rng) = vertex_flight(
        vol,
        &ray,
        ta,
        tb,
        cfg.lookup,
        FLIGHT_SALT,
        cfg.max_collisions,
        dims.lead_2d(SampleDims::vertex(0, VertexPattern::Flight)),
        rng,
    );
    st.set_tally(ff.tally);
    st.queries[0] = ShadowQuery {
        o: world.o,
        w: world.d,
        dist: f32::INFINITY,
        weight: background,
    };
    let mut rng = rng;
    let x = world.at(ff.t);
    if ff.found {
        let wo = world.d * -1.0;
        let albedo = scene.lighting.albedo;
        let (light, to_sun, r) = light_sample(scene, params.hg_g, x, wo, dims.lights(0), rng);
        st.map_query = (to_sun && scene.lighting.shadows != 0) as u32;
        let phase_lead = dims.lead_2d(SampleDims::vertex(0, VertexPattern::Phase));
        let (phase, r) = phase_sample(scene, params.hg_g, x, wo, phase_lead, r);
        rng = r;
        st.queries[1] = ShadowQuery {
            weight: light.weight.mul_rgb(albedo),
            ..light
        };
        st.queries[2] = ShadowQuery {
            weight: phase.weight.mul_rgb(albedo),
            ..phase
        };
    }
    st.rng = rng.state;
    (st, ff.found, x)
}

/// Stage 2 + k of a camera sample: the transmittance of query k (if it carries weight), added
/// to the radiance.
pub fn direct_estimate(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    st: DirectState,
    k: u32,
) -> DirectState {
    let q = st.queries[k as usize];
    add_shadowed(vol, cfg, params, scene, st, &q, k == 1 && st.map_query != 0)
}

/// Adds query q's weight times its transmittance (from the sun's shadow map if `map`, else by
/// the render's estimator) to the sample's radiance, with the state's generator and tally. The
/// one place a wavefront's estimate stage calls [`shadow`] (`restir`'s resampled light too: a
/// kernel inlines each call site of the estimators).
pub(super) fn add_shadowed(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    st: DirectState,
    q: &ShadowQuery,
    map: bool,
) -> DirectState {
    if q.weight.is_black() {
        return st;
    }
    let mut st = st;
    let rng = HashRng { state: st.rng };
    let (tr, t, rng) = if map {
        map_shadow(scene, q, rng)
    } else {
        shadow(vol, cfg, params, q, rng)
    };
    st.rng = rng.state;
    st.set_tally(st.tally().merge(t));
    st.total = st.total + q.weight * tr;
    st
}

/// The box [0, dims] of the grid as a vector.
#[inline]
pub(super) fn grid_hi(vol: &VolumeView<impl Texels>) -> V3 {
    let d = &vol.desc.dims;
    V3::new(d[0] as f32, d[1] as f32, d[2] as f32)
}

/// Transmittance along a query's ray through the grid, by the estimator of the render.
pub(super) fn shadow(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    q: &ShadowQuery,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let (ray, t0, t1) = shadow_segment(vol, params, q);
    if !(t0 < t1) {
        return (1.0, Tally::default(), rng);
    }
    estimate::transmittance(vol, cfg, params, &ray, t0, t1, rng)
}

/// [`shadow`] by the jackknife (or the naive mean) or by ratio tracking only, as `cfg.estimator`
/// says (`restir`'s target T̂): the same numbers as [`shadow`] for those estimators, and a kernel
/// that inlines it at every target evaluation holds none of the others' code.
pub(super) fn shadow_pair_or_ratio(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    q: &ShadowQuery,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let (ray, t0, t1) = shadow_segment(vol, params, q);
    if !(t0 < t1) {
        return (1.0, Tally::default(), rng);
    }
    if cfg.estimator == Estimator::RatioTracking {
        estimate::ratio_transmittance(vol, cfg, &ray, t0, t1, rng)
    } else {
        estimate::pair_transmittance(vol, cfg, params, &ray, t0, t1, rng)
    }
}

/// A query's shadow ray in index space and its segment [t0, t1] inside the grid (empty if
/// t0 >= t1).
#[inline]
pub(super) fn shadow_segment(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    q: &ShadowQuery,
) -> (Ray, f32, f32) {
    let world = Ray { o: q.o, d: q.w };
    let ray = to_index_space(&world, &params.world_to_index);
    let (t0, t1) = clip_to_box(&ray, grid_hi(vol), 0.0, q.dist);
    (ray, t0, t1)
}

/// Transmittance toward the sun at a query's origin from the moment shadow map (no voxel
/// lookups; a reconstruction that fell back is flagged).
pub(super) fn map_shadow(scene: &Scene, q: &ShadowQuery, rng: HashRng) -> (f32, Tally, HashRng) {
    let l = scene.lighting;
    let (tr, fell_back) = map_transmittance(
        &l.shadow_map,
        Shadows::from_u32(l.shadows),
        scene.shadow_map,
        q.o,
    );
    (tr, Tally::default().fallback_if(fell_back), rng)
}

/// Strategy 1 at x (per unit albedo, before T): a light drawn by the pmf over kinds, then a
/// direction (or a point light by power) on it; true if the light is the sun. The kind and the
/// 2D sample lead with `lead`'s two patterns when the sampler is on.
pub(super) fn light_sample(
    scene: &Scene,
    g: f32,
    x: V3,
    wo: V3,
    lead: (Lead, Lead),
    rng: HashRng,
) -> (ShadowQuery, bool, HashRng) {
    let l = scene.lighting;
    let (u_kind, rng) = lead.0.take(0, rng);
    let (u0, rng) = lead.1.take(0, rng);
    let (u1, rng) = lead.1.take(1, rng);
    let kind = scene.select_kind(u_kind);
    let query = match kind {
        LightKind::None => ShadowQuery::NONE,
        LightKind::Points => {
            let (k, inv_pmf) = sample_power(scene.points, scene.point_count, u0, u1);
            let light = scene.points[k as usize];
            let (w, dist, f) = unshadowed(&light, x, wo, g);
            if !(dist > 0.0) {
                ShadowQuery::NONE
            } else {
                let v = f / (l.p_points / inv_pmf);
                ShadowQuery {
                    o: x,
                    w,
                    dist,
                    weight: light.tint * v,
                }
            }
        }
        LightKind::Sun if l.sun.is_delta() => {
            let w = l.sun.dir;
            ShadowQuery {
                o: x,
                w,
                dist: f32::INFINITY,
                weight: l.sun.radiance * (phase_hg(wo.dot(w), g) / l.p_sun),
            }
        }
        LightKind::Sun | LightKind::Env => {
            let w = if kind == LightKind::Sun {
                l.sun.sample(u0, u1).dir
            } else {
                l.env.sample(scene.env, u0, u1).dir
            };
            // The full mixture density and radiance of the direction (map and disk overlap).
            let (radiance, p_light) = scene.directional(w);
            if !(p_light > 0.0) || radiance.is_black() {
                ShadowQuery::NONE
            } else {
                let p_phase = phase_hg(wo.dot(w), g);
                // f / p_light x p_light / (p_light + p_phase), f = phase L T.
                ShadowQuery {
                    o: x,
                    w,
                    dist: f32::INFINITY,
                    weight: radiance * (p_phase / (p_light + p_phase)),
                }
            }
        }
    };
    (query, kind == LightKind::Sun, rng)
}

/// Strategy 2 at x (per unit albedo, before T): a direction drawn from the phase function; it
/// reaches the map and a sun disk.
pub(super) fn phase_sample(
    scene: &Scene,
    g: f32,
    x: V3,
    wo: V3,
    lead: Lead,
    rng: HashRng,
) -> (ShadowQuery, HashRng) {
    let (u0, rng) = lead.take(0, rng);
    let (u1, rng) = lead.take(1, rng);
    let (w, p_phase) = sample_hg(wo, g, u0, u1);
    let (radiance, p_light) = scene.directional(w);
    if radiance.is_black() || !(p_phase > 0.0) {
        return (ShadowQuery::NONE, rng);
    }
    // f / p_phase x p_phase / (p_light + p_phase), f = phase L T and phase = p_phase.
    let query = ShadowQuery {
        o: x,
        w,
        dist: f32::INFINITY,
        weight: radiance * (p_phase / (p_light + p_phase)),
    };
    (query, rng)
}
