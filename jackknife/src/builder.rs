//! The brick grid the estimators traverse: per-brick statistics (min, max, mean and the
//! variance-aware importance P of Eq. 5) over the whole grid, and a pool of the f16 voxels of
//! the bricks that hold a nonzero voxel, built from a user's dense or sparse densities.

use half::f16;
use shared::volume::grid::{
    brick_log2_of, skip_slot, Brick, GridDesc, Lookup, VolumeView, EMPTY_BRICK, FIRST_EMPTY_SLOT,
    MAX_SKIP_LEVEL,
};
use shared::volume::pages::{Pages, GPU_PAGE_LOG2, MAX_PAGES, ONE_PAGE_LOG2};

use crate::adaptive::Supervoxels;
use crate::stats::box_stats;

/// Default brick (super-voxel) size B in voxels per axis, as in the paper.
pub const DEFAULT_BRICK_SIZE: u32 = 16;

/// Largest optical depth the estimators may meet: sums of up to ~1000 such terms (two estimates,
/// squares of half of it in the MIS weights' complex exponentials) stay within f32.
pub const MAX_OPTICAL_DEPTH: f64 = 1e35;

/// Largest page, log2 of its words: 2^28 words (1 GiB); [`MAX_PAGES`] such pages hold 2^31
/// words, every voxel a u32 pool index reaches (the pool's own limit).
pub const MAX_PAGE_LOG2: u32 = 28;

/// Longest grid axis in voxels: the kernels' u32 voxel coordinates keep room for a brick (and a
/// filter's reach) past the end.
pub const MAX_AXIS: u32 = 1 << 31;

/// Why a grid cannot be built. Voxels are given in the builder's index coordinates.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// The density scale is negative or not finite.
    #[error("the density scale must be finite and >= 0 (got {0})")]
    Scale(f32),
    /// The brick size is outside 2..=256.
    #[error("the brick size must be in 2..=256 (got {0})")]
    BrickSize(u32),
    /// The adaptive cell size does not divide the brick size into at least two cells per axis.
    #[error("the adaptive cell size must divide the brick size {brick} into 2 or more cells per axis (got {cell})")]
    CellSize {
        /// Voxels per cell axis.
        cell: u32,
        /// Voxels per brick axis.
        brick: u32,
    },
    /// The adaptive split ratio is not in (0, 1].
    #[error("the adaptive split ratio must be in (0, 1] (got {0})")]
    SplitRatio(f32),
    /// The adaptive split occupancy is not in (0, 1].
    #[error("the adaptive split occupancy must be in (0, 1] (got {0})")]
    SplitOccupancy(f32),
    /// The brick table (with the cells of the subdivided bricks) reaches 2^32 - 1 records.
    #[error("the super-voxel table of the {0:?} grid exceeds 2^32 - 1 records")]
    Table([u32; 3]),
    /// A dimension is 0 or above [`MAX_AXIS`], or a dense array's voxel count reaches 2^32 - 1.
    #[error("grid dimensions {0:?} are empty or too large")]
    Dims([u32; 3]),
    /// The dense array's length is not the product of the dimensions.
    #[error("{len} densities for a {dims:?} grid (expected {expected})")]
    Length {
        /// Values given.
        len: usize,
        /// Grid dimensions.
        dims: [u32; 3],
        /// Their product.
        expected: usize,
    },
    /// The pool of occupied bricks' voxels exceeds 2^32 - 1 f16 values (8 GiB).
    #[error("the occupied bricks of the {0:?} grid hold more than 2^32 - 1 voxels (8 GiB of f16)")]
    Pool([u32; 3]),
    /// A density is NaN, infinite or negative.
    #[error("voxel {voxel:?} has density {density}: densities must be finite and >= 0")]
    Density {
        /// The voxel.
        voxel: [u32; 3],
        /// Its density.
        density: f32,
    },
    /// The densest voxel's extinction (density x scale) exceeds f32's range.
    #[error("voxel {voxel:?} has density {density}, which times the density scale {scale} exceeds the f32 range of extinctions (3.4e38)")]
    Extinction {
        /// The densest voxel.
        voxel: [u32; 3],
        /// Its density.
        density: f32,
        /// The density scale.
        scale: f32,
    },
    /// The densest voxel times the scale gives optical depths f32 cannot sum.
    #[error("voxel {voxel:?} has density {density}, which times the density scale {scale} gives optical depths up to {depth:.1e} through the volume, beyond the {MAX_OPTICAL_DEPTH:e} that f32 arithmetic can sum")]
    OpticalDepth {
        /// The densest voxel.
        voxel: [u32; 3],
        /// Its density.
        density: f32,
        /// The density scale.
        scale: f32,
        /// Largest optical depth through the grid.
        depth: f64,
    },
}

