//! Primary-ray transmittance images (like the paper's Fig. 8) and radiance images of the
//! integrators: one pure function per pixel.

use crate::estimators::estimate;
use crate::geometry::{to_index_space, Ray, V3};
use crate::integrators::direct::{direct_estimate, direct_radiance, direct_start, DirectState};
use crate::integrators::path::{path_bounce, path_radiance, path_start, PathState};
pub use crate::integrators::restir::{is_reuse_stage, stage_kind as restir_stage_kind};

/// Whether a `restir` stage of kind `kind` is a reuse pass (reads the other pixels' states).
#[inline]
pub fn is_reuse_kind(kind: u32) -> bool {
    kind == KIND_REUSE
}
use crate::integrators::restir::{
    candidate_stage, query_stage, resolve_stage, restir_radiance, restir_stage_of_kind,
    restir_start, reuse_pass, stage_count, RestirState, KIND_REUSE, KIND_START,
};
use crate::integrators::restir_reuse::reuse;
use crate::integrators::restir_reuse::store_reuse;
use crate::integrators::stages::Wavefront;
use crate::integrators::unit::Family;
use crate::params::{Config, Estimator, Integrator, RenderParams, Sampler};
use crate::rgb::Rgb;
use crate::rng::HashRng;
use crate::sampling::lighting::Scene;
use crate::sampling::lights::PointLight;
use crate::sampling::sampler::{SampleDims, PIXEL};
use crate::tally::Tally;
use crate::volume::dda::clip_to_box;
use crate::volume::grid::VolumeView;
use crate::volume::texels::Texels;
use bytemuck::{Pod, Zeroable};

/// Per-pixel result: mean transmittance over spp and the high-resolution lookups taken.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PixelOut {
    pub t_mean: f32,
    /// Mean of the squared estimates (for the per-pixel standard deviation).
    pub t2_mean: f32,
    pub samples: u32,
    /// Samples (rays) of this pixel whose estimate a loop bound changed ([`Tally::capped`]).
    pub capped: u32,
    /// Samples with a jackknife estimate outside its regime ([`Tally::outside`]).
    pub outside: u32,
    /// Samples whose moment-shadow-map reconstruction fell back ([`Tally::fallback`]).
    pub fallback: u32,
    /// Mean RGB radiance (the `direct` integrator; the scalar integrators repeat `t_mean`).
    pub rgb_mean: Rgb,
}

/// Transmittance estimate of one world-space ray through the whole volume, and its tally
/// (decodes `params`; a render decodes once per pass and calls [`trace_transmittance`]).
#[inline]
pub fn ray_transmittance(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    world: &Ray,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    trace_transmittance(vol, &Config::decode(params, &vol.desc), params, world, rng)
}

/// [`ray_transmittance`] with the enums already decoded.
#[inline]
pub fn trace_transmittance(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    world: &Ray,
    rng: HashRng,
) -> (f32, Tally, HashRng) {
    let (ray, t0, t1) = index_segment(vol, params, world);
    if !(t0 < t1) {
        return (1.0, Tally::default(), rng);
    }
    estimate::transmittance(vol, cfg, params, &ray, t0, t1, rng)
}

/// Camera ray `world` in index space and its segment [t0, t1] inside the grid (empty, t0 >=
/// t1, when it misses).
#[inline]
pub fn index_segment(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    world: &Ray,
) -> (Ray, f32, f32) {
    let ray = to_index_space(world, &params.world_to_index);
    let d = &vol.desc.dims;
    let hi = V3::new(d[0] as f32, d[1] as f32, d[2] as f32);
    let (t0, t1) = clip_to_box(&ray, hi, 0.0, f32::INFINITY);
    (ray, t0, t1)
}

/// Samples per block: a pixel's sums start from zero at every multiple of this sample index,
/// and a render adds its blocks' sums exactly (the host's exact accumulator), so a render cut
/// into shards at block boundaries adds up to the bytes of one render. A power of two.
pub const SAMPLE_BLOCK: u32 = 256;

/// Whether sample `s` is the first of its block (its pixel's sums start from zero there).
#[inline]
pub fn starts_block(s: u32) -> bool {
    s & (SAMPLE_BLOCK - 1) == 0
}

