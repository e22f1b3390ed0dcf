//! MIS weight estimation and the single-scattering integrators (Sec. 5, App. D, Fig. 7).

use engine::render::render_scene;
use engine::scene::bricks::pack;
use engine::volume::DenseVolume;
use engine::Backend;
use integration_tests::{
    assert_bytes_equal, camera_params, gpu, mean_se as mean_se_of, test_lights, unit_cube, volume,
};
use shared::estimators::optical_depth::{estimate_pair, prepare};
use shared::geometry::Ray;
use shared::geometry::V3;
use shared::integrators::radiance;
use shared::mis::Mobius;
use shared::params::RenderParams;
use shared::params::{Importance, Jitter};
use shared::params::{Integrator, TransmittanceHat};
use shared::rng::{pcg_hash, unit_f32, HashRng, Pcg32};
use shared::sampling::lights::PointLight;
use shared::volume::dda::clip_to_box;
use shared::volume::grid::Lookup;

/// Lumpy 32^3 test volume spanning [-1, 1]^3 in world space.
fn lumpy(n: u32) -> DenseVolume {
    volume("lumpy", [n; 3], unit_cube(n), |x, y, z| {
        let cell = pcg_hash(x / 4 + 101 * (y / 4) + 10007 * (z / 4));
        let fine = unit_f32(pcg_hash(x + n * (y + n * z)));
        if !cell.is_multiple_of(4) {
            0.25 + fine * unit_f32(cell)
        } else {
            0.0
        }
    })
}

fn params(
    vol: &DenseVolume,
    w: u32,
    h: u32,
    spp: u32,
    integrator: Integrator,
    t_hat: TransmittanceHat,
) -> RenderParams {
    RenderParams {
        spp,
        seed: 1,
        n: 10,
        rm_scale: 1.0,
        f_delta: 0.3,
        pixel_jitter: 0,
        integrator: integrator as u32,
        light_count: 2,
        albedo: 0.8,
        hg_g: 0.0,
        t_hat: t_hat as u32,
        ..camera_params(vol, w, h)
    }
}

/// Mean and standard error of f over `trials` independent generators.
fn mean_se(trials: u32, salt: u32, f: impl Fn(HashRng) -> f64) -> (f64, f64) {
    let xs: Vec<f64> = (0..trials)
        .map(|s| f(HashRng::for_sample(salt, s, 99)))
        .collect();
    mean_se_of(&xs)
}

#[test]
fn mis_weights_of_a_pair_sum_to_one_in_expectation_with_independent_inputs() {
    // App. D: E[w0] + E[w1] = 1 when w0 and w1 use independent optical depth estimates.
    // 100k pairs each for 4 distances on one ray; |E[w0] + E[w1] - 1| < 4.5 combined standard
    // errors (99.999% two-sided), for jackknife and naive weights.
    let vol = lumpy(32);
    let packed = pack(&vol, 3.0, 8, Lookup::Nearest).unwrap();
    let view = packed.view();
    let ray = Ray {
        o: V3::new(-1.0, 15.3, 16.2),
        d: V3::new(1.0, 0.0, 0.0),
    };
    let (ta, tb) = clip_to_box(&ray, V3::new(32.0, 32.0, 32.0), 0.0, f32::INFINITY);
    for frac in [0.2f32, 0.4, 0.7, 1.0] {
        let t = ta + frac * (tb - ta);
        let prep = prepare(&view, &ray, ta, t, Importance::VarianceAware);
        let (mu, p0) = (0.9f32, 0.15f32);
        for naive in [false, true] {
            let w = |g: Mobius, rng: HashRng| {
                let (e, _) = estimate_pair(
                    &view,
                    &ray,
                    &prep,
                    10,
                    Importance::VarianceAware,
                    Jitter::Stratified,
                    Lookup::Nearest,
                    rng,
                );
                (if naive {
                    g.naive(e.x0, e.x1)
                } else {
                    g.jackknife(e.x0, e.x1)
                }) as f64
            };
            let (m1, s1) = mean_se(100_000, 1, |r| w(Mobius::free_flight_weight(mu, p0), r));
            let (m0, s0) = mean_se(100_000, 2, |r| w(Mobius::other_weight(mu, p0), r));
            let se = (s0 * s0 + s1 * s1).sqrt();
            assert!(
                (m0 + m1 - 1.0).abs() < 4.5 * se + 1e-6,
                "t = {t}, naive {naive}: {m0} + {m1} (se {se})"
            );
        }
    }
}

