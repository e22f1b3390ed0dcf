//! The sun's moment shadow map in renders (`--shadows msm4|msm6`): GPU == CPU bytes for the map
//! build (every storage and prefilter) and for `direct` and `path` under every shadow mode, and
//! the map's transmittance against an exact reference on a homogeneous slab.

use engine::lighting::{build, EnvSource, LightingOptions, SceneLights, SunSpec};
use engine::render::shadow_map::{build_into, MsmStorage, ShadowKind, ShadowOptions};
use engine::render::{render_resident_lit, Resident};
use engine::scene::bricks::{pack, PackedVolume};
use engine::scene::camera::occupied_world_bounds;
use engine::volume::DenseVolume;
use engine::Backend;
use integration_tests::{assert_bytes_equal, camera_params, gpu, lumpy_blobs};
use shared::params::{Estimator, Integrator, RenderParams};
use shared::shadows::map::MsmFilter;
use shared::volume::grid::Lookup;

/// Sun-lit scene lights (delta sun or a disk, no map).
fn sun_lights(radius_deg: f32) -> SceneLights {
    build(
        &LightingOptions {
            env: EnvSource::None,
            env_scale: 1.0,
            env_rotate_deg: 0.0,
            sun: Some(SunSpec {
                dir: [0.4, 1.0, -0.3],
                irradiance: Some(3.0),
                radius_deg,
            }),
            points: vec![],
            albedo: [0.9, 0.8, 0.7],
        },
        [0.0; 3],
        1.7,
    )
    .unwrap()
}

fn params(vol: &DenseVolume, integrator: Integrator, estimator: Estimator) -> RenderParams {
    RenderParams {
        spp: 3,
        seed: 5,
        n: 10,
        estimator: estimator as u32,
        rm_scale: 1.0,
        f_delta: 0.6,
        pixel_jitter: 1,
        integrator: integrator as u32,
        hg_g: 0.2,
        rr_depth: 2,
        max_depth: 6,
        ..camera_params(vol, 12, 10)
    }
}

fn packed(vol: &DenseVolume) -> PackedVolume {
    pack(vol, 1.0, 8, Lookup::Stochastic).unwrap()
}

fn opts(kind: ShadowKind, storage: Option<MsmStorage>, filter: MsmFilter, r: u32) -> ShadowOptions {
    ShadowOptions {
        kind,
        storage,
        resolution: 24,
        filter,
        radius: r,
    }
}

/// Every map setting of the tests.
fn map_settings() -> Vec<ShadowOptions> {
    vec![
        opts(ShadowKind::Msm4, None, MsmFilter::None, 0),
        opts(ShadowKind::Msm4, Some(MsmStorage::F32), MsmFilter::None, 0),
        opts(ShadowKind::Msm6, None, MsmFilter::None, 0),
        opts(ShadowKind::Msm4, None, MsmFilter::Box, 2),
        opts(ShadowKind::Msm6, None, MsmFilter::Gauss, 3),
    ]
}

/// Runs `f` with the test volume (dense and packed) resident on the CPU and on the GPU.
fn with_residents(f: impl FnOnce(&DenseVolume, &PackedVolume, &Resident, &Resident)) {
    let vol = lumpy_blobs(24, 6);
    let packed = packed(&vol);
    let gpu = Backend::Gpu(gpu());
    let cpu = Backend::Cpu;
    let (rc, rg) = (
        Resident::new(&cpu, &packed).unwrap(),
        Resident::new(&gpu, &packed).unwrap(),
    );
    f(&vol, &packed, &rc, &rg);
}

#[test]
fn map_build_is_bit_identical_on_gpu_and_cpu() {
    with_residents(|vol, _, rc, rg| {
        let p = params(vol, Integrator::Direct, Estimator::Jackknife);
        for o in map_settings() {
            let (mut lc, mut lg) = (sun_lights(0.0), sun_lights(0.0));
            let bounds = occupied_world_bounds(vol);
            build_into(rc, &p, &mut lc, bounds, &o).unwrap();
            build_into(rg, &p, &mut lg, bounds, &o).unwrap();
            let texels = (o.resolution * o.resolution) as usize;
            assert_eq!(
                lc.shadow_map.len(),
                texels * o.mode().words_per_texel() as usize,
                "{o:?}"
            );
            let ids: Vec<u32> = (0..lc.shadow_map.len() as u32).collect();
            assert_bytes_equal(&format!("map {o:?}"), &ids, &lg.shadow_map, &lc.shadow_map);
            assert!(lc.shadow_map.iter().any(|&w| w != 0), "{o:?}: empty map");
        }
    });
}