/// Running sums of one pixel's estimates (accumulated over render passes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PixelSums {
    pub t_sum: f32,
    pub t2_sum: f32,
    pub samples: u32,
    /// Samples whose estimate a loop bound changed.
    pub capped: u32,
    /// Samples with a jackknife estimate outside its regime.
    pub outside: u32,
    /// Samples whose moment-shadow-map reconstruction fell back.
    pub fallback: u32,
    /// Sum of the RGB estimates (`t_sum` holds their luminance; scalar integrators: T, T, T).
    pub rgb_sum: Rgb,
}

/// Push constants of the render kernel: the launch header, then the pass's sample range.
///
/// Passes keep each invocation's work short: lavapipe (gallivm) silently ends any shader loop
/// after 65535 iterations, so a whole-spp loop in one invocation gave wrong images.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RenderPass {
    pub launch: crate::kernels::launch::Launch,
    /// First sample index of this pass.
    pub s_begin: u32,
    /// One past the last sample index of this pass.
    pub s_end: u32,
    /// Pixel id held by element 0 of the sums buffer: images larger than one storage buffer
    /// are rendered tile by tile, each tile into its own buffer.
    pub sums_base: u32,
    pub _pad: u32,
}

/// The camera ray of sample s of pixel `id` (row-major) and the sample's generator, after the
/// two pixel-jitter draws (the jitter is the sampler's pixel pattern when it is on; the
/// generator draws the same two numbers either way).
#[inline]
pub fn camera_ray(params: &RenderParams, id: u32, s: u32) -> (Ray, HashRng) {
    let (y, x) = crate::math::div_rem_small(id, params.width);
    let rng = HashRng::for_sample(id, s, params.seed);
    let (jx, rng) = rng.next_f32();
    let (jy, rng) = rng.next_f32();
    let (jx, jy) = if params.sampler == Sampler::Sobol as u32 {
        let j = SampleDims::new(params, id, s).get_2d(PIXEL);
        (j[0], j[1])
    } else {
        (jx, jy)
    };
    let (jx, jy) = if params.pixel_jitter == 0 {
        (0.5, 0.5)
    } else {
        (jx, jy)
    };
    let world = params
        .camera
        .world_ray(x, y, jx, jy, params.width, params.height);
    (world, rng)
}

impl PixelSums {
    /// Adds one sample: its RGB value, the scalar `t` whose moments are kept, and its tally.
    #[inline]
    pub fn add(self, rgb: Rgb, t: f32, tally: Tally) -> PixelSums {
        PixelSums {
            t_sum: self.t_sum + t,
            t2_sum: self.t2_sum + t * t,
            samples: self.samples + tally.lookups,
            capped: self.capped + tally.capped,
            outside: self.outside + tally.outside,
            fallback: self.fallback + tally.fallback,
            rgb_sum: self.rgb_sum + rgb,
        }
    }
}

/// Adds samples s_begin..s_end of pixel `id` (row-major) to `prev`: one pass of a transmittance
/// or single-scattering render, as the GPU's `transmittance_cs` or `scattering_cs` runs it.
/// Accumulating pass after pass gives exactly the sums of one loop over all samples.
pub fn render_pixel_pass(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    lights: &[PointLight],
    id: u32,
    s_begin: u32,
    s_end: u32,
    prev: PixelSums,
) -> PixelSums {
    if params.integrator == 0 {
        transmittance_pixel_pass(vol, params, id, s_begin, s_end, prev)
    } else {
        scattering_pixel_pass(vol, params, lights, id, s_begin, s_end, prev)
    }
}

/// Adds samples s_begin..s_end of pixel `id` to `prev` by `params`' integrator, every stage of a
/// sample in one call: the CPU backend's pass for every family (a GPU runs a lit integrator's
/// stages as dispatches, and transmittance and single scattering as [`render_pixel_pass`]).
pub fn cpu_pixel_pass(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    scene: &Scene,
    id: u32,
    s_begin: u32,
    s_end: u32,
    prev: PixelSums,
) -> PixelSums {
    match Integrator::from_u32(params.integrator).family() {
        Family::Lit(Wavefront::Direct) => {
            direct_pixel_pass(vol, params, scene, id, s_begin, s_end, prev)
        }
        Family::Lit(Wavefront::Path) => {
            path_pixel_pass(vol, params, scene, id, s_begin, s_end, prev)
        }
        Family::Lit(Wavefront::Restir) => {
            restir_pixel_pass(vol, params, scene, id, s_begin, s_end, prev)
        }
        Family::Transmittance | Family::SingleScattering => {
            render_pixel_pass(vol, params, scene.points, id, s_begin, s_end, prev)
        }
    }
}