#[test]
fn fig7_jackknife_weight_bias_is_far_below_naive_below_the_line() {
    // (u0, u1, v0, v1) = (1, 0, 1, 1/2), X0, X1 ~ N(tau, sigma^2), 10^6 pairs per grid point
    // (fixed seed). Below sigma = 1.645 tau, wherever the naive bias exceeds 5 standard errors
    // (where it is measurable at all), the jackknife bias must be under a fifth of it (sigma <=
    // 1) or below it (elsewhere below the line), up to 3 of its own standard errors (99.7%
    // two-sided) of Monte Carlo noise.
    let g = Mobius {
        u0: 1.0,
        u1: 0.0,
        v0: 1.0,
        v1: 0.5,
    };
    let mut compared = 0;
    for &tau in &[0.25f64, 0.5, 1.0, 2.0, 3.0] {
        for &ratio in &[0.2f64, 0.5, 0.8, 1.2, 1.6] {
            // All grid points are below the line sigma = 1.645 tau.
            let sigma = ratio * tau;
            let exact = g.eval(tau as f32) as f64;
            let mut rng = Pcg32::new(7 + (tau * 100.0) as u64, (ratio * 10.0) as u64);
            let (mut sj, mut sj2, mut sn, mut sn2) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
            let trials = 1_000_000;
            for _ in 0..trials {
                let (a, r) = rng.next_f32();
                let (b, r) = r.next_f32();
                rng = r;
                let rad = (-2.0 * (1.0 - a as f64).ln()).sqrt();
                let ang = std::f64::consts::TAU * b as f64;
                let (x0, x1) = (
                    (tau + sigma * rad * ang.cos()) as f32,
                    (tau + sigma * rad * ang.sin()) as f32,
                );
                let j = g.jackknife(x0, x1) as f64;
                sj += j;
                sj2 += j * j;
                let n = g.naive(x0, x1) as f64;
                sn += n;
                sn2 += n * n;
            }
            let mean_j = sj / trials as f64;
            let bias_j = mean_j - exact;
            let se_j = ((sj2 / trials as f64 - mean_j * mean_j) / trials as f64).sqrt();
            let mean_n = sn / trials as f64;
            let bias_n = mean_n - exact;
            let se_n = ((sn2 / trials as f64 - mean_n * mean_n) / trials as f64).sqrt();
            // Far below naive for sigma <= 1; for larger sigma, S often approaches the poles at
            // Im = pi (App. E) and the jackknife is only below naive: at (tau, sigma) = (2, 2.4)
            // its bias is 0.029 against 0.080, at (3, 2.4) 0.022 against 0.080 (this test).
            let factor = if sigma <= 1.0 { 0.2 } else { 1.0 };
            if bias_n.abs() > 5.0 * se_n {
                assert!(
                    bias_j.abs() < factor * bias_n.abs() + 3.0 * se_j,
                    "tau {tau} sigma {sigma}: jackknife bias {bias_j} (se {se_j}), naive {bias_n}"
                );
                compared += 1;
            }
        }
    }
    assert!(
        compared >= 10,
        "only {compared} grid points had a measurable naive bias"
    );
}

#[test]
fn unbiased_integrators_agree_within_their_confidence_intervals() {
    // Every Eq. 9 variant with ratio-tracking T̂, equiangular (ratio T̂), free-flight and Miller
    // et al. estimate the same integral (shadow rays use the same jackknife estimator in all).
    // 200k samples per pixel ray for 3 pixels; each mean within 4.5 combined standard errors
    // (99.999% two-sided) of the lowest-variance one.
    let vol = lumpy(32);
    let packed = pack(&vol, 2.0, 8, Lookup::Nearest).unwrap();
    let view = packed.view();
    let l = test_lights();
    for (px, py) in [(15u32, 16u32), (10, 12), (20, 18)] {
        let mut results = Vec::new();
        for (integrator, t_hat) in [
            (Integrator::MisJackknife, TransmittanceHat::Ratio),
            (Integrator::MisNaive, TransmittanceHat::Ratio),
            (Integrator::MisPowerJackknife, TransmittanceHat::Ratio),
            (Integrator::Equiangular, TransmittanceHat::Ratio),
            (Integrator::FreeFlight, TransmittanceHat::Ratio),
            (Integrator::Miller, TransmittanceHat::Ratio),
        ] {
            let p = params(&vol, 32, 32, 1, integrator, t_hat);
            let world = p.camera.world_ray(px, py, 0.5, 0.5, 32, 32);
            let (m, se) = mean_se(200_000, px * 131 + py, |rng| {
                radiance(&view, &p, &l, &world, rng).0 as f64
            });
            results.push((integrator, m, se));
        }
        assert!(results[0].1 > 0.0, "pixel ({px}, {py}) sees no light");
        let best = results
            .iter()
            .cloned()
            .fold(results[0], |a, b| if b.2 < a.2 { b } else { a });
        for &(i, m, se) in &results {
            let z = (m - best.1) / (se * se + best.2 * best.2).sqrt().max(1e-12);
            assert!(
                z.abs() < 4.5,
                "pixel ({px}, {py}): {i:?} mean {m} (se {se}) vs {:?} {} (se {}): z = {z}",
                best.0,
                best.1,
                best.2
            );
        }
    }
}

