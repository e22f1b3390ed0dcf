//! `restir` (point lights resampled by GRIS with jackknife-estimated targets) and many-light
//! scenes: GPU == CPU bytes for every target and shadow-ray estimator; the streaming reservoir
//! keeps candidate i with probability w_i / sum w; the target stays positive where the integrand
//! is; without point lights it is `direct` bit for bit; with one candidate, and with eight for
//! every target, it agrees with `direct` in expectation (z-tests per pixel and image; the
//! quadrature tests of unbiasedness are in direct.rs). Spatial reuse: GPU == CPU bytes after
//! one, two and three passes with pairwise and balance weights; unbiased against `direct`;
//! neighbours stay in their window; a neighbour's target re-evaluated from another pixel is the
//! value its own reservoir holds (the shift's p̂_←j).

use engine::lighting::{build, EnvSource, LightingOptions, SceneLights};
use engine::render::render_lit;
use engine::scene::bricks::{pack, PackedVolume};
use engine::volume::DenseVolume;
use engine::Backend;
use integration_tests::{assert_bytes_equal, camera_params, gpu, lumpy_blobs, many_lights};
use shared::integrators::restir::{p_hat, stage_count, Reservoir, RestirState};
use shared::integrators::restir_reuse::{neighbour, NO_NEIGHBOUR};
use shared::kernels::render::{restir_wave_step, StageAt};
use shared::params::{
    Config, Estimator, Integrator, RenderParams, RestirMis, RestirParams, RestirTarget,
};
use shared::volume::grid::Lookup;

fn packed(vol: &DenseVolume) -> PackedVolume {
    pack(vol, 1.0, 8, Lookup::Stochastic).unwrap()
}

/// `restir` parameters for a w x h image of `vol` with M candidates and a target.
fn params(
    vol: &DenseVolume,
    (w, h, spp): (u32, u32, u32),
    estimator: Estimator,
    m: u32,
    target: RestirTarget,
) -> RenderParams {
    RenderParams {
        spp,
        seed: 5,
        n: 10,
        estimator: estimator as u32,
        rm_scale: 1.0,
        f_delta: 0.6,
        pixel_jitter: 1,
        integrator: Integrator::Restir as u32,
        hg_g: 0.3,
        restir: RestirParams {
            candidates: m,
            target: target as u32,
            n: 4,
            floor: 0.05,
            ..Default::default()
        },
        ..camera_params(vol, w, h)
    }
}

/// `p` with `passes` spatial reuse passes of k = 3 neighbours within `radius` pixels.
fn with_reuse(
    p: RenderParams,
    passes: u32,
    radius: u32,
    mis: RestirMis,
    m_cap: u32,
) -> RenderParams {
    RenderParams {
        restir: RestirParams {
            passes,
            neighbours: 3,
            radius,
            mis: mis as u32,
            m_cap,
            ..p.restir
        },
        ..p
    }
}

fn render(
    backend: &Backend,
    packed: &PackedVolume,
    p: &RenderParams,
    l: &SceneLights,
) -> Vec<shared::kernels::render::PixelOut> {
    let mut p = *p;
    p.light_count = l.points.len() as u32;
    let p = engine::render::fit_collision_cap(&p, &packed.desc);
    render_lit(backend, packed, &p, l, false).unwrap()
}

#[test]
fn restir_and_many_light_direct_are_bit_identical_on_gpu_and_cpu() {
    let vol = lumpy_blobs(24, 6);
    let packed = packed(&vol);
    let gpu = Backend::Gpu(gpu());
    let mut cases = Vec::new();
    for target in [
        RestirTarget::Jackknife,
        RestirTarget::Unshadowed,
        RestirTarget::Ratio,
    ] {
        for e in [Estimator::Jackknife, Estimator::RatioTracking] {
            for sky in [false, true] {
                let p = params(&vol, (12, 10, 2), e, 5, target);
                cases.push((
                    format!("restir {target:?}, {e:?}, sky {sky}"),
                    p,
                    many_lights(100, sky, true),
                ));
            }
        }
    }
    let mut direct = params(
        &vol,
        (12, 10, 2),
        Estimator::Jackknife,
        0,
        RestirTarget::Jackknife,
    );
    direct.integrator = Integrator::Direct as u32;
    cases.push((
        "direct, 100 lights".into(),
        direct,
        many_lights(100, false, false),
    ));
    for (name, p, l) in cases {
        let c = render(&Backend::Cpu, &packed, &p, &l);
        let g = render(&gpu, &packed, &p, &l);
        let ids: Vec<u32> = (0..c.len() as u32).collect();
        assert_bytes_equal(&name, &ids, &g, &c);
        assert!(c.iter().any(|px| px.rgb_mean.g > 0.0), "{name}: black");
    }
}

