//! Adaptive super-voxels (`Supervoxels::Adaptive`): the builder splits the bricks whose
//! importance is concentrated in thin sheets and keeps the homogeneous ones whole; a traversal
//! visits the cells of split bricks with their own statistics, crossing every brick boundary at
//! the same parameter (bits) as the fixed grid's traversal, passes over the zero cells around a
//! split brick's cell box without changing any estimate, and the estimators stay unbiased.
//! Statistics: per ray, the mean of 4000 optical-depth estimates (Alg. 1 + 2, N = 10) matches
//! regular tracking's exact optical depth and ratio tracking's mean matches exp(-tau) at
//! z < 4.5 (16 rays x 2 checks x 2 formats: a false alarm has probability about 5e-4).

mod common;

use common::assert_unbiased_on_ray;
use jackknife::{
    Brick, BuildError, Grid, GridBuilder, HashRng, Lookup, Ray, SupervoxelFormat, Supervoxels,
    VolumeView, V3,
};
use shared::estimators::tracking::regular_tracking_tau;
use shared::rng::{pcg_hash, unit_f32};
use shared::volume::dda::Segment;
use shared::volume::supervoxels::SuperVoxelDda;

const N: u32 = 48;

/// Thin sheets (one voxel thick, every 11th x plane) in the lower half, a homogeneous noisy
/// medium in the upper half (y >= 24).
fn density(x: u32, y: u32, z: u32) -> f32 {
    let v = unit_f32(pcg_hash(x + N * (y + N * z)));
    if y >= 24 {
        0.5 + 0.2 * v
    } else if x % 11 == 3 {
        4.0 + v
    } else {
        0.0
    }
}

fn build(mode: Supervoxels, format: SupervoxelFormat) -> Grid {
    GridBuilder::from_fn([N; 3], density)
        .brick_size(8)
        .lookup(Lookup::Nearest)
        .supervoxel_format(format)
        .supervoxels(mode)
        .build()
        .unwrap()
}

fn adaptive() -> Supervoxels {
    // A sheet in one of a cell row's four windows (four of ten planes) gives the cells
    // touched (half of them) importance mass sqrt(1/2) ~ 0.71 of the brick's.
    // (sheets: occupancy about sqrt(1/10); the medium: about 0.9.)
    Supervoxels::Adaptive {
        cell: 2,
        ratio: 0.8,
        occupancy: 0.5,
    }
}

/// A ray through the grid from seed r (some axis-parallel, some through cell corners).
fn ray(r: u32) -> Ray {
    let u = |k: u32| unit_f32(pcg_hash(r * 16 + k + 0xada));
    let o = V3::new(u(0) * 80.0 - 16.0, u(1) * 80.0 - 16.0, -20.0);
    let mut target = V3::new(u(2) * 48.0, u(3) * 48.0, 48.0);
    if r.is_multiple_of(7) {
        // Through cell corners: integer targets and origins.
        target = V3::new(target.x.round(), target.y.round(), 48.0);
        return Ray {
            o: V3::new(o.x.round(), o.y.round(), -20.0),
            d: V3::new(target.x - o.x.round(), target.y - o.y.round(), 68.0),
        };
    }
    if r.is_multiple_of(5) {
        return Ray {
            o: V3::new(u(4) * 48.0, u(5) * 48.0, -3.0),
            d: V3::new(0.0, 0.0, 1.0),
        };
    }
    Ray {
        o,
        d: V3::new(target.x - o.x, target.y - o.y, target.z - o.z),
    }
}

