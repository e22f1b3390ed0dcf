//! The `direct` integrator (RGB direct illumination from an environment map, a sun and point
//! lights): GPU == CPU bytes for every light type and shadow-ray estimator, and unbiasedness
//! against a quadrature of the exact single-scattering integral.

use engine::lighting::env::EnvMap;
use engine::lighting::{build, EnvSource, LightingOptions, SceneLights, SunSpec};
use engine::render::render_lit;
use engine::scene::bricks::{pack, PackedVolume};
use engine::scene::camera::{make_camera, world_bounds, world_to_index, CameraSpec};
use engine::volume::{Affine, DenseVolume};
use engine::Backend;
use integration_tests::{assert_bytes_equal, camera_params, gpu, lumpy_blobs};
use shared::params::{Estimator, Integrator, RenderParams};
use shared::sampling::lights::PointLight;
use shared::volume::grid::Lookup;

/// `direct` parameters for a w x h image of `vol`.
fn params(vol: &DenseVolume, w: u32, h: u32, spp: u32, estimator: Estimator) -> RenderParams {
    RenderParams {
        spp,
        seed: 3,
        n: 10,
        estimator: estimator as u32,
        rm_scale: 1.0,
        f_delta: 0.6,
        pixel_jitter: 1,
        integrator: Integrator::Direct as u32,
        hg_g: 0.3,
        ..camera_params(vol, w, h)
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
                    PointLight::new(shared::geometry::V3::new(0.2, 0.1, -0.3), 3.0),
                    PointLight::new(shared::geometry::V3::new(-1.5, 1.0, 0.5), 10.0),
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
    let (data, _) = map.clone().data(1.0).unwrap();
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
    let vol = lumpy_blobs(24, 6);
    let packed = packed(&vol);
    let gpu = Backend::Gpu(gpu());
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
    ];
    // Every light setup under every estimator.
    let mut lights: Vec<(String, SceneLights)> = setups()
        .into_iter()
        .map(|(name, opts)| (name.to_string(), scene(&opts)))
        .collect();
    lights.push(("map + sun disk".into(), map_scene()));
    for (name, l) in &lights {
        for e in Estimator::ALL {
            cases.push((format!("{name}, {e:?}"), l.clone(), e));
        }
    }
    for (name, lights, estimator) in cases {
        let mut p = params(&vol, 12, 10, 3, estimator);
        p.light_count = lights.points.len() as u32;
        let p = engine::render::fit_collision_cap(&p, &packed.desc);
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

/// One `direct` invocation holds one tracking loop or one estimate (a wavefront): every
/// estimator fits the loop budget with the full collision cap, unbiased ray marching included.
#[test]
fn direct_fits_every_estimator_without_lowering_the_collision_cap() {
    let vol = lumpy_blobs(24, 6);
    let packed = packed(&vol);
    for e in Estimator::ALL {
        let p = params(&vol, 4, 4, 1, e);
        assert!(
            engine::render::loop_iterations_per_ray(&p, &packed.desc) <= 60_000,
            "{e:?}"
        );
        let fitted = engine::render::fit_collision_cap(&p, &packed.desc);
        assert_eq!(fitted.collision_cap(), 10_000, "{e:?}");
    }
}

/// Distance from x (inside [-1, 1]^3) along unit w to the box's boundary.
fn exit_distance(x: [f64; 3], w: [f64; 3]) -> f64 {
    (0..3)
        .filter(|&a| w[a] != 0.0)
        .map(|a| ((if w[a] > 0.0 { 1.0 } else { -1.0 }) - x[a]) / w[a])
        .fold(f64::INFINITY, f64::min)
}

/// Henyey-Greenstein in f64 (pbrt-v4's convention: cos between wo and wi).
fn hg(cos: f64, g: f64) -> f64 {
    let d = 1.0 + g * g + 2.0 * g * cos;
    (1.0 - g * g) / (4.0 * std::f64::consts::PI * d * d.sqrt())
}

/// Gauss-Legendre nodes and weights on [a, b] (Newton on P_n).
fn gauss_legendre(n: usize, a: f64, b: f64) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    break;
                }
            }
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            (0.5 * (a + b) + 0.5 * (b - a) * x, 0.5 * (b - a) * w)
        })
        .collect()
}

