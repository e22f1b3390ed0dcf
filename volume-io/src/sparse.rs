//! A sparse extinction volume: the active voxels of a file's 8^3 leaves and its active tiles
//! (or a generated volume's non-empty 8^3 cells), stored once each, addressed by a table of 8^3
//! cells held per block of 8^3 cells that a leaf or tile touches. No array over the bounding box
//! is ever built, not even of cells: memory follows what is occupied, so two voxels at the
//! corners of a huge box cost two blocks. Voxels outside every leaf and tile read as 0.
//!
//! Local index conventions are those of [`crate::dense::DenseVolume`]: local voxel `p` is file
//! voxel `file_origin + p`, and a sparse volume reads exactly as the dense volume of the same
//! file would, voxel for voxel.

use crate::dense::Affine;

/// Voxels per cell axis: OpenVDB's leaf nodes are 8^3.
pub(crate) const CELL: i64 = 8;
/// Values per cell (a leaf's value count).
pub(crate) const CELL_VALUES: usize = 512;
/// Table entry of a cell no leaf or tile touches (background, 0).
const NONE: u32 = u32::MAX;
/// Table entry flag: the rest is an index into the tile values.
const TILE: u32 = 1 << 31;
/// Cells per block axis: the table is held in blocks of 8^3 cells (64^3 voxels).
const BLOCK: u32 = 8;
/// Cells per block.
const BLOCK_CELLS: usize = (BLOCK * BLOCK * BLOCK) as usize;
/// Voxels per block axis; blocks are aligned to multiples of it in file index coordinates, as
/// OpenVDB's internal nodes are, so a tile of 64 voxels or more covers whole blocks.
pub(crate) const BLOCK_VOXELS: i32 = (BLOCK as i32) * (CELL as i32);
/// Bytes a block's table takes (its entries; a uniform block takes only its map entry).
pub(crate) const BLOCK_TABLE_BYTES: u64 = BLOCK_CELLS as u64 * 4;
/// Bytes of one block's entry in the map (key, tag and pointer or entry, hash table overhead).
pub(crate) const BLOCK_ENTRY_BYTES: u64 = 32;

/// The table entries of one block of cells: one entry for all of them (none, or a tile covering
/// the block), or one per cell (x fastest).
#[derive(Clone, Debug)]
enum Block {
    Uniform(u32),
    Table(Box<[u32; BLOCK_CELLS]>),
}

/// Blocks by key (see [`Cells::key`]); a fixed hasher, though no result depends on the order.
type BlockMap = std::collections::HashMap<
    u64,
    Block,
    std::hash::BuildHasherDefault<std::collections::hash_map::DefaultHasher>,
>;

/// Index of cell `c` in its block's table.
fn in_block(c: [u32; 3]) -> usize {
    let l = c.map(|v| (v % BLOCK) as usize);
    (l[2] * BLOCK as usize + l[1]) * BLOCK as usize + l[0]
}

/// The cells of a sparse volume: 8^3 cells over the bounding box aligned to the file's index
/// coordinates, each empty, a constant (a tile) or a leaf's 512 values, with a table entry per
/// cell held only in the blocks a leaf or tile touches.
#[derive(Clone, Debug)]
pub(crate) struct Cells {
    /// File index of the first voxel of cell (0, 0, 0), a multiple of [`BLOCK_VOXELS`] per axis.
    origin: [i64; 3],
    /// Cells per axis.
    dims: [u32; 3],
    /// Blocks per axis.
    block_dims: [u32; 3],
    /// Per cell: [`NONE`] (also every cell of a block not in the map), `TILE | k` (value
    /// `tiles[k]`) or a leaf index.
    blocks: BlockMap,
    /// Tile values.
    tiles: Vec<f32>,
    /// Leaf values, [`CELL_VALUES`] per leaf, value `x << 6 | y << 3 | z` (OpenVDB's order).
    leaves: Store,
}

/// Leaf values: as f16 bits while every value is a half exactly (a half-float file), else f32.
#[derive(Clone, Debug)]
enum Store {
    F16(Vec<u16>),
    F32(Vec<f32>),
}

