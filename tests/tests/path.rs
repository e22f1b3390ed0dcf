//! The `path` integrator (multiple scattering, wavefront on the GPU): GPU == CPU bytes for its
//! light types and every shadow-ray estimator, and the white furnace.

use engine::lighting::{build, EnvSource, LightingOptions, SceneLights, SunSpec};
use engine::render::{fit_collision_cap, render_lit};
use engine::scene::bricks::pack;
use engine::volume::DenseVolume;
use engine::Backend;
use integration_tests::{assert_bytes_equal, camera_params, gpu, lumpy_blobs};
use shared::params::{Estimator, Integrator, RenderParams};
use shared::sampling::lights::PointLight;
use shared::volume::grid::Lookup;

/// `path` parameters for a w x h image of `vol`.
fn params(vol: &DenseVolume, w: u32, h: u32, spp: u32, estimator: Estimator) -> RenderParams {
    RenderParams {
        spp,
        seed: 9,
        n: 10,
        estimator: estimator as u32,
        rm_scale: 1.0,
        f_delta: 0.6,
        pixel_jitter: 1,
        integrator: Integrator::Path as u32,
        hg_g: 0.4,
        rr_depth: 2,
        max_depth: 12,
        ..camera_params(vol, w, h)
    }
}

/// The lights of `opts` around the unit box.
fn lights(opts: &LightingOptions) -> SceneLights {
    build(opts, [0.0; 3], 1.7).unwrap()
}

/// No lights; the caller adds what it tests.
fn no_lights() -> LightingOptions {
    LightingOptions {
        env: EnvSource::None,
        env_scale: 1.0,
        env_rotate_deg: 0.0,
        sun: None,
        points: vec![],
        albedo: [0.9, 0.75, 0.6],
    }
}

#[test]
fn path_is_bit_identical_on_gpu_and_cpu_for_its_lights_and_estimators() {
    let vol = lumpy_blobs(20, 5);
    let packed = pack(&vol, 1.5, 8, Lookup::Stochastic).unwrap();
    let gpu = Backend::Gpu(gpu());
    let sky = lights(&LightingOptions {
        env: EnvSource::Sky,
        ..no_lights()
    });
    let sun_and_points = lights(&LightingOptions {
        sun: Some(SunSpec {
            dir: [0.2, 1.0, -0.4],
            irradiance: Some(3.0),
            radius_deg: 6.0,
        }),
        points: vec![PointLight::new(
            shared::geometry::V3::new(0.3, 0.2, -0.2),
            2.0,
        )],
        ..no_lights()
    });
    // Every light setup under every estimator (one estimate per bounce fits, unbiased ray
    // marching included).
    let mut cases = Vec::new();
    for (name, l) in [("sky", &sky), ("sun + point", &sun_and_points)] {
        for e in Estimator::ALL {
            cases.push((name, l.clone(), e));
        }
    }
    // A constant environment (a 1 x 1 map, sampled uniformly over the sphere).
    let constant = lights(&LightingOptions {
        env: EnvSource::Constant([0.8, 1.0, 1.2]),
        ..no_lights()
    });
    for e in [Estimator::Jackknife, Estimator::RatioTracking] {
        cases.push(("constant", constant.clone(), e));
    }
    for (name, l, e) in cases {
        let mut p = params(&vol, 10, 8, 2, e);
        p.light_count = l.points.len() as u32;
        let p = fit_collision_cap(&p, &packed.desc);
        let c = render_lit(&Backend::Cpu, &packed, &p, &l, false).unwrap();
        let g = render_lit(&gpu, &packed, &p, &l, false).unwrap();
        let ids: Vec<u32> = (0..c.len() as u32).collect();
        assert_bytes_equal(&format!("path, {name}, {e:?}"), &ids, &g, &c);
        assert!(
            c.iter().any(|px| px.rgb_mean.b > 0.0),
            "{name}: black image"
        );
    }
}

