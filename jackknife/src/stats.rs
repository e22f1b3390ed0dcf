//! Statistics of a box of voxels, the super-voxel record of a brick or an adaptive cell: exact
//! min and max, and the mean and the variance-aware importance P of Eq. 5 rounded up.

use shared::volume::grid::{Brick, VolumeView, EMPTY_BRICK};

/// Statistics of the voxel box [lo, hi) (a brick's or an adaptive cell's): over the box
/// widened by one voxel per side and clamped to the grid (all 0 for a box outside the grid).
pub(crate) fn box_stats(view: &VolumeView, lo: [u32; 3], hi: [u32; 3]) -> Brick {
    let d = view.desc.dims;
    if (0..3).any(|a| lo[a] >= d[a]) {
        return Brick::ZERO;
    }
    let lo = [0, 1, 2].map(|a| lo[a].saturating_sub(1));
    let hi = [0, 1, 2].map(|a| (hi[a] + 1).min(d[a]));
    let (mut mn, mut mx) = (f32::INFINITY, 0.0f32);
    let (mut sum, mut sum2, mut n) = (0.0f64, 0.0f64, 0u64);
    for z in lo[2]..hi[2] {
        for y in lo[1]..hi[1] {
            for x in lo[0]..hi[0] {
                let mu = view.voxel(x, y, z);
                mn = mn.min(mu);
                mx = mx.max(mu);
                sum += mu as f64;
                sum2 += mu as f64 * mu as f64;
                n += 1;
            }
        }
    }
    let mean = sum / n as f64;
    let m2 = sum2 / n as f64;
    let min = mn as f64;
    let p = (m2 + min * (min - 2.0 * mean))
        .max(0.0)
        .sqrt()
        .max(0.01 * min);
    Brick {
        mu_min: mn,
        mu_max: mx,
        mean: round_up(mean),
        p: round_up(p),
        slot: EMPTY_BRICK,
        cells: 0,
    }
}

/// Smallest f32 >= v (v rounded up from f64).
fn round_up(v: f64) -> f32 {
    let f = v as f32;
    if (f as f64) < v {
        f.next_up()
    } else {
        f
    }
}
