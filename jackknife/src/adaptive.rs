//! Adaptive super-voxels (beyond the paper; its Sec. 7 names "adaptive subdivision" as future
//! work against the failure of Sec. 6.3): a brick whose importance is concentrated in part of it
//! is subdivided into s^3 cells of B / s voxels per axis, each with a brick's statistics over the
//! cell (min, max, mean, P of Eq. 5 over the cell widened by one voxel, rounded conservatively),
//! so Alg. 1 places its N samples where the extinction is instead of on the brick's zeros.

use crate::stats::box_stats;
use shared::volume::grid::{Brick, VolumeView, EMPTY_BRICK};

/// How the importance structure is built.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Supervoxels {
    /// One super-voxel per brick (the paper).
    #[default]
    Fixed,
    /// Bricks split into cells of `cell` voxels per axis (a divisor of the brick size) where
    /// the brick is sparse, its occupancy [`occupancy`] below `occupancy`, and the cells'
    /// importance mass, the sum of P x voxels over the cells, is at most `ratio` times the
    /// brick's own (P x its voxels).
    Adaptive {
        /// Voxels per cell axis.
        cell: u32,
        /// Largest ratio of the cells' to the brick's importance mass that splits a brick.
        ratio: f32,
        /// Occupancy below which a brick counts as sparse.
        occupancy: f32,
    },
}

/// Default cell of adaptive super-voxels: 4 voxels per axis (4^3 cells of a 16^3 brick).
pub const DEFAULT_CELL_SIZE: u32 = 4;
/// Default split ratio of adaptive super-voxels.
pub const DEFAULT_SPLIT_RATIO: f32 = 0.7;
/// Default occupancy below which adaptive super-voxels split a brick.
pub const DEFAULT_SPLIT_OCCUPANCY: f32 = 0.2;

/// Occupancy of a super-voxel, (mean - mu_min) / P in [0, 1]: the mean over the RMS of the
/// extinction above the control variate. Thin wisps (a fraction f of the voxels at one value,
/// the rest at mu_min) give sqrt(f), so most of Alg. 1's samples there land on mu_min, the
/// distribution of the optical-depth estimate is far from normal and the jackknife is biased
/// (the paper's Sec. 6.3); a smooth or noisy medium gives 0.6 to 1; a homogeneous one 0
/// (P = 0.01 mu_min, and nothing to gain from splitting: its cells have the same mass).
pub fn occupancy(b: &Brick) -> f32 {
    if b.p > 0.0 {
        ((b.mean - b.mu_min) / b.p).max(0.0)
    } else {
        0.0
    }
}

impl Supervoxels {
    /// The mode's name in flags and JSON: "fixed" or "adaptive".
    pub fn name(self) -> &'static str {
        match self {
            Supervoxels::Fixed => "fixed",
            Supervoxels::Adaptive { .. } => "adaptive",
        }
    }

    /// Adaptive super-voxels with the default cell, ratio and occupancy.
    pub fn adaptive() -> Self {
        Supervoxels::Adaptive {
            cell: DEFAULT_CELL_SIZE,
            ratio: DEFAULT_SPLIT_RATIO,
            occupancy: DEFAULT_SPLIT_OCCUPANCY,
        }
    }
}

/// Voxels of the box [lo, hi) inside a grid of `dims`.
fn voxels_inside(lo: [u32; 3], hi: [u32; 3], dims: [u32; 3]) -> f64 {
    (0..3)
        .map(|a| hi[a].min(dims[a]).saturating_sub(lo[a]) as f64)
        .product()
}

/// The s^3 cell records of brick `c` (x fastest; cells outside the grid all 0) if the brick is
/// sparse ([`occupancy`] below `occupancy`) and splitting it lowers its importance mass to at
/// most `ratio` times the brick's, else None. Only bricks with P > 0 are considered (an
/// all-zero window stays one super-voxel).
pub(crate) fn split(
    view: &VolumeView,
    brick: &Brick,
    c: [u32; 3],
    size: u32,
    cell: u32,
    (ratio, occupancy_below): (f32, f32),
) -> Option<Vec<Brick>> {
    if !(brick.p > 0.0) || !(occupancy(brick) < occupancy_below) {
        return None;
    }
    let dims = [0, 1, 2].map(|a| view.desc.dims[a]);
    let s = size / cell;
    let lo = c.map(|v| v * size);
    let brick_mass = brick.p as f64 * voxels_inside(lo, lo.map(|v| v + size), dims);
    let mut cells = Vec::with_capacity((s * s * s) as usize);
    let mut mass = 0.0f64;
    for z in 0..s {
        for y in 0..s {
            for x in 0..s {
                let a = [lo[0] + x * cell, lo[1] + y * cell, lo[2] + z * cell];
                let b = a.map(|v| v + cell);
                let stats = box_stats(view, a, b);
                mass += stats.p as f64 * voxels_inside(a, b, dims);
                cells.push(Brick {
                    slot: EMPTY_BRICK,
                    cells: 0,
                    ..stats
                });
            }
        }
    }
    (mass <= ratio as f64 * brick_mass).then_some(cells)
}

/// The box [lo, hi) of the cells (s^3 records, x fastest) whose statistics are not all 0, in
/// cell coordinates ([`Brick::cell_box_record`]); lo = hi = 0 when every cell is 0.
pub(crate) fn cell_box(cells: &[Brick], s: u32) -> ([u32; 3], [u32; 3]) {
    let (mut lo, mut hi) = ([s; 3], [0; 3]);
    for (i, c) in cells.iter().enumerate() {
        if c.has_zero_statistics() {
            continue;
        }
        let i = i as u32;
        let at = [i % s, i / s % s, i / (s * s)];
        for a in 0..3 {
            lo[a] = lo[a].min(at[a]);
            hi[a] = hi[a].max(at[a] + 1);
        }
    }
    if hi[0] == 0 {
        ([0; 3], [0; 3])
    } else {
        (lo, hi)
    }
}