/// Without point lights nothing is resampled: `restir` is `direct`, byte for byte.
#[test]
fn restir_without_point_lights_is_direct() {
    let vol = lumpy_blobs(24, 6);
    let packed = packed(&vol);
    let sky = build(
        &LightingOptions {
            env: EnvSource::Sky,
            env_scale: 1.0,
            env_rotate_deg: 0.0,
            sun: None,
            points: vec![],
            albedo: [0.9, 0.7, 0.5],
        },
        [0.0; 3],
        1.7,
    )
    .unwrap();
    let r = params(
        &vol,
        (10, 8, 3),
        Estimator::Jackknife,
        7,
        RestirTarget::Jackknife,
    );
    let d = RenderParams {
        integrator: Integrator::Direct as u32,
        ..r
    };
    let a = render(&Backend::Cpu, &packed, &r, &sky);
    let b = render(&Backend::Cpu, &packed, &d, &sky);
    let ids: Vec<u32> = (0..a.len() as u32).collect();
    assert_bytes_equal("restir vs direct, sky", &ids, &a, &b);
}

/// With one candidate the reservoir keeps it with W = 1 / p: `restir` is `direct`'s point-light
/// estimator in expectation. Per pixel of an 8 x 8 image (2048 spp each, seeds 5 and 6, ratio
/// tracking shadow rays so both are unbiased): every pixel within z < 4 (64 tests: a false alarm
/// below 0.5 % at the 4 sigma level) and the image mean within z < 4.
#[test]
fn one_candidate_agrees_with_direct_in_expectation() {
    restir_agrees_with_direct(1, RestirTarget::Jackknife);
}

/// The same with eight candidates and each target: restir with ratio-tracking final
/// contributions is unbiased for any target (z < 4 per pixel and over the image, against
/// `direct` with ratio-tracking shadow rays; 2048 spp each, seeds 5 and 6).
#[test]
fn eight_candidates_agree_with_direct_for_every_target() {
    for target in [
        RestirTarget::Jackknife,
        RestirTarget::Unshadowed,
        RestirTarget::Ratio,
    ] {
        restir_agrees_with_direct(8, target);
    }
}

/// The body of the agreement tests: restir with `m` candidates and `target` vs direct.
fn restir_agrees_with_direct(m: u32, target: RestirTarget) {
    let vol = lumpy_blobs(24, 6);
    let r = params(&vol, (8, 8, 2048), Estimator::RatioTracking, m, target);
    agrees_with_direct(&vol, &r, &format!("M = {m}, {target:?}"));
}

/// restir with spatial reuse is unbiased: two pairwise passes, and one balance-heuristic pass
/// with confidence capped at 2 M, each with 4 jackknife-target candidates and 3 neighbours
/// within 2 pixels, agree with `direct` (ratio-tracking shadow rays; 8 x 8 pixels, 2048 spp,
/// seeds 5 and 6): z < 4 per pixel; reuse correlates pixels, so the image mean's test bounds
/// restir's variance by (sum of the pixels' standard deviations)^2 (conservative).
#[test]
fn spatial_reuse_agrees_with_direct_in_expectation() {
    let vol = lumpy_blobs(24, 6);
    for (passes, mis, cap) in [(2, RestirMis::Pairwise, 0), (1, RestirMis::Balance, 8)] {
        let r = params(
            &vol,
            (8, 8, 2048),
            Estimator::RatioTracking,
            4,
            RestirTarget::Jackknife,
        );
        let r = with_reuse(r, passes, 2, mis, cap);
        agrees_with_direct(&vol, &r, &format!("{passes} passes, {mis:?}"));
    }
}