/// Nonzero densities whose extinction (scale x stored f16) is 0: how many, and the first one.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Underflow {
    /// Voxels with density > 0 whose extinction is 0.
    pub count: u64,
    /// Voxels with density > 0.
    pub nonzero: u64,
    /// The first such voxel and its density.
    pub first: Option<([u32; 3], f32)>,
}

/// A volume ready for the estimators: what [`VolumeView`] borrows.
#[derive(Clone, Debug)]
pub struct Grid {
    /// Shape, brick shape, lookup mode and the scale applied to the f16 voxels.
    pub desc: GridDesc,
    /// The pool: f16 voxel bits of the non-empty bricks, two per word; per brick its voxels x
    /// fastest over its extent clipped to the grid, each brick padded to a whole word.
    pub voxels: Vec<u32>,
    /// Statistics and pool slot of every brick, x fastest, then the cell records of the
    /// subdivided bricks (adaptive super-voxels, [`Brick::cells`]).
    pub bricks: Vec<Brick>,
    /// Nonzero densities lost to underflow.
    pub underflow: Underflow,
    /// log2 of the words per page the pool is laid out in: no brick's run crosses a multiple
    /// of 2^page_log2 words (`desc.page_log2` is [`ONE_PAGE_LOG2`]: the CPU reads one page).
    pub page_log2: u32,
}

impl Grid {
    /// Borrows the grid as the estimators' view.
    pub fn view(&self) -> VolumeView<'_> {
        VolumeView::new(self.desc, Pages::one(&self.voxels), &self.bricks)
    }

    /// The stored f16 bits of voxel (i, j, k) (0 in an empty brick); the extinction is
    /// `desc.density_scale` times their value.
    pub fn stored_f16(&self, i: u32, j: u32, k: u32) -> u16 {
        match self.view().pool_index(i, j, k) {
            Some(index) => (self.voxels[index / 2] >> (16 * (index % 2))) as u16,
            None => 0,
        }
    }

    /// The pool's pages as a kernel binds them (each at most 2^page_log2 words).
    pub fn pages(&self) -> impl Iterator<Item = &[u32]> {
        self.voxels.chunks(1 << self.page_log2)
    }

    /// The descriptor for a view that binds the pool in [`Grid::pages`], or None if there are
    /// more than [`MAX_PAGES`] pages.
    pub fn paged_desc(&self) -> Option<GridDesc> {
        (self.pages().count() <= MAX_PAGES).then_some(GridDesc {
            page_log2: self.page_log2,
            ..self.desc
        })
    }

    /// Bricks that hold a nonzero voxel (the pool holds their voxels only).
    pub fn occupied_bricks(&self) -> usize {
        self.grid_bricks()
            .iter()
            .filter(|b| b.stores_voxels())
            .count()
    }

    /// The records of the grid's bricks (without the cells of subdivided bricks).
    pub fn grid_bricks(&self) -> &[Brick] {
        let n: usize = self.desc.brick_dims[..3]
            .iter()
            .map(|&d| d as usize)
            .product();
        &self.bricks[..n]
    }

    /// Bricks split into cells (adaptive super-voxels).
    pub fn subdivided_bricks(&self) -> usize {
        self.grid_bricks().iter().filter(|b| b.cells != 0).count()
    }

    /// Bytes of the super-voxel table: the bricks' and the cells' records.
    pub fn table_bytes(&self) -> u64 {
        (self.bricks.len() * std::mem::size_of::<Brick>()) as u64
    }

    /// Bytes the table would take BC4-compressed ([`crate::bc4::bc4_table_bytes`]): the
    /// bricks', plus with subdivided bricks their cells' (each brick's s x s x s cells as s
    /// slices of s x s) and its 8-byte cell box ([`Brick::cell_box_record`]), and a 4-byte cell
    /// index per brick.
    pub fn bc4_table_bytes(&self) -> u64 {
        let d = self.desc.brick_dims;
        let bricks = crate::bc4::bc4_table_bytes([d[0], d[1], d[2]]);
        let n = self.subdivided_bricks() as u64;
        if n == 0 {
            return bricks;
        }
        let s = self.desc.cells_per_brick();
        let per_brick = crate::bc4::bc4_table_bytes([s, s, s]) - 4 * (s as u64).pow(3) + 8;
        bricks + n * per_brick + 4 * self.grid_bricks().len() as u64
    }

    /// The part [t0, t1] of an index-space ray inside the grid's box (t0 >= t1: a miss).
    pub fn clip(&self, ray: &shared::geometry::Ray) -> (f32, f32) {
        let d = &self.desc.dims;
        let hi = shared::geometry::V3::new(d[0] as f32, d[1] as f32, d[2] as f32);
        shared::volume::dda::clip_to_box(ray, hi, 0.0, f32::INFINITY)
    }
}

/// Fills `out` with the densities of the voxel box [lo, hi) (x fastest); false: all are 0.
type FillBox<'a> = dyn Fn([u32; 3], [u32; 3], &mut Vec<f32>) -> bool + Sync + 'a;