/// `v` as f16 bits if that is exact (the same f32 bits back).
pub(crate) fn exact_half(v: f32) -> Option<u16> {
    let h = half::f16::from_f32(v);
    (h.to_f32().to_bits() == v.to_bits()).then_some(h.to_bits())
}

impl Store {
    fn len(&self) -> usize {
        match self {
            Store::F16(v) => v.len(),
            Store::F32(v) => v.len(),
        }
    }

    fn bytes(&self) -> usize {
        match self {
            Store::F16(v) => v.len() * 2,
            Store::F32(v) => v.len() * 4,
        }
    }

    fn get(&self, i: usize) -> f32 {
        match self {
            Store::F16(v) => half::f16::from_bits(v[i]).to_f32(),
            Store::F32(v) => v[i],
        }
    }

    /// Widens f16 storage to f32 (for a value no half holds).
    fn widen(&mut self) -> &mut Vec<f32> {
        if let Store::F16(v) = self {
            *self = Store::F32(
                v.iter()
                    .map(|&h| half::f16::from_bits(h).to_f32())
                    .collect(),
            );
        }
        match self {
            Store::F32(v) => v,
            Store::F16(_) => unreachable!("just widened"),
        }
    }

    fn set(&mut self, i: usize, value: f32) {
        match (&mut *self, exact_half(value)) {
            (Store::F16(v), Some(h)) => v[i] = h,
            _ => self.widen()[i] = value,
        }
    }

    /// Appends one leaf of `fill`.
    fn push_leaf(&mut self, fill: f32) {
        match (&mut *self, exact_half(fill)) {
            (Store::F16(v), Some(h)) => v.resize(v.len() + CELL_VALUES, h),
            _ => {
                let v = self.widen();
                v.resize(v.len() + CELL_VALUES, fill);
            }
        }
    }

    /// Sets every value `v` to `g(v)`.
    fn map(&mut self, g: impl Fn(f32) -> f32) {
        for i in 0..self.len() {
            let v = self.get(i);
            let w = g(v);
            if w.to_bits() != v.to_bits() {
                self.set(i, w);
            }
        }
    }
}

impl Cells {
    /// Empty cells covering the inclusive file index box `lo..=hi`, their leaf values held as
    /// f16 while they are halves (`half`: a half-float file) else f32; `None` if the box's
    /// cells cannot be numbered in 64 bits.
    pub(crate) fn new(lo: [i64; 3], hi: [i64; 3], half: bool) -> Option<Self> {
        let aligned = i64::from(BLOCK_VOXELS);
        let origin = lo.map(|v| v.div_euclid(aligned) * aligned);
        let dims: [u32; 3] = std::array::from_fn(|a| {
            u32::try_from((hi[a] - origin[a]).div_euclid(CELL) + 1).unwrap_or(u32::MAX)
        });
        let block_dims = dims.map(|d| d.div_ceil(BLOCK));
        block_dims
            .iter()
            .try_fold(1u64, |n, &d| n.checked_mul(u64::from(d)))?;
        Some(Cells {
            origin,
            dims,
            block_dims,
            blocks: BlockMap::default(),
            tiles: Vec::new(),
            leaves: if half {
                Store::F16(Vec::new())
            } else {
                Store::F32(Vec::new())
            },
        })
    }

    /// Bytes held: the table and the values.
    pub(crate) fn bytes(&self) -> u64 {
        let tables = self
            .blocks
            .values()
            .filter(|b| matches!(b, Block::Table(_)))
            .count() as u64;
        self.blocks.len() as u64 * BLOCK_ENTRY_BYTES
            + tables * BLOCK_TABLE_BYTES
            + (self.tiles.len() * 4 + self.leaves.bytes()) as u64
    }

    /// The map key of the block holding cell `c`.
    fn key(&self, c: [u32; 3]) -> u64 {
        let [bx, by, bz] = c.map(|v| u64::from(v / BLOCK));
        let [nx, ny, _] = self.block_dims.map(u64::from);
        (bz * ny + by) * nx + bx
    }

