//! The traversals' iteration budgets from the occupied bricks (`GridDesc::brick_steps` and
//! `voxel_steps`): with empty-space skipping, no traversal of a random ray through a sparse grid
//! takes more iterations than the builder's bound (without even its slack for unverified skips),
//! none is cut short, and on long, mostly empty grids the bound is far below the stepping bound
//! that the GPU loop budget used to count.

use jackknife::{Grid, GridBuilder, Lookup, Ray, FALLBACK_STEPS, V3};
use shared::rng::{pcg_hash, unit_f32};
use shared::volume::dda::GridDda;
use shared::volume::grid::traversal_budget;

/// Iterations of the brick and of the voxel traversal of `ray` through `g`, and whether either
/// ran out of its budget.
fn iterations(g: &Grid, ray: &Ray) -> (u32, u32, bool) {
    let vol = g.view();
    let (t0, t1) = g.clip(ray);
    if !(t0 < t1) {
        return (0, 0, false);
    }
    let mut bricks = GridDda::bricks(&vol.desc, ray, t0, t1);
    let mut nb = 0;
    while !bricks.done() {
        bricks.step_brick(&vol);
        nb += 1;
    }
    let mut voxels = GridDda::voxels(&vol.desc, ray, t0, t1);
    let mut nv = 0;
    while !voxels.done() {
        voxels.step_voxel(&vol);
        nv += 1;
    }
    (nb, nv, bricks.exhausted() || voxels.exhausted())
}

/// A ray from a random point around the `dims` box to a random point inside; every `axis_every`
/// th one along x only, and some with one tiny direction component.
fn random_ray(dims: [u32; 3], i: u32, salt: u32) -> Ray {
    let u = |k: u32| unit_f32(pcg_hash(i.wrapping_mul(8) + k + salt));
    let d = dims.map(|v| v as f32);
    let o = V3::new(
        u(0) * 1.5 * d[0] - 0.25 * d[0],
        u(1) * 1.5 * d[1] - 0.25 * d[1],
        u(2) * 1.5 * d[2] - 0.25 * d[2],
    );
    let target = V3::new(u(3) * d[0], u(4) * d[1], u(5) * d[2]);
    let mut dir = V3::new(target.x - o.x, target.y - o.y, target.z - o.z);
    match i % 9 {
        0 => dir = V3::new(dir.x, 0.0, 0.0),
        1 => dir = V3::new(dir.x, 1e-7 * dir.y, dir.z),
        _ => {}
    }
    Ray { o, d: dir }
}

/// Checks every ray's iterations against the grid's budgets: at most the builder's bound
/// without its slack for unverified skips where the budget is that bound, at most the stepping
/// bound otherwise, and never cut short. Returns the largest counts seen (bricks, voxels).
fn check(name: &str, g: &Grid, rays: u32) -> (u32, u32) {
    let desc = g.desc;
    let b = desc.brick_dims;
    let d = desc.dims;
    let limit = |budget: u32, stepping: u32| {
        if budget < stepping {
            budget - FALLBACK_STEPS as u32
        } else {
            budget
        }
    };
    let brick_limit = limit(desc.brick_budget(), traversal_budget(0, [b[0], b[1], b[2]]));
    let voxel_limit = limit(desc.voxel_budget(), traversal_budget(0, [d[0], d[1], d[2]]));
    let (mut max_b, mut max_v) = (0, 0);
    for i in 0..rays {
        let ray = random_ray([d[0], d[1], d[2]], i, 977);
        if ray.d.x == 0.0 && ray.d.y == 0.0 && ray.d.z == 0.0 {
            continue;
        }
        let (nb, nv, cut) = iterations(g, &ray);
        assert!(!cut, "{name}: ray {i} ({ray:?}) used up its budget");
        assert!(
            nb <= brick_limit,
            "{name}: ray {i} ({ray:?}): {nb} brick iterations, bound {brick_limit}"
        );
        assert!(
            nv <= voxel_limit,
            "{name}: ray {i} ({ray:?}): {nv} voxel iterations, bound {voxel_limit}"
        );
        max_b = max_b.max(nb);
        max_v = max_v.max(nv);
    }
    (max_b, max_v)
}

/// One in `one_in` blocks of 8^3 voxels holds density (seeded by `salt`).
fn blobs(dims: [u32; 3], one_in: u32, salt: u32) -> impl Fn(u32, u32, u32) -> f32 + Sync {
    move |x, y, z| {
        let c = pcg_hash((x / 8 + 101 * (y / 8) + 10007 * (z / 8)) ^ salt);
        if c.is_multiple_of(one_in) {
            0.5 + 2.0 * unit_f32(pcg_hash(x + dims[0] * (y + dims[1] * z)))
        } else {
            0.0
        }
    }
}

