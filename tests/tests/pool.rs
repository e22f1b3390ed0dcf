//! The brick pool: only bricks holding a nonzero voxel are stored (their voxels over the brick's
//! extent clipped to the grid), every voxel reads back as the dense grid's f16 value, and sparse
//! volumes render bit-identically on the GPU and the CPU.

use engine::scene::bricks::pack;
use engine::volume::{Affine, DenseVolume};
use engine::Backend;
use integration_tests::{assert_bytes_equal, camera_params, gpu, volume};
use shared::camera::Camera;
use shared::geometry::V3;
use shared::params::{Estimator, Integrator, RenderParams};
use shared::rng::{pcg_hash, unit_f32};
use shared::volume::grid::{GridDesc, Lookup};

/// A 37 x 20 x 9 grid (no side a multiple of the brick size 8) where only some 4^3 cells hold
/// density.
fn patchy() -> DenseVolume {
    volume(
        "patchy",
        [37, 20, 9],
        Affine::scale_translate([0.05; 3], [-0.9, -0.5, -0.2]),
        |x, y, z| {
            let cell = pcg_hash(x / 4 + 31 * (y / 4) + 977 * (z / 4));
            if cell.is_multiple_of(5) {
                0.5 + 3.0 * unit_f32(pcg_hash(x + 37 * (y + 20 * z)))
            } else {
                0.0
            }
        },
    )
}

/// Jackknife (N = 10) render parameters of a `w` x `h` image of `vol`, for `integrator` (None:
/// transmittance).
fn jackknife_params(
    vol: &DenseVolume,
    w: u32,
    h: u32,
    integrator: Option<Integrator>,
) -> RenderParams {
    RenderParams {
        n: 10,
        estimator: Estimator::Jackknife as u32,
        rm_scale: 1.0,
        f_delta: 0.6,
        pixel_jitter: 1,
        integrator: integrator.map_or(0, |i| i as u32),
        ..camera_params(vol, w, h)
    }
}

/// A delta sun straight overhead (radiance 1) and albedo 0.8: the lights of `direct` and `path`.
fn overhead_sun() -> engine::lighting::SceneLights {
    engine::lighting::SceneLights {
        lighting: shared::sampling::lighting::Lighting {
            sun: shared::sampling::sun::Sun {
                dir: shared::geometry::V3::new(0.0, 1.0, 0.0),
                one_minus_cos: 0.0,
                radiance: shared::rgb::Rgb::splat(1.0),
                present: 1,
            },
            albedo: shared::rgb::Rgb::splat(0.8),
            p_sun: 1.0,
            ..Default::default()
        },
        ..engine::lighting::SceneLights::points_only(&[])
    }
}

#[test]
fn pool_holds_the_occupied_bricks_only_and_reads_back_every_voxel() {
    let vol = patchy();
    let b = 8;
    let p = pack(&vol, 1.5, b, Lookup::Nearest).unwrap();
    let view = p.view();
    let [dx, dy, dz] = vol.dims;
    let mut occupied_words = 0usize;
    let mut occupied = 0usize;
    for bz in 0..dz.div_ceil(b) {
        for by in 0..dy.div_ceil(b) {
            for bx in 0..dx.div_ceil(b) {
                let (lo, hi) = (
                    [bx * b, by * b, bz * b],
                    [
                        (bx * b + b).min(dx),
                        (by * b + b).min(dy),
                        (bz * b + b).min(dz),
                    ],
                );
                let any = (lo[2]..hi[2])
                    .any(|z| (lo[1]..hi[1]).any(|y| (lo[0]..hi[0]).any(|x| vol.at(x, y, z) > 0.0)));
                let brick = view.brick([bx, by, bz]);
                assert_eq!(brick.stores_voxels(), any, "brick {bx} {by} {bz}");
                if any {
                    occupied += 1;
                    let len = (0..3).map(|a| (hi[a] - lo[a]) as usize).product::<usize>();
                    // Each brick's run is padded to a whole word.
                    occupied_words += len.div_ceil(2);
                }
            }
        }
    }
    assert!(
        occupied > 0 && occupied < p.bricks.len(),
        "{occupied} of {}",
        p.bricks.len()
    );
    assert_eq!(p.occupied_bricks(), occupied);
    assert_eq!(p.voxels.len(), occupied_words);
    for z in 0..dz {
        for y in 0..dy {
            for x in 0..dx {
                let v = vol.at(x, y, z);
                let want = p.desc.density_scale * half::f16::from_f32(v).to_f32();
                assert_eq!(
                    view.voxel(x, y, z).to_bits(),
                    want.to_bits(),
                    "({x}, {y}, {z})"
                );
                assert_eq!(p.stored_f16(x, y, z), half::f16::from_f32(v).to_bits());
            }
        }
    }
}

