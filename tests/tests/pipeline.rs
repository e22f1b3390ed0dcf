//! The jackknife pipeline (Alg. 2 + Alg. 1 + Eq. 4) on volumes built in the test.

use engine::render::render;
use engine::scene::bricks::{pack, PackedVolume};
use engine::volume::{Affine, DenseVolume};
use engine::Backend;
use integration_tests::{assert_bytes_equal, camera_params, gpu, unit_cube, volume};
use shared::estimators::optical_depth::{estimate_pair, prepare};
use shared::geometry::Ray;
use shared::geometry::V3;
use shared::kernels::render::ray_transmittance;
use shared::params::Estimator;
use shared::params::RenderParams;
use shared::params::{Importance, Jitter};
use shared::rng::{pcg_hash, unit_f32, HashRng};
use shared::volume::dda::{clip_to_box, GridDda};
use shared::volume::grid::Lookup;

/// A sparse, lumpy test volume: hashed blobs with empty regions (deterministic).
fn lumpy(n: u32) -> DenseVolume {
    volume("lumpy", [n; 3], unit_cube(n), |x, y, z| {
        let cell = pcg_hash(x / 8 + 101 * (y / 8) + 10007 * (z / 8));
        let inside = !cell.is_multiple_of(3);
        let fine = unit_f32(pcg_hash(x + n * (y + n * z)));
        if inside {
            0.5 + 2.0 * fine * unit_f32(cell)
        } else {
            0.0
        }
    })
}

fn constant(n: u32, c: f32) -> DenseVolume {
    DenseVolume::new(
        "constant",
        [n; 3],
        vec![c; (n * n * n) as usize],
        Affine::identity(),
    )
    .unwrap()
}

fn params(vol: &DenseVolume, w: u32, h: u32, spp: u32, estimator: Estimator) -> RenderParams {
    RenderParams {
        spp,
        seed: 5,
        n: 10,
        estimator: estimator as u32,
        importance: Importance::VarianceAware as u32,
        jitter: Jitter::Stratified as u32,
        rm_scale: 1.0,
        f_delta: 0.3,
        pixel_jitter: 1,
        ..camera_params(vol, w, h)
    }
}

/// Random index-space rays through (or near) the grid of `packed`.
fn random_rays(packed: &PackedVolume, count: u32) -> Vec<Ray> {
    let d = packed.desc.dims;
    (0..count)
        .map(|i| {
            let r = |k: u32| unit_f32(pcg_hash(i * 8 + k));
            let o = V3::new(
                (r(0) * 3.0 - 1.0) * d[0] as f32,
                (r(1) * 3.0 - 1.0) * d[1] as f32,
                -(d[2] as f32),
            );
            let target = V3::new(r(2) * d[0] as f32, r(3) * d[1] as f32, r(4) * d[2] as f32);
            let dir = target - o;
            let len = dir.dot(dir).sqrt();
            Ray {
                o,
                d: dir * (1.0 / len),
            }
        })
        .collect()
}

#[test]
fn dda_segments_tile_the_clipped_ray_and_match_their_cells() {
    let packed = pack(&lumpy(40), 1.0, 16, Lookup::Nearest).unwrap();
    let d = packed.desc.dims;
    let hi = V3::new(d[0] as f32, d[1] as f32, d[2] as f32);
    let mut checked = 0;
    for ray in random_rays(&packed, 2000) {
        let (t0, t1) = clip_to_box(&ray, hi, 0.0, f32::INFINITY);
        if !(t0 < t1) {
            continue;
        }
        let mut dda = GridDda::bricks(&packed.desc, &ray, t0, t1);
        let mut t = t0;
        while !dda.done() {
            let s = dda.step();
            assert_eq!(s.t0, t, "segments must be contiguous");
            assert!(s.t1 >= s.t0);
            if s.t1 - s.t0 > 1e-3 {
                let mid = ray.at(0.5 * (s.t0 + s.t1));
                for a in 0..3 {
                    let c = (mid.get(a) / 16.0).floor() as u32;
                    assert_eq!(
                        c, s.cell[a],
                        "midpoint of [{}, {}] not in brick {:?}",
                        s.t0, s.t1, s.cell
                    );
                }
            }
            t = s.t1;
        }
        assert!(
            (t - t1).abs() <= 1e-4 * t1.abs().max(1.0),
            "traversal ended at {t}, not {t1}"
        );
        checked += 1;
    }
    assert!(checked > 1000);
}