/// Where the densities come from.
enum Source<'a> {
    Dense(&'a [f32]),
    Func(Box<dyn Fn(u32, u32, u32) -> f32 + Sync + 'a>),
    Boxes(Box<FillBox<'a>>),
}

/// Builds a [`Grid`] from densities: extinction = density x `density_scale`.
///
/// Voxels are stored as f16 (as in the author's code), prescaled by an exact power of two where
/// the densities do not fit f16 as they are, so any scale up to f32's range keeps 11 significant
/// bits. Brick statistics come from exactly the values the estimators read, over each brick
/// widened by one voxel per side (conservative for stochastic filtering); mu_min is exact, mean,
/// max and P are rounded up, and P >= 0.01 mu_min so non-empty bricks get samples.
pub struct GridBuilder<'a> {
    dims: [u32; 3],
    source: Source<'a>,
    density_scale: f32,
    brick_size: u32,
    lookup: Lookup,
    chord: Option<f64>,
    page_log2: u32,
    format: SupervoxelFormat,
    supervoxels: Supervoxels,
}

/// How the super-voxel statistics are stored.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SupervoxelFormat {
    /// f32 each, rounded conservatively from the exact statistics.
    #[default]
    F32,
    /// BC4 block compression as in the paper's figures (see [`crate::bc4`]): 4 bits per brick
    /// and statistic plus 8-bit endpoints per 4 x 4 block, conservative; the brick table holds
    /// the decoded values.
    Bc4,
}

impl SupervoxelFormat {
    /// The format's name in flags and JSON: "f32" or "bc4".
    pub fn name(self) -> &'static str {
        match self {
            SupervoxelFormat::F32 => "f32",
            SupervoxelFormat::Bc4 => "bc4",
        }
    }
}

impl<'a> GridBuilder<'a> {
    /// Densities of a dense `dims` grid, x fastest (`values.len()` = dims product).
    pub fn dense(dims: [u32; 3], values: &'a [f32]) -> Self {
        Self::with_source(dims, Source::Dense(values))
    }

    /// Densities from a function of the voxel (x, y, z), e.g. a lookup in a sparse structure.
    pub fn from_fn(dims: [u32; 3], f: impl Fn(u32, u32, u32) -> f32 + Sync + 'a) -> Self {
        Self::with_source(dims, Source::Func(Box::new(f)))
    }

    /// Densities box by box, for sparse sources: `fill(lo, hi, out)` writes the densities of the
    /// voxel box [lo, hi) into `out` (x fastest) or returns false, leaving `out` as it is, when
    /// it knows that every one of them is 0; such bricks cost no work beyond the call.
    pub fn from_boxes(
        dims: [u32; 3],
        fill: impl Fn([u32; 3], [u32; 3], &mut Vec<f32>) -> bool + Sync + 'a,
    ) -> Self {
        Self::with_source(dims, Source::Boxes(Box::new(fill)))
    }

    fn with_source(dims: [u32; 3], source: Source<'a>) -> Self {
        GridBuilder {
            dims,
            source,
            density_scale: 1.0,
            brick_size: DEFAULT_BRICK_SIZE,
            lookup: Lookup::Stochastic,
            chord: None,
            page_log2: GPU_PAGE_LOG2,
            format: SupervoxelFormat::F32,
            supervoxels: Supervoxels::Fixed,
        }
    }

    /// Fixed super-voxels (one per brick, the default) or adaptive ones ([`Supervoxels`]).
    pub fn supervoxels(mut self, mode: Supervoxels) -> Self {
        self.supervoxels = mode;
        self
    }

    /// Extinction per unit of density (default 1).
    pub fn density_scale(mut self, scale: f32) -> Self {
        self.density_scale = scale;
        self
    }

    /// Voxels per brick axis, 2..=256 (default 16).
    pub fn brick_size(mut self, b: u32) -> Self {
        self.brick_size = b;
        self
    }

    /// How the estimators read voxels (default: stochastic filtering, as in the paper).
    pub fn lookup(mut self, lookup: Lookup) -> Self {
        self.lookup = lookup;
        self
    }

    /// How the super-voxel statistics are stored (default f32; BC4 as in the paper's figures).
    pub fn supervoxel_format(mut self, format: SupervoxelFormat) -> Self {
        self.format = format;
        self
    }

    /// Lays the pool out in pages of 2^`log2` words (default [`GPU_PAGE_LOG2`], 128 MiB: any
    /// Vulkan device binds such pages; a device with larger storage buffers binds pages up to
    /// [`MAX_PAGE_LOG2`]); smaller pages exercise paging on small volumes. The voxels read are
    /// the same for every page size. At most [`MAX_PAGE_LOG2`]; raised to fit one brick.
    pub fn page_log2(mut self, log2: u32) -> Self {
        self.page_log2 = log2.min(MAX_PAGE_LOG2);
        self
    }