    /// The table entry of cell `c` (inside the grid).
    fn entry(&self, c: [u32; 3]) -> u32 {
        match self.blocks.get(&self.key(c)) {
            None => NONE,
            Some(Block::Uniform(e)) => *e,
            Some(Block::Table(t)) => t[in_block(c)],
        }
    }

    /// Sets the table entry of cell `c` (inside the grid).
    fn set(&mut self, c: [u32; 3], e: u32) {
        let key = self.key(c);
        let block = self.blocks.entry(key).or_insert(Block::Uniform(NONE));
        if let Block::Uniform(u) = *block {
            if u == e {
                return;
            }
            *block = Block::Table(Box::new([u; BLOCK_CELLS]));
        }
        if let Block::Table(t) = block {
            t[in_block(c)] = e;
        }
    }

    /// Total cells of the grid (x fastest, then y, then z).
    fn cell_count(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }

    /// Leaves stored.
    pub(crate) fn leaf_count(&self) -> usize {
        self.leaves.len() / CELL_VALUES
    }

    /// The cell holding file voxel `ijk`, if the grid covers it.
    fn cell_of(&self, ijk: [i64; 3]) -> Option<[u32; 3]> {
        let mut cell = [0u32; 3];
        for a in 0..3 {
            let c = (ijk[a] - self.origin[a]).div_euclid(CELL);
            if c < 0 || c >= i64::from(self.dims[a]) {
                return None;
            }
            cell[a] = c as u32;
        }
        Some(cell)
    }

    /// Sets every cell of an active tile of `2^log2` (>= 8) voxels per axis at `origin` (a
    /// multiple of 8) to `value`, clipped to the table; later tiles replace earlier ones.
    pub(crate) fn tile(&mut self, origin: [i32; 3], log2: u32, value: f32) {
        let size = 1i64 << log2;
        let lo: [i64; 3] =
            std::array::from_fn(|a| ((i64::from(origin[a]) - self.origin[a]) / CELL).max(0));
        let hi: [i64; 3] = std::array::from_fn(|a| {
            ((i64::from(origin[a]) + size - self.origin[a]) / CELL).min(i64::from(self.dims[a]))
        });
        if (0..3).any(|a| lo[a] >= hi[a]) {
            return;
        }
        let k = self.tiles.len() as u32;
        self.tiles.push(value);
        let (lo, hi) = (lo.map(|v| v as u32), hi.map(|v| v as u32));
        // Block by block: one entry for a block the tile covers (within the grid), else per cell.
        let (b_lo, b_hi) = (lo.map(|v| v / BLOCK), hi.map(|v| v.div_ceil(BLOCK)));
        for bz in b_lo[2]..b_hi[2] {
            for by in b_lo[1]..b_hi[1] {
                for bx in b_lo[0]..b_hi[0] {
                    let b = [bx, by, bz];
                    let c_lo: [u32; 3] = std::array::from_fn(|a| (b[a] * BLOCK).max(lo[a]));
                    let c_hi: [u32; 3] =
                        std::array::from_fn(|a| ((b[a] + 1) * BLOCK).min(self.dims[a]).min(hi[a]));
                    let whole = (0..3).all(|a| {
                        c_lo[a] == b[a] * BLOCK && c_hi[a] == ((b[a] + 1) * BLOCK).min(self.dims[a])
                    });
                    if whole {
                        let key = self.key(c_lo);
                        self.blocks.insert(key, Block::Uniform(TILE | k));
                        continue;
                    }
                    for z in c_lo[2]..c_hi[2] {
                        for y in c_lo[1]..c_hi[1] {
                            for x in c_lo[0]..c_hi[0] {
                                self.set([x, y, z], TILE | k);
                            }
                        }
                    }
                }
            }
        }
    }

