//! Empty-space skipping is exact (the traversal itself: `shared::volume::dda`'s unit tests): the
//! builder marks exactly the maximal all-zero aligned cubes, and every estimator and integrator
//! renders the same bytes with the skip marks as without them, on the CPU and on lavapipe.

use engine::render::render_scene;
use engine::scene::bricks::{pack, PackedVolume};
use engine::scene::camera::world_to_index;
use engine::Backend;
use integration_tests::{assert_bytes_equal, camera_params, gpu, test_lights, unit_cube, volume};
use shared::params::{Estimator, Integrator};
use shared::rng::{pcg_hash, unit_f32};
use shared::volume::grid::{Brick, Lookup, EMPTY_BRICK, NO_SKIP};

/// A 64^3 volume with dense blobs in a mostly empty box (one in nine 8^3 blocks occupied).
fn sparse_blobs() -> engine::volume::DenseVolume {
    let n = 64;
    volume("sparse blobs", [n; 3], unit_cube(n), |x, y, z| {
        let c = pcg_hash(x / 8 + 101 * (y / 8) + 10007 * (z / 8));
        if c.is_multiple_of(9) {
            0.5 + 2.0 * unit_f32(pcg_hash(x + n * (y + n * z)))
        } else {
            0.0
        }
    })
}

/// `packed` with every skip mark removed (all-zero bricks as plain [`EMPTY_BRICK`]s) and the
/// traversals' budgets at the stepping bound: the traversals then step through every brick.
fn without_skips(packed: &PackedVolume) -> PackedVolume {
    let mut p = packed.clone();
    p.desc.brick_steps = 0;
    p.desc.voxel_steps = 0;
    for b in &mut p.bricks {
        if b.skip_level() != NO_SKIP {
            b.slot = EMPTY_BRICK;
        }
    }
    p
}

fn zero(b: &Brick) -> bool {
    !b.stores_voxels() && b.mu_min == 0.0 && b.mu_max == 0.0 && b.mean == 0.0 && b.p == 0.0
}

#[test]
fn the_builder_marks_the_largest_all_zero_cubes() {
    let packed = pack(&sparse_blobs(), 1.0, 4, Lookup::Nearest).unwrap();
    let d = packed.desc.brick_dims;
    let at = |c: [u32; 3]| packed.bricks[(c[0] + d[0] * (c[1] + d[1] * c[2])) as usize];
    let cube_is_zero = |c: [u32; 3], level: u32| {
        let lo = c.map(|v| v >> level << level);
        (lo[2]..(lo[2] + (1 << level)).min(d[2])).all(|z| {
            (lo[1]..(lo[1] + (1 << level)).min(d[1]))
                .all(|y| (lo[0]..(lo[0] + (1 << level)).min(d[0])).all(|x| zero(&at([x, y, z]))))
        })
    };
    let (mut marked, mut above_zero) = (0, 0);
    for z in 0..d[2] {
        for y in 0..d[1] {
            for x in 0..d[0] {
                let b = at([x, y, z]);
                let level = b.skip_level();
                assert_eq!(level != NO_SKIP, zero(&b), "brick {x} {y} {z}");
                if level == NO_SKIP {
                    continue;
                }
                marked += 1;
                above_zero += usize::from(level > 0);
                assert!(cube_is_zero([x, y, z], level), "{x} {y} {z}: level {level}");
                let covers_grid = (0..3).all(|a| (1u32 << level) >= d[a]);
                assert!(
                    covers_grid || !cube_is_zero([x, y, z], level + 1),
                    "{x} {y} {z}: level {level} is not the largest"
                );
            }
        }
    }
    assert!(
        marked > 1000 && above_zero > 100,
        "{marked} marked, {above_zero} above 0"
    );
}

#[test]
fn every_estimator_and_integrator_renders_the_same_bytes_with_and_without_skips() {
    let gpu = Backend::Gpu(gpu());
    let vol = sparse_blobs();
    for (brick, lookup) in [
        (4, Lookup::Nearest),
        (8, Lookup::Stochastic),
        (4, Lookup::Trilinear),
    ] {
        let skipping = pack(&vol, 4.0, brick, lookup).unwrap();
        assert!(skipping.bricks.iter().any(|b| b.skip_level() > 0));
        let stepping = without_skips(&skipping);
        let base = shared::params::RenderParams {
            spp: 2,
            n: 12,
            rm_scale: 1.0,
            f_delta: 0.3,
            world_to_index: world_to_index(&vol.index_to_world).unwrap(),
            ..camera_params(&vol, 12, 10)
        };
        let mut cases: Vec<(String, shared::params::RenderParams)> = Estimator::ALL
            .iter()
            .map(|&e| {
                let p = shared::params::RenderParams {
                    estimator: e as u32,
                    ..base
                };
                (format!("{e:?}"), p)
            })
            .collect();
        for integrator in [Integrator::Direct, Integrator::Path] {
            for e in [Estimator::Jackknife, Estimator::RatioTracking] {
                let p = shared::params::RenderParams {
                    integrator: integrator as u32,
                    estimator: e as u32,
                    max_depth: 4,
                    ..base
                };
                cases.push((format!("{integrator:?} {e:?}"), p));
            }
        }
        for (what, p) in &cases {
            let what = format!("{what}, brick {brick}, {lookup:?}");
            let lights = test_lights();
            let a = render_scene(&Backend::Cpu, &skipping, p, &lights, false).unwrap();
            let mut b = render_scene(&Backend::Cpu, &stepping, p, &lights, false).unwrap();
            let ids: Vec<u32> = (0..a.len() as u32).collect();
            if p.estimator == Estimator::RegularTracking as u32 && p.integrator == 0 {
                // Regular tracking counts the voxels it reads: fewer with skipping (none in a
                // skipped cube), the same image bits.
                let reads = |v: &[shared::kernels::render::PixelOut]| {
                    v.iter().map(|px| px.samples as u64).sum::<u64>()
                };
                assert!(
                    reads(&a) < reads(&b),
                    "{what}: skipping read no fewer voxels"
                );
                for (x, y) in a.iter().zip(b.iter_mut()) {
                    assert!(
                        x.samples <= y.samples,
                        "{what}: {} > {}",
                        x.samples,
                        y.samples
                    );
                    y.samples = x.samples;
                }
            }
            assert_bytes_equal(&format!("{what}: skip vs step"), &ids, &a, &b);
            let g = render_scene(&gpu, &skipping, p, &lights, false).unwrap();
            assert_bytes_equal(&format!("{what}: gpu vs cpu"), &ids, &g, &a);
        }
    }
}