/// The sample loop of a scalar image: adds samples s_begin..s_end of pixel `id` to `prev`, each
/// sample's value from `$trace` with `$world` and `$rng` bound to its camera ray and generator.
/// A macro, not a function taking the tracer as a closure: that closure (its captured references)
/// made lavapipe's LLVM compile of each `scattering_cs` pipeline 15x slower (314 s instead of
/// 21 s for `free-flight`, measured).
macro_rules! sample_loop {
    ($params:expr, $id:expr, $s_begin:expr, $s_end:expr, $prev:expr,
     |$world:ident, $rng:ident| $trace:expr) => {{
        let mut acc = $prev;
        let mut s = $s_begin;
        while s < $s_end {
            let ($world, $rng) = camera_ray($params, $id, s);
            let (t, tally, _) = $trace;
            acc = acc.add(Rgb::splat(t), t, tally);
            s += 1;
        }
        acc
    }};
}

/// [`render_pixel_pass`] of a primary-ray transmittance image (`transmittance_cs`).
pub fn transmittance_pixel_pass(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    id: u32,
    s_begin: u32,
    s_end: u32,
    prev: PixelSums,
) -> PixelSums {
    let cfg = Config::decode(params, &vol.desc);
    if cfg.estimator == Estimator::FirstCollision {
        return depth_pixel_pass(vol, &cfg, params, id, s_begin, s_end, prev);
    }
    sample_loop!(params, id, s_begin, s_end, prev, |world, rng| {
        trace_transmittance(vol, &cfg, params, &world, rng)
    })
}

/// Adds samples s_begin..s_end of the first collision of pixel `id`'s camera rays (the `depth`
/// layer's pass): per sample (t, 1, 0) to the RGB sums for a collision at distance t from the
/// camera (world units), (0, 0, 0) for none; t to the scalar moments.
fn depth_pixel_pass(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    id: u32,
    s_begin: u32,
    s_end: u32,
    prev: PixelSums,
) -> PixelSums {
    let mut acc = prev;
    let mut s = s_begin;
    while s < s_end {
        let (world, rng) = camera_ray(params, id, s);
        let (t, hit, tally) = first_collision(vol, cfg, params, &world, rng);
        acc = acc.add(Rgb::new(t, hit, 0.0), t, tally);
        s += 1;
    }
    acc
}

/// The first collision of camera ray `world` by delta tracking (track-length's, with its
/// collision cap): its distance from the ray's origin and 1, or (0, 0) when the ray leaves the
/// volume first.
#[inline]
pub fn first_collision(
    vol: &VolumeView<impl Texels>,
    cfg: &Config,
    params: &RenderParams,
    world: &Ray,
    rng: HashRng,
) -> (f32, f32, Tally) {
    let (ray, t0, t1) = index_segment(vol, params, world);
    if !(t0 < t1) {
        return (0.0, 0.0, Tally::default());
    }
    let (flight, _) = crate::estimators::tracking::delta_tracking_capped(
        vol,
        &ray,
        t0,
        t1,
        cfg.lookup,
        crate::estimators::tracking::JITTER_SALT,
        cfg.max_collisions,
        true,
        rng,
    );
    if flight.found {
        (flight.t, 1.0, flight.tally)
    } else {
        (0.0, 0.0, flight.tally)
    }
}

/// [`render_pixel_pass`] of a single-scattering image (`scattering_cs`).
pub fn scattering_pixel_pass(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    lights: &[PointLight],
    id: u32,
    s_begin: u32,
    s_end: u32,
    prev: PixelSums,
) -> PixelSums {
    let cfg = Config::decode(params, &vol.desc);
    sample_loop!(params, id, s_begin, s_end, prev, |world, rng| {
        crate::integrators::trace_radiance(vol, &cfg, params, lights, &world, rng)
    })
}

/// [`render_pixel_pass`] of the `direct` integrator on the CPU (the GPU runs the same stages as
/// dispatches, [`direct_wave_step`]): RGB radiance, its luminance's moments.
pub fn direct_pixel_pass(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    scene: &Scene,
    id: u32,
    s_begin: u32,
    s_end: u32,
    prev: PixelSums,
) -> PixelSums {
    let cfg = Config::decode(params, &vol.desc);
    radiance_pass(params, id, s_begin, s_end, prev, |s, world, rng| {
        let dims = SampleDims::new(params, id, s);
        direct_radiance(vol, &cfg, params, scene, world, dims, rng)
    })
}