#[test]
fn traversals_of_sparse_grids_keep_to_their_budgets() {
    for (dims, one_in, brick, lookup) in [
        ([64, 64, 64], 9, 4, Lookup::Nearest),
        ([64, 64, 64], 9, 8, Lookup::Stochastic),
        ([70, 33, 50], 30, 4, Lookup::Trilinear),
        ([64, 64, 64], 40, 12, Lookup::Nearest),
        ([100, 20, 90], 60, 16, Lookup::Nearest),
        ([96, 96, 96], 200, 2, Lookup::Nearest),
    ] {
        let g = GridBuilder::from_fn(dims, blobs(dims, one_in, brick))
            .brick_size(brick)
            .lookup(lookup)
            .build()
            .unwrap();
        check(&format!("{dims:?} 1/{one_in} B={brick}"), &g, 3000);
    }
}

#[test]
fn long_mostly_empty_grids_get_budgets_from_their_occupied_bricks() {
    // Density at both ends of a 4096-voxel-long grid: the stepping bound counts every brick on
    // the way, the builder's bound only the occupied ones and the empty cubes between them.
    let dims = [4096, 8, 8];
    let ends = |x: u32, _: u32, _: u32| if !(6..4090).contains(&x) { 2.0 } else { 0.0 };
    for brick in [4, 16] {
        let g = GridBuilder::from_fn(dims, ends)
            .brick_size(brick)
            .build()
            .unwrap();
        let b = g.desc.brick_dims;
        let stepping = traversal_budget(0, [b[0], b[1], b[2]]);
        assert!(
            g.desc.brick_budget() * 2 < stepping,
            "B={brick}: budget {} vs stepping {stepping}",
            g.desc.brick_budget()
        );
        assert!(
            (g.desc.voxel_budget() as u64) * 2 < dims.iter().map(|&v| v as u64).sum::<u64>(),
            "B={brick}: voxel budget {}",
            g.desc.voxel_budget()
        );
        let (nb, nv) = check(&format!("long B={brick}"), &g, 4000);
        // The rays along x cross the whole grid: they do skip (and meet both ends).
        assert!(nb >= 3 && nv > 2 * brick, "B={brick}: {nb} {nv}");
    }
    // An all-zero grid: one skip per traversal.
    let g = GridBuilder::from_fn([300, 40, 500], |_, _, _| 0.0)
        .build()
        .unwrap();
    assert_eq!(g.desc.brick_budget(), 1 + FALLBACK_STEPS as u32);
    assert_eq!(check("empty", &g, 500), (1, 1));
}

/// A box of more than 2^32 voxels (2001^3 = 8.0e9) built from boxes, as a sparse file's loader
/// gives it: two occupied bricks at opposite corners, its 126^3 bricks' table, traversal budgets
/// from the occupied bricks; a dense array of that many voxels and a box longer than
/// [`jackknife::MAX_AXIS`] are refused, as is a brick table past a u32 index.
#[test]
fn boxes_above_2_pow_32_voxels_build_brick_by_brick() {
    use jackknife::{BuildError, MAX_AXIS};
    let dims = [2001; 3];
    let corner = |v: u32| v < 3 || v == 2000;
    let g = GridBuilder::from_boxes(dims, move |lo, hi, out| {
        if !(0..3).all(|a| corner(lo[a]) || corner(hi[a] - 1)) {
            return false;
        }
        out.clear();
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                for x in lo[0]..hi[0] {
                    let near = [x, y, z].iter().all(|&c| c < 3) || [x, y, z] == [2000; 3];
                    out.push(if near { 1.5 } else { 0.0 });
                }
            }
        }
        true
    })
    .build()
    .unwrap();
    assert_eq!(g.desc.brick_dims, [126, 126, 126, 0]);
    assert_eq!(g.occupied_bricks(), 2);
    assert_eq!(g.bricks.len(), 126 * 126 * 126);
    check("2001^3, two corners", &g, 2000);
    let err = |dims: [u32; 3], brick: u32| {
        GridBuilder::from_boxes(dims, |_, _, _| false)
            .brick_size(brick)
            .build()
            .unwrap_err()
    };
    assert_eq!(
        err([MAX_AXIS + 1, 1, 1], 16),
        BuildError::Dims([MAX_AXIS + 1, 1, 1])
    );
    assert_eq!(
        err([MAX_AXIS, 1 << 20, 4], 2),
        BuildError::Table([MAX_AXIS, 1 << 20, 4])
    );
    let dense = vec![0.0f32; 1];
    let big = GridBuilder::dense([1 << 16, 1 << 16, 1], &dense)
        .build()
        .unwrap_err();
    assert_eq!(big, BuildError::Dims([1 << 16, 1 << 16, 1]));
}