#[test]
fn sheets_are_split_and_the_homogeneous_medium_is_not() {
    let grid = build(adaptive(), SupervoxelFormat::F32);
    let s = grid.desc.cells_per_brick;
    assert_eq!(s, 4);
    let bricks = grid.grid_bricks();
    let d = grid.desc.brick_dims;
    let (mut split_low, mut split_high, mut low, mut high) = (0, 0, 0, 0);
    for (i, b) in bricks.iter().enumerate() {
        let by = (i as u32 / d[0]) % d[1];
        // Bricks 3 (y 24..32) and up hold the medium; the windows of bricks 2 and 3 reach into
        // the other half.
        if by >= 4 {
            high += 1;
            split_high += (b.cells != 0) as u32;
        } else if by < 2 && b.p > 0.0 {
            // (the bricks at x in [16, 24) hold no sheet: all zero)
            low += 1;
            split_low += (b.cells != 0) as u32;
        }
    }
    assert_eq!(split_high, 0, "{split_high} of {high} medium bricks split");
    assert_eq!(split_low, low, "{split_low} of {low} sheet bricks split");
    assert_eq!(
        grid.bricks.len(),
        bricks.len() + grid.subdivided_bricks() * (s * s * s + 1) as usize
    );
    assert!(grid.desc.cell_steps > 0);
    // The voxels do not change, nor do the bricks' own records but for the cell index.
    let fixed = build(Supervoxels::Fixed, SupervoxelFormat::F32);
    assert_eq!(grid.voxels, fixed.voxels);
    for (a, b) in bricks.iter().zip(&fixed.bricks) {
        assert_eq!(
            jackknife::Brick { cells: 0, ..*a },
            *b,
            "a split brick keeps its record"
        );
    }
    assert_eq!(fixed.desc.cells_per_brick, 0);
}

/// The segments of a traversal (in order, never overlapping), their statistics checked against
/// nearest lookups at points inside them; between segments (the zero cells around a subdivided
/// brick's cell box, which the traversal passes over) the extinction is 0.
fn segments(grid: &Grid, ray: &Ray, t0: f32, t1: f32) -> Vec<(Segment, Brick)> {
    let vol = grid.view();
    let inside =
        |p: V3| p.x > 0.01 && p.y > 0.01 && p.z > 0.01 && p.x < 47.99 && p.y < 47.99 && p.z < 47.99;
    let mut dda = SuperVoxelDda::new(&grid.desc, ray, t0, t1);
    let mut out = Vec::new();
    let mut last = t0;
    while !dda.done() {
        let (seg, b) = dda.step(&vol);
        assert!(seg.t0 >= last, "segments are in order");
        assert!(seg.t1 >= seg.t0);
        assert!(seg.t1 <= t1);
        // Points well inside the segment read voxels within the super-voxel's widened window:
        // the statistics bound them; points in a gap read 0.
        for k in 1..4 {
            let f = k as f32 * 0.25;
            let p = ray.at(seg.t0 + (seg.t1 - seg.t0) * f);
            if inside(p) {
                let mu = vol.mu_nearest(p);
                assert!(
                    b.mu_min <= mu && mu <= b.mu_max,
                    "mu {mu} at {p:?} outside [{}, {}] of segment {seg:?}",
                    b.mu_min,
                    b.mu_max
                );
            }
            let p = ray.at(last + (seg.t0 - last) * f);
            if seg.t0 > last && inside(p) {
                assert_eq!(vol.mu_nearest(p), 0.0, "a gap at {p:?} holds extinction");
            }
        }
        last = seg.t1;
        out.push((seg, b));
    }
    assert!(!dda.exhausted(), "budget exhausted");
    out
}

/// Bits of the segment boundaries of a traversal ([`segments`]), and its steps.
fn boundaries(grid: &Grid, ray: &Ray, t0: f32, t1: f32) -> (Vec<u32>, Vec<(f32, f32)>) {
    let segs = segments(grid, ray, t0, t1);
    let mut out: Vec<u32> = segs
        .iter()
        .flat_map(|(s, _)| [s.t0.to_bits(), s.t1.to_bits()])
        .collect();
    out.dedup();
    (out, segs.iter().map(|(s, _)| (s.t0, s.t1)).collect())
}

