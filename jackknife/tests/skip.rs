//! Empty-space skipping changes no estimate: every estimator gives the same bits on a grid with
//! the builder's skip marks as on the same grid with the marks removed (every brick stepped),
//! for random rays through a sparse volume, with every lookup mode (natively; the renders on
//! both backends are compared in `tests/tests/skip.rs`).

use jackknife::{GridBuilder, HashRng, Importance, Jitter, Lookup, Ray, V3};
use shared::estimators::optical_depth::{estimate_pair, prepare};
use shared::estimators::ray_marching::{biased_ray_marching, unbiased_ray_marching};
use shared::estimators::tracking::{
    exact_free_flight, ratio_tracking, regular_tracking_tau, track_length,
};
use shared::rng::{pcg_hash, unit_f32};
use shared::volume::grid::{EMPTY_BRICK, NO_SKIP};

/// Every estimate of one ray as bits.
fn estimates(g: &jackknife::Grid, ray: &Ray, lookup: Lookup, seed: u32) -> Vec<u32> {
    let vol = g.view();
    let (t0, t1) = g.clip(ray);
    let rng = HashRng::for_sample(seed, 0, 7);
    let mut out = Vec::new();
    for mode in [Importance::VarianceAware, Importance::Mean] {
        let prep = prepare(&vol, ray, t0, t1, mode);
        out.extend([prep.f, prep.t_min, prep.t_max].map(f32::to_bits));
        if prep.f > 0.0 {
            for jitter in [Jitter::Stratified, Jitter::Uniform] {
                let (e, _) = estimate_pair(&vol, ray, &prep, 20, mode, jitter, lookup, rng);
                out.extend([e.x0.to_bits(), e.x1.to_bits(), e.samples]);
            }
        }
    }
    out.push(track_length(&vol, ray, t0, t1, lookup, rng).0.to_bits());
    out.push(
        ratio_tracking(&vol, ray, t0, t1, lookup, false, rng)
            .0
            .to_bits(),
    );
    out.push(
        biased_ray_marching(&vol, ray, t0, t1, 1.0, lookup, rng)
            .0
            .to_bits(),
    );
    out.push(
        unbiased_ray_marching(&vol, ray, t0, t1, 1.0, lookup, rng)
            .0
            .to_bits(),
    );
    // The voxel traversals (regular tracking, and the exact free flight at the collision cap):
    // the same optical depth and collision bits whether they skip or step.
    out.push(regular_tracking_tau(&vol, ray, t0, t1).0.to_bits());
    let target = 0.05 + 3.0 * unit_f32(pcg_hash(seed ^ 0x51ed));
    let f = exact_free_flight(&vol, ray, t0, t1, target);
    out.extend([f.t.to_bits(), f.mu.to_bits(), f.found as u32]);
    out
}

#[test]
fn every_estimate_is_the_same_with_and_without_skip_marks() {
    let n = 64u32;
    // One in nine 8^3 blocks occupied: long empty stretches between dense blobs.
    let density = move |x: u32, y: u32, z: u32| {
        let c = pcg_hash(x / 8 + 101 * (y / 8) + 10007 * (z / 8));
        if c.is_multiple_of(9) {
            0.5 + 2.0 * unit_f32(pcg_hash(x + n * (y + n * z)))
        } else {
            0.0
        }
    };
    let mut rays = 0;
    for (brick, lookup) in [
        (4, Lookup::Nearest),
        (8, Lookup::Stochastic),
        (4, Lookup::Trilinear),
        (16, Lookup::Nearest),
    ] {
        let skipping = GridBuilder::from_fn([n; 3], density)
            .density_scale(0.5)
            .brick_size(brick)
            .lookup(lookup)
            .build()
            .unwrap();
        let marked = skipping
            .bricks
            .iter()
            .filter(|b| b.skip_level() != NO_SKIP)
            .count();
        assert!(brick == 16 || marked > 50, "brick {brick}: {marked} marked");
        let mut stepping = skipping.clone();
        // Stepping needs the stepping bound's budget (0: that bound).
        stepping.desc.brick_steps = 0;
        stepping.desc.voxel_steps = 0;
        for b in &mut stepping.bricks {
            if b.skip_level() != NO_SKIP {
                b.slot = EMPTY_BRICK;
            }
        }
        for i in 0..3000u32 {
            let u = |k: u32| unit_f32(pcg_hash(i * 8 + k + 1000 * brick));
            let o = V3::new(u(0) * 96.0 - 16.0, u(1) * 96.0 - 16.0, u(2) * 96.0 - 16.0);
            let target = V3::new(u(3) * 64.0, u(4) * 64.0, u(5) * 64.0);
            let mut d = V3::new(target.x - o.x, target.y - o.y, target.z - o.z);
            // Axis-parallel rays now and then.
            if i % 7 == 0 {
                d = V3::new(d.x, 0.0, 0.0);
            }
            if d.x == 0.0 && d.y == 0.0 && d.z == 0.0 {
                continue;
            }
            let ray = Ray { o, d };
            let a = estimates(&skipping, &ray, lookup, i);
            let b = estimates(&stepping, &ray, lookup, i);
            assert_eq!(a, b, "brick {brick}, {lookup:?}, ray {i}: {ray:?}");
            rays += 1;
        }
    }
    assert!(rays > 10_000, "{rays} rays");
}
