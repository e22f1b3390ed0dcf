//! Defined behaviour for degenerate rays and cameras: zero-length segments, rays that miss,
//! infinite t_max, zero/NaN/infinite directions, axis-parallel rays on a face, and a camera
//! inside the volume (the last two also GPU = CPU byte for byte).

use engine::render::render;
use engine::scene::bricks::{pack, PackedVolume};
use engine::scene::camera::{make_camera, world_bounds, world_to_index, CameraSpec};
use engine::volume::{Affine, DenseVolume};
use engine::Backend;
use integration_tests::gpu;
use shared::estimators::optical_depth::{estimate_pair, prepare};
use shared::estimators::ray_marching::{biased_ray_marching, unbiased_ray_marching};
use shared::estimators::tracking::{ratio_tracking, regular_tracking_tau, track_length};
use shared::geometry::Ray;
use shared::geometry::V3;
use shared::kernels::render::ray_transmittance;
use shared::params::Estimator;
use shared::params::RenderParams;
use shared::params::{Importance, Jitter};
use shared::rng::{pcg_hash, unit_f32, HashRng};
use shared::volume::dda::{clip_to_box, is_usable};
use shared::volume::grid::Lookup;

/// A 32^3 volume of hashed densities in [0.5, 2.5] over [-1, 1]^3.
fn volume() -> DenseVolume {
    let n = 32u32;
    let v = (0..n * n * n)
        .map(|i| 0.5 + 2.0 * unit_f32(pcg_hash(i)))
        .collect();
    let map = Affine::scale_translate([2.0 / n as f32; 3], [-1.0; 3]);
    DenseVolume::new("hashed", [n; 3], v, map).unwrap()
}

fn packed(lookup: Lookup) -> PackedVolume {
    pack(&volume(), 1.0, 8, lookup).unwrap()
}

fn params(estimator: Estimator) -> RenderParams {
    RenderParams {
        width: 1,
        height: 1,
        spp: 1,
        n: 10,
        estimator: estimator as u32,
        rm_scale: 1.0,
        f_delta: 0.3,
        world_to_index: world_to_index(&volume().index_to_world).unwrap(),
        ..Default::default()
    }
}

#[test]
fn zero_length_segments_give_transmittance_one_without_lookups() {
    for lookup in [Lookup::Nearest, Lookup::Stochastic] {
        let p = packed(lookup);
        let vol = p.view();
        let ray = Ray {
            o: V3::new(16.0, 16.0, 16.0),
            d: V3::new(0.6, 0.0, 0.8),
        };
        for t in [0.0f32, 3.0, 7.5] {
            let rng = HashRng { state: 7 };
            let prep = prepare(&vol, &ray, t, t, Importance::VarianceAware);
            assert_eq!(prep.f, 0.0, "F at t = {t}");
            let mode = (Importance::VarianceAware, Jitter::Stratified);
            let (est, _) = estimate_pair(&vol, &ray, &prep, 10, mode.0, mode.1, lookup, rng);
            assert_eq!(
                (est.x0, est.x1, est.samples),
                (0.0, 0.0, 0),
                "pair at t = {t}"
            );
            let (tau, tally) = regular_tracking_tau(&vol, &ray, t, t);
            assert_eq!((tau, tally.lookups, tally.capped), (0.0, 0, 0));
            for (name, (tr, n, _)) in [
                ("track-length", track_length(&vol, &ray, t, t, lookup, rng)),
                (
                    "ratio",
                    ratio_tracking(&vol, &ray, t, t, lookup, false, rng),
                ),
                (
                    "biased-rm",
                    biased_ray_marching(&vol, &ray, t, t, 1.0, lookup, rng),
                ),
                (
                    "unbiased-rm",
                    unbiased_ray_marching(&vol, &ray, t, t, 1.0, lookup, rng),
                ),
            ] {
                assert_eq!((tr, n.lookups), (1.0, 0), "{name} at t = {t} ({lookup:?})");
            }
        }
    }
}

