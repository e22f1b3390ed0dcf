//! BC4-compressed super-voxel statistics (`SupervoxelFormat::Bc4`) keep the estimators unbiased:
//! the statistics only steer the sampling (importance P, control variate mu_min, majorant
//! mu_max), and conservative rounding keeps P > 0 wherever the extinction is, mu_max a majorant.
//! Per ray, the mean of many optical-depth estimates (Alg. 1 + 2) matches regular tracking's
//! exact optical depth, and ratio tracking's mean matches exp(-tau), at z < 4.5 (trials and seeds
//! below; 24 rays x 3 checks: a false alarm has probability about 5e-4).

mod common;

use common::{assert_unbiased_on_ray, RATIO_Z_MAX_TAU};
use jackknife::{GridBuilder, Lookup, Ray, SupervoxelFormat, V3};
use shared::estimators::tracking::regular_tracking_tau;
use shared::rng::{pcg_hash, unit_f32};

#[test]
fn bc4_statistics_keep_optical_depth_and_ratio_tracking_unbiased() {
    let n = 48u32;
    // Per 4 x 4 block of 8^3 bricks (a BC4 block): in its first column of bricks one dense brick
    // and faint ones, the third column all-zero (two bricks from any density, so its statistics
    // are 0): the faint bricks' P lies far below the block's top endpoint and above its bottom
    // one (0), so BC4 moves it by whole levels; up is conservative, down would zero it and bias
    // the estimates (this test fails with P rounded down).
    let density = move |x: u32, y: u32, z: u32| {
        let (bx, by) = (x / 8, y / 8);
        let v = unit_f32(pcg_hash(x + n * (y + n * z)));
        if bx % 4 != 0 {
            0.0
        } else if by % 4 == 0 {
            20.0 + 20.0 * v
        } else {
            0.1 + 0.05 * v
        }
    };
    let f32_grid = GridBuilder::from_fn([n; 3], density)
        .brick_size(8)
        .lookup(Lookup::Nearest)
        .build()
        .unwrap();
    let grid = GridBuilder::from_fn([n; 3], density)
        .brick_size(8)
        .lookup(Lookup::Nearest)
        .supervoxel_format(SupervoxelFormat::Bc4)
        .build()
        .unwrap();
    // The format changes statistics (else this test would test nothing) but never voxels.
    assert_eq!(grid.voxels, f32_grid.voxels);
    let changed = grid
        .bricks
        .iter()
        .zip(&f32_grid.bricks)
        .filter(|(a, b)| a.p != b.p)
        .count();
    assert!(
        changed * 4 > grid.bricks.len(),
        "{changed} bricks' P changed"
    );
    let vol = grid.view();
    let trials = 4000u32;
    let (mut rays, mut ratio_rays) = (0, 0);
    for r in 0..200u32 {
        let u = |k: u32| unit_f32(pcg_hash(r * 16 + k + 0xbc4));
        let o = V3::new(u(0) * 80.0 - 16.0, u(1) * 80.0 - 16.0, -20.0);
        let target = V3::new(u(2) * 48.0, u(3) * 48.0, 48.0);
        let ray = Ray {
            o,
            d: V3::new(target.x - o.x, target.y - o.y, target.z - o.z),
        };
        let (t0, t1) = grid.clip(&ray);
        if !(t0 < t1) {
            continue;
        }
        let (tau, _) = regular_tracking_tau(&vol, &ray, t0, t1);
        if !(tau > 0.05) {
            continue;
        }
        if assert_unbiased_on_ray(&vol, &ray, t0, t1, tau, trials, r, 11, &format!("ray {r}")) {
            ratio_rays += 1;
        }
        rays += 1;
        if rays == 24 {
            break;
        }
    }
    assert_eq!(rays, 24);
    println!(
        "ratio tracking's mean tested on {ratio_rays} of {rays} rays (tau <= {RATIO_Z_MAX_TAU})"
    );
    assert!(ratio_rays >= 12, "{ratio_rays} rays test ratio tracking");
}