    /// Writes the active values of a leaf at `origin` (a multiple of 8): bit `n` of `mask`
    /// active means `values[n]`. Inactive values keep what the cell held (a tile's value, an
    /// earlier leaf's values at the same origin, or 0), as a dense grid filled in file order.
    pub(crate) fn leaf(&mut self, origin: [i32; 3], mask: &[u64; 8], values: &[f32]) {
        if mask.iter().all(|&w| w == 0) {
            return;
        }
        let Some(cell) = self.cell_of(origin.map(i64::from)) else {
            return;
        };
        let entry = self.entry(cell);
        let n = if entry != NONE && entry & TILE == 0 {
            entry as usize
        } else {
            let fill = if entry == NONE {
                0.0
            } else {
                self.tiles[(entry & !TILE) as usize]
            };
            let n = self.leaf_count();
            self.leaves.push_leaf(fill);
            self.set(cell, n as u32);
            n
        };
        for (w, &word) in mask.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                let i = w * 64 + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                self.leaves.set(n * CELL_VALUES + i, values[i]);
            }
        }
    }

    /// Reserves room for `leaves` leaves; false if that memory cannot be had.
    pub(crate) fn reserve_leaves(&mut self, leaves: usize) -> bool {
        leaves
            .checked_mul(CELL_VALUES)
            .is_some_and(|n| match &mut self.leaves {
                Store::F16(v) => v.try_reserve_exact(n).is_ok(),
                Store::F32(v) => v.try_reserve_exact(n).is_ok(),
            })
    }
}

/// A volume stored as the cells its file's leaves and tiles touch: memory proportional to the
/// active leaves, not the bounding box.
#[derive(Clone, Debug)]
pub struct SparseVolume {
    /// The file it came from, for messages.
    pub name: String,
    /// Voxel counts of the active bounding box along x, y, z (each >= 1).
    pub dims: [u32; 3],
    /// Voxel index space to world space.
    pub index_to_world: Affine,
    /// For a file: the file index of local voxel (0, 0, 0) (None for generated volumes).
    pub file_origin: Option<[i32; 3]>,
    pub(crate) cells: Cells,
}

/// One cell's part of a local box: the cell's table entry and the local voxel box [lo, hi) it
/// covers there.
struct Piece {
    entry: u32,
    lo: [u32; 3],
    hi: [u32; 3],
    /// Local coordinates of the cell's first voxel (may be negative at the grid's low faces).
    cell_lo: [i64; 3],
}

impl SparseVolume {
    /// A volume of `dims` voxels generated 8^3 cell by 8^3 cell, in parallel. Cell `c` holds
    /// voxels `8 c .. 8 c + 8` per axis (those beyond `dims` are ignored); `constant(c)` may say
    /// that every voxel of it has one value (0: nothing is stored), else `values(c, out)` writes
    /// its densities (finite, >= 0) at [`SparseVolume::cell_index`]. The constant cells are
    /// found first, then the others are written straight into their place: memory is the
    /// non-constant cells' values and a table of the cells, never a dense array.
    pub fn generate(
        name: impl Into<String>,
        dims: [u32; 3],
        index_to_world: Affine,
        constant: impl Fn([u32; 3]) -> Option<f32> + Sync,
        values: impl Fn([u32; 3], &mut [f32]) + Sync,
    ) -> Self {
        use rayon::prelude::*;
        let hi = dims.map(|d| i64::from(d.max(1)) - 1);
        let mut cells = Cells::new([0; 3], hi, false).expect("a generated grid's cell table fits");
        let [cx, cy, _] = cells.dims.map(|d| d as usize);
        let coords = |at: usize| {
            [
                (at % cx) as u32,
                (at / cx % cy) as u32,
                (at / (cx * cy)) as u32,
            ]
        };
        let kinds: Vec<Option<f32>> = (0..cells.cell_count())
            .into_par_iter()
            .map(|at| constant(coords(at)))
            .collect();
        let mut leaf_cells = Vec::new();
        for (at, kind) in kinds.iter().enumerate() {
            match kind {
                Some(v) if v.to_bits() == 0 => {}
                Some(v) => {
                    let k = TILE | cells.tiles.len() as u32;
                    cells.set(coords(at), k);
                    cells.tiles.push(*v);
                }
                None => {
                    cells.set(coords(at), leaf_cells.len() as u32);
                    leaf_cells.push(at);
                }
            }
        }
        let mut leaves = vec![0.0; leaf_cells.len() * CELL_VALUES];
        leaves
            .par_chunks_mut(CELL_VALUES)
            .zip(leaf_cells.par_iter())
            .for_each(|(out, &at)| values(coords(at), out));
        cells.leaves = Store::F32(leaves);
        SparseVolume {
            name: name.into(),
            dims,
            index_to_world,
            file_origin: None,
            cells,
        }
    }