#[test]
fn homogeneous_medium_is_exact_for_jackknife_and_naive() {
    // Constant density: P = 0.01 mu_min, every sample contributes 0, X0 = X1 = tau_c = tau.
    // 0.0625 is exact in f16, so the stored volume is exactly constant.
    let c = 0.0625;
    let vol = constant(48, c);
    let packed = pack(&vol, 1.0, 16, Lookup::Nearest).unwrap();
    let view = packed.view();
    let hi = V3::new(48.0, 48.0, 48.0);
    for (i, ray) in random_rays(&packed, 500).iter().enumerate() {
        let (t0, t1) = clip_to_box(ray, hi, 0.0, f32::INFINITY);
        if !(t0 < t1) {
            continue;
        }
        let exact = (-(c as f64) * (t1 - t0) as f64).exp();
        for est in [Estimator::Jackknife, Estimator::NaiveMean] {
            let mut p = params(&vol, 1, 1, 1, est);
            p.world_to_index = shared::geometry::Affine3x4 {
                rows: [
                    [1.0, 0.0, 0.0, 0.0],
                    [0.0, 1.0, 0.0, 0.0],
                    [0.0, 0.0, 1.0, 0.0],
                ],
            };
            let (t, samples, _) =
                ray_transmittance(&view, &p, ray, HashRng::for_sample(i as u32, 0, 1));
            assert_eq!(samples.lookups, 20);
            assert!(
                (t as f64 - exact).abs() <= 2e-6 * exact.max(1e-3),
                "{est:?}: T = {t}, exact {exact}"
            );
        }
    }
}

#[test]
fn every_ray_through_a_nonempty_brick_takes_exactly_20_samples() {
    // The lumpy volume with its x < 16 slab emptied: bricks with x index 0 are empty (their
    // widened window reaches x = 16, which is still empty), so rays along z there have F = 0.
    let mut vol = lumpy(64);
    for (i, v) in vol.values.iter_mut().enumerate() {
        if i % 64 <= 16 {
            *v = 0.0;
        }
    }
    let packed = pack(&vol, 1.0, 16, Lookup::Stochastic).unwrap();
    let view = packed.view();
    let d = packed.desc.dims;
    let hi = V3::new(d[0] as f32, d[1] as f32, d[2] as f32);
    let (mut with, mut without) = (0, 0);
    let mut rays = random_rays(&packed, 20_000);
    rays.extend((0..500).map(|i| Ray {
        o: V3::new(0.5 + (i % 15) as f32, (i / 15) as f32 * 1.9, -5.0),
        d: V3::new(0.0, 0.0, 1.0),
    }));
    for (i, ray) in rays.iter().enumerate() {
        let (t0, t1) = clip_to_box(ray, hi, 0.0, f32::INFINITY);
        if !(t0 < t1) {
            continue;
        }
        for mode in [Importance::VarianceAware, Importance::Mean] {
            let prep = prepare(&view, ray, t0, t1, mode);
            for jitter in [Jitter::Stratified, Jitter::Uniform] {
                let rng = HashRng::for_sample(i as u32, 0, 3);
                let (est, _) =
                    estimate_pair(&view, ray, &prep, 10, mode, jitter, Lookup::Stochastic, rng);
                if prep.f > 0.0 {
                    assert_eq!(
                        est.samples, 20,
                        "ray {i}: F = {}, {mode:?} {jitter:?}",
                        prep.f
                    );
                    with += 1;
                } else {
                    assert_eq!(est.samples, 0);
                    assert_eq!((est.x0, est.x1), (0.0, 0.0));
                    without += 1;
                }
                assert!(
                    est.x0 >= 0.0 && est.x1 >= 0.0,
                    "negative optical depth {est:?}"
                );
            }
        }
    }
    assert!(
        with > 10_000 && without > 0,
        "test rays must cover both cases ({with}, {without})"
    );
}