/// Two dense slabs at the ends of a 300-voxel-long grid: two of its 38 bricks stored (one of
/// them a partial brick at the edge), and transmittance and `direct` images are bit-identical
/// on the GPU and the CPU.
#[test]
fn a_sparse_volume_renders_identically_on_gpu_and_cpu() {
    let vol = volume(
        "two voxels",
        [300, 6, 6],
        Affine::scale_translate([0.01; 3], [-1.5, -0.03, -0.03]),
        |x, _, _| if !(4..296).contains(&x) { 40.0 } else { 0.0 },
    );
    let p = pack(&vol, 1.0, 8, Lookup::Stochastic).unwrap();
    assert_eq!(p.occupied_bricks(), 2);
    // Brick 0 (8 x 6 x 6 voxels) and the last brick (296..300: 4 x 6 x 6).
    assert_eq!(p.voxels.len(), (8 + 4) * 6 * 6 / 2);
    let gpu = Backend::Gpu(gpu());
    for integrator in [None, Some(Integrator::Direct)] {
        let params = RenderParams {
            spp: 4,
            seed: 9,
            ..jackknife_params(&vol, 96, 12, integrator)
        };
        let lights = overhead_sun();
        let c = engine::render::render_lit(&Backend::Cpu, &p, &params, &lights, false).unwrap();
        let g = engine::render::render_lit(&gpu, &p, &params, &lights, false).unwrap();
        let ids: Vec<u32> = (0..c.len() as u32).collect();
        assert_bytes_equal(&format!("{integrator:?}"), &ids, &g, &c);
        assert!(
            c.iter().any(|px| px.t_mean < 0.999),
            "{integrator:?}: nothing hit"
        );
    }
}

/// A 200000 x 2 x 2 grid with density at both ends, seen down its length: stepping through its
/// bricks would take one ray past a GPU invocation's loop budget (the GPU refused it before), but
/// empty-space skipping bounds each traversal by the occupied bricks (`GridDesc::brick_steps`,
/// `voxel_steps`), so both backends render it, bit-identically, with estimators of every family
/// (Alg. 1/2, tracking over the bricks, regular tracking over the voxels, ray marching), and no
/// ray reaches a traversal's budget. The pool holds the two end bricks only.
#[test]
fn long_mostly_empty_grids_render_on_the_gpu_within_the_budget_of_their_occupied_bricks() {
    let vol = volume(
        "long",
        [200_000, 2, 2],
        Affine::scale_translate([1e-5; 3], [-1.0, -1e-5, -1e-5]),
        // 8 voxels of 1e-5 world units at each end: tau 0.4 per end at extinction 5000.
        |x, _, _| {
            if !(8..199_992).contains(&x) {
                5000.0
            } else {
                0.0
            }
        },
    );
    let p = pack(&vol, 1.0, 8, Lookup::Nearest).unwrap();
    assert_eq!(p.occupied_bricks(), 2);
    let mut base = RenderParams {
        spp: 2,
        seed: 1,
        ..jackknife_params(&vol, 8, 4, None)
    };
    // Down the line (world x): every ray crosses both ends and the empty span between them.
    base.camera = Camera {
        origin: V3::new(-1.5, 0.0, 0.0),
        forward: V3::new(1.0, 0.0, 0.0),
        right: V3::new(0.0, 0.0, 2e-6),
        up: V3::new(0.0, 1.5e-6, 0.0),
        ..Default::default()
    };
    let stepping = GridDesc {
        brick_steps: 0,
        voxel_steps: 0,
        ..p.desc
    };
    let gpu = Backend::Gpu(gpu());
    for e in [
        Estimator::Jackknife,
        Estimator::RatioTracking,
        Estimator::TrackLength,
        Estimator::RegularTracking,
        Estimator::UnbiasedRayMarching,
    ] {
        let params = RenderParams {
            estimator: e as u32,
            ..base
        };
        use engine::render::{loop_iterations_per_ray, LOOP_BUDGET};
        assert!(
            loop_iterations_per_ray(&params, &stepping) > LOOP_BUDGET,
            "{e:?}"
        );
        assert!(
            loop_iterations_per_ray(&params, &p.desc) <= LOOP_BUDGET,
            "{e:?}"
        );
        let c = engine::render::render(&Backend::Cpu, &p, &params, false).unwrap();
        let g = engine::render::render(&gpu, &p, &params, false).unwrap();
        let ids: Vec<u32> = (0..c.len() as u32).collect();
        assert_bytes_equal(&format!("{e:?}"), &ids, &g, &c);
        assert!(c.iter().all(|px| px.capped == 0), "{e:?}: capped rays");
        // Both ends absorb (tau 0.4 each): T = e^-0.8 = 0.45 on every ray; the image mean of
        // 64 samples (track-length's are 0 or 1: std 0.06) lies within (0.25, 0.65).
        let mean = c.iter().map(|px| px.t_mean as f64).sum::<f64>() / c.len() as f64;
        assert!(mean > 0.25 && mean < 0.65, "{e:?}: mean T {mean}");
    }
}

