//! Multiple scattering (`--integrator path`): a volumetric path tracer with delta-tracking
//! vertices, next-event estimation at every vertex (one light sample, its shadow ray's
//! transmittance by the chosen estimator after roulette by its bound ([`super::shadow_roulette`]),
//! balance-heuristic weighted against phase sampling),
//! Henyey-Greenstein continuation, Russian roulette after `rr_depth` vertices and at most
//! `max_depth` vertices (the ray leaving the last vertex still meets the lights: `max_depth` 1 is
//! direct illumination).
//!
//! One call of [`path_bounce`] advances a path by one vertex, so a GPU invocation runs one
//! free flight and one shadow ray (lavapipe's loop budget); the state between calls is a
//! [`PathState`] in a buffer (wavefront). The continuation's transmittance is the next free
//! flight's escape; an escape after a phase sample meets the map and the sun disk with the MIS
//! weight p_phase / (p_phase + p_light), the counterpart of the light sample's.

use super::direct::{light_sample, map_shadow};
use super::shadow_roulette::rouletted_shadow;
use crate::estimators::inverted_tracking::vertex_flight;
use crate::geometry::{to_index_space, Ray, V3};
use crate::params::{Config, RenderParams};
use crate::rgb::Rgb;
use crate::rng::HashRng;
use crate::sampling::lighting::Scene;
use crate::sampling::phase::sample_hg;
use crate::sampling::sampler::{SampleDims, VertexPattern};
use crate::tally::Tally;
use crate::volume::dda::clip_to_box;
use crate::volume::grid::VolumeView;
use crate::volume::texels::Texels;
use bytemuck::{Pod, Zeroable};

/// Salt of the stochastic-lookup jitter key of the path's free flights.
const FLIGHT_SALT: u32 = 0x2f6b_3c1d;
/// Smallest survival probability of Russian roulette.
const MIN_SURVIVAL: f32 = 0.05;

/// One path between bounces (88 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PathState {
    /// Origin of the next flight (world space).
    pub o: V3,
    /// Vertices so far.
    pub depth: u32,
    /// Unit direction of the next flight.
    pub d: V3,
    /// 1 while the path continues.
    pub alive: u32,
    /// Throughput so far (albedo products and roulette weights).
    pub throughput: Rgb,
    /// Density of the phase sample that chose `d` (0 for the camera ray: no MIS on escape).
    pub p_phase: f32,
    /// Radiance gathered so far.
    pub radiance: Rgb,
    /// The path's generator state.
    pub rng: u32,
    /// Lookups, capped and out-of-regime estimates of the whole path.
    pub lookups: u32,
    pub capped: u32,
    pub outside: u32,
    /// 1 if a moment-shadow-map lookup of the path fell back.
    pub fallback: u32,
    /// The sampler's pixel seed and the sample's index ([`SampleDims`]).
    pub pixel_seed: u32,
    pub sample: u32,
}

impl PathState {
    /// The tally of the path.
    #[inline]
    pub fn tally(&self) -> Tally {
        Tally {
            lookups: self.lookups,
            capped: self.capped,
            outside: self.outside,
            fallback: self.fallback,
        }
    }

    /// Merges a tally into the path's ([`Tally::merge`]: lookups add, flags per path).
    #[inline]
    fn count(&mut self, t: Tally) {
        let m = self.tally().merge(t);
        self.lookups = m.lookups;
        self.capped = m.capped;
        self.outside = m.outside;
        self.fallback = m.fallback;
    }
}

/// A path leaving the camera along `world` with generator `rng` and sampler dimensions `dims`.
#[inline]
pub fn path_start(world: &Ray, dims: SampleDims, rng: HashRng) -> PathState {
    PathState {
        o: world.o,
        d: world.d,
        alive: 1,
        throughput: Rgb::splat(1.0),
        rng: rng.state,
        pixel_seed: dims.seed,
        sample: dims.index,
        ..Default::default()
    }
}