/// Issue 43, item 3: the 16-bit map of the procedural cloud at 64^2 and 256^2 texels is the
/// same on both backends (lavapipe fused an inexact product of the quantization transform into
/// the sum after it and stored 3 and 20 words one unit off; `math::rounded` now keeps each
/// product rounded on its own), and so is the f32 map it quantizes.
#[test]
fn u16_maps_of_the_cloud_are_bit_identical_on_gpu_and_cpu() {
    let vol = engine::scene::procedural::cloud(64);
    let packed = pack(&vol, 8.0, 16, Lookup::Stochastic).unwrap();
    let gpu = Backend::Gpu(gpu());
    let (rc, rg) = (
        Resident::new(&Backend::Cpu, &packed).unwrap(),
        Resident::new(&gpu, &packed).unwrap(),
    );
    let p = RenderParams {
        spp: 1,
        seed: 3,
        integrator: Integrator::Direct as u32,
        ..camera_params(&vol, 16, 16)
    };
    let sun = || {
        build(
            &LightingOptions {
                env: EnvSource::None,
                env_scale: 1.0,
                env_rotate_deg: 0.0,
                sun: Some(SunSpec {
                    dir: [0.7, 0.6, -0.45],
                    irradiance: Some(1.0),
                    radius_deg: 0.0,
                }),
                points: vec![],
                albedo: [0.8; 3],
            },
            [0.0; 3],
            1.7,
        )
        .unwrap()
    };
    let bounds = occupied_world_bounds(&vol);
    for storage in [None, Some(MsmStorage::F32)] {
        for resolution in [64, 256] {
            let o = ShadowOptions {
                kind: ShadowKind::Msm4,
                storage,
                resolution,
                filter: MsmFilter::None,
                radius: 0,
            };
            let (mut lc, mut lg) = (sun(), sun());
            build_into(&rc, &p, &mut lc, bounds, &o).unwrap();
            build_into(&rg, &p, &mut lg, bounds, &o).unwrap();
            let ids: Vec<u32> = (0..lc.shadow_map.len() as u32).collect();
            assert_bytes_equal(&format!("map {o:?}"), &ids, &lg.shadow_map, &lc.shadow_map);
        }
    }
}

#[test]
fn direct_and_path_with_shadow_maps_are_bit_identical_on_gpu_and_cpu() {
    with_residents(|vol, packed, rc, rg| {
        let bounds = occupied_world_bounds(vol);
        for integrator in [Integrator::Direct, Integrator::Path] {
            for estimator in [Estimator::Jackknife, Estimator::RatioTracking] {
                for (k, o) in map_settings().into_iter().enumerate() {
                    // A delta sun and a sun disk (the disk's light samples also use the map).
                    let radius = if k % 2 == 0 { 0.0 } else { 2.0 };
                    let p = params(vol, integrator, estimator);
                    let p = engine::render::fit_collision_cap(&p, &packed.desc);
                    let mut lights = sun_lights(radius);
                    build_into(rc, &p, &mut lights, bounds, &o).unwrap();
                    let c = render_resident_lit(rc, &p, &lights, false).unwrap();
                    let g = render_resident_lit(rg, &p, &lights, false).unwrap();
                    let ids: Vec<u32> = (0..c.len() as u32).collect();
                    let what = format!("{integrator:?} {estimator:?} {o:?}");
                    assert_bytes_equal(&what, &ids, &g, &c);
                    assert!(c.iter().any(|px| px.rgb_mean.g > 0.0), "{what}: black");
                    // The map replaced the sun's shadow rays: fewer voxel lookups than with rays.
                    let mut rays = sun_lights(radius);
                    build_into(rc, &p, &mut rays, bounds, &ShadowOptions::default()).unwrap();
                    let r = render_resident_lit(rc, &p, &rays, false).unwrap();
                    let lookups = |px: &[shared::kernels::render::PixelOut]| -> u64 {
                        px.iter().map(|x| x.samples as u64).sum()
                    };
                    assert!(lookups(&c) < lookups(&r), "{what}: no lookups saved");
                }
            }
        }
    });
}
