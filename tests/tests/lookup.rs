//! `--lookup trilinear`: the interpolation reproduces linear fields and voxel values, clamps at
//! the grid's edge, and the estimators built on it stay unbiased for the interpolated field
//! (ratio tracking's transmittance and the jackknife's against a fine quadrature of the same
//! field).

use engine::scene::bricks::pack;
use engine::volume::Affine;
use integration_tests::volume;
use shared::geometry::{Ray, V3};
use shared::kernels::render::ray_transmittance;
use shared::params::{Estimator, RenderParams};
use shared::rng::{pcg_hash, unit_f32, HashRng};
use shared::volume::grid::Lookup;

/// mu = 1 + x + 2 y + 3 z at voxel (x, y, z) of an 8^3 grid (exact in f16), world = index space.
fn linear() -> engine::volume::DenseVolume {
    volume(
        "linear",
        [8; 3],
        Affine::scale_translate([1.0; 3], [0.0; 3]),
        |x, y, z| (1 + x + 2 * y + 3 * z) as f32,
    )
}

#[test]
fn trilinear_reproduces_linear_fields_and_voxel_values_and_clamps_at_edges() {
    let vol = linear();
    let p = pack(&vol, 1.0, 4, Lookup::Trilinear).unwrap();
    let view = p.view();
    let field = |q: V3| 1.0 + (q.x - 0.5) + 2.0 * (q.y - 0.5) + 3.0 * (q.z - 0.5);
    for k in 0..2000u32 {
        let r = |s: u32| unit_f32(pcg_hash(k * 3 + s));
        let q = V3::new(0.5 + 7.0 * r(0), 0.5 + 7.0 * r(1), 0.5 + 7.0 * r(2));
        let (got, want) = (view.mu_trilinear(q), field(q));
        assert!((got - want).abs() <= 2e-5 * want, "{q:?}: {got} vs {want}");
    }
    for (x, y, z) in [(0, 0, 0), (3, 5, 1), (7, 7, 7)] {
        let c = V3::new(x as f32 + 0.5, y as f32 + 0.5, z as f32 + 0.5);
        assert_eq!(view.mu_trilinear(c), view.voxel(x, y, z));
    }
    // Outside the centres' range the edge voxels extend constantly.
    let edge = view.mu_trilinear(V3::new(0.1, 0.2, 0.3));
    assert_eq!(edge, view.voxel(0, 0, 0));
    assert_eq!(
        view.mu_trilinear(V3::new(7.9, 7.7, 7.6)),
        view.voxel(7, 7, 7)
    );
    assert_eq!(
        view.mu_trilinear(V3::new(f32::NAN, 0.0, 0.0)),
        view.voxel(0, 0, 0)
    );
}

/// Ratio tracking and the jackknife with trilinear lookups against exp(-tau) of a 20000-step
/// midpoint quadrature of the interpolated field along each of 6 rays through a lumpy grid:
/// 40000 estimates per ray (seeds 0..40000), |mean - T| within 4 standard errors (ratio
/// tracking is unbiased; the jackknife's bias is far below that here).
#[test]
fn estimators_are_unbiased_for_the_trilinear_field() {
    let vol = volume(
        "lumpy",
        [12; 3],
        Affine::scale_translate([1.0; 3], [0.0; 3]),
        |x, y, z| 0.05 + 0.3 * unit_f32(pcg_hash(x + 12 * (y + 12 * z))),
    );
    let p = pack(&vol, 1.0, 4, Lookup::Trilinear).unwrap();
    let view = p.view();
    for k in 0..6u32 {
        let r = |s: u32| unit_f32(pcg_hash(1000 + k * 7 + s));
        let o = V3::new(-1.0, 1.0 + 10.0 * r(0), 1.0 + 10.0 * r(1));
        let target = V3::new(13.0, 1.0 + 10.0 * r(2), 1.0 + 10.0 * r(3));
        let d = target - o;
        let d = d * (1.0 / d.dot(d).sqrt());
        let ray = Ray { o, d };
        let (t0, t1) = p.clip(&ray);
        let steps = 20_000;
        let h = (t1 - t0) as f64 / steps as f64;
        let tau: f64 = (0..steps)
            .map(|i| view.mu_trilinear(ray.at(t0 + ((i as f64 + 0.5) * h) as f32)) as f64 * h)
            .sum();
        let exact = (-tau).exp();
        for estimator in [Estimator::RatioTracking, Estimator::Jackknife] {
            let params = RenderParams {
                n: 10,
                estimator: estimator as u32,
                rm_scale: 1.0,
                f_delta: 0.6,
                world_to_index: engine::scene::camera::world_to_index(&vol.index_to_world).unwrap(),
                ..Default::default()
            };
            let n = 40_000u32;
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for s in 0..n {
                let (t, _, _) =
                    ray_transmittance(&view, &params, &ray, HashRng::for_sample(k, s, 3));
                sum += t as f64;
                sum2 += t as f64 * t as f64;
            }
            let mean = sum / n as f64;
            let se = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
            let z = (mean - exact) / se.max(1e-7);
            assert!(
                z.abs() < 4.0,
                "ray {k} {estimator:?}: {mean} vs {exact} (z = {z:.2})"
            );
        }
    }
}