    /// Length of the longest ray segment through the grid in the units of the rays' t (default:
    /// the sum of the dimensions, for rays with unit direction in index space); bounds the
    /// optical depths checked against [`MAX_OPTICAL_DEPTH`].
    pub fn max_chord(mut self, length: f64) -> Self {
        self.chord = Some(length);
        self
    }

    /// Fills `out` with the densities of the voxel box [lo, hi) (x fastest); false (leaving
    /// `out` unspecified) when the source knows they are all 0.
    fn fill(&self, lo: [u32; 3], hi: [u32; 3], out: &mut Vec<f32>) -> bool {
        let rows = || (lo[2]..hi[2]).flat_map(move |z| (lo[1]..hi[1]).map(move |y| (y, z)));
        match &self.source {
            Source::Dense(v) => {
                out.clear();
                let [dx, dy, _] = self.dims.map(|d| d as usize);
                for (y, z) in rows() {
                    let row = (z as usize * dy + y as usize) * dx;
                    out.extend_from_slice(&v[row + lo[0] as usize..row + hi[0] as usize]);
                }
                true
            }
            Source::Func(f) => {
                out.clear();
                for (y, z) in rows() {
                    out.extend((lo[0]..hi[0]).map(|x| f(x, y, z)));
                }
                true
            }
            Source::Boxes(f) => f(lo, hi, out),
        }
    }

    /// The voxel box [lo, hi) of brick `i` (x fastest), clamped to the grid.
    fn brick_box(&self, i: usize, brick_dims: [u32; 3]) -> ([u32; 3], [u32; 3]) {
        let (dims, b) = (self.dims, self.brick_size);
        let c = unflatten(i, brick_dims);
        let lo = [0, 1, 2].map(|a| c[a] * b);
        let hi = [0, 1, 2].map(|a| ((c[a] + 1) * b).min(dims[a]));
        (lo, hi)
    }