/// The `direct` estimate of one camera ray through a homogeneous cube (extinction `mu` in
/// [-1, 1]^3) lit by a 3 x 3 texel map, a sun disk and a point light is unbiased: its mean over
/// 2^17 samples (regular tracking shadow rays: exact T, so all noise is the integrator's) agrees
/// with a quadrature of L = L_bg T + albedo int mu e^(-mu s) int phase L_e T dw ds within z < 4.
/// Seed 11; the quadrature's own error is below 1e-4 relative (texel borders on cell borders).
#[test]
fn direct_is_unbiased_against_a_quadrature_of_single_scattering() {
    single_scattering_against_quadrature(Integrator::Direct, Estimator::RegularTracking, ONE, 0);
}

/// One point light of the quadrature tests: position, intensity.
type Point = ([f64; 3], f64);
/// The quadrature scene's point light.
const ONE: &[Point] = &[([0.5, -0.3, 0.2], 2.0)];
/// Three point lights (one outside the cube) of intensities over a factor 20.
const THREE: &[Point] = &[
    ([0.5, -0.3, 0.2], 2.0),
    ([-1.4, 0.6, 0.3], 6.0),
    ([0.1, 0.2, -0.4], 0.3),
];

/// `restir` (M = 4, jackknife targets of N = 4, floor 0.05) lit by the map, the sun and three
/// point lights is unbiased against the same quadrature: z < 4 (2^17 samples, seed 11; regular
/// tracking shadow rays).
#[test]
fn restir_is_unbiased_against_the_quadrature() {
    single_scattering_against_quadrature(Integrator::Restir, Estimator::RegularTracking, THREE, 4);
}

/// The same with one candidate and ratio-tracking shadow rays (the unbiased setting).
#[test]
fn restir_of_one_candidate_with_ratio_shadow_rays_is_unbiased() {
    single_scattering_against_quadrature(Integrator::Restir, Estimator::RatioTracking, THREE, 1);
}

/// `direct` with the three lights (drawn by power): z < 4.
#[test]
fn direct_with_three_point_lights_is_unbiased_against_the_quadrature() {
    single_scattering_against_quadrature(Integrator::Direct, Estimator::RegularTracking, THREE, 0);
}

/// The same with ratio-tracking shadow rays (unbiased, noisier): z < 4.
#[test]
fn direct_with_ratio_shadow_rays_is_unbiased_against_the_quadrature() {
    single_scattering_against_quadrature(Integrator::Direct, Estimator::RatioTracking, ONE, 0);
}

/// `path` with `--max-depth 1` (one vertex; the ray leaving it still meets the lights) is the
/// same estimate in expectation: the same quadrature, z < 4 (2^17 samples, seed 11).
#[test]
fn path_of_depth_one_is_unbiased_against_the_same_quadrature() {
    single_scattering_against_quadrature(Integrator::Path, Estimator::RegularTracking, ONE, 0);
}