/// The same grid with density along its whole length: every brick is occupied, so a ray's
/// traversal bound stays the brick count and exceeds what a GPU invocation runs: the GPU backend
/// refuses it naming `--backend cpu`, and the CPU backend, which has no such limit, renders it.
#[test]
fn long_occupied_grids_beyond_the_gpu_loop_budget_render_on_the_cpu() {
    let vol = volume(
        "long",
        [200_000, 2, 2],
        Affine::scale_translate([1e-5; 3], [-1.0, -1e-5, -1e-5]),
        |x, _, _| 1e-4 * (1 + x % 7) as f32,
    );
    let p = pack(&vol, 1.0, 8, Lookup::Nearest).unwrap();
    let params = RenderParams {
        spp: 2,
        seed: 1,
        ..jackknife_params(&vol, 8, 4, None)
    };
    assert!(
        engine::render::loop_iterations_per_ray(&params, &p.desc) > engine::render::LOOP_BUDGET
    );
    let c = engine::render::render(&Backend::Cpu, &p, &params, false).unwrap();
    assert!(c.iter().all(|px| px.t_mean.is_finite() && px.t_mean <= 1.0));
    let gpu = Backend::Gpu(gpu());
    let e = engine::render::render(&gpu, &p, &params, false)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("--backend cpu") && e.contains("200000x2x2"),
        "{e}"
    );
}

/// BC4-compressed super-voxel statistics (`--supervoxel-format bc4`): the brick table holds the
/// decoded values, so every estimator family renders the same bytes on lavapipe as on the CPU,
/// and the images differ from the f32 statistics' (the format changes the sampling).
#[test]
fn bc4_statistics_render_identically_on_gpu_and_cpu() {
    let vol = patchy();
    let pack_as = |format| {
        engine::scene::bricks::pack_paged(
            &vol,
            1.5,
            4,
            format,
            jackknife::Supervoxels::Fixed,
            Lookup::Nearest,
            shared::volume::pages::GPU_PAGE_LOG2,
        )
        .unwrap()
    };
    let bc4 = pack_as(jackknife::SupervoxelFormat::Bc4);
    let f32s = pack_as(jackknife::SupervoxelFormat::F32);
    assert_eq!(bc4.voxels, f32s.voxels);
    let gpu = Backend::Gpu(gpu());
    for e in [
        Estimator::Jackknife,
        Estimator::JackknifeAdaptive,
        Estimator::RatioTracking,
        Estimator::BiasedRayMarching,
    ] {
        let params = RenderParams {
            estimator: e as u32,
            spp: 3,
            seed: 5,
            ..jackknife_params(&vol, 24, 16, None)
        };
        let c = engine::render::render(&Backend::Cpu, &bc4, &params, false).unwrap();
        let g = engine::render::render(&gpu, &bc4, &params, false).unwrap();
        let ids: Vec<u32> = (0..c.len() as u32).collect();
        assert_bytes_equal(&format!("{e:?}"), &ids, &g, &c);
        let f = engine::render::render(&Backend::Cpu, &f32s, &params, false).unwrap();
        assert!(
            c.iter().zip(&f).any(|(a, b)| a.t_mean != b.t_mean),
            "{e:?}: bc4 rendered exactly as f32"
        );
    }
}

/// `patchy()` packed with pages of 2^`page_log2` words (brick size 4, stochastic lookups).
fn patchy_paged(vol: &DenseVolume, page_log2: u32) -> engine::scene::bricks::PackedVolume {
    use engine::volume::VolumeData;
    jackknife::GridBuilder::from_boxes(vol.dims, |lo, hi, out| vol.fill(lo, hi, out))
        .density_scale(1.5)
        .brick_size(4)
        .lookup(Lookup::Stochastic)
        .page_log2(page_log2)
        .build()
        .unwrap()
}