/// restir `r` against direct with seed 6: z < 4 per pixel and for the image mean (restir's
/// pixels bounded as fully correlated when it reuses).
fn agrees_with_direct(vol: &DenseVolume, r: &RenderParams, what: &str) {
    let packed = packed(vol);
    let (spp, r) = (r.spp, *r);
    let correlated = r.restir.passes > 0;
    let d = RenderParams {
        integrator: Integrator::Direct as u32,
        seed: 6,
        ..r
    };
    let a = render(&Backend::Cpu, &packed, &r, &many_lights(40, false, true));
    let b = render(&Backend::Cpu, &packed, &d, &many_lights(40, false, false));
    let (mut diff, mut var, mut sd_a) = (0.0f64, 0.0f64, 0.0f64);
    for (k, (x, y)) in a.iter().zip(&b).enumerate() {
        let v = |p: &shared::kernels::render::PixelOut| {
            let m = p.t_mean as f64;
            ((p.t2_mean as f64 - m * m).max(0.0) / spp as f64, m)
        };
        let ((va, ma), (vb, mb)) = (v(x), v(y));
        if va + vb > 0.0 {
            let z = (ma - mb) / (va + vb).sqrt();
            assert!(
                z.abs() < 4.0,
                "{what}, pixel {k}: restir {ma} direct {mb}, z = {z:.2}"
            );
        }
        diff += ma - mb;
        var += if correlated { vb } else { va + vb };
        sd_a += va.sqrt();
    }
    if correlated {
        var += sd_a * sd_a;
    }
    let z = diff / var.sqrt();
    assert!(z.abs() < 4.0, "{what}, image mean: z = {z:.2}");
    assert!(a.iter().any(|p| p.t_mean > 0.0));
}

/// A streaming reservoir keeps candidate i with probability w_i / sum w (GRIS Sec. 6.2): 2^18
/// streams of 6 weights (one zero) with hashed uniforms; each frequency within 5 sigma.
#[test]
fn reservoir_keeps_each_candidate_in_proportion_to_its_weight() {
    let w = [0.5f32, 0.0, 2.0, 1.5, 0.25, 3.0];
    let total: f32 = w.iter().sum();
    let trials = 1u32 << 18;
    let mut count = [0u32; 6];
    for t in 0..trials {
        let mut r = Reservoir::default();
        for (i, &wi) in w.iter().enumerate() {
            let u = shared::rng::unit_f32(shared::rng::pcg_hash(t * 8 + i as u32 + 1));
            r = r.update(i as u32, wi, wi + 1.0, u);
        }
        assert_eq!(r.m, 6);
        assert_eq!(r.w_sum, total);
        assert_eq!(
            r.p_hat,
            w[r.y as usize] + 1.0,
            "p̂ travels with the kept sample"
        );
        count[r.y as usize] += 1;
    }
    for i in 0..6 {
        let p = (w[i] / total) as f64;
        let f = count[i] as f64 / trials as f64;
        let sigma = (p * (1.0 - p) / trials as f64).sqrt();
        assert!(
            (f - p).abs() <= 5.0 * sigma + 1e-12,
            "candidate {i}: {f} vs {p}"
        );
    }
    assert_eq!(count[1], 0);
    assert_eq!(Reservoir::default().contribution_weight(), 0.0);
}