    /// Index of local voxel (x, y, z) (each 0..8) in a cell's values: OpenVDB's leaf order.
    pub const fn cell_index(x: usize, y: usize, z: usize) -> usize {
        (x << 6) | (y << 3) | z
    }

    /// The stored cells meeting the local voxel box [lo, hi), with their parts of it, block by
    /// block (no consumer depends on the order).
    fn pieces(&self, lo: [u32; 3], hi: [u32; 3], mut f: impl FnMut(Piece)) {
        let c = &self.cells;
        let origin = self.file_origin.unwrap_or([0; 3]);
        let shift: [i64; 3] = std::array::from_fn(|a| i64::from(origin[a]) - c.origin[a]);
        let c_lo: [i64; 3] = std::array::from_fn(|a| (i64::from(lo[a]) + shift[a]) / CELL);
        let c_hi: [i64; 3] = std::array::from_fn(|a| (i64::from(hi[a]) - 1 + shift[a]) / CELL + 1);
        if (0..3).any(|a| lo[a] >= hi[a]) {
            return;
        }
        let c_lo = c_lo.map(|v| v.max(0) as u32);
        let c_hi: [u32; 3] = std::array::from_fn(|a| c_hi[a].clamp(0, i64::from(c.dims[a])) as u32);
        let (b_lo, b_hi) = (c_lo.map(|v| v / BLOCK), c_hi.map(|v| v.div_ceil(BLOCK)));
        for bz in b_lo[2]..b_hi[2] {
            for by in b_lo[1]..b_hi[1] {
                for bx in b_lo[0]..b_hi[0] {
                    let b = [bx, by, bz];
                    let block = match c.blocks.get(&c.key(b.map(|v| v * BLOCK))) {
                        None | Some(Block::Uniform(NONE)) => continue,
                        Some(block) => block,
                    };
                    let lo_b: [u32; 3] = std::array::from_fn(|a| (b[a] * BLOCK).max(c_lo[a]));
                    let hi_b: [u32; 3] = std::array::from_fn(|a| ((b[a] + 1) * BLOCK).min(c_hi[a]));
                    for z in lo_b[2]..hi_b[2] {
                        for y in lo_b[1]..hi_b[1] {
                            for x in lo_b[0]..hi_b[0] {
                                let entry = match block {
                                    Block::Uniform(e) => *e,
                                    Block::Table(t) => t[in_block([x, y, z])],
                                };
                                if entry == NONE {
                                    continue;
                                }
                                let cell = [x, y, z].map(i64::from);
                                let cell_lo: [i64; 3] =
                                    std::array::from_fn(|a| cell[a] * CELL - shift[a]);
                                f(Piece {
                                    entry,
                                    lo: std::array::from_fn(|a| {
                                        cell_lo[a].max(i64::from(lo[a])) as u32
                                    }),
                                    hi: std::array::from_fn(|a| {
                                        (cell_lo[a] + CELL).min(i64::from(hi[a])) as u32
                                    }),
                                    cell_lo,
                                });
                            }
                        }
                    }
                }
            }
        }
    }