#[test]
fn transmittance_stays_in_unit_interval_and_empty_volume_gives_one() {
    let vol = lumpy(48);
    for lookup in Lookup::ALL {
        let packed = pack(&vol, 4.0, 16, lookup).unwrap();
        let view = packed.view();
        let p = params(&vol, 1, 1, 1, Estimator::Jackknife);
        for (i, ray) in random_rays(&packed, 5000).iter().enumerate() {
            let (t, _, _) = ray_transmittance(&view, &p, ray, HashRng::for_sample(i as u32, 0, 9));
            assert!((-1.0..=1.0).contains(&t), "T = {t}");
        }
    }
    let empty = constant(32, 0.0);
    let packed = pack(&empty, 1.0, 16, Lookup::Nearest).unwrap();
    let p = params(&empty, 16, 16, 2, Estimator::Jackknife);
    for px in render(&Backend::Cpu, &packed, &p, false).unwrap() {
        assert_eq!(px.t_mean, 1.0);
        assert_eq!(px.samples, 0);
    }
}

#[test]
fn gpu_and_cpu_render_identical_images_for_every_estimator_and_lookup() {
    let gpu = Backend::Gpu(gpu());
    let vol = lumpy(64);
    for lookup in Lookup::ALL {
        let packed = pack(&vol, 3.0, 16, lookup).unwrap();
        for est in [Estimator::Jackknife, Estimator::NaiveMean] {
            for (importance, jitter) in [
                (Importance::VarianceAware, Jitter::Stratified),
                (Importance::Mean, Jitter::Uniform),
            ] {
                let mut p = params(&vol, 48, 40, 3, est);
                p.importance = importance as u32;
                p.jitter = jitter as u32;
                let g = render(&gpu, &packed, &p, false).unwrap();
                let c = render(&Backend::Cpu, &packed, &p, false).unwrap();
                let ids: Vec<u32> = (0..g.len() as u32).collect();
                assert_bytes_equal(
                    &format!("transmittance_cs {lookup:?} {est:?} {importance:?} {jitter:?}"),
                    &ids,
                    &g,
                    &c,
                );
                assert!(
                    c.iter().any(|px| px.samples > 0),
                    "the camera must see the volume"
                );
            }
        }
    }
}

/// The first `count` of 40 [`random_rays`] that cross the grid box of `packed`, with their
/// clipped segment [t0, t1] and its optical depth by regular tracking; panics if fewer cross.
fn crossing_rays(packed: &PackedVolume, count: usize) -> Vec<(Ray, f32, f32, f32)> {
    let view = packed.view();
    let d = packed.desc.dims;
    let hi = V3::new(d[0] as f32, d[1] as f32, d[2] as f32);
    let rays: Vec<_> = random_rays(packed, 40)
        .into_iter()
        .filter_map(|ray| {
            let (t0, t1) = clip_to_box(&ray, hi, 0.0, f32::INFINITY);
            let (tau, _) = (t0 < t1)
                .then(|| shared::estimators::tracking::regular_tracking_tau(&view, &ray, t0, t1))?;
            Some((ray, t0, t1, tau))
        })
        .take(count)
        .collect();
    assert_eq!(rays.len(), count, "too few random rays cross the grid");
    rays
}

/// Mean of `trials` optical depth estimates of one ray and its standard error.
fn mean_depth(trials: u32, f: impl Fn(HashRng) -> f32) -> (f64, f64) {
    let xs: Vec<f64> = (0..trials)
        .map(|s| f(HashRng::for_sample(77, s, 5)) as f64)
        .collect();
    integration_tests::mean_se(&xs)
}

#[test]
fn optical_depth_estimates_are_unbiased_in_every_mode() {
    // 20k estimates per ray and mode; |mean - tau| < 4.5 standard errors (two-sided 99.999%
    // for a normal mean) on 8 rays x 6 modes, against regular tracking of the same grid.
    let vol = lumpy(48);
    let packed = pack(&vol, 2.0, 16, Lookup::Nearest).unwrap();
    let view = packed.view();
    for (ray, t0, t1, tau) in crossing_rays(&packed, 8) {
        let ray = &ray;
        for mode in [Importance::VarianceAware, Importance::Mean] {
            let prep = prepare(&view, ray, t0, t1, mode);
            for (jitter, n) in [
                (Jitter::Stratified, 10),
                (Jitter::Uniform, 10),
                (Jitter::Uniform, 37),
            ] {
                let (m, se) = mean_depth(20_000, |rng| {
                    shared::estimators::optical_depth::estimate_single(
                        &view,
                        ray,
                        &prep,
                        n,
                        mode,
                        jitter,
                        Lookup::Nearest,
                        rng,
                    )
                    .0
                    .x0
                });
                assert!(
                    (m - tau as f64).abs() < 4.5 * se + 1e-5 * tau as f64,
                    "{mode:?} {jitter:?} N={n}: mean {m} vs tau {tau} (se {se})"
                );
            }
        }
    }
}