/// The sums of a pixel when sample `sample` starts: zero at the first sample of a block (the
/// buffer holds the previous block's or render's), else `*sums`. By reference, so a kernel reads
/// its buffer only where the pass continues a block (lavapipe runs a masked read as a loop over
/// its lanes).
#[inline]
pub fn sums_before(sample: u32, sums: &PixelSums) -> PixelSums {
    if starts_block(sample) {
        PixelSums::default()
    } else {
        *sums
    }
}

/// Adds samples s_begin..s_end of pixel `id` to `prev`, each sample's RGB radiance from
/// `radiance(s, camera ray, generator)` (the CPU passes of the RGB integrators).
fn radiance_pass(
    params: &RenderParams,
    id: u32,
    s_begin: u32,
    s_end: u32,
    prev: PixelSums,
    radiance: impl Fn(u32, &Ray, HashRng) -> (Rgb, Tally, HashRng),
) -> PixelSums {
    let mut acc = prev;
    let mut s = s_begin;
    while s < s_end {
        let (world, rng) = camera_ray(params, id, s);
        let (l, tally, _) = radiance(s, &world, rng);
        acc = acc.add(l, l.luminance(), tally);
        s += 1;
    }
    acc
}

/// Push constants of the path and direct kernels: the launch header, the sample, and the step
/// (path: 0 starts the sample's paths at the camera, 1 is one bounce of every live path;
/// direct: 0 starts, 1 to 3 estimate one query each).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PathPass {
    pub launch: crate::kernels::launch::Launch,
    /// Sample index of the paths.
    pub sample: u32,
    /// 0: start, 1: bounce.
    pub mode: u32,
    /// Pixel id held by element 0 of the sums and states buffers.
    pub sums_base: u32,
    pub _pad: u32,
}

/// Where one invocation of a wavefront kernel stands: its pixel `id` (row-major), the sample,
/// the stage (the push mode) and the stage's kind (the kernels' specialization constant 2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StageAt {
    pub id: u32,
    pub sample: u32,
    pub stage: u32,
    pub kind: u32,
}

impl StageAt {
    /// Stage `stage` of `restir`'s sample `sample` of pixel `id`, with its kind
    /// ([`restir_stage_kind`]).
    #[inline]
    pub fn restir(params: &RenderParams, id: u32, sample: u32, stage: u32) -> Self {
        StageAt {
            id,
            sample,
            stage,
            kind: restir_stage_kind(params, stage),
        }
    }
}

pub use crate::integrators::stages::wave_kind;

/// One stage of the wavefront `direct` render (`direct_cs`): kind 0 starts the sample at the
/// camera ([`direct_start`]), stages 1 to 3 estimate one query each; after stage 3 the radiance
/// is added to the pixel's sums. Returns the new state and sums.
pub fn direct_wave_step(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    scene: &Scene,
    at: StageAt,
    st: DirectState,
    sums: PixelSums,
) -> (DirectState, PixelSums) {
    let cfg = Config::decode(params, &vol.desc);
    if at.kind == 0 {
        let (world, rng) = camera_ray(params, at.id, at.sample);
        let dims = SampleDims::new(params, at.id, at.sample);
        return (
            direct_start(vol, &cfg, params, scene, &world, dims, rng),
            sums_before(at.sample, &sums),
        );
    }
    let next = direct_estimate(vol, &cfg, params, scene, st, at.stage - 1);
    if at.stage < 3 {
        return (next, sums);
    }
    let l = next.total;
    (next, sums.add(l, l.luminance(), next.tally()))
}

/// [`render_pixel_pass`] of the `restir` integrator on the CPU (the GPU runs the same stages as
/// dispatches, [`restir_wave_step`]).
pub fn restir_pixel_pass(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    scene: &Scene,
    id: u32,
    s_begin: u32,
    s_end: u32,
    prev: PixelSums,
) -> PixelSums {
    let cfg = Config::decode(params, &vol.desc);
    radiance_pass(params, id, s_begin, s_end, prev, |s, world, rng| {
        restir_radiance(vol, &cfg, params, scene, id, s, world, rng)
    })
}