    /// Calls `f(local voxel, value)` for every voxel of a piece.
    fn piece_values(&self, p: &Piece, mut f: impl FnMut([u32; 3], f32)) {
        let c = &self.cells;
        for z in p.lo[2]..p.hi[2] {
            for y in p.lo[1]..p.hi[1] {
                for x in p.lo[0]..p.hi[0] {
                    let v = if p.entry & TILE != 0 {
                        c.tiles[(p.entry & !TILE) as usize]
                    } else {
                        let l = [x, y, z].map(i64::from);
                        let i = ((l[0] - p.cell_lo[0]) << 6)
                            | ((l[1] - p.cell_lo[1]) << 3)
                            | (l[2] - p.cell_lo[2]);
                        c.leaves.get(p.entry as usize * CELL_VALUES + i as usize)
                    };
                    f([x, y, z], v);
                }
            }
        }
    }

    /// Calls `f(local voxel, value)` for every stored voxel inside the grid (those of the
    /// leaves and tiles; every other voxel is 0), cell by cell.
    pub fn for_each_stored(&self, mut f: impl FnMut([u32; 3], f32)) {
        self.pieces([0; 3], self.dims, |p| self.piece_values(&p, &mut f));
    }

    /// Sets every stored value `v` to `g(v)` (tiles once per tile), returning how many voxels
    /// inside the grid changed.
    pub(crate) fn map_values(&mut self, g: impl Fn(f32) -> f32) -> u64 {
        let mut changed = 0u64;
        self.for_each_stored(|_, v| {
            if g(v).to_bits() != v.to_bits() {
                changed += 1;
            }
        });
        for v in self.cells.tiles.iter_mut() {
            *v = g(*v);
        }
        self.cells.leaves.map(g);
        changed
    }

    /// The first voxel in x-fastest order whose density is NaN, infinite or negative, and
    /// that density.
    pub(crate) fn first_bad(&self) -> Option<([u32; 3], f32)> {
        let mut first: Option<([u32; 3], f32)> = None;
        self.for_each_stored(|v, value| {
            let before = |f: &[u32; 3]| (v[2], v[1], v[0]) < (f[2], f[1], f[0]);
            if !(value.is_finite() && value >= 0.0) && first.is_none_or(|(f, _)| before(&f)) {
                first = Some((v, value));
            }
        });
        first
    }

    /// Writes the densities of the local voxel box [lo, hi) into `out` (x fastest); returns
    /// false, leaving `out` unspecified, when every density there is 0.
    pub fn fill(&self, lo: [u32; 3], hi: [u32; 3], out: &mut Vec<f32>) -> bool {
        let n: [usize; 3] = std::array::from_fn(|a| hi[a].saturating_sub(lo[a]) as usize);
        let mut any = false;
        self.pieces(lo, hi, |p| {
            if !any {
                out.clear();
                out.resize(n[0] * n[1] * n[2], 0.0);
                any = true;
            }
            self.piece_values(&p, |v, value| {
                let l: [usize; 3] = std::array::from_fn(|a| (v[a] - lo[a]) as usize);
                out[l[0] + n[0] * (l[1] + n[1] * l[2])] = value;
            });
        });
        any
    }

    /// Bytes of the stored cells (table and values).
    pub fn stored_bytes(&self) -> u64 {
        self.cells.bytes()
    }

    /// Leaves stored (8^3 blocks of values).
    pub fn leaf_count(&self) -> usize {
        self.cells.leaf_count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_storage_widens_for_a_value_no_half_holds_and_keeps_every_bit() {
        let mut s = Store::F16(Vec::new());
        s.push_leaf(0.5);
        s.set(3, 1.25);
        assert!(matches!(s, Store::F16(_)));
        assert_eq!(s.bytes(), CELL_VALUES * 2);
        // 0.1 is no half: the store turns f32, the halves already held keep their values.
        s.set(4, 0.1);
        assert!(matches!(s, Store::F32(_)));
        assert_eq!((s.get(0), s.get(3), s.get(4)), (0.5, 1.25, 0.1));
        s.map(|v| if v > 1.0 { 0.0 } else { v });
        assert_eq!(s.get(3), 0.0);
        // A NaN's bits survive too (validation reports it later).
        let mut n = Store::F16(vec![0; 4]);
        n.set(1, f32::from_bits(0x7fc0_0123));
        assert_eq!(n.get(1).to_bits(), 0x7fc0_0123);
    }
}
