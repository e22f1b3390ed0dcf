//! Single scattering from point lights along primary rays (Sec. 5.2): free-flight and
//! equiangular distance sampling, their MIS combinations with jackknife or naive MIS weights
//! (Eq. 9), the biased combined estimate (Eq. 10), Miller et al. 2019 (balance heuristic,
//! ratio-tracking densities) and the power heuristic through Re g (beyond the paper); and
//! direct illumination from an environment map, a sun and point lights in RGB (`direct`), and
//! multiple scattering (`path`).

pub mod budget;
mod context;
pub mod direct;
mod equiangular;
mod free_flight;
mod lighting;
pub mod path;
pub mod resampling_mis;
pub mod restir;
pub mod restir_reuse;
pub mod shadow_roulette;
pub mod stages;
mod strategy;
pub mod unit;
mod weights;

use crate::geometry::{to_index_space, Ray};
use crate::params::{Config, Integrator, RenderParams};
use crate::rng::HashRng;
use crate::sampling::equiangular::Equiangular;
use crate::sampling::lights::{select_light, PointLight};
use crate::tally::Tally;
use crate::volume::dda::clip_to_box;
use crate::volume::grid::VolumeView;
use crate::volume::texels::Texels;
use context::{grid_hi, Context};
use strategy::strategy;

/// Radiance along one world-space camera ray; returns (L, tally, rng) (decodes `params`; a render
/// decodes once per pass and calls [`trace_radiance`]).
pub fn radiance(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    lights: &[PointLight],
    world: &Ray,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    trace_radiance(
        vol,
        &Config::decode(params, &vol.desc),
        params,
        lights,
        world,
        rng,
    )
}

/// [`radiance`] with the enums already decoded.
pub fn trace_radiance(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    lights: &[PointLight],
    world: &Ray,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let ray = to_index_space(world, &params.world_to_index);
    let (ta, tb) = clip_to_box(&ray, grid_hi(vol), 0.0, f32::INFINITY);
    if !(ta < tb) || params.light_count == 0 {
        return (0.0, Tally::default(), rng);
    }
    let (u, rng) = rng.next_f32();
    let (k, p_light) = select_light(lights, params.light_count, world.o, world.d, ta, tb, u);
    let light = lights[k as usize];
    let ctx = Context {
        vol: *vol,
        params,
        cfg,
        world: *world,
        ray,
        ta,
        tb,
        light,
        p_light,
        eq: Equiangular::new(world.o, world.d, light.position, ta, tb),
        lookup: cfg.lookup,
    };
    let which = cfg.integrator;
    let mut total = 0.0f32;
    let mut tally = Tally::default();
    let mut rng = rng;
    // Strategy 0 (equiangular) unless free-flight only, strategy 1 (free flight) unless
    // equiangular only: one loop body, so a kernel holds the strategies' estimators once.
    let mut s = u32::from(which == Integrator::FreeFlight);
    let last = u32::from(which != Integrator::Equiangular);
    while s <= last {
        let (l, t, r) = strategy(&ctx, which, s, rng);
        total += l;
        tally = tally.merge(t);
        rng = r;
        s += 1;
    }
    (total, tally, rng)
}