/// The target keeps full support: in a volume where the jackknife of N = 1 often falls below the
/// floor (down to <= 0) or above 1, p̂ is still at least floor x the unshadowed contribution and
/// at most it (both cases occur more than 10 times in 400),
/// and it is the same number each time it is evaluated (keyed by pixel, sample, light).
#[test]
fn target_is_positive_bounded_and_a_fixed_function() {
    let vol = engine::volume::DenseVolume::new(
        "dense",
        [16; 3],
        (0..16u32.pow(3))
            .map(|k| if k % 7 < 3 { 0.0 } else { 3.0 })
            .collect(),
        integration_tests::unit_cube(16),
    )
    .unwrap();
    let packed = pack(&vol, 1.0, 4, Lookup::Nearest).unwrap();
    let view = packed.view();
    let lights = many_lights(30, false, true);
    let scene = lights.view();
    let mut p = params(
        &vol,
        (4, 4, 1),
        Estimator::Jackknife,
        4,
        RestirTarget::Jackknife,
    );
    p.restir.n = 1;
    let cfg = Config::decode(&p, &view.desc);
    let unshadowed = RenderParams {
        restir: RestirParams {
            target: RestirTarget::Unshadowed as u32,
            ..p.restir
        },
        ..p
    };
    let (mut floored, mut between) = (0, 0);
    for i in 0..400u32 {
        let x = shared::geometry::V3::new(
            -0.9 + 1.8 * shared::rng::unit_f32(shared::rng::pcg_hash(3 * i)),
            -0.9 + 1.8 * shared::rng::unit_f32(shared::rng::pcg_hash(3 * i + 1)),
            -0.9 + 1.8 * shared::rng::unit_f32(shared::rng::pcg_hash(3 * i + 2)),
        );
        let wo = shared::geometry::V3::new(0.0, 0.0, -1.0);
        let k = i % 30;
        let (a, _) = p_hat(&view, &cfg, &p, &scene, i, 0, x, wo, k);
        let (again, _) = p_hat(&view, &cfg, &p, &scene, i, 0, x, wo, k);
        let (f0, _) = p_hat(&view, &cfg, &unshadowed, &scene, i, 0, x, wo, k);
        assert_eq!(a.to_bits(), again.to_bits(), "a fixed function");
        assert!(f0 > 0.0);
        assert!(
            a >= 0.05 * f0 * (1.0 - 1e-6) && a <= f0,
            "p̂ {a} vs unshadowed {f0}"
        );
        if a <= 0.05 * f0 * (1.0 + 1e-6) {
            floored += 1;
        } else if a < f0 {
            between += 1;
        }
    }
    assert!(
        floored > 10 && between > 10,
        "floored {floored}, between {between}"
    );
}

/// Spatial reuse on both backends, byte for byte, after one, two and three passes: pairwise and
/// balance weights, every target, both shadow-ray estimators, with and without the sky, capped
/// and uncapped confidence (12 x 10 pixels, 2 spp, 4 candidates, 3 neighbours within 3 pixels).
/// Reuse changes the image (it is not skipped).
#[test]
fn spatial_reuse_is_bit_identical_on_gpu_and_cpu() {
    let vol = lumpy_blobs(24, 6);
    let packed = packed(&vol);
    let gpu = Backend::Gpu(gpu());
    let cases = [
        (
            1,
            RestirMis::Pairwise,
            0,
            RestirTarget::Jackknife,
            Estimator::Jackknife,
            false,
        ),
        (
            2,
            RestirMis::Pairwise,
            0,
            RestirTarget::Ratio,
            Estimator::RatioTracking,
            true,
        ),
        (
            3,
            RestirMis::Pairwise,
            10,
            RestirTarget::Unshadowed,
            Estimator::Jackknife,
            false,
        ),
        (
            1,
            RestirMis::Balance,
            0,
            RestirTarget::Unshadowed,
            Estimator::RatioTracking,
            true,
        ),
        (
            2,
            RestirMis::Balance,
            6,
            RestirTarget::Jackknife,
            Estimator::Jackknife,
            false,
        ),
    ];
    for (passes, mis, cap, target, e, sky) in cases {
        let name = format!("{passes} passes, {mis:?}, cap {cap}, {target:?}, {e:?}, sky {sky}");
        let p = params(&vol, (12, 10, 2), e, 4, target);
        let l = many_lights(100, sky, true);
        let c = render(
            &Backend::Cpu,
            &packed,
            &with_reuse(p, passes, 3, mis, cap),
            &l,
        );
        let g = render(&gpu, &packed, &with_reuse(p, passes, 3, mis, cap), &l);
        let ids: Vec<u32> = (0..c.len() as u32).collect();
        assert_bytes_equal(&name, &ids, &g, &c);
        assert!(c.iter().any(|px| px.rgb_mean.g > 0.0), "{name}: black");
        let none = render(&Backend::Cpu, &packed, &p, &l);
        assert!(
            c.iter().zip(&none).any(|(a, b)| a.rgb_mean != b.rgb_mean),
            "{name}: the same image as without reuse"
        );
    }
}

