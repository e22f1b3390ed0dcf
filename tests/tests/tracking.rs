//! Regular tracking, track-length and ratio tracking (shared/src/tracking.rs) on volumes built here.
//!
//! Statistical tests use fixed seeds, so they are deterministic; each check is a two-sided
//! z-test at 4 standard errors (per-check confidence 99.994% for a normal statistic, so with the
//! ~40 checks below a correct implementation would fail with probability < 0.3% over seeds).

use engine::scene::bricks::{pack, PackedVolume};
use engine::volume::{Affine, DenseVolume};
use shared::estimators::optical_depth::prepare_with_mean;
use shared::estimators::telescoping::{telescoping, telescoping_cycles};
use shared::estimators::tracking::{
    ratio_tracking, regular_tracking_tau, track_length, MAX_TENTATIVE_COLLISIONS,
};
use shared::geometry::Ray;
use shared::geometry::V3;
use shared::integrators::shadow_roulette::{rouletted_transmittance, survival};
use shared::params::{
    Config, Estimator as Which, Importance, Integrator, Jitter, RenderParams, TransmittanceHat,
};
use shared::rng::{pcg_hash, unit_f32, HashRng};
use shared::sampling::exponential::MajorantIter;
use shared::volume::dda::clip_to_box;
use shared::volume::grid::{Lookup, VolumeView};

/// Trials per ray in the statistical tests.
const TRIALS: u32 = 200_000;
/// Two-sided acceptance band in standard errors.
const Z: f64 = 4.0;

type Estimator = fn(&VolumeView, &Ray, f32, f32, Lookup, HashRng) -> (f32, u32, HashRng);

/// Track-length estimate as (T, lookups, rng).
fn length(
    v: &VolumeView,
    r: &Ray,
    t0: f32,
    t1: f32,
    l: Lookup,
    rng: HashRng,
) -> (f32, u32, HashRng) {
    let (t, tally, rng) = track_length(v, r, t0, t1, l, rng);
    (t, tally.lookups, rng)
}

/// Ratio tracking as (T, lookups, rng), with pbrt-v4's Russian roulette if `ROULETTE`.
fn ratio_of<const ROULETTE: bool>(
    v: &VolumeView,
    r: &Ray,
    t0: f32,
    t1: f32,
    l: Lookup,
    rng: HashRng,
) -> (f32, u32, HashRng) {
    let (t, tally, rng) = ratio_tracking(v, r, t0, t1, l, ROULETTE, rng);
    (t, tally.lookups, rng)
}

/// Ratio tracking without roulette (the default, as in the paper).
const RATIO: Estimator = ratio_of::<false>;
/// Ratio tracking with pbrt-v4's Russian roulette.
const RATIO_RR: Estimator = ratio_of::<true>;

/// A test volume of `dims` unit voxels with density `f(x, y, z)`.
fn volume(dims: [u32; 3], f: impl Fn(u32, u32, u32) -> f32) -> DenseVolume {
    integration_tests::volume("tracking-test", dims, Affine::identity(), f)
}

fn packed(vol: &DenseVolume) -> PackedVolume {
    pack(vol, 1.0, 16, Lookup::Nearest).unwrap()
}

/// Homogeneous 32^3 box, c = 1/16 (exact in f16): majorant tight everywhere.
fn homogeneous() -> PackedVolume {
    packed(&volume([32; 3], |_, _, _| 0.0625))
}

/// 64x32x32, four brick columns along x with densities 1/32, 0, 1/16 and 1/64, plus a hot voxel
/// (2.0) at (40, 8, 8). Brick majorants (over windows widened by one voxel): column 0 tight
/// (1/32), column 1 loose (empty, majorant 1/16 from its neighbour), column 2 tight except in the
/// bricks around the hot voxel (majorant 2 = 32x the density), column 3 loose (1/16 vs 1/64).
fn piecewise() -> PackedVolume {
    packed(&volume([64, 32, 32], |x, y, z| {
        if (x, y, z) == (40, 8, 8) {
            return 2.0;
        }
        match x / 16 {
            0 => 0.03125,
            1 => 0.0,
            2 => 0.0625,
            _ => 0.015625,
        }
    }))
}