#[test]
fn cell_traversal_crosses_every_brick_boundary_where_the_brick_traversal_does() {
    let grid = build(adaptive(), SupervoxelFormat::F32);
    let fixed = build(Supervoxels::Fixed, SupervoxelFormat::F32);
    let (mut more, mut rays) = (0, 0);
    for r in 0..400 {
        let ray = ray(r);
        let (t0, t1) = grid.clip(&ray);
        if !(t0 < t1) {
            continue;
        }
        rays += 1;
        let (a, segs) = boundaries(&grid, &ray, t0, t1);
        let (f, fixed_segs) = boundaries(&fixed, &ray, t0, t1);
        for bits in &f {
            // A brick boundary is a segment boundary with the same bits, or lies in a gap
            // (never inside a segment: no cell spans a brick boundary).
            let t = f32::from_bits(*bits);
            let found = a
                .binary_search_by(|x| f32::from_bits(*x).total_cmp(&t))
                .is_ok();
            assert!(
                found || !segs.iter().any(|&(s0, s1)| s0 < t && t < s1),
                "ray {r}: brick boundary {t} inside a segment of the adaptive traversal"
            );
        }
        more += (segs.len() > fixed_segs.len()) as u32;
    }
    assert!(rays > 300);
    // Rays through the sheets visit cells: the test tests the cells.
    assert!(more * 3 > rays, "{more} of {rays} rays visited cells");
}

/// The grid with every subdivided brick's cell box widened to the whole brick: the traversal
/// then visits every cell a ray crosses (as before cell boxes).
fn without_cell_boxes(grid: &Grid) -> Grid {
    let mut full = grid.clone();
    let s = grid.desc.cells_per_brick;
    for i in 0..full.grid_bricks().len() {
        let first = full.bricks[i].cells as usize;
        if first != 0 {
            full.bricks[first] = Brick::cell_box_record([0; 3], [s; 3]);
        }
    }
    full
}

#[test]
fn cell_boxes_hold_every_cell_with_statistics_and_fit_them() {
    for format in [SupervoxelFormat::F32, SupervoxelFormat::Bc4] {
        let grid = build(adaptive(), format);
        let s = grid.desc.cells_per_brick;
        let (mut split, mut smaller) = (0, 0);
        for b in grid.grid_bricks() {
            if b.cells == 0 {
                continue;
            }
            split += 1;
            let (lo, hi) = grid.bricks[b.cells as usize].cell_box();
            let (mut fit_lo, mut fit_hi) = ([s; 3], [0; 3]);
            for z in 0..s {
                for y in 0..s {
                    for x in 0..s {
                        let c = grid.view().cell(b.cells, [x, y, z]);
                        let at = [x, y, z];
                        let inside = (0..3).all(|a| lo[a] <= at[a] && at[a] < hi[a]);
                        if !c.has_zero_statistics() {
                            assert!(inside, "{format:?}: cell {at:?} outside {lo:?}..{hi:?}");
                            for a in 0..3 {
                                fit_lo[a] = fit_lo[a].min(at[a]);
                                fit_hi[a] = fit_hi[a].max(at[a] + 1);
                            }
                        }
                    }
                }
            }
            assert_eq!(
                (lo, hi),
                (fit_lo, fit_hi),
                "{format:?}: the box fits its cells"
            );
            smaller += (lo != [0; 3] || hi != [s; 3]) as u32;
        }
        // The sheets fill one or two cells of four along x: the boxes are smaller.
        assert!(split > 0 && smaller * 2 > split, "{smaller} of {split}");
    }
}

