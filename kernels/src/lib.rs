//! rust-gpu compute entry points. Each unpacks its id and buffers and calls one `shared` function;
//! the CPU backend calls the same functions over the same ids.
//!
//! Binding numbers follow `shared::kernels::launch::bindings` (rust-gpu needs integer literals in
//! `#[spirv(binding = N)]`; the host checks them against its named bindings at compile time).
//! The per-dispatch structs (`RenderParams`, `GridDesc`, `Lighting`) are uniform blocks, every
//! array a storage buffer (the voxel pool and the brick table also uniform texel buffers):
//! lavapipe reads a uniform block at a uniform offset with one scalar
//! load, where each storage-buffer load is a loop over the SIMD lanes (Mesa's `emit_load_mem`);
//! push constants are one `shared` struct per kernel (`Launch`, or `RenderPass` for `transmittance_cs` and `scattering_cs`).
//! Specialization constants by id (host: `gpu::render::specialization`): 0 the integrator, 1 the
//! estimator, 2 a wavefront stage's kind, 3 whether the voxel pool spans several pages (0: the
//! whole pool is binding `VOXELS`; 1: pages of `GridDesc::page_log2` words at `VOXELS` and
//! `VOXEL_PAGES`), 4 the lookup, 5 the cells per brick (1: the fixed grid), 6 `GridDesc::brick_log2`,
//! 7 the importance, 8 `GridDesc::brick_stepping`, 9 whether the voxel pool (one page) and the
//! brick table are read from their uniform texel buffers (`POOL_TEXELS`, `BRICK_TEXELS`; see
//! `texel_tables`) instead of their storage buffers (`GridDesc::specialized`,
//! `RenderParams::specialized`; each 0xffffffff:
//! the buffer's value), so one module serves every variant and each pipeline holds one
//! variant's code: lavapipe runs every branch of a SIMD group with masks, so code a pipeline
//! cannot reach still costs time unless the driver folds it away.
#![cfg_attr(target_arch = "spirv", no_std)]
#![cfg_attr(target_arch = "spirv", feature(asm_experimental_arch))]

mod texel_tables;

use shared::integrators::direct::DirectState;
use shared::integrators::path::PathState;
use shared::integrators::restir::RestirState;
use shared::kernels::launch::Launch;
use shared::kernels::probe::{self, DepthPair, MathValues, RngDraws, TransmittancePair};
use shared::kernels::render::{self, PathPass, PixelSums, RenderPass, StageAt};
use shared::kernels::shadow_map::{self, MsmPass};
use shared::params::{RenderParams, UNSPECIALIZED};
use shared::sampling::lighting::{Lighting, Scene};
use shared::sampling::lights::PointLight;
use shared::shadows::map::RAW_PER_TEXEL;
use shared::volume::grid::{Brick, GridDesc, VolumeView};
use shared::volume::pages::Pages;
use spirv_std::glam::UVec3;
use spirv_std::spirv;
use texel_tables::{TexelTables, WordTexels};