/// 32^3 box of density 1/8 with one hot voxel (2.0) at (16, 16, 16), inside the widened window of
/// every brick: majorant 2 = 16x the density everywhere, tau = 4 along an axis, so ratio tracking
/// falls below the Russian roulette threshold on nearly every ray.
fn loose() -> PackedVolume {
    packed(&volume([32; 3], |x, y, z| {
        if (x, y, z) == (16, 16, 16) {
            2.0
        } else {
            0.125
        }
    }))
}

fn ray(o: [f32; 3], target: [f32; 3]) -> Ray {
    let o = V3::new(o[0], o[1], o[2]);
    let dir = V3::new(target[0], target[1], target[2]) - o;
    Ray {
        o,
        d: dir * (1.0 / dir.dot(dir).sqrt()),
    }
}

/// Ray `i` of the family `seed` along z: from a point of [-s, 2s)^2 x {z0} to one of [0, s)^3.
fn z_ray(seed: u32, i: u32, z0: f32, s: f32) -> Ray {
    let u = |k: u32| unit_f32(pcg_hash(seed + i * 8 + k));
    let w = 3.0 * s;
    ray(
        [u(0) * w - s, u(1) * w - s, z0],
        [u(2) * s, u(3) * s, u(4) * s],
    )
}

/// Ray `i` of the family `seed` along x: from x[0] to x[1], both ends in [0, s)^2 in y and z.
fn x_ray(seed: u32, i: u32, x: [f32; 2], s: f32) -> Ray {
    let u = |k: u32| unit_f32(pcg_hash(seed + i * 8 + k));
    ray([x[0], u(0) * s, u(1) * s], [x[1], u(2) * s, u(3) * s])
}

fn clip(p: &PackedVolume, r: &Ray) -> (f32, f32) {
    let d = p.desc.dims;
    clip_to_box(
        r,
        V3::new(d[0] as f32, d[1] as f32, d[2] as f32),
        0.0,
        f32::INFINITY,
    )
}

/// Mean, sample variance and standard error of the mean.
fn stats(xs: &[f64]) -> (f64, f64, f64) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
    (mean, var, (var / n).sqrt())
}

/// `TRIALS` estimates of one ray with independent per-trial rngs (seeded by ray id and trial).
fn run(est: Estimator, p: &PackedVolume, r: &Ray, t0: f32, t1: f32, id: u32) -> Vec<(f32, u32)> {
    let view = p.view();
    (0..TRIALS)
        .map(|k| {
            let (t, n, _) = est(
                &view,
                r,
                t0,
                t1,
                Lookup::Nearest,
                HashRng::for_sample(id, k, 17),
            );
            (t, n)
        })
        .collect()
}

#[test]
fn regular_tracking_equals_chord_length_times_density_in_a_constant_box() {
    let p = homogeneous();
    let view = p.view();
    let mut checked = 0;
    for i in 0..2000u32 {
        let r = z_ray(0, i, -20.0, 32.0);
        let (t0, t1) = clip(&p, &r);
        if !(t0 < t1) {
            continue;
        }
        let (tau, tally) = regular_tracking_tau(&view, &r, t0, t1);
        let visited = tally.lookups;
        assert_eq!(tally.capped, 0);
        let exact = 0.0625 * (t1 - t0) as f64;
        assert!(
            (tau as f64 - exact).abs() <= 1e-5 * exact.max(1.0),
            "ray {i}: tau {tau}, exact {exact}"
        );
        assert!((1..=32 * 3 + 4).contains(&visited), "visited {visited}");
        checked += 1;
    }
    assert!(checked > 1000, "only {checked} rays hit the box");
}