/// One stage of the wavefront `restir` render (on the GPU `restir_*_cs`, one kernel per kind,
/// each calling only its kind's step below, so that a module holds one kind's code: one module
/// of every kind took lavapipe 110-240 s per pipeline): stage 0 starts the sample at the camera,
/// then the candidates, the resolve and the four estimates ([`restir_stage`]); after the last
/// the radiance is added to the pixel's sums. The CPU calls it with [`StageAt::restir`].
pub fn restir_wave_step(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    scene: &Scene,
    at: StageAt,
    st: RestirState,
    sums: PixelSums,
) -> (RestirState, PixelSums) {
    if at.kind == KIND_START {
        return restir_start_step(vol, params, scene, at, st, sums);
    }
    let cfg = Config::decode(params, &vol.desc);
    let next = restir_stage_of_kind(
        vol, &cfg, params, scene, at.id, at.sample, st, at.stage, at.kind,
    );
    restir_finish(params, at.stage, next, sums)
}

/// After stage `stage` left `next`: the pixel's sums, with the sample's radiance added after the
/// last stage.
#[inline]
fn restir_finish(
    params: &RenderParams,
    stage: u32,
    next: RestirState,
    sums: PixelSums,
) -> (RestirState, PixelSums) {
    if stage + 1 < stage_count(params) {
        return (next, sums);
    }
    let l = next.direct.total;
    (next, sums.add(l, l.luminance(), next.direct.tally()))
}

/// A `restir` start stage (`restir_start_cs`): the sample's camera ray, scattering vertex and
/// `direct`'s light and phase samples.
pub fn restir_start_step(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    scene: &Scene,
    at: StageAt,
    _st: RestirState,
    sums: PixelSums,
) -> (RestirState, PixelSums) {
    let cfg = Config::decode(params, &vol.desc);
    let (world, rng) = camera_ray(params, at.id, at.sample);
    let dims = SampleDims::new(params, at.id, at.sample);
    (
        restir_start(vol, &cfg, params, scene, &world, dims, rng),
        sums_before(at.sample, &sums),
    )
}

/// A `restir` candidate stage (`restir_candidate_cs`).
pub fn restir_candidate_step(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    scene: &Scene,
    at: StageAt,
    st: RestirState,
    sums: PixelSums,
) -> (RestirState, PixelSums) {
    let cfg = Config::decode(params, &vol.desc);
    let next = candidate_stage(vol, &cfg, params, scene, at.id, at.sample, st);
    restir_finish(params, at.stage, next, sums)
}

/// A `restir` resolve stage (`restir_resolve_cs`).
pub fn restir_resolve_step(
    _vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    scene: &Scene,
    at: StageAt,
    st: RestirState,
    sums: PixelSums,
) -> (RestirState, PixelSums) {
    let next = resolve_stage(scene, params, st);
    restir_finish(params, at.stage, next, sums)
}

/// A `restir` transmittance-query stage (`restir_query_cs`).
pub fn restir_query_step(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    scene: &Scene,
    at: StageAt,
    st: RestirState,
    sums: PixelSums,
) -> (RestirState, PixelSums) {
    let cfg = Config::decode(params, &vol.desc);
    let next = query_stage(vol, &cfg, params, scene, st, at.stage);
    restir_finish(params, at.stage, next, sums)
}

/// What `restir_reuse_cs` does in a stage that is not a reuse stage (the host never dispatches
/// it so): leaves the state and sums as they are.
#[inline]
pub fn restir_unchanged_step(
    _vol: &VolumeView<impl Texels>,
    _params: &RenderParams,
    _scene: &Scene,
    _at: StageAt,
    st: RestirState,
    sums: PixelSums,
) -> (RestirState, PixelSums) {
    (st, sums)
}

/// One reuse stage of the wavefront `restir` render (`restir_reuse_cs`, when
/// [`is_reuse_stage`]): the pixel's new state from every pixel's (`states[j - base]` is pixel
/// j's); [`store_reuse`] writes what changed.
pub fn restir_reuse_step(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    scene: &Scene,
    at: StageAt,
    states: &[RestirState],
    base: u32,
) -> RestirState {
    let cfg = Config::decode(params, &vol.desc);
    let pass = reuse_pass(params, at.stage);
    reuse(
        vol, &cfg, params, scene, at.id, at.sample, pass, states, base,
    )
}