#[test]
fn unbiased_ray_marching_matches_regular_tracking() {
    // 100k estimates per ray and scale; |mean - exp(-tau)| < 4.5 standard errors (two-sided
    // 99.999% for a normal mean), 6 rays x 2 sample-count scales.
    let vol = lumpy(48);
    let packed = pack(&vol, 0.06, 16, Lookup::Nearest).unwrap();
    let view = packed.view();
    for (ray, t0, t1, tau) in crossing_rays(&packed, 6) {
        let ray = &ray;
        let exact = (-(tau as f64)).exp();
        for scale in [1.0, 2.0] {
            let (m, se) = mean_depth(100_000, |rng| {
                shared::estimators::ray_marching::unbiased_ray_marching(
                    &view,
                    ray,
                    t0,
                    t1,
                    scale,
                    Lookup::Nearest,
                    rng,
                )
                .0
            });
            assert!(
                (m - exact).abs() < 4.5 * se,
                "scale {scale}: mean {m} vs exp(-tau) {exact} (se {se}, tau {tau})"
            );
        }
    }
}

#[test]
fn gpu_and_cpu_agree_for_every_estimator_and_many_samples_per_pixel() {
    // 3000 spp runs in many passes: lavapipe ends shader loops after 65535 iterations, which
    // once truncated a whole-spp loop on the GPU only. Every estimator, both lookups.
    let gpu = Backend::Gpu(gpu());
    let vol = lumpy(48);
    for lookup in Lookup::ALL {
        let packed = pack(&vol, 0.3, 16, lookup).unwrap();
        for spec in engine::estimators::ESTIMATORS {
            let mut p = params(
                &vol,
                6,
                5,
                if spec.name == "jackknife" { 3000 } else { 40 },
                Estimator::Jackknife,
            );
            spec.apply(&mut p);
            p.pixel_jitter = 0; // one ray per pixel: each sample takes 0 or 20 lookups
            let g = render(&gpu, &packed, &p, false).unwrap();
            let c = render(&Backend::Cpu, &packed, &p, false).unwrap();
            let ids: Vec<u32> = (0..g.len() as u32).collect();
            assert_bytes_equal(
                &format!("transmittance_cs {} {lookup:?}", spec.name),
                &ids,
                &g,
                &c,
            );
            if spec.name == "jackknife" {
                let full: Vec<_> = c.iter().filter(|px| px.samples > 0).collect();
                assert!(!full.is_empty());
                assert!(
                    full.iter().all(|px| px.samples == 20 * 3000),
                    "every sample of every pass ran"
                );
            }
        }
    }
}

#[test]
fn dense_media_with_long_loops_still_agree_between_gpu_and_cpu() {
    // Dense volume (optical depths in the hundreds): long tracking and ray-marching loops, passes
    // sized by engine::render::spp_per_pass to stay within lavapipe's 65535-iteration limit.
    let gpu = Backend::Gpu(gpu());
    let vol = lumpy(48);
    let packed = pack(&vol, 40.0, 8, Lookup::Nearest).unwrap();
    for name in [
        "track-length",
        "ratio",
        "unbiased-rm2",
        "biased-rm2",
        "regular",
    ] {
        let spec = engine::estimators::by_name(name).unwrap();
        let mut p = params(&vol, 4, 4, 48, Estimator::Jackknife);
        spec.apply(&mut p);
        assert!(engine::render::spp_per_pass(&p, &packed.desc).unwrap() >= 1);
        let g = render(&gpu, &packed, &p, false).unwrap();
        let c = render(&Backend::Cpu, &packed, &p, false).unwrap();
        let ids: Vec<u32> = (0..g.len() as u32).collect();
        assert_bytes_equal(&format!("transmittance_cs dense {name}"), &ids, &g, &c);
        let per_ray = c.iter().map(|px| px.samples as u64).sum::<u64>() as f64 / (16.0 * 48.0);
        println!("{name}: {per_ray:.1} lookups per ray");
        if name.ends_with("rm2") {
            assert!(
                per_ray > 50.0,
                "{name}: volume too thin for this test ({per_ray} lookups/ray)"
            );
        } else {
            assert!(per_ray > 1.0, "{name}: the camera must see the volume");
        }
    }
}