/// A probe kernel (`bindings::map`): output i = `$f`(input i).
macro_rules! map_kernel {
    ($(#[$doc:meta])* $name:ident, $in:ty, $out:ty, $f:path) => {
        $(#[$doc])*
        #[spirv(compute(threads(64)))]
        pub fn $name(
            #[spirv(global_invocation_id)] gid: UVec3,
            #[spirv(push_constant)] launch: &Launch,
            // bindings::map::INPUT
            #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] input: &[$in],
            // bindings::map::OUTPUT
            #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] output: &mut [$out],
        ) {
            if let Some(i) = launch.id(gid.x) {
                output[i] = $f(input[i]);
            }
        }
    };
}

map_kernel!(
    /// Jackknife (Eq. 4) and naive transmittance of each (X0, X1) pair.
    transmittance_pair_cs,
    DepthPair,
    TransmittancePair,
    probe::transmittance_pair
);

map_kernel!(
    /// exp, ln, sin, cos of each input, to pin the deterministic math on the GPU.
    math_values_cs,
    f32,
    MathValues,
    probe::math_values
);

map_kernel!(
    /// Henyey-Greenstein sample and phase value per configuration (diagnostics).
    phase_cs,
    probe::PhaseIn,
    probe::PhaseOut,
    probe::phase
);

map_kernel!(
    /// A moment-shadow-map lookup per configuration (diagnostics).
    msm_lookup_cs,
    probe::MsmLookupIn,
    probe::MsmLookupOut,
    probe::msm_lookup
);

map_kernel!(
    /// Equiangular sampling setup, sample and pdf per configuration (diagnostics).
    equiangular_cs,
    probe::EquiangularIn,
    probe::EquiangularOut,
    probe::equiangular
);

/// PCG32, PCG hash and PCG3D outputs for each id.
#[spirv(compute(threads(64)))]
pub fn rng_draws_cs(
    #[spirv(global_invocation_id)] gid: UVec3,
    #[spirv(push_constant)] launch: &Launch,
    // bindings::rng_draws::OUTPUT
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] output: &mut [RngDraws],
) {
    if let Some(i) = launch.id(gid.x) {
        output[i] = probe::rng_draws(i as u32, launch.seed);
    }
}

macro_rules! render_kernel {
    ($(#[$doc:meta])* $name:ident, |$vol:ident, $p:ident, $lights:ident, $i:ident, $pass:ident, $prev:ident| $call:expr) => {
        $(#[$doc])*
        #[allow(clippy::too_many_arguments)] // one argument per binding
        #[spirv(compute(threads(64)))]
        pub fn $name(
            #[spirv(global_invocation_id)] gid: UVec3,
            #[spirv(push_constant)] pass: &RenderPass,
            // bindings::render::PARAMS (a uniform block, as every per-dispatch struct)
            #[spirv(uniform, descriptor_set = 0, binding = 0)] params: &RenderParams,
            // bindings::render::DESC
            #[spirv(uniform, descriptor_set = 0, binding = 1)] desc: &GridDesc,
            // bindings::render::VOXELS
            #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] voxels: &[u32],
            // bindings::render::BRICKS
            #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] bricks: &[Brick],
            // bindings::render::LIGHTS
            #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] lights: &[PointLight],
            // bindings::render::SUMS
            #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] sums: &mut [PixelSums],
            // bindings::render::VOXEL_PAGES + 0
            #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] voxels_1: &[u32],
            // bindings::render::VOXEL_PAGES + 1
            #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] voxels_2: &[u32],
            // bindings::render::VOXEL_PAGES + 2
            #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] voxels_3: &[u32],
            // bindings::render::VOXEL_PAGES + 3
            #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] voxels_4: &[u32],
            // bindings::render::VOXEL_PAGES + 4
            #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] voxels_5: &[u32],
            // bindings::render::VOXEL_PAGES + 5
            #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] voxels_6: &[u32],
            // bindings::render::VOXEL_PAGES + 6
            #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] voxels_7: &[u32],
            // bindings::render::POOL_TEXELS
            #[spirv(descriptor_set = 0, binding = 13)] pool_texels: &WordTexels,
            // bindings::render::BRICK_TEXELS
            #[spirv(descriptor_set = 0, binding = 14)] brick_texels: &WordTexels,
            // Specialization constants (host: gpu::render::specialization): integrator,
            // estimator, whether the pool spans several pages, lookup, cells per brick, brick
            // log2, brick stepping, importance.
            #[spirv(spec_constant(id = 0, default = 4294967295))] integrator: u32,
            #[spirv(spec_constant(id = 1, default = 4294967295))] estimator: u32,
            #[spirv(spec_constant(id = 3, default = 0))] paged: u32,
            #[spirv(spec_constant(id = 4, default = 4294967295))] lookup: u32,
            #[spirv(spec_constant(id = 5, default = 4294967295))] cells_per_brick: u32,
            #[spirv(spec_constant(id = 6, default = 4294967295))] brick_log2: u32,
            #[spirv(spec_constant(id = 8, default = 4294967295))] brick_stepping: u32,
            #[spirv(spec_constant(id = 9, default = 0))] texels: u32,
            #[spirv(spec_constant(id = 7, default = 4294967295))] importance: u32,
        ) {
            // The uniform blocks read before any branch: lavapipe reads a uniform word once for
            // all lanes only where every lane runs, and lane by lane inside control flow.
            let desc = desc.specialized(lookup, cells_per_brick, brick_log2, brick_stepping);
            let params = params.specialized(integrator, estimator, importance);
            if let Some(i) = pass.launch.id(gid.x) {
                let vol = VolumeView {
                    // By value: the pipeline's specialized copy (held by reference in this
                    // struct, rust-gpu dropped every read of it).
                    desc,
                    voxels: Pages {
                        p0: voxels,
                        p1: voxels_1,
                        p2: voxels_2,
                        p3: voxels_3,
                        p4: voxels_4,
                        p5: voxels_5,
                        p6: voxels_6,
                        p7: voxels_7,
                        single: paged == 0,
                    },
                    bricks,
                    texels: TexelTables {
                        pool: pool_texels,
                        bricks: brick_texels,
                        bound: texels == 1,
                    },
                };
                let slot = i - pass.sums_base as usize;
                let prev = render::sums_before(pass.s_begin, &sums[slot]);
                let ($vol, $p, $lights, $i, $pass, $prev) =
                    (&vol, &params, lights, i as u32, pass, prev);
                sums[slot] = $call;
            }
        }
    };
}

render_kernel!(
    /// One pass of a primary-ray transmittance image: adds samples s_begin..s_end of each pixel.
    transmittance_cs,
    |vol, p, _lights, i, pass, prev| render::transmittance_pixel_pass(vol, p, i, pass.s_begin, pass.s_end, prev)
);

render_kernel!(
    /// One pass of a single-scattering image: adds samples s_begin..s_end of each pixel.
    scattering_cs,
    |vol, p, lights, i, pass, prev| render::scattering_pixel_pass(vol, p, lights, i, pass.s_begin, pass.s_end, prev)
);

/// A wavefront kernel (`direct_cs`, `path_cs`): the bindings of `bindings::direct` ==
/// `bindings::path` with `$state` per pixel, and one call of `$step` per invocation: the stage
/// `pass.mode` of sample `pass.sample`. With `reuse = $reuse`, a stage for which `$is_reuse`
/// holds instead calls `$reuse` with every state and stores what it changed (`$store`).
macro_rules! wave_kernel {
    ($(#[$doc:meta])* $name:ident, $state:ty, $step:path, $kind:expr
     $(, reuse = $reuse:path, $is_reuse:path, $store:path)?) => {
        $(#[$doc])*
        #[allow(clippy::too_many_arguments)] // one argument per binding
        #[spirv(compute(threads(64)))]
        pub fn $name(
            #[spirv(global_invocation_id)] gid: UVec3,
            #[spirv(push_constant)] pass: &PathPass,
            // bindings::path::PARAMS
            #[spirv(uniform, descriptor_set = 0, binding = 0)] params: &RenderParams,
            // bindings::path::DESC
            #[spirv(uniform, descriptor_set = 0, binding = 1)] desc: &GridDesc,
            // bindings::path::VOXELS
            #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] voxels: &[u32],
            // bindings::path::BRICKS
            #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] bricks: &[Brick],
            // bindings::path::LIGHTS
            #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] lights: &[PointLight],
            // bindings::path::SUMS
            #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] sums: &mut [PixelSums],
            // bindings::path::LIGHTING
            #[spirv(uniform, descriptor_set = 0, binding = 6)] lighting: &Lighting,
            // bindings::path::ENV
            #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] env: &[f32],
            // bindings::path::STATES
            #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] states: &mut [$state],
            // bindings::path::SHADOW_MAP
            #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] shadow_map: &[u32],
            // bindings::path::VOXEL_PAGES + 0
            #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] voxels_1: &[u32],
            // bindings::path::VOXEL_PAGES + 1
            #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] voxels_2: &[u32],
            // bindings::path::VOXEL_PAGES + 2
            #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] voxels_3: &[u32],
            // bindings::path::VOXEL_PAGES + 3
            #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] voxels_4: &[u32],
            // bindings::path::VOXEL_PAGES + 4
            #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] voxels_5: &[u32],
            // bindings::path::VOXEL_PAGES + 5
            #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] voxels_6: &[u32],
            // bindings::path::VOXEL_PAGES + 6
            #[spirv(storage_buffer, descriptor_set = 0, binding = 16)] voxels_7: &[u32],
            // bindings::path::POOL_TEXELS
            #[spirv(descriptor_set = 0, binding = 17)] pool_texels: &WordTexels,
            // bindings::path::BRICK_TEXELS
            #[spirv(descriptor_set = 0, binding = 18)] brick_texels: &WordTexels,
            // Specialization constants (host: gpu::render::wave_specialization): integrator,
            // estimator, the stage's kind (`$kind` of the stage), whether the pool spans several
            // pages.
            #[spirv(spec_constant(id = 0, default = 4294967295))] integrator: u32,
            #[spirv(spec_constant(id = 1, default = 4294967295))] estimator: u32,
            #[spirv(spec_constant(id = 2, default = 4294967295))] stage_kind: u32,
            #[spirv(spec_constant(id = 3, default = 0))] paged: u32,
            #[spirv(spec_constant(id = 4, default = 4294967295))] lookup: u32,
            #[spirv(spec_constant(id = 5, default = 4294967295))] cells_per_brick: u32,
            #[spirv(spec_constant(id = 6, default = 4294967295))] brick_log2: u32,
            #[spirv(spec_constant(id = 8, default = 4294967295))] brick_stepping: u32,
            #[spirv(spec_constant(id = 9, default = 0))] texels: u32,
            #[spirv(spec_constant(id = 7, default = 4294967295))] importance: u32,
        ) {
            // The uniform blocks read before any branch: lavapipe reads a uniform word once for
            // all lanes only where every lane runs, and lane by lane inside control flow.
            let desc = desc.specialized(lookup, cells_per_brick, brick_log2, brick_stepping);
            let params = params.specialized(integrator, estimator, importance);
            if let Some(i) = pass.launch.id(gid.x) {
                let vol = VolumeView {
                    // By value: the pipeline's specialized copy (held by reference in this
                    // struct, rust-gpu dropped every read of it).
                    desc,
                    voxels: Pages {
                p0: voxels,
                p1: voxels_1,
                p2: voxels_2,
                p3: voxels_3,
                p4: voxels_4,
                p5: voxels_5,
                p6: voxels_6,
                p7: voxels_7,
                single: paged == 0,
            },
                    bricks,
                    texels: TexelTables {
                        pool: pool_texels,
                        bricks: brick_texels,
                        bound: texels == 1,
                    },
                };
                let slot = i - pass.sums_base as usize;
                let p = &params;
                let scene = Scene {
                    lighting,
                    points: lights,
                    point_count: p.light_count,
                    env,
                    shadow_map,
                };
                let kind = if stage_kind == UNSPECIALIZED {
                    $kind(p, pass.mode)
                } else {
                    stage_kind
                };
                let at = StageAt {
                    id: i as u32,
                    sample: pass.sample,
                    stage: pass.mode,
                    kind,
                };
                #[allow(unused_mut)]
                let mut whole = true;
                $(
                    if $is_reuse(kind) {
                        whole = false;
                        let st = $reuse(&vol, p, &scene, at, states, pass.sums_base);
                        $store(&mut states[slot], &st, p, pass.mode);
                    }
                )?
                if whole {
                    let (st, s) = $step(&vol, p, &scene, at, states[slot], sums[slot]);
                    states[slot] = st;
                    sums[slot] = s;
                }
            }
        }
    };
}

wave_kernel!(
    /// One stage of a `direct` image (RGB direct illumination, wavefront): start each pixel's
    /// sample at the camera (mode 0), or estimate one of its three transmittance queries.
    direct_cs,
    DirectState,
    render::direct_wave_step,
    render::wave_kind
);

// A `restir` image (direct illumination with resampled point lights, wavefront) runs one kernel
// per stage kind, so that each module holds one kind's code: lavapipe built each pipeline of a
// module of every kind in 110-240 s (docs/design/kernel-build.md).

wave_kernel!(
    /// `restir` stage 0: start each pixel's sample at the camera.
    restir_start_cs,
    RestirState,
    render::restir_start_step,
    render::restir_stage_kind
);

wave_kernel!(
    /// A `restir` candidate stage: stream one light candidate into each pixel's reservoir.
    restir_candidate_cs,
    RestirState,
    render::restir_candidate_step,
    render::restir_stage_kind
);

wave_kernel!(
    /// A `restir` reuse stage: resample each pixel's neighbours' reservoirs.
    restir_reuse_cs,
    RestirState,
    render::restir_unchanged_step,
    render::restir_stage_kind,
    reuse = render::restir_reuse_step,
    render::is_reuse_kind,
    render::restir_store_reuse
);

wave_kernel!(
    /// The `restir` resolve stage: the kept light sample's contribution and shadow query.
    restir_resolve_cs,
    RestirState,
    render::restir_resolve_step,
    render::restir_stage_kind
);

wave_kernel!(
    /// A `restir` query stage: estimate one transmittance query.
    restir_query_cs,
    RestirState,
    render::restir_query_step,
    render::restir_stage_kind
);

wave_kernel!(
    /// One step of a `path` image (multiple scattering, wavefront): start each pixel's path of
    /// one sample (mode 0), or advance every live path by one vertex.
    path_cs,
    PathState,
    render::path_wave_step,
    render::wave_kind
);

macro_rules! msm_build_kernel {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[allow(clippy::too_many_arguments)] // one argument per binding
        #[spirv(compute(threads(64)))]
        pub fn $name(
            #[spirv(global_invocation_id)] gid: UVec3,
            #[spirv(push_constant)] pass: &MsmPass,
            // bindings::msm_build::PARAMS
            #[spirv(uniform, descriptor_set = 0, binding = 0)] params: &RenderParams,
            // bindings::msm_build::DESC
            #[spirv(uniform, descriptor_set = 0, binding = 1)] desc: &GridDesc,
            // bindings::msm_build::VOXELS
            #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] voxels: &[u32],
            // bindings::msm_build::BRICKS
            #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] bricks: &[Brick],
            // bindings::msm_build::LIGHTING
            #[spirv(uniform, descriptor_set = 0, binding = 4)] lighting: &Lighting,
            // bindings::msm_build::RAW
            #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] raw: &mut [f32],
            // bindings::msm_build::VOXEL_PAGES + 0
            #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] voxels_1: &[u32],
            // bindings::msm_build::VOXEL_PAGES + 1
            #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] voxels_2: &[u32],
            // bindings::msm_build::VOXEL_PAGES + 2
            #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] voxels_3: &[u32],
            // bindings::msm_build::VOXEL_PAGES + 3
            #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] voxels_4: &[u32],
            // bindings::msm_build::VOXEL_PAGES + 4
            #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] voxels_5: &[u32],
            // bindings::msm_build::VOXEL_PAGES + 5
            #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] voxels_6: &[u32],
            // bindings::msm_build::VOXEL_PAGES + 6
            #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] voxels_7: &[u32],
            // bindings::msm_build::POOL_TEXELS
            #[spirv(descriptor_set = 0, binding = 13)] pool_texels: &WordTexels,
            // bindings::msm_build::BRICK_TEXELS
            #[spirv(descriptor_set = 0, binding = 14)] brick_texels: &WordTexels,
            // Specialization constant (host: gpu::render::specialization): whether the
            // pool spans several pages.
            #[spirv(spec_constant(id = 3, default = 0))] paged: u32,
            #[spirv(spec_constant(id = 4, default = 4294967295))] lookup: u32,
            #[spirv(spec_constant(id = 5, default = 4294967295))] cells_per_brick: u32,
            #[spirv(spec_constant(id = 6, default = 4294967295))] brick_log2: u32,
            #[spirv(spec_constant(id = 8, default = 4294967295))] brick_stepping: u32,
            #[spirv(spec_constant(id = 9, default = 0))] texels: u32,
        ) {
            if let Some(k) = pass.launch.id(gid.x) {
                let vol = VolumeView {
                    // By value: the pipeline's specialized copy (held by reference in this
                    // struct, rust-gpu dropped every read of it).
                    desc: desc.specialized(lookup, cells_per_brick, brick_log2, brick_stepping),
                    voxels: Pages {
                        p0: voxels,
                        p1: voxels_1,
                        p2: voxels_2,
                        p3: voxels_3,
                        p4: voxels_4,
                        p5: voxels_5,
                        p6: voxels_6,
                        p7: voxels_7,
                        single: paged == 0,
                    },
                    bricks,
                    texels: TexelTables {
                        pool: pool_texels,
                        bricks: brick_texels,
                        bound: texels == 1,
                    },
                };
                let m = shadow_map::msm_raw_texel(&vol, params, lighting, k as u32);
                let mut c = 0;
                while c < RAW_PER_TEXEL {
                    raw[RAW_PER_TEXEL * k + c] = m[c];
                    c += 1;
                }
            }
        }
    };
}

msm_build_kernel!(
    /// Pass 1 of the sun's moment shadow map: the raw moments b_1 .. b_6 of each texel (the
    /// voxel pool in one page or several: specialization constant 3).
    msm_build_cs
);

/// Pass 2 of the sun's moment shadow map: each texel prefiltered and stored.
#[spirv(compute(threads(64)))]
pub fn msm_store_cs(
    #[spirv(global_invocation_id)] gid: UVec3,
    #[spirv(push_constant)] pass: &MsmPass,
    // bindings::msm_store::LIGHTING
    #[spirv(uniform, descriptor_set = 0, binding = 0)] lighting: &Lighting,
    // bindings::msm_store::RAW
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] raw: &[f32],
    // bindings::msm_store::MAP
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] map: &mut [u32],
) {
    if let Some(k) = pass.launch.id(gid.x) {
        let l = lighting;
        let w = shadow_map::msm_store_texel(l, raw, pass, k as u32);
        let n = shared::shadows::map::Shadows::from_u32(l.shadows).words_per_texel() as usize;
        let mut c = 0;
        while c < n {
            map[n * k + c] = w[c];
            c += 1;
        }
    }
}