/// Stores what reuse stage `stage` changed in pixel state `dst` (its output reservoir and
/// generator; never what other pixels read during the stage).
#[inline]
pub fn restir_store_reuse(
    dst: &mut RestirState,
    src: &RestirState,
    params: &RenderParams,
    stage: u32,
) {
    store_reuse(dst, src, reuse_pass(params, stage));
}

/// One step of the wavefront `path` render (`path_cs`): kind 0 starts the sample's path at the
/// camera, any other kind advances it by one vertex (every bounce is the same step); a path that
/// ends adds its radiance to the pixel's sums. Returns the new state and sums.
#[inline]
pub fn path_wave_step(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    scene: &Scene,
    at: StageAt,
    st: PathState,
    sums: PixelSums,
) -> (PathState, PixelSums) {
    if at.kind == 0 {
        let (world, rng) = camera_ray(params, at.id, at.sample);
        let dims = SampleDims::new(params, at.id, at.sample);
        return (path_start(&world, dims, rng), sums_before(at.sample, &sums));
    }
    if st.alive == 0 {
        return (st, sums);
    }
    let cfg = Config::decode(params, &vol.desc);
    let next = path_bounce(vol, &cfg, params, scene, st);
    if next.alive != 0 {
        return (next, sums);
    }
    let l = next.radiance;
    (next, sums.add(l, l.luminance(), next.tally()))
}

/// [`render_pixel_pass`] of the `path` integrator on the CPU: each sample's whole path, the same
/// bounces as the GPU's steps.
pub fn path_pixel_pass(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    scene: &Scene,
    id: u32,
    s_begin: u32,
    s_end: u32,
    prev: PixelSums,
) -> PixelSums {
    let cfg = Config::decode(params, &vol.desc);
    let mut acc = prev;
    let mut s = s_begin;
    while s < s_end {
        let (world, rng) = camera_ray(params, id, s);
        let start = path_start(&world, SampleDims::new(params, id, s), rng);
        let st = path_radiance(vol, &cfg, params, scene, start);
        acc = acc.add(st.radiance, st.radiance.luminance(), st.tally());
        s += 1;
    }
    acc
}

/// Side of the square pixel tiles that the CPU backend's consecutive work items cover, so one
/// thread traces neighbouring rays (measured 2-3% faster than row order on the CPU; on lavapipe
/// 8 x 8-tile workgroups were 8% slower for the jackknife, so the GPU kernel keeps row order).
pub const TILE: u32 = 8;

/// The pixel (row-major id) of work item `k` in tile order: full 8 x 8 tiles row by row, each
/// tile row-major inside; then the pixels right of the last full tile column (row-major), then
/// those below the last full tile row. A bijection of `0..width * height`.
#[inline]
pub fn tile_order_pixel(k: u32, width: u32, height: u32) -> u32 {
    let tw = width / TILE * TILE;
    let th = height / TILE * TILE;
    let full = tw * th;
    if k < full {
        let tile = k / (TILE * TILE);
        let inner = k % (TILE * TILE);
        let tiles_per_row = tw / TILE;
        let x = (tile % tiles_per_row) * TILE + inner % TILE;
        let y = (tile / tiles_per_row) * TILE + inner / TILE;
        return y * width + x;
    }
    let k = k - full;
    let right = width - tw;
    if k < th * right {
        return (k / right) * width + tw + k % right;
    }
    th * width + (k - th * right)
}

/// Per-pixel means from the sums of `spp` estimates.
pub fn finish_pixel(sums: PixelSums, spp: u32) -> PixelOut {
    PixelOut {
        t_mean: sums.t_sum / spp as f32,
        t2_mean: sums.t2_sum / spp as f32,
        samples: sums.samples,
        capped: sums.capped,
        outside: sums.outside,
        fallback: sums.fallback,
        rgb_mean: Rgb::new(
            sums.rgb_sum.r / spp as f32,
            sums.rgb_sum.g / spp as f32,
            sums.rgb_sum.b / spp as f32,
        ),
    }
}

/// Mean transmittance of pixel `id` over all `spp` samples in one pass (tests, small renders).
pub fn render_pixel(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    lights: &[PointLight],
    id: u32,
) -> PixelOut {
    let sums = render_pixel_pass(vol, params, lights, id, 0, params.spp, PixelSums::default());
    finish_pixel(sums, params.spp)
}