#[test]
fn degenerate_rays_miss_and_give_transmittance_one() {
    let hi = V3::new(32.0, 32.0, 32.0);
    let inside = V3::new(16.0, 16.0, 16.0);
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    let bad = [
        Ray {
            o: inside,
            d: V3::new(0.0, 0.0, 0.0),
        },
        Ray {
            o: inside,
            d: V3::new(nan, 0.0, 1.0),
        },
        Ray {
            o: inside,
            d: V3::new(0.0, inf, 0.0),
        },
        Ray {
            o: V3::new(nan, 1.0, 1.0),
            d: V3::new(0.0, 0.0, 1.0),
        },
        Ray {
            o: V3::new(1.0, -inf, 1.0),
            d: V3::new(0.0, 1.0, 0.0),
        },
        Ray {
            o: inside,
            d: V3::new(1e30, 1e30, 1e30),
        }, // |d|^2 overflows
    ];
    for ray in &bad {
        assert!(!is_usable(ray), "{ray:?}");
        let (t0, t1) = clip_to_box(ray, hi, 0.0, inf);
        assert!(!(t0 < t1), "{ray:?} hit [{t0}, {t1}]");
    }
    let good = Ray {
        o: inside,
        d: V3::new(0.0, 0.0, 1.0),
    };
    // NaN or empty parameter ranges miss too.
    for (lo, up) in [(nan, 1.0), (0.0, nan), (2.0, 2.0), (3.0, 1.0)] {
        let (t0, t1) = clip_to_box(&good, hi, lo, up);
        assert!(!(t0 < t1), "[{lo}, {up}] hit [{t0}, {t1}]");
    }
    // World-space versions through the render path: T = 1 exactly, no lookups, every estimator.
    for lookup in [Lookup::Nearest, Lookup::Stochastic] {
        let p = packed(lookup);
        for e in Estimator::ALL {
            for world in [
                Ray {
                    o: V3::new(0.0, 0.0, 0.0),
                    d: V3::new(0.0, 0.0, 0.0),
                },
                Ray {
                    o: V3::new(0.0, 0.0, 0.0),
                    d: V3::new(nan, nan, nan),
                },
                Ray {
                    o: V3::new(nan, 0.0, 0.0),
                    d: V3::new(0.0, 0.0, 1.0),
                },
                // Misses: outside the box, pointing away.
                Ray {
                    o: V3::new(0.0, 0.0, 5.0),
                    d: V3::new(0.0, 0.0, 1.0),
                },
                Ray {
                    o: V3::new(2.0, 0.0, 0.0),
                    d: V3::new(0.0, 1.0, 0.0),
                },
            ] {
                let (t, n, _) =
                    ray_transmittance(&p.view(), &params(e), &world, HashRng { state: 3 });
                assert_eq!((t, n.lookups), (1.0, 0), "{e:?} {lookup:?} {world:?}");
            }
        }
    }
}

#[test]
fn infinite_t_max_clips_to_the_box_exit() {
    let hi = V3::new(32.0, 16.0, 8.0);
    for (o, d, exit) in [
        (V3::new(1.0, 1.0, 1.0), V3::new(1.0, 0.0, 0.0), 31.0),
        (V3::new(1.0, 1.0, 1.0), V3::new(0.0, -1.0, 0.0), 1.0),
        (V3::new(-4.0, 8.0, 4.0), V3::new(2.0, 0.0, 0.0), 18.0),
    ] {
        let (t0, t1) = clip_to_box(&Ray { o, d }, hi, 0.0, f32::INFINITY);
        assert!(t0.is_finite() && t1 == exit, "{o:?} {d:?}: [{t0}, {t1}]");
    }
}