#[test]
fn cell_boxes_change_no_estimate() {
    use shared::estimators::optical_depth::{estimate_pair, prepare};
    use shared::estimators::tracking::ratio_tracking;
    use shared::params::{Importance, Jitter};
    for format in [SupervoxelFormat::F32, SupervoxelFormat::Bc4] {
        let grid = build(adaptive(), format);
        let full = without_cell_boxes(&grid);
        let (vol, full_vol) = (grid.view(), full.view());
        let (mut fewer, mut rays) = (0, 0);
        for r in 0..400u32 {
            let ray = ray(r);
            let (t0, t1) = grid.clip(&ray);
            if !(t0 < t1) {
                continue;
            }
            rays += 1;
            // The same segments with statistics, bit for bit; the others are all 0.
            let a = segments(&grid, &ray, t0, t1);
            let b = segments(&full, &ray, t0, t1);
            let kept = |v: &[(Segment, Brick)]| -> Vec<(Segment, Brick)> {
                v.iter()
                    .filter(|(s, b)| s.t0 < s.t1 && !b.has_zero_statistics())
                    .copied()
                    .collect()
            };
            assert_eq!(kept(&a), kept(&b), "{format:?} ray {r}");
            fewer += (a.len() < b.len()) as u32;
            for mode in [Importance::VarianceAware, Importance::Mean] {
                let (pa, pb) = (
                    prepare(&vol, &ray, t0, t1, mode),
                    prepare(&full_vol, &ray, t0, t1, mode),
                );
                assert_eq!(pa, pb, "{format:?} ray {r}");
                for seed in 0..4 {
                    let rng = HashRng::for_sample(r, seed, 5);
                    let est = |v: &VolumeView, p| {
                        estimate_pair(
                            v,
                            &ray,
                            p,
                            10,
                            mode,
                            Jitter::Stratified,
                            Lookup::Nearest,
                            rng,
                        )
                    };
                    assert_eq!(est(&vol, &pa).0, est(&full_vol, &pb).0);
                }
            }
            for seed in 0..4 {
                let rng = HashRng::for_sample(r, seed, 9);
                let rt =
                    |v: &VolumeView| ratio_tracking(v, &ray, t0, t1, Lookup::Nearest, false, rng);
                assert_eq!(rt(&vol).0.to_bits(), rt(&full_vol).0.to_bits(), "ray {r}");
            }
        }
        assert!(rays > 300);
        assert!(
            fewer * 3 > rays,
            "{format:?}: {fewer} of {rays} rays took fewer steps"
        );
    }
}

#[test]
fn adaptive_supervoxels_keep_optical_depth_and_ratio_tracking_unbiased() {
    for format in [SupervoxelFormat::F32, SupervoxelFormat::Bc4] {
        let grid = build(adaptive(), format);
        let vol = grid.view();
        let trials = 4000u32;
        let (mut rays, mut ratio_rays) = (0, 0);
        for r in 0..400u32 {
            let ray = ray(r);
            let (t0, t1) = grid.clip(&ray);
            if !(t0 < t1) {
                continue;
            }
            let (tau, _) = regular_tracking_tau(&vol, &ray, t0, t1);
            if !(tau > 0.05 && tau < 8.0) {
                continue;
            }
            let what = format!("{format:?} ray {r}");
            if assert_unbiased_on_ray(&vol, &ray, t0, t1, tau, trials, r, 17, &what) {
                ratio_rays += 1;
            }
            rays += 1;
            if rays == 16 {
                break;
            }
        }
        assert_eq!(rays, 16);
        println!("{format:?}: ratio tracking's mean tested on {ratio_rays} of {rays} rays");
        assert!(ratio_rays >= 8, "{ratio_rays} rays test ratio tracking");
    }
}

#[test]
fn bad_cells_and_ratios_are_refused() {
    let b = |mode| {
        GridBuilder::from_fn([16; 3], |_, _, _| 1.0)
            .brick_size(12)
            .supervoxels(mode)
            .build()
            .map(|_| ())
    };
    for cell in [0, 5, 12, 24] {
        assert_eq!(
            b(Supervoxels::Adaptive {
                cell,
                ratio: 0.5,
                occupancy: 0.2
            }),
            Err(BuildError::CellSize { cell, brick: 12 })
        );
    }
    for ratio in [0.0, -1.0, 1.5, f32::NAN] {
        let e = b(Supervoxels::Adaptive {
            cell: 4,
            ratio,
            occupancy: 0.2,
        });
        assert!(
            matches!(e, Err(BuildError::SplitRatio(_))),
            "{ratio}: {e:?}"
        );
        let e = b(Supervoxels::Adaptive {
            cell: 4,
            ratio: 0.5,
            occupancy: ratio,
        });
        assert!(
            matches!(e, Err(BuildError::SplitOccupancy(_))),
            "{ratio}: {e:?}"
        );
    }
    assert_eq!(
        b(Supervoxels::Adaptive {
            cell: 3,
            ratio: 1.0,
            occupancy: 1.0
        }),
        Ok(())
    );
}