#[test]
fn regular_tracking_equals_sum_of_densities_times_lengths_in_two_halves() {
    // x < 16: a = 0.5, x >= 16: b = 1.5 (both exact in f16). Axis-parallel and oblique rays.
    let (a, b) = (0.5f64, 1.5f64);
    let p = packed(&volume(
        [32, 8, 8],
        |x, _, _| if x < 16 { 0.5 } else { 1.5 },
    ));
    let view = p.view();
    let axis = ray([-5.0, 3.3, 4.7], [40.0, 3.3, 4.7]);
    let (t0, t1) = clip(&p, &axis);
    let (tau, tally) = regular_tracking_tau(&view, &axis, t0, t1);
    assert_eq!((t0, t1), (5.0, 37.0));
    assert_eq!(tau, 0.5 * 16.0 + 1.5 * 16.0, "axis-parallel ray");
    assert_eq!(tally.lookups, 32);
    // A sub-interval starting and ending inside voxels: x from 10.25 to 20.5.
    let (tau, _) = regular_tracking_tau(&view, &axis, 15.25, 25.5);
    assert_eq!(tau, (0.5 * 5.75 + 1.5 * 4.5) as f32, "sub-interval");
    let mut checked = 0;
    for i in 0..2000u32 {
        let r = x_ray(0x5eed, i, [-10.0, 42.0], 8.0);
        let (t0, t1) = clip(&p, &r);
        if !(t0 < t1) {
            continue;
        }
        // Where the ray crosses x = 16, clamped to the clipped interval; La + Lb = t1 - t0.
        let tc = ((16.0 - r.o.x as f64) / r.d.x as f64).clamp(t0 as f64, t1 as f64);
        let exact = a * (tc - t0 as f64) + b * (t1 as f64 - tc);
        let (tau, _) = regular_tracking_tau(&view, &r, t0, t1);
        assert!(
            (tau as f64 - exact).abs() <= 2e-5 * exact.max(1.0),
            "ray {i}: tau {tau}, exact {exact}"
        );
        checked += 1;
    }
    assert!(checked > 500, "only {checked} rays hit the box");
}

#[test]
fn majorant_segments_tile_the_ray_and_bound_every_voxel_they_cross() {
    let p = piecewise();
    let view = p.view();
    for i in 0..500u32 {
        let r = x_ray(0xabc, i, [-8.0, 72.0], 32.0);
        let (t0, t1) = clip(&p, &r);
        if !(t0 < t1) {
            continue;
        }
        let mut it = MajorantIter::new(&view, &r, t0, t1);
        let mut t = t0;
        while !it.done() {
            let s = it.next_segment(&view);
            assert_eq!(s.t0, t, "segments must be contiguous");
            // Every voxel along the segment is below its majorant (sampled densely).
            for k in 0..=16 {
                let tk = s.t0 + (s.t1 - s.t0) * k as f32 / 16.0;
                let mu = view.mu_nearest(r.at(tk));
                assert!(
                    mu <= s.sigma_maj,
                    "mu {mu} > majorant {} at t {tk}",
                    s.sigma_maj
                );
            }
            t = s.t1;
        }
        assert!((t - t1).abs() <= 1e-4 * t1, "ended at {t}, not {t1}");
    }
}