#[test]
fn rays_along_axes_and_on_faces_stay_finite() {
    let p = packed(Lookup::Stochastic);
    // Axis-parallel rays on the box's faces, edges and corners and through its interior.
    for e in Estimator::ALL {
        for (o, d) in [
            ([0.0, 0.0, -2.0], [0.0, 0.0, 1.0]),
            ([-1.0, -1.0, -2.0], [0.0, 0.0, 1.0]),
            ([1.0, 1.0, -2.0], [0.0, 0.0, 1.0]),
            ([-1.0, 0.3, -2.0], [0.0, 0.0, 1.0]),
            ([-2.0, 0.25, 0.25], [1.0, 0.0, 0.0]),
            ([0.0, 2.0, 0.0], [0.0, -1.0, 0.0]),
            ([0.0, 0.0, 0.0], [0.0, 0.0, -1.0]),
        ] {
            let world = Ray {
                o: V3::new(o[0], o[1], o[2]),
                d: V3::new(d[0], d[1], d[2]),
            };
            let (t, n, _) = ray_transmittance(&p.view(), &params(e), &world, HashRng { state: 11 });
            assert!(
                t.is_finite() && (-1.0..=1.0).contains(&t),
                "{e:?} {o:?}: T = {t}"
            );
            assert!(n.lookups < 100_000, "{e:?} {o:?}: {n:?}");
        }
    }
}

/// A render from `camera` looking at `look_at` on both backends; returns the CPU image.
fn render_both(
    gpu: &Backend,
    camera: [f32; 3],
    look_at: [f32; 3],
    w: u32,
    estimator: Estimator,
) -> Vec<f32> {
    let vol = volume();
    let packed = pack(&vol, 1.0, 8, Lookup::Stochastic).unwrap();
    let spec = CameraSpec {
        position: Some(camera),
        look_at: Some(look_at),
        fov_deg: 60.0,
    };
    let params = RenderParams {
        camera: make_camera(&spec, world_bounds(&vol), w, w).unwrap(),
        pixel_jitter: 0,
        width: w,
        height: w,
        spp: 4,
        seed: 2,
        ..params(estimator)
    };
    let cpu = render(&Backend::Cpu, &packed, &params, false).unwrap();
    let gpu = render(gpu, &packed, &params, false).unwrap();
    let cpu_bytes: &[u8] = bytemuck::cast_slice(&cpu);
    let gpu_bytes: &[u8] = bytemuck::cast_slice(&gpu);
    assert!(
        cpu_bytes == gpu_bytes,
        "{estimator:?} from {camera:?}: GPU and CPU differ"
    );
    cpu.iter().map(|p| p.t_mean).collect()
}

#[test]
fn camera_inside_the_volume_and_on_a_face_renders_identically_on_both_backends() {
    let gpu = Backend::Gpu(gpu());
    for e in [
        Estimator::Jackknife,
        Estimator::RatioTracking,
        Estimator::UnbiasedRayMarching,
    ] {
        // Inside: every ray starts in the medium and crosses at least 0.8 units of density
        // >= 0.5, so every pixel's expected transmittance is below exp(-0.4) = 0.67 (most
        // are far below: the mean is about 0.2).
        let t = render_both(&gpu, [0.1, -0.2, 0.05], [1.0, 0.3, 0.2], 9, e);
        let mean = t.iter().sum::<f32>() / t.len() as f32;
        assert!(
            t.iter().all(|v| v.is_finite()) && mean < 0.67,
            "{e:?} inside: {t:?}"
        );
        // On the z = -1 face looking along +z: the centre pixel's ray is axis-parallel (odd
        // width, no pixel jitter) and starts exactly on the box.
        let t = render_both(&gpu, [0.0, 0.0, -1.0], [0.0, 0.0, 1.0], 9, e);
        assert!(t.iter().all(|v| v.is_finite()), "{e:?} face: {t:?}");
        assert!(
            t[4 * 9 + 4] < 0.5,
            "{e:?}: the axis ray through 2 units of medium: {t:?}"
        );
    }
}