/// Advances a live path by one vertex (see the module doc); a finished path is returned as is.
pub fn path_bounce(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    st: PathState,
) -> PathState {
    if st.alive == 0 {
        return st;
    }
    let mut st = st;
    let mut rng = HashRng { state: st.rng };
    // The sampler's patterns of this bounce: its free flight, the vertex it reaches, the
    // continuation from there.
    let dims = SampleDims::from_parts(params, st.pixel_seed, st.sample);
    let v = st.depth;
    let world = Ray { o: st.o, d: st.d };
    let ray = to_index_space(&world, &params.world_to_index);
    let (ta, tb) = clip_to_box(&ray, super::direct::grid_hi(vol), 0.0, f32::INFINITY);
    let mut found = false;
    let mut t = 0.0f32;
    if ta < tb {
        let (ff, r) = vertex_flight(
            vol,
            &ray,
            ta,
            tb,
            cfg.lookup,
            FLIGHT_SALT,
            cfg.max_collisions,
            dims.lead_2d(SampleDims::vertex(v, VertexPattern::Flight)),
            rng,
        );
        rng = r;
        st.count(ff.tally);
        found = ff.found;
        t = ff.t;
    }
    if !found {
        // Escape: the map and the sun disk, MIS-weighted after a phase sample.
        let (l, w) = if st.p_phase > 0.0 {
            let (l, p_light) = scene.directional(st.d);
            (l, st.p_phase / (st.p_phase + p_light))
        } else {
            (scene.directional_radiance(st.d), 1.0)
        };
        st.radiance = st.radiance + l.mul_rgb(st.throughput) * w;
        st.alive = 0;
        st.rng = rng.state;
        return st;
    }
    if st.depth >= params.max_depth {
        // A vertex beyond the last: the path ends (as pbrt-v4's volpath, the escape of the ray
        // after the last vertex still counted above). Its further scattering is cut off, so
        // the path is counted as capped (reported as `capped_rays`, with a warning).
        st.count(Tally::default().capped_if(true));
        st.alive = 0;
        st.rng = rng.state;
        return st;
    }
    let x = world.at(t);
    let wo = st.d * -1.0;
    st.throughput = st.throughput.mul_rgb(scene.lighting.albedo);
    st.depth += 1;
    if st.throughput.is_black() {
        // Albedo 0 in every channel the path still carries: nothing more can reach the camera
        // (pbrt-v4's volpath ends such a path too); its radiance is final.
        st.alive = 0;
        st.rng = rng.state;
        return st;
    }
    // Next-event estimation.
    let (q, to_sun, r) = light_sample(scene, params.hg_g, x, wo, dims.lights(v), rng);
    rng = r;
    if !q.weight.is_black() {
        let (tr, tally, r) = if to_sun && scene.lighting.shadows != 0 {
            map_shadow(scene, &q, rng)
        } else {
            rouletted_shadow(vol, cfg, params, &q, rng)
        };
        rng = r;
        st.count(tally);
        st.radiance = st.radiance + q.weight.mul_rgb(st.throughput) * tr;
    }
    // Continuation: phase sampling (phase / pdf = 1), roulette, depth limit.
    let phase = dims.lead_2d(SampleDims::vertex(v, VertexPattern::Phase));
    let (u0, r) = phase.take(0, rng);
    let (u1, r) = phase.take(1, r);
    let (u2, r) = dims
        .lead_1d(SampleDims::vertex(v, VertexPattern::Roulette))
        .take(0, r);
    rng = r;
    let (wi, p_phase) = sample_hg(wo, params.hg_g, u0, u1);
    st.o = x;
    st.d = wi;
    st.p_phase = p_phase;
    if st.depth >= params.rr_depth {
        let q = max3(st.throughput);
        if q < 1.0 {
            let survive = if q > MIN_SURVIVAL { q } else { MIN_SURVIVAL };
            if u2 < survive {
                st.throughput = st.throughput * (1.0 / survive);
            } else {
                st.alive = 0;
            }
        }
    }
    if !(p_phase > 0.0) {
        st.alive = 0;
    }
    st.rng = rng.state;
    st
}

/// The largest component.
#[inline]
fn max3(c: Rgb) -> f32 {
    let m = if c.r > c.g { c.r } else { c.g };
    if m > c.b {
        m
    } else {
        c.b
    }
}

/// A whole path (the CPU backend; the GPU runs the same `max_depth + 1` bounces, one dispatch
/// each): its radiance and tally.
pub fn path_radiance(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    scene: &Scene,
    start: PathState,
) -> PathState {
    let mut st = start;
    let mut k = 0;
    while k <= params.max_depth && st.alive != 0 {
        st = path_bounce(vol, cfg, params, scene, st);
        k += 1;
    }
    st
}