/// White furnace: albedo 1 under a constant white map, any density: every pixel's expected
/// radiance is exactly the map's (1). Image mean over 24 x 24 pixels x 64 samples (ratio-tracking
/// shadow rays, unbiased; HG g = 0.5; no roulette loss since the throughput stays 1; at most
/// 1024 vertices, which a path through this optical thickness (at most ~30) does not reach:
/// checked by `capped`) within z < 4 of 1, seed 9, on the CPU.
///
/// Twice: under the 4 x 2 constant light probe (sampled by texel) and under `--env
/// constant:1` (a 1 x 1 map, sampled uniformly over the sphere; built as the CLI builds it).
#[test]
fn path_passes_the_white_furnace() {
    let furnace = integration_tests::white_furnace();
    let uniform = lights(&LightingOptions {
        env: EnvSource::Constant([1.0; 3]),
        albedo: [1.0; 3],
        ..no_lights()
    });
    assert!(uniform.lighting.env.uniform() && !furnace.lighting.env.uniform());
    for (name, l) in [("probe", furnace), ("constant:1", uniform)] {
        white_furnace_under(name, &l);
    }
}

/// The white furnace of [`path_passes_the_white_furnace`] under lights `l`.
fn white_furnace_under(name: &str, l: &SceneLights) {
    let vol = lumpy_blobs(20, 5);
    let packed = pack(&vol, 4.0, 8, Lookup::Nearest).unwrap();
    let mut p = params(&vol, 24, 24, 64, Estimator::RatioTracking);
    p.hg_g = 0.5;
    p.rr_depth = 5;
    p.max_depth = 1024;
    let px = render_lit(&Backend::Cpu, &packed, &p, l, false).unwrap();
    let n = px.len() as f64;
    let mean = px.iter().map(|q| q.t_mean as f64).sum::<f64>() / n;
    let var: f64 = px
        .iter()
        .map(|q| (q.t2_mean as f64 - (q.t_mean as f64).powi(2)).max(0.0) / p.spp as f64)
        .sum();
    let se = var.sqrt() / n;
    let z = (mean - 1.0) / se;
    assert!(
        z.abs() < 4.0,
        "white furnace ({name}): image mean {mean:.6} +- {se:.6}, z = {z:.2}"
    );
    println!("white furnace ({name}): image mean {mean:.6} +- {se:.6}, z = {z:.2}");
    assert!(
        se < 0.01,
        "the test is too noisy to detect a 4% loss: se {se}"
    );
    assert!(px.iter().all(|q| q.capped == 0));
}

/// A path cut off by `--max-depth` is counted as capped (the same on both backends); with a
/// depth no path reaches, none is.
#[test]
fn paths_cut_off_by_max_depth_are_counted() {
    let vol = lumpy_blobs(20, 5);
    let packed = pack(&vol, 4.0, 8, Lookup::Nearest).unwrap();
    let l = lights(&LightingOptions {
        env: EnvSource::Sky,
        albedo: [0.99; 3],
        ..no_lights()
    });
    let gpu = Backend::Gpu(gpu());
    let mut p = params(&vol, 8, 8, 4, Estimator::Jackknife);
    p.max_depth = 1;
    p.rr_depth = 1024;
    let c = render_lit(&Backend::Cpu, &packed, &p, &l, false).unwrap();
    let g = render_lit(&gpu, &packed, &p, &l, false).unwrap();
    let capped: u32 = c.iter().map(|px| px.capped).sum();
    assert!(capped > 0, "no path counted as cut off at depth 1");
    assert_eq!(capped, g.iter().map(|px| px.capped).sum::<u32>());
    p.max_depth = 1024;
    p.rr_depth = 5;
    let c = render_lit(&Backend::Cpu, &packed, &p, &l, false).unwrap();
    assert_eq!(c.iter().map(|px| px.capped).sum::<u32>(), 0);
}