    /// Calls `f(flat index in the grid, density)` for every voxel of brick `i` in x-fastest
    /// order (bricks the source knows to be all zero: none); `buf` is scratch space.
    fn brick_values(
        &self,
        i: usize,
        brick_dims: [u32; 3],
        buf: &mut Vec<f32>,
        mut f: impl FnMut(usize, f32),
    ) {
        let (lo, hi) = self.brick_box(i, brick_dims);
        if !self.fill(lo, hi, buf) {
            return;
        }
        let [dx, dy, _] = self.dims.map(|d| d as usize);
        let mut values = buf.iter();
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                let row = (z as usize * dy + y as usize) * dx;
                for x in lo[0]..hi[0] {
                    f(row + x as usize, *values.next().expect("a full box"));
                }
            }
        }
    }

    /// Checks everything, quantizes and computes the brick statistics.
    pub fn build(&self) -> Result<Grid, BuildError> {
        let scale = self.density_scale;
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(BuildError::Scale(scale));
        }
        if !(2..=256).contains(&self.brick_size) {
            return Err(BuildError::BrickSize(self.brick_size));
        }
        if let Supervoxels::Adaptive {
            cell,
            ratio,
            occupancy,
        } = self.supervoxels
        {
            let brick = self.brick_size;
            if cell == 0 || !brick.is_multiple_of(cell) || brick / cell < 2 {
                return Err(BuildError::CellSize { cell, brick });
            }
            if !(ratio > 0.0 && ratio <= 1.0) {
                return Err(BuildError::SplitRatio(ratio));
            }
            if !(occupancy > 0.0 && occupancy <= 1.0) {
                return Err(BuildError::SplitOccupancy(occupancy));
            }
        }
        let dims = self.dims;
        let count = dims
            .iter()
            .try_fold(1usize, |n, &d| n.checked_mul(d as usize))
            .filter(|&n| n > 0 && dims.iter().all(|&d| d <= MAX_AXIS))
            .ok_or(BuildError::Dims(dims))?;
        // Only a dense array is indexed by flat voxel; boxes are read brick by brick.
        if matches!(self.source, Source::Dense(_)) && count >= u32::MAX as usize {
            return Err(BuildError::Dims(dims));
        }
        if let Source::Dense(v) = &self.source {
            if v.len() != count {
                return Err(BuildError::Length {
                    len: v.len(),
                    dims,
                    expected: count,
                });
            }
        }
        let b = self.brick_size;
        let brick_dims = [0, 1, 2].map(|a| dims[a].div_ceil(b));
        let n_bricks = brick_dims.iter().map(|&d| d as usize).product::<usize>();
        // The kernels index the brick table with a u32 (EMPTY_BRICK and the cells above it).
        if n_bricks >= u32::MAX as usize {
            return Err(BuildError::Table(dims));
        }
        let (max_i, max, min_positive) = self.extremes(brick_dims)?;
        self.check_optical_depth(max_i, max)?;
        let k = Self::f16_exponent(max, min_positive);
        let stored_scale = (scale as f64 * pow2(-k)) as f32;
        // Pages hold at least one brick's run (B^3 / 2 words; 2^23 for B = 256).
        let run_words = (b * b * b).div_ceil(2);
        let page_log2 = self
            .page_log2
            .max(run_words.next_power_of_two().trailing_zeros());
        let (slots, voxels, underflow) = self.pool(brick_dims, k, stored_scale, page_log2)?;
        let desc = GridDesc {
            dims: [dims[0], dims[1], dims[2], 0],
            brick_dims: [brick_dims[0], brick_dims[1], brick_dims[2], 0],
            brick_size: b,
            lookup: self.lookup as u32,
            density_scale: stored_scale,
            page_log2: ONE_PAGE_LOG2,
            brick_steps: 0,
            voxel_steps: 0,
            cells_per_brick: 0,
            cell_steps: 0,
            brick_log2: brick_log2_of(b),
            brick_stepping: 0,
        };
        let slots_only: Vec<Brick> = slots
            .iter()
            .map(|&slot| Brick {
                slot,
                ..Brick::default()
            })
            .collect();
        let view = VolumeView::new(desc, Pages::one(&voxels), &slots_only);
        use rayon::prelude::*;
        // A brick whose widened window lies in empty bricks only has all-zero statistics.
        let empty_around = |c: [u32; 3]| {
            let lo = c.map(|v| v.saturating_sub(1));
            let hi: [u32; 3] = std::array::from_fn(|a| (c[a] + 2).min(brick_dims[a]));
            (lo[2]..hi[2]).all(|z| {
                (lo[1]..hi[1]).all(|y| {
                    (lo[0]..hi[0]).all(|x| {
                        let j = x as usize
                            + brick_dims[0] as usize
                                * (y as usize + brick_dims[1] as usize * z as usize);
                        slots[j] == EMPTY_BRICK
                    })
                })
            })
        };
        let bricks: Vec<Brick> = (0..n_bricks)
            .into_par_iter()
            .map(|i| {
                let c = unflatten(i, brick_dims);
                let stats = if empty_around(c) {
                    Brick::ZERO
                } else {
                    brick_stats(&view, c, b)
                };
                Brick {
                    slot: slots[i],
                    ..stats
                }
            })
            .collect();
        let (mut bricks, cells, s) = match self.supervoxels {
            Supervoxels::Fixed => (bricks, Vec::new(), 0),
            Supervoxels::Adaptive {
                cell,
                ratio,
                occupancy,
            } => {
                let split: Vec<Option<Vec<Brick>>> = bricks
                    .par_iter()
                    .enumerate()
                    .map(|(i, brick)| {
                        let c = unflatten(i, brick_dims);
                        crate::adaptive::split(&view, brick, c, b, cell, (ratio, occupancy))
                    })
                    .collect();
                let mut bricks = bricks;
                let mut cells = Vec::new();
                let per_brick = ((b / cell) as usize).pow(3);
                for (brick, split) in bricks.iter_mut().zip(split) {
                    if let Some(split) = split {
                        // Each subdivided brick: its cell box record, then its cells.
                        let first = n_bricks + cells.len() / per_brick * (per_brick + 1);
                        brick.cells = u32::try_from(first)
                            .ok()
                            .filter(|&f| f as usize + per_brick < u32::MAX as usize)
                            .ok_or(BuildError::Table(dims))?;
                        cells.extend(split);
                    }
                }
                (bricks, cells, b / cell)
            }
        };
        if self.format == SupervoxelFormat::Bc4 {
            bricks = crate::bc4::compress_bricks(&bricks, brick_dims);
        }
        let (mut bricks, levels) = mark_skippable(bricks, brick_dims);
        let [brick_steps, voxel_steps] = traversal_steps(&levels, brick_dims, dims, b);
        let subdivided = bricks.iter().filter(|b| b.cells != 0).count() as u64;
        if !cells.is_empty() {
            let n = (s * s) as usize;
            let dims = [s, s, (cells.len() / n) as u32];
            let cells = match self.format {
                SupervoxelFormat::F32 => cells,
                SupervoxelFormat::Bc4 => crate::bc4::compress_bricks(&cells, dims),
            };
            for split in cells.chunks(n * s as usize) {
                let (lo, hi) = crate::adaptive::cell_box(split, s);
                bricks.push(Brick::cell_box_record(lo, hi));
                bricks.extend_from_slice(split);
            }
        }
        let s = if subdivided == 0 { 0 } else { s };
        let cell_steps = cell_steps(subdivided, brick_steps, s);
        Ok(Grid {
            desc: GridDesc {
                brick_steps,
                voxel_steps,
                cells_per_brick: s,
                cell_steps,
                ..desc
            },
            voxels,
            bricks,
            underflow,
            page_log2,
        })
    }

    /// One pass over the densities, brick by brick in parallel: the densest voxel (flat index,
    /// density; the first in x-fastest order among equals) and the smallest positive density
    /// (infinity if none); refuses NaN, infinite and negative densities, naming the first.
    fn extremes(&self, brick_dims: [u32; 3]) -> Result<(usize, f32, f32), BuildError> {
        use rayon::prelude::*;
        /// (first bad voxel, densest voxel, smallest positive density) of some bricks.
        type Scan = (Option<(usize, f32)>, (usize, f32), f32);
        let none: Scan = (None, (usize::MAX, 0.0), f32::INFINITY);
        let merge = |a: Scan, b: Scan| -> Scan {
            let bad = match (a.0, b.0) {
                (Some(x), Some(y)) => Some(if x.0 <= y.0 { x } else { y }),
                (x, y) => x.or(y),
            };
            let best = if b.1 .1 > a.1 .1 || (b.1 .1 == a.1 .1 && b.1 .0 < a.1 .0) {
                b.1
            } else {
                a.1
            };
            (bad, best, a.2.min(b.2))
        };
        let n_bricks = brick_dims.iter().map(|&d| d as usize).product::<usize>();
        let (bad, best, min_positive) = (0..n_bricks)
            .into_par_iter()
            .map_init(Vec::new, |buf, i| {
                let mut scan = none;
                self.brick_values(i, brick_dims, buf, |at, v| {
                    if !(v.is_finite() && v >= 0.0) {
                        if scan.0.is_none() {
                            scan.0 = Some((at, v));
                        }
                    } else {
                        if v > scan.1 .1 {
                            scan.1 = (at, v);
                        }
                        if v > 0.0 && v < scan.2 {
                            scan.2 = v;
                        }
                    }
                });
                scan
            })
            .reduce(|| none, merge);
        if let Some((at, density)) = bad {
            return Err(BuildError::Density {
                voxel: unflatten(at, self.dims),
                density,
            });
        }
        let max_i = if best.1 > 0.0 { best.0 } else { 0 };
        Ok((max_i, best.1, min_positive))
    }

    /// Refuses a scale whose largest extinction exceeds f32 or, times the longest chord through
    /// the grid ([`GridBuilder::max_chord`]), exceeds [`MAX_OPTICAL_DEPTH`].
    fn check_optical_depth(&self, max_i: usize, max: f32) -> Result<(), BuildError> {
        let mu = max as f64 * self.density_scale as f64;
        if mu > f32::MAX as f64 {
            return Err(BuildError::Extinction {
                voxel: unflatten(max_i, self.dims),
                density: max,
                scale: self.density_scale,
            });
        }
        let chord = self
            .chord
            .unwrap_or_else(|| self.dims.iter().map(|&d| d as f64).sum());
        let depth = mu * chord;
        if depth > MAX_OPTICAL_DEPTH {
            return Err(BuildError::OpticalDepth {
                voxel: unflatten(max_i, self.dims),
                density: max,
                scale: self.density_scale,
                depth,
            });
        }
        Ok(())
    }

    /// The exponent k of the f16 voxels' power-of-two prescale: 0 when every density fits f16
    /// as it is (the largest at most 65504, the smallest positive not rounding to 0: rounding is
    /// monotonic, so the others fit too); otherwise the largest k for which the largest density
    /// x 2^k stays within 65504 (fewest values lost to underflow).
    fn f16_exponent(max: f32, min_positive: f32) -> i32 {
        if !(max > 0.0) {
            return 0;
        }
        let fits = |v: f32| f16::from_f32(v).is_finite();
        if fits(max) && f16::from_f32(min_positive).to_f32() != 0.0 {
            return 0;
        }
        let mut k = (f16::MAX.to_f32() as f64 / max as f64).log2().floor() as i32;
        while !fits((max as f64 * pow2(k)) as f32) {
            k -= 1;
        }
        k
    }

    /// Density v x 2^k as f16 bits.
    #[inline]
    fn quantized(v: f32, prescale: f64) -> u16 {
        f16::from_f32((v as f64 * prescale) as f32).to_bits()
    }

    /// The brick table's slots, the pool and the underflow count, without a dense copy of the
    /// grid: a first pass over each brick (in parallel) quantizes its voxels (density x 2^k as
    /// f16), finds whether any is nonzero and counts the nonzero densities whose extinction
    /// (`stored_scale` x f16) is 0; the occupied bricks get consecutive runs of the pool (slot =
    /// the pool index of the brick's first voxel; voxels x fastest over the brick's extent
    /// clipped to the grid, padded to a whole word and moved to the next page of 2^`page_log2`
    /// words rather than cross into it), which a second pass writes as packed words; all-zero
    /// bricks get [`EMPTY_BRICK`] and store nothing.
    fn pool(
        &self,
        brick_dims: [u32; 3],
        k: i32,
        stored_scale: f32,
        page_log2: u32,
    ) -> Result<(Vec<u32>, Vec<u32>, Underflow), BuildError> {
        use rayon::prelude::*;
        let dims = self.dims;
        let prescale = pow2(k);
        let n_bricks = brick_dims.iter().map(|&d| d as usize).product::<usize>();
        // Pass 1: occupancy, voxel count and underflow of each brick (the first underflow as
        // the smallest flat index, so the report does not depend on the thread count).
        let scan: Vec<(bool, usize, u64, u64, Option<usize>)> = (0..n_bricks)
            .into_par_iter()
            .map_init(Vec::new, |buf, i| {
                let (lo, hi) = self.brick_box(i, brick_dims);
                let len = (0..3).map(|a| (hi[a] - lo[a]) as usize).product();
                let (mut any, mut nonzero, mut lost) = (false, 0u64, 0u64);
                let mut first = None;
                self.brick_values(i, brick_dims, buf, |at, v| {
                    let h = Self::quantized(v, prescale);
                    any |= h != 0;
                    // A scale of 0 empties the volume on purpose: nothing to report.
                    if v > 0.0 && self.density_scale > 0.0 {
                        nonzero += 1;
                        if stored_scale * f16::from_bits(h).to_f32() == 0.0 {
                            lost += 1;
                            first = Some(first.map_or(at, |f: usize| f.min(at)));
                        }
                    }
                });
                (any, len, nonzero, lost, first)
            })
            .collect();
        let mut underflow = Underflow::default();
        let mut first: Option<usize> = None;
        let mut slots = vec![EMPTY_BRICK; n_bricks];
        let mut runs = Vec::new();
        let mut total = 0usize;
        for (i, &(any, len, nonzero, lost, f)) in scan.iter().enumerate() {
            underflow.nonzero += nonzero;
            underflow.count += lost;
            if let Some(f) = f {
                first = Some(first.map_or(f, |g| g.min(f)));
            }
            if any {
                // Runs start on whole words (at most one padding voxel per brick) and never
                // cross a page boundary (a run that would starts the next page).
                let (start, words) = (total / 2, len.div_ceil(2));
                let page = |w: usize| w >> page_log2;
                if page(start) != page(start + words - 1) {
                    total = (page(start) + 1) << (page_log2 + 1);
                }
                if total + len >= FIRST_EMPTY_SLOT as usize {
                    return Err(BuildError::Pool(dims));
                }
                slots[i] = total as u32;
                runs.push((i, len));
                total += len + len % 2;
            }
        }
        underflow.first = first.map(|f| {
            let v = unflatten(f, dims);
            let mut one = Vec::new();
            let density = if self.fill(v, v.map(|c| c + 1), &mut one) {
                one[0]
            } else {
                0.0
            };
            (v, density)
        });
        drop(scan);
        // Pass 2: each occupied brick's run of the pool, written as packed words directly.
        let mut words = vec![0u32; total / 2];
        let mut parts = Vec::with_capacity(runs.len());
        let mut rest = words.as_mut_slice();
        let mut at = 0usize;
        for &(i, len) in &runs {
            let start = slots[i] as usize / 2;
            let (_, tail) = rest.split_at_mut(start - at);
            let (run, tail) = tail.split_at_mut(len.div_ceil(2));
            parts.push((i, run));
            rest = tail;
            at = start + len.div_ceil(2);
        }
        parts
            .into_par_iter()
            .for_each_init(Vec::new, |buf, (i, dst)| {
                let mut n = 0;
                self.brick_values(i, brick_dims, buf, |_, v| {
                    let h = Self::quantized(v, prescale) as u32;
                    dst[n / 2] |= h << (16 * (n % 2));
                    n += 1;
                });
            });
        if words.is_empty() {
            // An all-zero grid: GPU buffers may not be empty.
            words.push(0);
        }
        Ok((slots, words, underflow))
    }
}

