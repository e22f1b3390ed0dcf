//! The `direct` integrator (RGB direct illumination from an environment map, a sun and point
//! lights): GPU == CPU bytes for every light type and shadow-ray estimator, and unbiasedness
//! against a quadrature of the exact single-scattering integral.

use host::bricks::{pack, PackedVolume};
use host::lighting::env::EnvMap;
use host::lighting::{build, EnvSource, LightingOptions, SceneLights, SunSpec};
use host::render::{make_camera, render_lit, world_bounds, world_to_index, CameraSpec};
use host::volume::{Affine, DenseVolume};
use host::Backend;
use integration_tests::{assert_bytes_equal, gpu};
use shared::params::{Estimator, Integrator, RenderParams};
use shared::rng::{pcg_hash, unit_f32};
use shared::sampling::lights::PointLight;
use shared::volume::grid::Lookup;

/// A lumpy 24^3 test volume in [-1, 1]^3: hashed blobs with empty regions (deterministic).
fn lumpy(n: u32) -> DenseVolume {
    let mut v = Vec::with_capacity((n * n * n) as usize);
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let cell = pcg_hash(x / 6 + 101 * (y / 6) + 10007 * (z / 6));
                let inside = !cell.is_multiple_of(3);
                let fine = unit_f32(pcg_hash(x + n * (y + n * z)));
                v.push(if inside {
                    0.5 + 2.0 * fine * unit_f32(cell)
                } else {
                    0.0
                });
            }
        }
    }
    DenseVolume::new(
        "lumpy",
        [n; 3],
        v,
        Affine::scale_translate([2.0 / n as f32; 3], [-1.0; 3]),
    )
    .unwrap()
}

/// Direct-integrator parameters for a w x h image of `vol`.
fn params(vol: &DenseVolume, w: u32, h: u32, spp: u32, estimator: Estimator) -> RenderParams {
    let spec = CameraSpec {
        position: None,
        look_at: None,
        fov_deg: 40.0,
    };
    RenderParams {
        camera: make_camera(&spec, world_bounds(vol), w, h).unwrap(),
        world_to_index: world_to_index(&vol.index_to_world).unwrap(),
        width: w,
        height: h,
        spp,
        seed: 3,
        n: 10,
        estimator: estimator as u32,
        rm_scale: 1.0,
        f_delta: 0.6,
        pixel_jitter: 1,
        integrator: Integrator::Direct as u32,
        hg_g: 0.3,
        ..Default::default()
    }
}

/// A small map with structure in every direction: 16 x 8 texels.
fn gradient_map() -> EnvMap {
    let (w, h) = (16u32, 8u32);
    let texels = (0..w * h)
        .map(|k| {
            let (i, j) = ((k % w) as f32, (k / w) as f32);
            [0.2 + i / 8.0, 1.0 / (1.0 + j), 0.1 + (i * j) / 64.0]
        })
        .collect();
    EnvMap {
        width: w,
        height: h,
        texels,
    }
}

/// The light setups of the GPU == CPU test.
fn setups() -> Vec<(&'static str, LightingOptions)> {
    let base = LightingOptions {
        env: EnvSource::None,
        env_scale: 1.0,
        env_rotate_deg: 0.0,
        sun: None,
        points: vec![],
        albedo: [0.9, 0.7, 0.5],
    };
    let sun = |r: f32| SunSpec {
        dir: [0.3, 1.0, -0.2],
        irradiance: Some(4.0),
        radius_deg: r,
    };
    vec![
        (
            "sky",
            LightingOptions {
                env: EnvSource::Sky,
                ..base.clone()
            },
        ),
        (
            "sun disk",
            LightingOptions {
                sun: Some(sun(5.0)),
                ..base.clone()
            },
        ),
        (
            "delta sun",
            LightingOptions {
                sun: Some(sun(0.0)),
                ..base.clone()
            },
        ),
        (
            "points",
            LightingOptions {
                points: vec![
                    PointLight {
                        position: shared::geometry::V3::new(0.2, 0.1, -0.3),
                        intensity: 3.0,
                    },
                    PointLight {
                        position: shared::geometry::V3::new(-1.5, 1.0, 0.5),
                        intensity: 10.0,
                    },
                ],
                ..base.clone()
            },
        ),
    ]
}

/// The scene lights of a setup; "map" setups get the gradient map.
fn scene(opts: &LightingOptions) -> SceneLights {
    build(opts, [0.0; 3], 1.7).unwrap()
}