/// The pool in pages as a GPU binds it (here pages of a few bricks, so a small volume spans
/// several): no brick's run crosses a page, every voxel reads as in the one-page layout, and
/// transmittance, direct and path images are the same bytes on the CPU, paged or not, and on the
/// GPU (pages bound as separate buffers) for transmittance and path (`transmittance_cs` and `path_cs`
/// specialized with paged = 1; `direct_cs` comes from the same macro as `path_cs`, and each
/// paged pipeline takes lavapipe ~30 s to compile).
#[test]
fn paged_pools_render_identically_on_gpu_and_cpu() {
    let vol = patchy();
    let one = patchy_paged(&vol, 25);
    assert_eq!(one.pages().count(), 1);
    // The smallest pages (at least one 4^3 brick, 32 words) that give at most 8 of them.
    let paged = (5..25)
        .map(|log2| patchy_paged(&vol, log2))
        .find(|p| p.pages().count() <= 8)
        .unwrap();
    let pages = paged.pages().count();
    assert!(pages >= 4, "{pages} pages of 2^{} words", paged.page_log2);
    let [dx, dy, dz] = vol.dims;
    let view = paged.view();
    for bz in 0..dz.div_ceil(4) {
        for by in 0..dy.div_ceil(4) {
            for bx in 0..dx.div_ceil(4) {
                let slot = view.brick([bx, by, bz]).slot;
                if view.brick([bx, by, bz]).stores_voxels() {
                    // The brick's voxels inside the grid: 4 per axis, fewer in the last brick.
                    let extent = |n: u32, b: u32| (n - 4 * b).min(4);
                    let len = extent(dx, bx) * extent(dy, by) * extent(dz, bz);
                    let (start, words) = (slot as usize / 2, len.div_ceil(2) as usize);
                    let page = |w: usize| w >> paged.page_log2;
                    assert_eq!(page(start), page(start + words - 1), "brick {bx} {by} {bz}");
                }
            }
        }
    }
    for z in 0..dz {
        for y in 0..dy {
            for x in 0..dx {
                let (a, b) = (one.view().voxel(x, y, z), paged.view().voxel(x, y, z));
                assert_eq!(a.to_bits(), b.to_bits(), "voxel {x} {y} {z}");
            }
        }
    }
    let gpu = Backend::Gpu(gpu());
    for integrator in [None, Some(Integrator::Direct), Some(Integrator::Path)] {
        let params = RenderParams {
            spp: 3,
            seed: 4,
            max_depth: 4,
            ..jackknife_params(&vol, 24, 16, integrator)
        };
        let lights = overhead_sun();
        let render = |backend: &Backend, p: &engine::scene::bricks::PackedVolume| {
            engine::render::render_lit(backend, p, &params, &lights, false).unwrap()
        };
        let c = render(&Backend::Cpu, &one);
        let ids: Vec<u32> = (0..c.len() as u32).collect();
        let what = format!("{integrator:?}");
        assert_bytes_equal(
            &format!("{what} paged cpu"),
            &ids,
            &render(&Backend::Cpu, &paged),
            &c,
        );
        assert_bytes_equal(
            &format!("{what} paged gpu"),
            &ids,
            &render(&gpu, &paged),
            &c,
        );
        assert!(c.iter().any(|px| px.t_mean < 0.99), "{what}: nothing hit");
    }
}

/// A pool of more pages than the kernels bind is refused on the GPU, naming the CPU backend,
/// which renders it.
#[test]
fn pools_beyond_the_bound_pages_are_refused_on_the_gpu() {
    let vol = patchy();
    let paged = patchy_paged(&vol, 5);
    assert!(paged.pages().count() > 8, "{} pages", paged.pages().count());
    let params = RenderParams {
        spp: 1,
        seed: 4,
        ..jackknife_params(&vol, 8, 8, None)
    };
    let c = engine::render::render(&Backend::Cpu, &paged, &params, false).unwrap();
    assert!(c.iter().all(|px| px.t_mean.is_finite()));
    let gpu = Backend::Gpu(gpu());
    let e = engine::render::render(&gpu, &paged, &params, false)
        .unwrap_err()
        .to_string();
    assert!(e.contains("pages") && e.contains("--backend cpu"), "{e}");
}