/// 2^k exactly, for |k| < 1000.
fn pow2(k: i32) -> f64 {
    2f64.powi(k)
}

/// (x, y, z) of flat index i in a grid of `dims`, x fastest.
fn unflatten(i: usize, dims: [u32; 3]) -> [u32; 3] {
    let (dx, dy) = (dims[0] as usize, dims[1] as usize);
    [
        (i % dx) as u32,
        (i / dx % dy) as u32,
        (i / (dx * dy)) as u32,
    ]
}

/// Whether a traversal may skip brick `b`: no voxels stored and all statistics 0 (adds nothing
/// to any estimator's sums, takes no sample and no free flight stops in it).
fn is_zero(b: &Brick) -> bool {
    !b.stores_voxels() && b.has_zero_statistics()
}

/// Gives every all-zero brick ([`is_zero`]) the slot [`skip_slot`]`(L)` of the largest aligned
/// cube of 2^L bricks per axis (clipped to the grid) around it that holds only all-zero bricks:
/// a pyramid of such cubes, level by level, each cube all-zero iff its (up to eight) halves are.
/// Returns the bricks and the pyramid (per level, x fastest: whether the cube is all-zero).
fn mark_skippable(mut bricks: Vec<Brick>, brick_dims: [u32; 3]) -> (Vec<Brick>, Vec<Vec<bool>>) {
    let index = |c: [u32; 3], d: [u32; 3]| {
        c[0] as usize + d[0] as usize * (c[1] as usize + d[1] as usize * c[2] as usize)
    };
    let mut level: Vec<bool> = bricks.iter().map(is_zero).collect();
    let mut dims = brick_dims;
    let mut levels = vec![level.clone()];
    while dims.iter().any(|&d| d > 1) && (levels.len() as u32) <= MAX_SKIP_LEVEL {
        let up = dims.map(|d| d.div_ceil(2));
        let mut next = vec![false; up.iter().map(|&d| d as usize).product()];
        for z in 0..up[2] {
            for y in 0..up[1] {
                for x in 0..up[0] {
                    let mut all = true;
                    for k in 0..8u32 {
                        let c = [2 * x + (k & 1), 2 * y + (k >> 1 & 1), 2 * z + (k >> 2)];
                        if (0..3).all(|a| c[a] < dims[a]) {
                            all &= level[index(c, dims)];
                        }
                    }
                    next[index([x, y, z], up)] = all;
                }
            }
        }
        levels.push(next.clone());
        level = next;
        dims = up;
    }
    for (i, b) in bricks.iter_mut().enumerate() {
        if !levels[0][i] {
            continue;
        }
        let c = unflatten(i, brick_dims);
        let mut l = 0;
        let mut d = brick_dims;
        while l + 1 < levels.len() {
            d = d.map(|v| v.div_ceil(2));
            let up = c.map(|v| v >> (l + 1));
            if !levels[l + 1][index(up, d)] {
                break;
            }
            l += 1;
        }
        b.slot = skip_slot(l as u32);
    }
    (bricks, levels)
}

