//! Builds a small grid, then prints the jackknife, naive and ratio-tracking transmittance of one
//! ray (means of 100,000 estimates with their standard errors) next to the exact value.
//!
//! `cargo +stable run -p jackknife --example ray --release`

use jackknife::{Estimator, GridBuilder, Lookup, Ray, SegmentEstimator, V3};

fn main() {
    // A 64^3 smooth blob: extinction 0.1 per voxel length at the centre, Gaussian fall-off.
    let n = 64u32;
    let blob = |x: u32, y: u32, z: u32| {
        let c = |v: u32| (v as f32 + 0.5) / n as f32 - 0.5;
        let r2 = c(x) * c(x) + c(y) * c(y) + c(z) * c(z);
        0.1 * (-r2 / 0.03).exp()
    };
    let grid = GridBuilder::from_fn([n; 3], blob)
        .lookup(Lookup::Nearest)
        .build()
        .expect("a valid grid");
    // A ray through the blob, off-centre, with unit direction in index space.
    let d = V3::new(1.0, 0.15, 0.05);
    let len = (d.x * d.x + d.y * d.y + d.z * d.z).sqrt();
    let ray = Ray {
        o: V3::new(-4.0, 26.0, 30.0),
        d: V3::new(d.x / len, d.y / len, d.z / len),
    };
    let (t0, t1) = grid.clip(&ray);
    let exact = SegmentEstimator::new(Estimator::RegularTracking, 10)
        .estimate(&grid, &ray, t0, t1, 0)
        .0;
    println!("ray through a 64^3 blob, [t0, t1] = [{t0:.2}, {t1:.2}], nearest lookups");
    println!("exact (regular tracking)   T = {exact:.6}");
    let trials = 100_000u32;
    for (name, est) in [
        ("jackknife (Eq. 4, N = 10)", SegmentEstimator::jackknife(10)),
        (
            "naive exp(-X̄), N = 10",
            SegmentEstimator::new(Estimator::NaiveMean, 10),
        ),
        (
            "ratio tracking",
            SegmentEstimator::new(Estimator::RatioTracking, 10),
        ),
    ] {
        let (mut s, mut s2, mut lookups) = (0.0f64, 0.0f64, 0u64);
        for seed in 0..trials {
            let (t, tally) = est.estimate(&grid, &ray, t0, t1, seed);
            s += t as f64;
            s2 += t as f64 * t as f64;
            lookups += tally.lookups as u64;
        }
        let mean = s / trials as f64;
        let se = ((s2 / trials as f64 - mean * mean) / trials as f64).sqrt();
        println!(
            "{name:<26} T = {mean:.6} ± {se:.6}  (bias {:+.6}, {:.1} lookups/ray)",
            mean - exact as f64,
            lookups as f64 / trials as f64
        );
    }
}
