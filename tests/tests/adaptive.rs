//! Adaptive super-voxels (`--supervoxels adaptive`) render the same bytes on lavapipe as on the
//! CPU: every transmittance estimator for every format x lookup, and the MIS integrator on f32
//! statistics with stochastic lookups; the images differ from the fixed grid's (the cells change
//! the sampling).

use engine::scene::bricks::pack_paged;
use engine::volume::{Affine, DenseVolume};
use engine::Backend;
use integration_tests::{assert_bytes_equal, camera_params, gpu, volume};
use jackknife::{SupervoxelFormat, Supervoxels};
use shared::params::{Estimator, Integrator, RenderParams};
use shared::rng::{pcg_hash, unit_f32};
use shared::volume::grid::Lookup;

/// A 40 x 27 x 19 grid (no side a multiple of the brick size 8): thin sheets (every 7th x
/// plane, one voxel thick) in a third of it, a wisp along a diagonal, a noisy block.
fn wisps() -> DenseVolume {
    volume(
        "wisps",
        [40, 27, 19],
        Affine::scale_translate([0.05; 3], [-1.0, -0.7, -0.5]),
        |x, y, z| {
            let v = unit_f32(pcg_hash(x + 40 * (y + 27 * z)));
            if y < 9 && x % 7 == 2 {
                2.0 + 2.0 * v
            } else if x.abs_diff(y) <= 1 && z % 5 == 1 {
                5.0 * v
            } else if y >= 18 && x >= 24 {
                0.3 + 0.5 * v
            } else {
                0.0
            }
        },
    )
}

fn params(vol: &DenseVolume, e: Estimator, integrator: Integrator) -> RenderParams {
    RenderParams {
        n: 10,
        estimator: e as u32,
        integrator: integrator as u32,
        rm_scale: 1.0,
        f_delta: 0.6,
        pixel_jitter: 1,
        spp: 3,
        seed: 9,
        ..camera_params(vol, 24, 16)
    }
}

#[test]
fn adaptive_supervoxels_render_identically_on_gpu_and_cpu() {
    let vol = wisps();
    let pack = |format, mode, lookup| {
        pack_paged(
            &vol,
            1.5,
            8,
            format,
            mode,
            lookup,
            shared::volume::pages::GPU_PAGE_LOG2,
        )
        .unwrap()
    };
    let adaptive = Supervoxels::Adaptive {
        cell: 2,
        ratio: 0.8,
        occupancy: 0.5,
    };
    let gpu = Backend::Gpu(gpu());
    for format in [SupervoxelFormat::F32, SupervoxelFormat::Bc4] {
        for lookup in Lookup::ALL {
            let grid = pack(format, adaptive, lookup);
            assert!(
                grid.subdivided_bricks() > 4,
                "{} bricks split",
                grid.subdivided_bricks()
            );
            let fixed = pack(format, Supervoxels::Fixed, lookup);
            let mut runs: Vec<(Estimator, Integrator)> = Estimator::ALL
                .iter()
                .map(|&e| (e, Integrator::Transmittance))
                .collect();
            if format == SupervoxelFormat::F32 && lookup == Lookup::Stochastic {
                runs.push((Estimator::Jackknife, Integrator::MisJackknife));
            }
            for (e, integrator) in runs {
                let label = format!("{format:?} {lookup:?} {e:?} {integrator:?}");
                let p = params(&vol, e, integrator);
                let c = engine::render::render(&Backend::Cpu, &grid, &p, false).unwrap();
                let g = engine::render::render(&gpu, &grid, &p, false).unwrap();
                let ids: Vec<u32> = (0..c.len() as u32).collect();
                assert_bytes_equal(&label, &ids, &g, &c);
                assert!(c.iter().all(|px| px.capped == 0), "{label}: capped rays");
                // (The MIS image has no lights here: its radiance is 0 either way.)
                if e != Estimator::RegularTracking && integrator == Integrator::Transmittance {
                    let f = engine::render::render(&Backend::Cpu, &fixed, &p, false).unwrap();
                    assert!(
                        c.iter().zip(&f).any(|(a, b)| a.t_mean != b.t_mean),
                        "{label}: adaptive rendered exactly as fixed"
                    );
                }
            }
        }
    }
}
