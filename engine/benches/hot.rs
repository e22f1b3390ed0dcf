//! criterion micro-benchmarks of the hot `shared` functions, natively (the CPU backend's code):
//! the deterministic math, one brick-DDA traversal, Alg. 2 + Alg. 1 for one ray, and a whole
//! ray estimate for several estimators. `cargo bench -p host --bench hot`.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use engine::scene::bricks::pack;
use engine::scene::camera::world_to_index;
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
use std::hint::black_box;

/// 1024 arguments spread over a function's useful range.
fn args(lo: f32, hi: f32) -> Vec<f32> {
    (0..1024u32)
        .map(|i| lo + (hi - lo) * unit_f32(pcg_hash(i)))
        .collect()
}

fn math(c: &mut Criterion) {
    let mut g = c.benchmark_group("math");
    g.throughput(Throughput::Elements(1024));
    let x = args(-20.0, 0.0);
    g.bench_function("exp", |b| {
        b.iter(|| {
            x.iter()
                .map(|&v| shared::math::exp(black_box(v)))
                .sum::<f32>()
        })
    });
    let x = args(1e-3, 100.0);
    g.bench_function("ln", |b| {
        b.iter(|| {
            x.iter()
                .map(|&v| shared::math::ln(black_box(v)))
                .sum::<f32>()
        })
    });
    let x = args(-10.0, 10.0);
    g.bench_function("sin_cos", |b| {
        b.iter(|| {
            x.iter()
                .map(|&v| {
                    let (s, c) = shared::math::sin_cos(black_box(v));
                    s + c
                })
                .sum::<f32>()
        })
    });
    let pairs: Vec<(f32, f32)> = args(0.0, 4.0).into_iter().zip(args(0.0, 4.0)).collect();
    g.bench_function("jackknife (Eq. 4)", |b| {
        b.iter(|| {
            pairs
                .iter()
                .map(|&(a, c)| {
                    shared::estimators::transmittance::jackknife(black_box(a), black_box(c))
                })
                .sum::<f32>()
        })
    });
    g.finish();
}

/// The embedded cloud at 128^3, packed for stochastic lookups, and 1024 rays through it.
fn scene() -> (engine::scene::bricks::PackedVolume, RenderParams, Vec<Ray>) {
    let vol = engine::scene::procedural::by_name("cloud", 128).expect("embedded");
    let scale = engine::scene::procedural::default_density_scale("cloud");
    let packed = pack(&vol, scale, 16, Lookup::Stochastic).expect("packs");
    let params = RenderParams {
        world_to_index: world_to_index(engine::volume::VolumeData::index_to_world(&vol))
            .expect("invertible"),
        n: 10,
        rm_scale: 1.0,
        f_delta: 0.3,
        ..Default::default()
    };
    // World-space rays from a sphere around the volume towards random points near its center.
    let rays = (0..1024u32)
        .map(|i| {
            let r = |k| unit_f32(pcg_hash(4 * i + k)) * 2.0 - 1.0;
            let o = V3::new(r(0), r(1), r(2)) * 3.0;
            let target = V3::new(r(3), r(0) * 0.5, r(1) * 0.5) * 0.3;
            let d = target - o;
            let len = d.dot(d).sqrt();
            Ray {
                o,
                d: d * (1.0 / len),
            }
        })
        .collect();
    (packed, params, rays)
}

fn traversal(c: &mut Criterion) {
    let (packed, params, rays) = scene();
    let vol = packed.view();
    let index_rays: Vec<Ray> = rays
        .iter()
        .map(|r| shared::geometry::to_index_space(r, &params.world_to_index))
        .collect();
    let d = packed.desc.dims;
    let hi = V3::new(d[0] as f32, d[1] as f32, d[2] as f32);
    let mut g = c.benchmark_group("traversal");
    g.throughput(Throughput::Elements(rays.len() as u64));
    g.bench_function("brick DDA (whole ray)", |b| {
        b.iter(|| {
            let mut cells = 0u32;
            for ray in &index_rays {
                let (t0, t1) = clip_to_box(ray, hi, 0.0, f32::INFINITY);
                if t0 < t1 {
                    let mut dda = GridDda::bricks(&vol.desc, ray, t0, t1);
                    while !dda.done() {
                        black_box(dda.step());
                        cells += 1;
                    }
                }
            }
            cells
        })
    });
    g.bench_function("Alg. 2 + Alg. 1 (N = 10 pair)", |b| {
        b.iter_batched(
            || HashRng { state: 9 },
            |rng| {
                let mut acc = 0.0f32;
                for ray in &index_rays {
                    let (t0, t1) = clip_to_box(ray, hi, 0.0, f32::INFINITY);
                    if t0 < t1 {
                        let prep = prepare(&vol, ray, t0, t1, Importance::VarianceAware);
                        let (est, _) = estimate_pair(
                            &vol,
                            ray,
                            &prep,
                            10,
                            Importance::VarianceAware,
                            Jitter::Stratified,
                            Lookup::Stochastic,
                            rng,
                        );
                        acc += est.x0 + est.x1;
                    }
                }
                acc
            },
            BatchSize::SmallInput,
        )
    });
    g.finish();

    let mut g = c.benchmark_group("ray estimate");
    g.throughput(Throughput::Elements(rays.len() as u64));
    for (name, e) in [
        ("jackknife", Estimator::Jackknife),
        ("track-length", Estimator::TrackLength),
        ("ratio", Estimator::RatioTracking),
        ("unbiased-rm", Estimator::UnbiasedRayMarching),
        ("telescoping", Estimator::Telescoping),
    ] {
        let p = RenderParams {
            estimator: e as u32,
            ..params
        };
        g.bench_function(name, |b| {
            b.iter(|| {
                rays.iter()
                    .enumerate()
                    .map(|(i, r)| ray_transmittance(&vol, &p, r, HashRng { state: i as u32 }).0)
                    .sum::<f32>()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, math, traversal);
criterion_main!(benches);