/// Reuse pass neighbours: never the pixel itself, always within r pixels in x and y and inside
/// the image, and every other pixel of the window drawn (4000 draws for each of 3 pixels of a
/// 9 x 7 image with r = 2; each of the window's <= 24 pixels expected >= 160 times: a miss has
/// probability below 1e-60).
#[test]
fn neighbours_stay_in_their_window() {
    let p = RenderParams {
        width: 9,
        height: 7,
        seed: 3,
        restir: RestirParams {
            radius: 2,
            ..Default::default()
        },
        ..Default::default()
    };
    for id in [0u32, 31, 62] {
        let (x, y) = ((id % 9) as i32, (id / 9) as i32);
        let mut hits = std::collections::HashMap::new();
        for t in 0..4000 {
            let q = neighbour(&p, id, t / 8, t % 4, t % 8);
            if q == NO_NEIGHBOUR {
                continue;
            }
            let (qx, qy) = ((q % 9) as i32, (q / 9) as i32);
            assert!(q != id && q < 63);
            assert!((qx - x).abs() <= 2 && (qy - y).abs() <= 2, "{id} -> {q}");
            *hits.entry(q).or_insert(0) += 1;
        }
        let window = (-2..=2)
            .flat_map(|dy| (-2..=2).map(move |dx| (x + dx, y + dy)))
            .filter(|&(a, b)| (0..9).contains(&a) && (0..7).contains(&b) && (a, b) != (x, y))
            .count();
        assert_eq!(hits.len(), window, "pixel {id}: {hits:?}");
    }
}

/// The shift keeps the light (identity on the light index, |J| = 1), so p̂_←j(y) is pixel j's
/// target at y: re-evaluated from anywhere with j's id, vertex and direction, it is bit for bit
/// the p̂ that j's own reservoir stored for its kept light (every pixel of a 6 x 5 image with a
/// vertex, 3 samples, jackknife and ratio targets).
#[test]
fn a_neighbours_target_re_evaluated_is_the_one_it_stored() {
    let vol = lumpy_blobs(24, 6);
    let packed = packed(&vol);
    let view = packed.view();
    let lights = many_lights(50, false, true);
    let scene = lights.view();
    let mut checked = 0;
    for target in [RestirTarget::Jackknife, RestirTarget::Ratio] {
        let mut p = params(&vol, (6, 5, 3), Estimator::Jackknife, 6, target);
        p.light_count = lights.points.len() as u32;
        let cfg = Config::decode(&p, &view.desc);
        for id in 0..30 {
            for s in 0..3 {
                let mut st = RestirState::default();
                let mut sums = Default::default();
                // The start and the candidates only.
                for stage in 0..=p.restir.candidates {
                    let at = StageAt::restir(&p, id, s, stage);
                    (st, sums) = restir_wave_step(&view, &p, &scene, at, st, sums);
                }
                assert!(stage_count(&p) > p.restir.candidates + 1);
                if st.found == 0 || !(st.reservoir.w_sum > 0.0) {
                    continue;
                }
                let r = st.reservoir;
                let (again, _) = p_hat(&view, &cfg, &p, &scene, id, s, st.x, st.wo, r.y);
                assert_eq!(again.to_bits(), r.p_hat.to_bits(), "pixel {id}, sample {s}");
                checked += 1;
            }
        }
    }
    assert!(checked > 20, "only {checked} pixels had a vertex");
}