/// The three test volumes of the statistical tests, by name.
fn test_volumes() -> [(&'static str, PackedVolume); 3] {
    [
        ("homogeneous", homogeneous()),
        ("piecewise", piecewise()),
        ("loose", loose()),
    ]
}

/// Rays of one test volume: (name, ray, t0, t1); the last of each set is a sub-interval.
fn test_rays(name: &str, p: &PackedVolume) -> Vec<(String, Ray, f32, f32)> {
    let d = p.desc.dims;
    let (x, y, z) = (d[0] as f32, d[1] as f32, d[2] as f32);
    let rays = [
        ("axis", ray([-3.0, 3.5, 3.5], [x + 3.0, 3.5, 3.5])),
        ("hot", ray([-3.0, 8.5, 8.5], [x + 3.0, 8.5, 8.5])),
        (
            "oblique",
            ray([-3.0, 1.0, 2.0], [x + 3.0, y - 1.5, z - 0.5]),
        ),
        (
            "diagonal",
            ray([0.3, -1.0, -1.0], [x - 0.7, y + 1.0, z + 1.0]),
        ),
    ];
    let mut out: Vec<_> = rays
        .iter()
        .map(|(n, r)| {
            let (t0, t1) = clip(p, r);
            assert!(t0 < t1, "{name}/{n} misses the box");
            (format!("{name}/{n}"), *r, t0, t1)
        })
        .collect();
    // The hot ray from inside brick 0 to inside the last brick along x.
    let (_, r, t0, t1) = out[1].clone();
    out.push((format!("{name}/hot-sub"), r, t0 + 5.3, t1 - 9.1));
    out
}

/// One estimator's z-tests against regular tracking on the rays of the three test volumes: per
/// ray `TRIALS` estimates, |mean - exp(-tau)| <= Z se + `floor` asserted; and its power: on the
/// rays where `judged(T, |T - T'|, se)` holds, with T' = exp(-1.05 tau) (a 5% error in the
/// optical depth), the test must also reject T'. Returns (rays judged, of them rejected).
fn z_tests_against_regular(
    est_name: &str,
    est: Estimator,
    floor: f64,
    judged: fn(f64, f64, f64) -> bool,
) -> (u32, u32) {
    let (mut total, mut rejected) = (0, 0);
    for (name, p) in test_volumes() {
        let view = p.view();
        for (id, (what, r, t0, t1)) in test_rays(name, &p).into_iter().enumerate() {
            let (tau, _) = regular_tracking_tau(&view, &r, t0, t1);
            let reference = (-(tau as f64)).exp();
            let runs = run(est, &p, &r, t0, t1, id as u32);
            let xs: Vec<f64> = runs.iter().map(|&(t, _)| t as f64).collect();
            let lookups = runs.iter().map(|&(_, n)| n as f64).sum::<f64>() / runs.len() as f64;
            let (mean, var, se) = stats(&xs);
            println!(
                "{what:22} {est_name:14} tau {tau:8.5} T {reference:.6} mean {mean:.6} \
                 se {se:.2e} var {var:.3e} z {:+.2} lookups {lookups:.2}",
                (mean - reference) / se
            );
            assert!(xs.iter().all(|x| x.is_finite()), "{what} {est_name}");
            assert!(
                (mean - reference).abs() <= Z * se + floor,
                "{what} {est_name}: mean {mean} vs exp(-tau) {reference} (se {se})"
            );
            let wrong = (-1.05 * tau as f64).exp();
            if judged(reference, (reference - wrong).abs(), se) {
                if (mean - wrong).abs() > Z * se + floor {
                    rejected += 1;
                }
                total += 1;
            }
        }
    }
    (total, rejected)
}

#[test]
fn track_length_and_ratio_tracking_are_unbiased_against_regular_tracking() {
    // 200k trials per (volume, ray, estimator), 3 volumes x 5 rays x 3 estimators = 45 z-tests
    // at 4 standard errors. Power check: wherever T >= 1e-3 (all rays but the loose diagonal,
    // T = 1e-4, ~20 escapes in 200k track-length trials), the test must also reject exp(-1.05 tau),
    // i.e. a 5% error in the optical depth, so the band is not vacuous.
    for (est_name, est) in [
        ("track-length", length as Estimator),
        ("ratio", RATIO),
        ("ratio-roulette", RATIO_RR),
    ] {
        let (total, rejected) = z_tests_against_regular(est_name, est, 0.0, |t, _, _| t >= 1e-3);
        assert_eq!(
            rejected, total,
            "{est_name}: the test cannot tell a 5% error in tau"
        );
    }
}

/// The unbiased telescoping series (Misso et al. 2022) with n = 4 level-0 samples, as
/// (T, lookups, rng).
fn telescoping_n4(
    v: &VolumeView,
    r: &Ray,
    t0: f32,
    t1: f32,
    l: Lookup,
    rng: HashRng,
) -> (f32, u32, HashRng) {
    let (t, tally, rng) = telescoping(v, r, t0, t1, 4, Importance::VarianceAware, l, rng);
    (t, tally.lookups, rng)
}

/// Cycles 5.0's truncated telescoping shadow rays, as (T, lookups, rng).
fn cycles(
    v: &VolumeView,
    r: &Ray,
    t0: f32,
    t1: f32,
    l: Lookup,
    rng: HashRng,
) -> (f32, u32, HashRng) {
    let (t, tally, rng) = telescoping_cycles(v, r, t0, t1, l, rng);
    (t, tally.lookups, rng)
}

#[test]
fn telescoping_is_unbiased_against_regular_tracking() {
    // As the tracking test above: 200k trials per (volume, ray), 15 z-tests at 4 standard errors
    // plus f32 rounding (1e-6: in the homogeneous box the control variate is exact and every
    // estimate is exp(-tau) to the last bits, se 0). Power: on every ray where a 5% error in tau
    // moves T by more than 8 standard errors (11 of the 15; not the two through the hot voxel of
    // `piecewise`, whose variance is 30x the others', nor the loose diagonal, T = 1e-4), the
    // test must reject exp(-1.05 tau). The expected lookups per estimate are
    // n (1 + sum_l 2^(l-1) r^l) = 2.21 n where the series is not cut. Cycles' truncated form is
    // printed beside it (biased: only its finiteness is asserted, with a band wide enough for
    // any mean).
    let (total, rejected) =
        z_tests_against_regular("telescoping", telescoping_n4, 1e-6, |_, d, se| {
            d > 2.0 * Z * se
        });
    assert!(total >= 11, "only {total} rays can tell a 5% error in tau");
    assert_eq!(rejected, total, "the test cannot tell a 5% error in tau");
    z_tests_against_regular("telescoping-cycles", cycles, 1.0, |_, _, _| false);
}

#[test]
fn track_length_is_bernoulli_with_variance_t_times_one_minus_t() {
    // 200k trials per ray on the piecewise volume. Estimates must be exactly 0 or 1, and the
    // sample variance s^2 must match T(1 - T) (T = exp(-tau_regular)) within 4 standard errors of
    // s^2, se(s^2) = sqrt((mu4 - sigma^4) / n) with mu4 = p(1-p)(1 - 3p + 3p^2) for a Bernoulli.
    let p = piecewise();
    let view = p.view();
    for (id, (what, r, t0, t1)) in test_rays("piecewise", &p).into_iter().enumerate() {
        let (tau, _) = regular_tracking_tau(&view, &r, t0, t1);
        let t = (-(tau as f64)).exp();
        let runs = run(length, &p, &r, t0, t1, 100 + id as u32);
        assert!(runs.iter().all(|&(x, _)| x == 0.0 || x == 1.0));
        let xs: Vec<f64> = runs.iter().map(|&(x, _)| x as f64).collect();
        let (_, var, _) = stats(&xs);
        let sigma2 = t * (1.0 - t);
        let mu4 = sigma2 * (1.0 - 3.0 * t + 3.0 * t * t);
        let se = ((mu4 - sigma2 * sigma2) / TRIALS as f64).sqrt();
        println!(
            "{what:22} T {t:.6} var {var:.6} T(1-T) {sigma2:.6} se {se:.2e} z {:+.2}",
            (var - sigma2) / se
        );
        assert!(
            (var - sigma2).abs() <= Z * se,
            "{what}: variance {var} vs T(1-T) {sigma2} (se {se})"
        );
    }
}

#[test]
fn tentative_collisions_are_poisson_in_the_majorant_optical_depth() {
    // An empty 32^3 box whose bricks all see a hot voxel 0.5 at (16, 16, 16) through their widened
    // windows: along y = z = 3.5 mu = 0 but the majorant is 0.5 in both bricks along x, so ratio
    // tracking always returns 1 and its lookup count is Poisson(0.5 * 32 = 16) if free flights
    // restart correctly at the brick boundary. 200k trials; mean and variance within 4 se
    // (se of the variance of a Poisson(l): sqrt((l + 3 l^2 - l^2) / n) = sqrt((l + 2 l^2) / n)).
    let p = packed(&volume([32; 3], |x, y, z| {
        if (x, y, z) == (16, 16, 16) {
            0.5
        } else {
            0.0
        }
    }));
    let r = ray([-3.0, 3.5, 3.5], [40.0, 3.5, 3.5]);
    let (t0, t1) = clip(&p, &r);
    let lambda = 0.5 * (t1 - t0) as f64;
    assert_eq!(lambda, 16.0);
    let runs = run(RATIO, &p, &r, t0, t1, 7);
    assert!(runs.iter().all(|&(t, _)| t == 1.0));
    let ns: Vec<f64> = runs.iter().map(|&(_, n)| n as f64).collect();
    let (mean, var, se) = stats(&ns);
    let se_var = ((lambda + 2.0 * lambda * lambda) / TRIALS as f64).sqrt();
    println!(
        "lookups: mean {mean:.4} (se {se:.4}), var {var:.4} (se {se_var:.4}), lambda {lambda}"
    );
    assert!((mean - lambda).abs() <= Z * se, "mean count {mean}");
    assert!((var - lambda).abs() <= Z * se_var, "count variance {var}");
}

#[test]
fn ratio_tracking_stays_finite_in_unit_interval_and_russian_roulette_fires() {
    // RR only acts below 0.05 and survival multiplies by 4 (< 0.2), and every factor is in [0, 1],
    // so estimates never exceed 1. On the loose volume's axis ray (mu = 1/8 < majorant 2 all
    // along it) no factor is 0, so every 0 is a roulette termination.
    let lumpy = volume([40; 3], |x, y, z| {
        if pcg_hash(x / 8 + 101 * (y / 8) + 10007 * (z / 8)).is_multiple_of(3) {
            0.0
        } else {
            2.0 * unit_f32(pcg_hash(x + 40 * (y + 40 * z)))
        }
    });
    for lookup in [Lookup::Nearest, Lookup::Stochastic] {
        let p = pack(&lumpy, 1.0, 16, lookup).unwrap();
        let view = p.view();
        for i in 0..20_000u32 {
            let r = z_ray(0x77, i, -30.0, 40.0);
            let (t0, t1) = clip(&p, &r);
            if !(t0 < t1) {
                continue;
            }
            let rng = HashRng::for_sample(i, 0, 3);
            let (t, _, _) = RATIO_RR(&view, &r, t0, t1, lookup, rng);
            assert!(t.is_finite() && (0.0..=1.0).contains(&t), "T = {t}");
        }
    }
    let p = loose();
    let r = ray([-3.0, 3.5, 3.5], [40.0, 3.5, 3.5]);
    let (t0, t1) = clip(&p, &r);
    let runs = run(RATIO_RR, &p, &r, t0, t1, 11);
    let zeros = runs.iter().filter(|&&(t, _)| t == 0.0).count();
    let scaled = runs.iter().filter(|&&(t, _)| t >= 0.05).count();
    println!("loose axis ray: {zeros} of {TRIALS} terminated by roulette, {scaled} >= 0.05");
    assert!(runs
        .iter()
        .all(|&(t, _)| t.is_finite() && (0.0..=1.0).contains(&t)));
    assert!(
        zeros > TRIALS as usize / 2,
        "roulette must terminate most rays here"
    );
    assert!(scaled > 0, "survivors are scaled up by 1 / (1 - q)");
}

#[test]
fn empty_volume_gives_one_without_lookups() {
    let p = packed(&volume([32; 3], |_, _, _| 0.0));
    let view = p.view();
    let r = ray([-3.0, 1.0, 2.0], [35.0, 30.0, 31.0]);
    let (t0, t1) = clip(&p, &r);
    for est in [length as Estimator, RATIO, RATIO_RR] {
        let rng = HashRng::for_sample(1, 2, 3);
        let (t, n, out) = est(&view, &r, t0, t1, Lookup::Nearest, rng);
        assert_eq!((t, n, out), (1.0, 0, rng), "zero majorants take no sample");
    }
    assert_eq!(regular_tracking_tau(&view, &r, t0, t1).0, 0.0);
}

#[test]
fn same_rng_state_gives_the_same_result() {
    let p = piecewise();
    let view = p.view();
    let mut differ = 0;
    for (_, r, t0, t1) in test_rays("piecewise", &p) {
        for lookup in [Lookup::Nearest, Lookup::Stochastic] {
            for est in [length as Estimator, RATIO, RATIO_RR] {
                for k in 0..200 {
                    let rng = HashRng::for_sample(5, k, 9);
                    let a = est(&view, &r, t0, t1, lookup, rng);
                    let b = est(&view, &r, t0, t1, lookup, rng);
                    assert_eq!(a.0.to_bits(), b.0.to_bits());
                    assert_eq!((a.1, a.2), (b.1, b.2));
                    assert!(a.1 < MAX_TENTATIVE_COLLISIONS);
                    if a.1 > 0 {
                        assert_ne!(a.2, rng, "a lookup draws random numbers");
                    }
                    let c = est(
                        &view,
                        &r,
                        t0,
                        t1,
                        lookup,
                        HashRng::for_sample(5, k + 1000, 9),
                    );
                    if (a.0.to_bits(), a.1) != (c.0.to_bits(), c.1) {
                        differ += 1;
                    }
                }
            }
        }
    }
    assert!(
        differ > 1000,
        "different seeds must give different results ({differ})"
    );
}

/// Delta tracking with one uniform for its collision tests (the path's free flight under
/// `--sampler sobol`) samples the free-flight distribution exactly: over 200,000 flights per ray and threshold, P(collision before t) equals
/// 1 - exp(-tau(t0, t)) of regular tracking within 4 standard errors, with its two leading
/// uniforms from the generator and from a scrambled Sobol pattern (flight k takes point k), on
/// rays through the piecewise volume (tight, loose and empty bricks, a hot voxel) and through
/// the loose one (majorant 16x the density).
#[test]
fn inverted_delta_tracking_samples_the_free_flight_distribution() {
    use shared::estimators::inverted_tracking::inverted_delta_tracking;
    use shared::sampling::sampler::Lead;
    use shared::sampling::sobol::sobol_2d;
    let mut checked = 0;
    for (name, p, r) in [
        (
            "piecewise",
            piecewise(),
            ray([-5.0, 8.3, 8.6], [70.0, 8.5, 8.4]),
        ),
        (
            "piecewise, oblique",
            piecewise(),
            ray([-5.0, 2.0, 30.0], [70.0, 20.0, 3.0]),
        ),
        (
            "loose",
            loose(),
            ray([16.4, 16.5, -5.0], [16.6, 16.3, 40.0]),
        ),
    ] {
        let view = p.view();
        let (t0, t1) = clip(&p, &r);
        assert!(t0 < t1, "{name}: the ray misses the volume");
        for led in [false, true] {
            let ts: Vec<Option<f32>> = (0..TRIALS)
                .map(|k| {
                    let lead = if led {
                        let u = sobol_2d(k, 0x1234_5678);
                        Lead {
                            u0: u[0],
                            u1: u[1],
                            on: 1,
                        }
                    } else {
                        Lead::OFF
                    };
                    let rng = HashRng::for_sample(7, k, 23);
                    let (f, _) = inverted_delta_tracking(
                        &view,
                        &r,
                        t0,
                        t1,
                        Lookup::Nearest,
                        0,
                        MAX_TENTATIVE_COLLISIONS,
                        lead,
                        rng,
                    );
                    assert!(f.tally.capped == 0);
                    f.found.then_some(f.t)
                })
                .collect();
            for x in [0.2f32, 0.5, 0.8, 1.0] {
                let t = t0 + x * (t1 - t0);
                let (tau, _) = regular_tracking_tau(&view, &r, t0, t);
                let p_exact = 1.0 - (-(tau as f64)).exp();
                let hits = ts.iter().filter(|f| f.is_some_and(|f| f < t)).count();
                let p_hat = hits as f64 / TRIALS as f64;
                let se = (p_exact * (1.0 - p_exact) / TRIALS as f64).sqrt().max(1e-9);
                let z = (p_hat - p_exact) / se;
                assert!(
                    z.abs() < Z,
                    "{name}, led {led}, t at {x} of the chord: P(collision) {p_hat:.5} vs exact \
                     {p_exact:.5} (z = {z:.2})"
                );
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 24);
}

/// The jackknife (N = 10, Alg. 2's importance, stratified) of a ray, with the shadow rays'
/// roulette if `ROULETTE`, as (T, lookups, rng).
fn jackknife_of<const ROULETTE: bool>(
    v: &VolumeView,
    r: &Ray,
    t0: f32,
    t1: f32,
    l: Lookup,
    rng: HashRng,
) -> (f32, u32, HashRng) {
    let cfg = Config {
        estimator: Which::Jackknife,
        importance: Importance::VarianceAware,
        jitter: Jitter::Stratified,
        lookup: l,
        integrator: Integrator::Path,
        t_hat: TransmittanceHat::Jackknife,
        roulette: false,
        max_collisions: MAX_TENTATIVE_COLLISIONS,
    };
    let params = RenderParams {
        n: 10,
        ..Default::default()
    };
    let (t, tally, rng) = if ROULETTE {
        rouletted_transmittance(v, &cfg, &params, r, t0, t1, rng)
    } else {
        shared::estimators::estimate::transmittance(v, &cfg, &params, r, t0, t1, rng)
    };
    (t, tally.lookups, rng)
}

#[test]
fn shadow_roulette_keeps_the_jackknifes_mean() {
    // Per ray of the three test volumes, 200k jackknife estimates with the shadow rays' roulette
    // against 200k without (other generators: trial ids offset): the means agree within 4
    // combined standard errors (15 two-sample z-tests, 99.994 % each). The roulette applies
    // (P < 1) on at least 3 rays (the loose volume's, tau 4 and more), and on each of those the
    // test must reject the roulette without its weight 1/P (the mean x P), so it can fail.
    let (mut applied, mut rejected_unweighted) = (0, 0);
    for (name, p) in test_volumes() {
        let view = p.view();
        for (id, (what, r, t0, t1)) in test_rays(name, &p).into_iter().enumerate() {
            let prep = prepare_with_mean(&view, &r, t0, t1, Importance::VarianceAware);
            let p_survive = survival(prep.tau_mean) as f64;
            let with: Vec<f64> = run(jackknife_of::<true>, &p, &r, t0, t1, id as u32)
                .iter()
                .map(|&(t, _)| t as f64)
                .collect();
            let without: Vec<f64> = run(jackknife_of::<false>, &p, &r, t0, t1, id as u32 + 1000)
                .iter()
                .map(|&(t, _)| t as f64)
                .collect();
            let (m1, _, se1) = stats(&with);
            let (m0, _, se0) = stats(&without);
            let se = (se1 * se1 + se0 * se0).sqrt();
            println!(
                "{what:22} P {p_survive:.3} with {m1:.6} without {m0:.6} z {:+.2}",
                (m1 - m0) / se
            );
            assert!(with.iter().all(|x| x.is_finite()), "{what}");
            assert!(
                (m1 - m0).abs() <= Z * se + 1e-6,
                "{what}: mean {m1} with the roulette, {m0} without (se {se})"
            );
            if p_survive < 1.0 {
                applied += 1;
                if (m1 * p_survive - m0).abs() > Z * se + 1e-6 {
                    rejected_unweighted += 1;
                }
            }
        }
    }
    assert!(applied >= 3, "the roulette applies on {applied} rays only");
    assert_eq!(
        rejected_unweighted, applied,
        "the test cannot tell a roulette without its weight"
    );
}