/// Slack for skips the traversal cannot verify in closed form and steps instead (a few in
/// 10^5 skips, one or two cells each); a traversal past its budget is counted as capped.
pub const FALLBACK_STEPS: u64 = 32;

/// The iteration budgets of one brick traversal and one skipping voxel traversal
/// ([`GridDesc::brick_steps`], [`GridDesc::voxel_steps`]): the smaller of the stepping bound
/// (cells per axis summed, + 3) and a bound from the occupied cubes of the pyramid `levels`.
///
/// A traversal steps through each brick that is not all-zero (a voxel traversal through at most
/// 3B of its voxels) and skips each maximal all-zero cube in one iteration. A maximal cube of
/// level L below the top lies in a cube of level L + 1 holding a brick that is not all-zero, and
/// a line meets at most 4 of a cube's 8 halves (it crosses each of the 3 mid-planes once), so
/// with M_l the cubes of level l that are not all-zero and S_l the most cells of level l a ray
/// meets (cells per axis summed): skips <= 1 + sum over l >= 1 of 4 min(M_l, S_l).
fn traversal_steps(levels: &[Vec<bool>], brick_dims: [u32; 3], dims: [u32; 3], b: u32) -> [u32; 2] {
    let mut cells = brick_dims;
    let mut occupied = [0u64; 2];
    let mut skips = 1u64;
    for (l, level) in levels.iter().enumerate() {
        let m = level.iter().filter(|&&zero| !zero).count() as u64;
        let s = cells.iter().map(|&c| c as u64).sum::<u64>();
        if l == 0 {
            occupied = [m.min(s), 3 * b as u64 * m.min(s)];
        } else {
            skips += 4 * m.min(s);
        }
        cells = cells.map(|c| c.div_ceil(2));
    }
    let bound = |occ: u64, d: [u32; 3]| {
        let b = (occ + skips + FALLBACK_STEPS).min(u32::MAX as u64) as u32;
        shared::volume::grid::traversal_budget(b, d)
    };
    [bound(occupied[0], brick_dims), bound(occupied[1], dims)]
}

/// The budget of cell steps of one super-voxel traversal ([`GridDesc::cell_steps`]): a ray
/// crosses at most 3s - 2 cells of a brick of s^3 cells (3s + 3, the stepping bound, allowing
/// for a start clamped into the brick), in at most min(subdivided bricks, brick iterations)
/// subdivided bricks.
fn cell_steps(subdivided: u64, brick_steps: u32, s: u32) -> u32 {
    if subdivided == 0 {
        return 0;
    }
    (subdivided.min(brick_steps as u64) * (3 * s as u64 + 3)).min(u32::MAX as u64) as u32
}

/// Statistics of brick b over its widened, clamped window ([-1, B+1) per axis): exact min,
/// max, mean and P of Eq. 5 (RMS of mu - mu_min) rounded up, P >= 0.01 mu_min.
fn brick_stats(view: &VolumeView, b: [u32; 3], size: u32) -> Brick {
    box_stats(view, b.map(|c| c * size), b.map(|c| (c + 1) * size))
}