/// Mean and standard error of `trials` radiance samples of one camera ray, in parallel.
fn radiance_mean_se(
    view: &shared::volume::grid::VolumeView,
    p: &RenderParams,
    l: &[PointLight],
    world: &Ray,
    trials: u32,
    salt: u32,
) -> (f64, f64) {
    use rayon::prelude::*;
    let (s, s2) = (0..trials)
        .into_par_iter()
        .map(|k| {
            let x = radiance(view, p, l, world, HashRng::for_sample(salt, k, 7)).0 as f64;
            (x, x * x)
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    let m = s / trials as f64;
    let v = (s2 / trials as f64 - m * m) * trials as f64 / (trials - 1) as f64;
    (m, (v / trials as f64).sqrt())
}

#[test]
fn miller_agrees_with_free_flight_and_equiangular_per_ray() {
    // Issue 13: with Russian roulette in Miller et al.'s ratio tracking the two balance-heuristic
    // weights no longer sum to one and Miller was 0.7-2.3% low (z -10..-15 at 10^6 samples).
    // 10^6 samples per ray and integrator (seeds: salt = ray index, trial k, 7), 4 rays of a thin
    // and a dense volume (T through the centre about 0.2 and 0.002); Miller within z < 4 of
    // free-flight and of equiangular with ratio-tracking T̂ (99.994% two-sided per comparison).
    let vol = lumpy(32);
    let l = test_lights();
    let mut checked = 0;
    for (scale, rays) in [
        (2.0f32, [(15u32, 16u32), (20, 18)]),
        (8.0, [(16, 16), (12, 14)]),
    ] {
        let packed = pack(&vol, scale, 8, Lookup::Nearest).unwrap();
        let view = packed.view();
        for (r, &(px, py)) in rays.iter().enumerate() {
            let mut results = Vec::new();
            for integrator in [
                Integrator::Miller,
                Integrator::FreeFlight,
                Integrator::Equiangular,
            ] {
                let p = params(&vol, 32, 32, 1, integrator, TransmittanceHat::Ratio);
                let world = p.camera.world_ray(px, py, 0.5, 0.5, 32, 32);
                let salt = 1000 * scale as u32 + r as u32;
                results.push(radiance_mean_se(&view, &p, &l, &world, 1_000_000, salt));
            }
            let (miller, se_m) = results[0];
            assert!(
                miller > 0.0,
                "ray ({px}, {py}) at scale {scale} sees no light"
            );
            for (name, (m, se)) in [("free-flight", results[1]), ("equiangular", results[2])] {
                let z = (miller - m) / (se_m * se_m + se * se).sqrt();
                println!("scale {scale} ray ({px}, {py}): Miller {miller:.6} vs {name} {m:.6}: z = {z:+.2}");
                assert!(z.abs() < 4.0, "scale {scale} ray ({px}, {py}): Miller {miller} (se {se_m}) vs {name} {m} (se {se}): z = {z}");
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 4);
}

#[test]
fn gpu_and_cpu_render_identical_images_for_every_integrator() {
    let gpu = Backend::Gpu(gpu());
    let vol = lumpy(32);
    for lookup in [Lookup::Nearest, Lookup::Stochastic] {
        let packed = pack(&vol, 2.0, 8, lookup).unwrap();
        // The integrators lit by point lights (direct, path, restir: tests/tests/direct.rs,
        // path.rs, restir.rs).
        let point_lit = engine::integrators::integrators().filter(|i| !i.is_lit());
        for integrator in point_lit {
            for t_hat in [TransmittanceHat::Jackknife, TransmittanceHat::Ratio] {
                let mut p = params(&vol, 12, 10, 6, integrator, t_hat);
                p.pixel_jitter = 1;
                p.hg_g = 0.3;
                let g = render_scene(&gpu, &packed, &p, &test_lights(), false).unwrap();
                let c = render_scene(&Backend::Cpu, &packed, &p, &test_lights(), false).unwrap();
                let ids: Vec<u32> = (0..g.len() as u32).collect();
                assert_bytes_equal(
                    &format!("scattering_cs {integrator:?} {t_hat:?} {lookup:?}"),
                    &ids,
                    &g,
                    &c,
                );
                assert!(
                    c.iter().any(|px| px.t_mean > 0.0),
                    "{integrator:?}: black image"
                );
            }
        }
    }
}
