//! What the OpenVDB and NanoVDB readers share: a tree topology's active tiles and leaves, met in
//! file order by a [`TopologySink`]: first a [`Survey`] (bounds, leaves, whether the grid can be
//! kept sparse), then the [`Voxels`] being filled.

use super::{sparse, DenseBuilder, Voxels};
use anyhow::{ensure, Context, Result};

/// A leaf node found in the topology; its values come later, in the buffer section.
pub(crate) struct Leaf {
    pub(crate) origin: [i32; 3],
    pub(crate) mask: [u64; 8],
}

/// Receives the active tiles and the leaves of a tree topology, in file order.
pub(crate) trait TopologySink {
    /// An active tile of `2^log2` voxels per axis at `origin`.
    fn tile(&mut self, origin: [i32; 3], log2: u32, value: f32);
    /// A leaf node at `origin` with active-voxel mask `mask`.
    fn leaf(&mut self, origin: [i32; 3], mask: [u64; 8]);
}

/// Pass one over the topology: the active bounding box and the leaves.
#[derive(Default)]
pub(crate) struct Survey {
    pub(crate) bounds: DenseBuilder,
    pub(crate) leaves: Vec<Leaf>,
    /// A tile or leaf off the 8-voxel lattice (only in corrupt files).
    off_lattice: bool,
    /// Voxels of the active tiles with a positive value ([`super::Topology::tile_voxels`]).
    pub(crate) tile_voxels: u64,
    /// Origins of the active tiles smaller than a block of the cell table (each makes its block
    /// hold a table).
    small_tiles: Vec<[i32; 3]>,
    /// Blocks the larger active tiles cover, each one uniform entry of the cell table.
    tile_blocks: u64,
}

impl Survey {
    /// Whether the grid can be kept as [`sparse::Cells`]: background 0 (+0: a -0 background
    /// reads as stored nonzero f16 bits) and every node on the 8-voxel lattice.
    pub(crate) fn fits_cells(&self, background: f32) -> bool {
        background.to_bits() == 0 && !self.off_lattice
    }

    /// Empty cells over the bounding box, with room for the leaves; refuses boxes longer than
    /// [`super::MAX_SPARSE_AXIS`] and tables or leaves that do not fit memory. No cap on the
    /// box's voxel count: only the cells of the box and the leaves are held.
    pub(crate) fn allocate_cells(&self, half: bool) -> Result<Voxels> {
        let (lo, hi) = self
            .bounds
            .bounds
            .context("the grid has no active voxels (it is empty); pick another grid")?;
        let dims = super::sparse_dims(lo, hi)?;
        let leaves = self.leaves.len();
        // The leaves' values (f16 from a half-float file, else f32), later the f16 pool of at
        // most as many voxels, and the cell table: a table per block a leaf or small tile
        // touches, one entry per block a large tile covers. Nothing scales with the box.
        let block = sparse::BLOCK_VOXELS;
        let touched: std::collections::HashSet<[i32; 3]> = (self.leaves.iter().map(|l| l.origin))
            .chain(self.small_tiles.iter().copied())
            .map(|o| o.map(|v| v.div_euclid(block)))
            .collect();
        let table = (touched.len() as u64)
            .saturating_mul(sparse::BLOCK_TABLE_BYTES + sparse::BLOCK_ENTRY_BYTES)
            .saturating_add(self.tile_blocks.saturating_mul(sparse::BLOCK_ENTRY_BYTES));
        let value_bytes = if half { 2 } else { 4 };
        let bytes =
            (leaves as u64 * sparse::CELL_VALUES as u64 * (value_bytes + 2)).saturating_add(table);
        super::check_bytes(
            bytes,
            &format!("its {leaves} leaves (8^3 voxels each) and their table"),
            super::available_memory(),
        )?;
        let mut cells = sparse::Cells::new(lo, hi, half)
            .context("the grid's cell table does not fit memory; crop the volume")?;
        ensure!(
            cells.reserve_leaves(leaves),
            "cannot allocate {:.1} GiB for its {leaves} leaves; crop or resample the volume",
            bytes as f64 / (1u64 << 30) as f64
        );
        Ok(Voxels::Sparse {
            cells,
            min: lo.map(|v| v as i32),
            dims,
        })
    }
}