/// `scene` with the gradient map as the environment and a sun disk.
fn map_scene() -> SceneLights {
    let mut s = scene(&LightingOptions {
        env: EnvSource::None,
        env_scale: 1.0,
        env_rotate_deg: 30.0,
        sun: Some(SunSpec {
            dir: [-0.5, 0.4, 0.7],
            irradiance: Some(2.0),
            radius_deg: 3.0,
        }),
        points: vec![],
        albedo: [0.9, 0.7, 0.5],
    });
    let map = gradient_map();
    let (data, _) = map.data(1.0);
    s.lighting.env = shared::sampling::env::EnvDesc {
        width: map.width,
        height: map.height,
        cos_rotation: 30f32.to_radians().cos(),
        sin_rotation: 30f32.to_radians().sin(),
    };
    s.env = data;
    s.lighting.p_env = 0.6;
    s.lighting.p_sun = 0.4;
    s
}

fn packed(vol: &DenseVolume) -> PackedVolume {
    pack(vol, 1.0, 8, Lookup::Stochastic).unwrap()
}

#[test]
fn direct_is_bit_identical_on_gpu_and_cpu_for_every_light_and_estimator() {
    let vol = lumpy(24);
    let packed = packed(&vol);
    let gpu = Backend::Gpu(Box::new(gpu()));
    let mut only_phase = map_scene();
    only_phase.lighting.p_env = 0.0;
    only_phase.lighting.p_sun = 1.0;
    let mut only_env = map_scene();
    only_env.lighting.p_env = 1.0;
    only_env.lighting.p_sun = 0.0;
    only_env.lighting.sun.present = 0;
    let mut cases: Vec<(String, SceneLights, Estimator)> = vec![
        (
            "map via phase".into(),
            only_phase,
            Estimator::RegularTracking,
        ),
        ("map via env".into(), only_env, Estimator::RegularTracking),
        ("map + sun disk".into(), map_scene(), Estimator::Jackknife),
    ];
    for (name, opts) in setups() {
        cases.push((name.into(), scene(&opts), Estimator::Jackknife));
    }
    // Unbiased ray marching's three estimates per camera ray do not fit one GPU invocation's
    // loop budget: refused on both backends (see the test below).
    for e in Estimator::ALL {
        if e != Estimator::UnbiasedRayMarching {
            cases.push((format!("map, {e:?}"), map_scene(), e));
        }
    }
    for (name, lights, estimator) in cases {
        let mut p = params(&vol, 12, 10, 3, estimator);
        p.light_count = lights.points.len() as u32;
        let p = host::render::fit_collision_cap(&p, &packed.desc);
        let c = render_lit(&Backend::Cpu, &packed, &p, &lights, false).unwrap();
        let g = render_lit(&gpu, &packed, &p, &lights, false).unwrap();
        let ids: Vec<u32> = (0..c.len() as u32).collect();
        assert_bytes_equal(&format!("direct, {name}"), &ids, &g, &c);
        assert!(
            c.iter().any(|px| px.rgb_mean.g > 0.0),
            "{name}: the image is black"
        );
    }
}

#[test]
fn direct_refuses_shadow_rays_that_exceed_the_loop_budget_on_both_backends() {
    let vol = lumpy(24);
    let packed = packed(&vol);
    let mut p = params(&vol, 4, 4, 1, Estimator::UnbiasedRayMarching);
    let p0 = p;
    p = host::render::fit_collision_cap(&p, &packed.desc);
    assert_eq!(p, p0, "ray marching has no collision cap to lower");
    let err = render_lit(&Backend::Cpu, &packed, &p, &map_scene(), false)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("--integrator direct") && err.contains("another --estimator"),
        "{err}"
    );
}

#[test]
fn direct_with_tracking_shadow_rays_lowers_the_collision_cap_to_fit() {
    let vol = lumpy(24);
    let packed = packed(&vol);
    for e in [Estimator::RatioTracking, Estimator::TrackLength] {
        let p = params(&vol, 4, 4, 1, e);
        assert!(host::render::loop_iterations_per_ray(&p, &packed.desc) > 60_000);
        let fitted = host::render::fit_collision_cap(&p, &packed.desc);
        let cap = host::render::collision_cap(&fitted);
        assert!(
            (host::render::MIN_COLLISION_CAP..10_000).contains(&cap),
            "{e:?}: cap {cap}"
        );
        assert!(host::render::loop_iterations_per_ray(&fitted, &packed.desc) <= 60_000);
        // The largest cap that fits: one more collision would not.
        let mut more = fitted;
        more.max_collisions = cap + 1;
        assert!(host::render::loop_iterations_per_ray(&more, &packed.desc) > 60_000);
    }
}