/// The body of the two quadrature tests.
fn single_scattering_against_quadrature(
    integrator: Integrator,
    shadow: Estimator,
    points: &[Point],
    candidates: u32,
) {
    let n = 16u32;
    let mu = 0.9f64;
    let vol = DenseVolume::new(
        "cube",
        [n; 3],
        vec![mu as f32; (n * n * n) as usize],
        Affine::scale_translate([2.0 / n as f32; 3], [-1.0; 3]),
    )
    .unwrap();
    let packed = pack(&vol, 1.0, 8, Lookup::Nearest).unwrap();
    // Rows: theta in [0, 60), [60, 120), [120, 180] degrees; columns: phi thirds.
    let rows = [[2.0f32, 1.5, 1.0], [0.6, 0.3, 0.9], [0.1, 0.2, 0.05]];
    let map = EnvMap {
        width: 3,
        height: 3,
        texels: rows.iter().flatten().map(|&v| [v; 3]).collect(),
    };
    let g = 0.3f64;
    let sun_dir = {
        let d = [0.4f64, 0.8, -0.3];
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        d.map(|v| v / l)
    };
    let (sun_e, sun_radius_deg) = (3.0f64, 4.0f64);
    let mut lights = build(
        &LightingOptions {
            env: EnvSource::None,
            env_scale: 1.0,
            env_rotate_deg: 0.0,
            sun: Some(SunSpec {
                dir: sun_dir.map(|v| v as f32),
                irradiance: Some(sun_e as f32),
                radius_deg: sun_radius_deg as f32,
            }),
            points: points
                .iter()
                .map(|(x, i)| {
                    PointLight::new(
                        shared::geometry::V3::new(x[0] as f32, x[1] as f32, x[2] as f32),
                        *i as f32,
                    )
                })
                .collect(),
            albedo: [0.8; 3],
        },
        [0.0; 3],
        1.7,
    )
    .unwrap();
    let (data, _) = map.clone().data(1.0).unwrap();
    lights.env = data;
    lights.lighting.env = shared::sampling::env::EnvDesc {
        width: 3,
        height: 3,
        cos_rotation: 1.0,
        sin_rotation: 0.0,
    };
    (
        lights.lighting.p_sun,
        lights.lighting.p_env,
        lights.lighting.p_points,
    ) = (0.3, 0.5, 0.2);
    if integrator == Integrator::Restir {
        lights.resample_points();
    }
    let spec = CameraSpec {
        position: Some([0.0, 0.0, -3.0]),
        look_at: Some([0.0, 0.0, 0.0]),
        fov_deg: 10.0,
    };
    let spp = 1u32 << 17;
    let p = RenderParams {
        camera: make_camera(&spec, world_bounds(&vol), 1, 1).unwrap(),
        world_to_index: world_to_index(&vol.index_to_world).unwrap(),
        width: 1,
        height: 1,
        spp,
        seed: 11,
        n: 10,
        estimator: shadow as u32,
        rm_scale: 1.0,
        pixel_jitter: 0,
        integrator: integrator as u32,
        hg_g: g as f32,
        light_count: points.len() as u32,
        restir: shared::params::RestirParams {
            candidates,
            target: shared::params::RestirTarget::Jackknife as u32,
            n: 4,
            floor: 0.05,
            ..Default::default()
        },
        rr_depth: 5,
        max_depth: 1,
        ..Default::default()
    };
    let px = render_lit(&Backend::Cpu, &packed, &p, &lights, false).unwrap()[0];

    // The map's radiance (nearest texel, as the renderer's lookup).
    let env = |w: [f64; 3]| -> f64 {
        let theta = w[1].clamp(-1.0, 1.0).acos();
        let mut phi = w[2].atan2(w[0]);
        if phi < 0.0 {
            phi += 2.0 * std::f64::consts::PI;
        }
        let j = ((theta / std::f64::consts::PI * 3.0) as usize).min(2);
        let i = ((phi / (2.0 * std::f64::consts::PI) * 3.0) as usize).min(2);
        rows[j][i] as f64
    };
    let (alpha, cos_a) = (
        sun_radius_deg.to_radians(),
        sun_radius_deg.to_radians().cos(),
    );
    let sun_l = sun_e / (2.0 * std::f64::consts::PI * (1.0 - cos_a));
    let wo = [0.0, 0.0, -1.0];
    let t = |x: [f64; 3], w: [f64; 3]| (-mu * exit_distance(x, w)).exp();
    // In-scattered radiance at x (per unit albedo): map + sun disk + point light.
    let l_s = |x: [f64; 3]| -> f64 {
        let (nc, np) = (400usize, 600usize);
        let mut sum = 0.0;
        for a in 0..nc {
            let c = -1.0 + 2.0 * (a as f64 + 0.5) / nc as f64;
            let s = (1.0 - c * c).sqrt();
            for b in 0..np {
                let phi = 2.0 * std::f64::consts::PI * (b as f64 + 0.5) / np as f64;
                let w = [s * phi.cos(), c, s * phi.sin()];
                let cos = wo[0] * w[0] + wo[1] * w[1] + wo[2] * w[2];
                sum += hg(cos, g) * env(w) * t(x, w);
            }
        }
        let mut total = sum * (2.0 / nc as f64) * (2.0 * std::f64::consts::PI / np as f64);
        // The disk in its own frame: theta' in [0, alpha], Gauss-Legendre in cos theta'.
        let (tb, bb) = {
            let n = sun_dir;
            let a = if n[0].abs() > 0.9 {
                [0.0, 1.0, 0.0]
            } else {
                [1.0, 0.0, 0.0]
            };
            let t = [
                a[1] * n[2] - a[2] * n[1],
                a[2] * n[0] - a[0] * n[2],
                a[0] * n[1] - a[1] * n[0],
            ];
            let l = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
            let t = t.map(|v| v / l);
            let b = [
                n[1] * t[2] - n[2] * t[1],
                n[2] * t[0] - n[0] * t[2],
                n[0] * t[1] - n[1] * t[0],
            ];
            (t, b)
        };
        let _ = alpha;
        for (c, wc) in gauss_legendre(24, cos_a, 1.0) {
            let s = (1.0 - c * c).sqrt();
            for k in 0..96 {
                let phi = 2.0 * std::f64::consts::PI * (k as f64 + 0.5) / 96.0;
                let w: [f64; 3] = std::array::from_fn(|i| {
                    s * (phi.cos() * tb[i] + phi.sin() * bb[i]) + c * sun_dir[i]
                });
                let cos = wo[0] * w[0] + wo[1] * w[1] + wo[2] * w[2];
                total += wc * (2.0 * std::f64::consts::PI / 96.0) * hg(cos, g) * sun_l * t(x, w);
            }
        }
        for point in points {
            let to = [point.0[0] - x[0], point.0[1] - x[1], point.0[2] - x[2]];
            let d2 = to[0] * to[0] + to[1] * to[1] + to[2] * to[2];
            let d = d2.sqrt();
            let w = to.map(|v| v / d);
            let cos = wo[0] * w[0] + wo[1] * w[1] + wo[2] * w[2];
            let tp = (-mu * d.min(exit_distance(x, w))).exp();
            total += point.1 * hg(cos, g) * tp / d2;
        }
        total
    };
    let mut scattered = 0.0;
    for (s, ws) in gauss_legendre(32, 0.0, 2.0) {
        scattered += ws * mu * (-mu * s).exp() * l_s([0.0, 0.0, -1.0 + s]);
    }
    let exact = env([0.0, 0.0, 1.0]) * (-2.0 * mu).exp() + 0.8 * scattered;
    let mean = px.t_mean as f64;
    let var = (px.t2_mean as f64 - mean * mean).max(0.0);
    let se = (var / spp as f64).sqrt();
    let z = (mean - exact) / se;
    assert!(
        z.abs() < 4.0,
        "{integrator:?} with {shadow:?}: mean {mean:.6} +- {se:.6} vs quadrature {exact:.6}: z = {z:.2}"
    );
    if integrator != Integrator::Path {
        // No loop bound changed the estimate.
        assert_eq!(px.capped, 0);
    } else {
        // `--max-depth 1` cuts off every path that scatters twice (intended here: single
        // scattering is the quantity compared) and counts it; no tracking cap is near.
        assert!(px.capped > 0 && px.capped < spp, "capped {}", px.capped);
    }
}