impl TopologySink for Survey {
    fn tile(&mut self, origin: [i32; 3], log2: u32, value: f32) {
        self.off_lattice |= origin.iter().any(|&o| o % 8 != 0) || log2 < 3;
        // Positive only: a negative tile is refused or (--clamp-negative) set to 0, never stored.
        if value > 0.0 {
            self.tile_voxels = self.tile_voxels.saturating_add(1u64 << (3 * log2));
        }
        self.bounds.include_tile(origin, log2);
        let block_log2 = sparse::BLOCK_VOXELS.trailing_zeros();
        if log2 < block_log2 {
            self.small_tiles.push(origin);
        } else {
            let side = 1u64 << (log2 - block_log2);
            self.tile_blocks = self.tile_blocks.saturating_add(side * side * side);
        }
    }

    fn leaf(&mut self, origin: [i32; 3], mask: [u64; 8]) {
        self.off_lattice |= origin.iter().any(|&o| o % 8 != 0);
        self.bounds.include_leaf(origin, &mask);
        self.leaves.push(Leaf { origin, mask });
    }
}

/// Pass two over the topology: the active tiles' values.
impl TopologySink for Voxels {
    fn tile(&mut self, origin: [i32; 3], log2: u32, value: f32) {
        match self {
            Voxels::Dense(dense) => dense.fill_tile(origin, log2, value),
            Voxels::Sparse { cells, .. } => cells.tile(origin, log2, value),
        }
    }

    fn leaf(&mut self, _origin: [i32; 3], _mask: [u64; 8]) {}
}

impl Voxels {
    /// Writes the active values of a leaf at `origin` (bit `n` of `mask`: `values[n]`).
    pub(crate) fn set_leaf(&mut self, origin: [i32; 3], mask: &[u64; 8], values: &[f32]) {
        match self {
            Voxels::Dense(dense) => {
                for n in ones(mask) {
                    let v = [n >> 6, (n >> 3) & 7, n & 7];
                    dense.set(
                        std::array::from_fn(|a| origin[a].wrapping_add(v[a] as i32)),
                        values[n],
                    );
                }
            }
            Voxels::Sparse { cells, .. } => cells.leaf(origin, mask, values),
        }
    }
}

/// Origin of child `n` of a node at `origin` with `2^log2` children per axis (x slowest).
pub(crate) fn child_origin(origin: [i32; 3], n: usize, log2: u32, child_log2: u32) -> [i32; 3] {
    let dim = (1usize << log2) - 1;
    let local = [n >> (2 * log2), (n >> log2) & dim, n & dim];
    std::array::from_fn(|a| origin[a].wrapping_add((local[a] as i32) << child_log2))
}

/// Whether bit `n` of `mask` is set.
pub(crate) fn bit(mask: &[u64], n: usize) -> bool {
    mask[n / 64] >> (n % 64) & 1 == 1
}

/// Indices of the set bits of `mask`, in increasing order.
pub(crate) fn ones(mask: &[u64]) -> impl Iterator<Item = usize> + '_ {
    mask.iter().enumerate().flat_map(|(w, &word)| {
        let mut bits = word;
        std::iter::from_fn(move || {
            (bits != 0).then(|| {
                let b = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                w * 64 + b
            })
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ones_lists_set_bits_in_order() {
        let mask = [0b1010u64, 1 << 63];
        assert_eq!(ones(&mask).collect::<Vec<_>>(), vec![1, 3, 127]);
    }

    #[test]
    fn child_origin_puts_x_slowest() {
        assert_eq!(child_origin([0, 0, 0], 1, 4, 3), [0, 0, 8]);
        assert_eq!(child_origin([0, 0, 0], 16, 4, 3), [0, 8, 0]);
        assert_eq!(child_origin([-128, 0, 0], 256, 4, 3), [-120, 0, 0]);
    }
}
