//! Views of the high-resolution volume and of its super-voxel ("brick") grid: a brick table
//! over the whole grid (statistics, and where each brick's voxels are) and a pool holding the
//! f16 voxels of the non-empty bricks only, so memory grows with the occupied bricks, not with
//! the bounding box.

use crate::geometry::V3;
use crate::half::f16_to_f32_lanes;
use crate::lanes::{Lanes, One};
use crate::spec::or_keep;
use crate::volume::pages::Pages;
use crate::volume::texels::{NoTexels, Texels};
use bytemuck::{Pod, Zeroable};

/// How the high-resolution volume is read at a point.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lookup {
    /// The voxel containing the point.
    Nearest = 0,
    /// Stochastic texture filtering: jitter by (PCG3D - 0.5) voxels, then nearest (Sec. 4.3).
    Stochastic = 1,
    /// Deterministic trilinear interpolation of the eight nearest voxel centres (the filter the
    /// paper replaces by stochastic filtering; eight voxel reads per lookup).
    Trilinear = 2,
}

impl Lookup {
    /// Every lookup mode.
    pub const ALL: [Lookup; 3] = [Lookup::Nearest, Lookup::Stochastic, Lookup::Trilinear];

    /// From the `u32` stored in [`GridDesc`] (unknown values read as nearest).
    #[inline]
    pub fn from_u32(v: u32) -> Self {
        match v {
            1 => Lookup::Stochastic,
            2 => Lookup::Trilinear,
            _ => Lookup::Nearest,
        }
    }
}

/// The two voxels along one axis that a trilinear lookup at coordinate x (in voxel units, centres
/// at i + 1/2, x already shifted by -1/2) blends, and their weights (f + 1 - x, x - f): clamped
/// to the edge voxel (weights (1, 0)) outside [0, n - 1]; NaN reads voxel 0. Both weights are
/// computed from x (written as 1 - w1, shader compilers fuse the blend into a lerp that rounds
/// differently from the CPU).
#[inline]
fn trilinear_axis(x: f32, n: u32) -> (u32, u32, f32, f32) {
    let f = crate::math::floor(x);
    if !(f >= 0.0) {
        return (0, 0, 1.0, 0.0);
    }
    if f >= (n - 1) as f32 {
        return (n - 1, n - 1, 1.0, 0.0);
    }
    let i = f as u32;
    (i, i + 1, (f + 1.0) - x, x - f)
}

/// Shape of the volume and its brick grid, as the kernels see it. All in voxel index space:
/// voxel (i, j, k) covers [i, i+1) x [j, j+1) x [k, k+1).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GridDesc {
    /// Voxel counts (x, y, z); w unused.
    pub dims: [u32; 4],
    /// Brick counts (x, y, z); w unused.
    pub brick_dims: [u32; 4],
    /// Voxels per brick along each axis (B, default 16).
    pub brick_size: u32,
    /// [`Lookup`] as u32.
    pub lookup: u32,
    /// Extinction per unit of stored density ("density scale"); already applied to bricks.
    pub density_scale: f32,
    /// log2 of the words per page of the pool as this view binds it (see [`Pages`]).
    pub page_log2: u32,
    /// Most iterations one traversal of the brick grid may take, skips included: the budget of
    /// [`crate::volume::dda::GridDda::bricks`] (0: the stepping bound, the sum of the brick
    /// counts + 3). The builder sets the smaller of that and a bound from the occupied bricks.
    pub brick_steps: u32,
    /// Most iterations one skipping traversal of the voxels may take (regular tracking): the
    /// budget of [`crate::volume::dda::GridDda::voxels`] (0: the sum of the voxel counts + 3).
    pub voxel_steps: u32,
    /// Adaptive super-voxels: cells per axis s of a subdivided brick (each cell B / s voxels per
    /// axis; B a multiple of s), whose statistics follow the grid's bricks in the table
    /// ([`Brick::cells`]); 0 or 1: every brick is one super-voxel (the paper's fixed grid).
    pub cells_per_brick: u32,
    /// Most cells one traversal may visit inside subdivided bricks, the budget of the cell
    /// steps of [`crate::volume::supervoxels::SuperVoxelDda`] (0: one stepping bound, 3 s + 3,
    /// per brick of the brick budget).
    pub cell_steps: u32,
    /// log2 of [`GridDesc::brick_size`] when it is a power of two, else [`BRICK_DIVIDES`]: a
    /// voxel's brick is then a shift, not a division ([`GridDesc::brick_of`]).
    pub brick_log2: u32,
    /// 1: the brick traversal steps through all-zero bricks instead of skipping their cubes
    /// ([`crate::volume::dda::GridDda::step_brick`]); 0 (the builder's value): it skips. The same
    /// segment sums either way (an all-zero segment adds 0 and takes no sample); stepping is
    /// the faster form on SIMD devices that run every branch arm under masks, and exact only
    /// where the budgets are the stepping bounds ([`GridDesc::can_step`]).
    pub brick_stepping: u32,
}

/// [`GridDesc::brick_log2`] of a brick size that is not a power of two (bricks by division).
pub const BRICK_DIVIDES: u32 = 32;

/// [`GridDesc::brick_log2`] of brick size `b`.
#[inline]
pub const fn brick_log2_of(b: u32) -> u32 {
    if b.is_power_of_two() {
        b.trailing_zeros()
    } else {
        BRICK_DIVIDES
    }
}

/// Iteration budget of a traversal of a grid of `cells` cells: `steps`, unless it is 0 or above
/// the stepping bound (cells per axis summed, + 3), which it then is.
#[inline]
pub fn traversal_budget(steps: u32, cells: [u32; 3]) -> u32 {
    let stepping = cells[0] + cells[1] + cells[2] + 3;
    if steps == 0 || steps > stepping {
        stepping
    } else {
        steps
    }
}

impl GridDesc {
    /// The brick coordinate of voxel coordinate `i`: i / B, as a shift where B is a power of
    /// two (a vector integer division is a scalar loop on SIMD devices).
    #[inline]
    pub fn brick_of(&self, i: u32) -> u32 {
        if self.brick_log2 < BRICK_DIVIDES {
            i >> self.brick_log2
        } else {
            i / self.brick_size
        }
    }

    /// `self` with the fields a pipeline fixes by specialization constants replaced: the
    /// lookup, the cells per brick, [`GridDesc::brick_log2`] and [`GridDesc::brick_stepping`]
    /// ([`crate::spec::UNSPECIALIZED`] keeps a field). The host passes the values of the grid
    /// it binds (stepping only where [`GridDesc::can_step`]), so the segment sums do not
    /// change; the driver folds the values and compiles only this grid's layout and lookup.
    #[inline]
    pub fn specialized(
        &self,
        lookup: u32,
        cells_per_brick: u32,
        brick_log2: u32,
        brick_stepping: u32,
    ) -> GridDesc {
        GridDesc {
            lookup: or_keep(lookup, self.lookup),
            cells_per_brick: or_keep(cells_per_brick, self.cells_per_brick),
            brick_log2: or_keep(brick_log2, self.brick_log2),
            brick_stepping: or_keep(brick_stepping, self.brick_stepping),
            ..*self
        }
    }

    /// Whether the brick and voxel budgets are the stepping bounds: then traversals that step
    /// through every all-zero brick ([`GridDesc::brick_stepping`]) and traversals that skip
    /// their cubes (never more iterations than stepping) both reach the end of every ray
    /// uncapped, with the same segment sums and reads. Where the builder's bound from the
    /// occupied bricks is smaller (long, mostly empty grids), only skipping fits it.
    #[inline]
    pub fn can_step(&self) -> bool {
        let (b, d) = (self.brick_dims, self.dims);
        (self.brick_budget() == traversal_budget(0, [b[0], b[1], b[2]]))
            & (self.voxel_budget() == traversal_budget(0, [d[0], d[1], d[2]]))
    }

    /// Iteration budget of one traversal of the bricks ([`GridDesc::brick_steps`]).
    #[inline]
    pub fn brick_budget(&self) -> u32 {
        let d = self.brick_dims;
        traversal_budget(self.brick_steps, [d[0], d[1], d[2]])
    }

    /// Cells per axis of a subdivided brick, or 1 (no brick is subdivided).
    #[inline]
    pub fn cells_per_brick(&self) -> u32 {
        if self.cells_per_brick > 1 {
            self.cells_per_brick
        } else {
            1
        }
    }

    /// Iteration budget of the cell steps of one traversal of the super-voxels
    /// ([`GridDesc::cell_steps`]; 0 without subdivided bricks).
    #[inline]
    pub fn cell_budget(&self) -> u32 {
        let s = self.cells_per_brick();
        if s == 1 {
            0
        } else if self.cell_steps != 0 {
            self.cell_steps
        } else {
            // Without overflow (rust-gpu has no saturating arithmetic): at most 65535 x 771.
            let b = self.brick_budget();
            let b = if b > 65535 { 65535 } else { b };
            let s = if s > 256 { 256 } else { s };
            b * (3 * s + 3)
        }
    }

    /// Iterations of one whole super-voxel traversal: bricks and cells
    /// ([`GridDesc::brick_budget`] + [`GridDesc::cell_budget`], at most u32::MAX).
    #[inline]
    pub fn supervoxel_budget(&self) -> u32 {
        let (a, b) = (self.brick_budget(), self.cell_budget());
        if a > u32::MAX - b {
            u32::MAX
        } else {
            a + b
        }
    }

    /// Iteration budget of one skipping traversal of the voxels ([`GridDesc::voxel_steps`]).
    #[inline]
    pub fn voxel_budget(&self) -> u32 {
        let d = self.dims;
        traversal_budget(self.voxel_steps, [d[0], d[1], d[2]])
    }
}

/// Statistics of one brick, already multiplied by the density scale and rounded conservatively.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Brick {
    /// Minimum extinction mu_min (control variate, Sec. 4.2); rounded down.
    pub mu_min: f32,
    /// Maximum extinction (majorant for delta and ratio tracking); rounded up.
    pub mu_max: f32,
    /// Mean extinction (Kettunen et al.'s importance); rounded up.
    pub mean: f32,
    /// Variance-aware importance P (Eq. 5), >= 0.01 mu_min; rounded up.
    pub p: f32,
    /// Index in the pool of the brick's first voxel (its voxels follow x fastest, over the
    /// brick's extent clipped to the grid), or, at [`FIRST_EMPTY_SLOT`] and above, a brick
    /// whose voxels are all 0 (none stored): [`EMPTY_BRICK`], or [`skip_slot`]`(L)` when its
    /// statistics are 0 too and so are those of every brick of the aligned cube of 2^L bricks
    /// per axis around it (clipped to the grid), which a traversal may then skip.
    /// [`EMPTY_BRICK`] in a cell record (the brick's slot locates the voxels).
    pub slot: u32,
    /// Adaptive super-voxels: index in the table of this brick's cell box record
    /// ([`Brick::cell_box`]), followed by its s^3 cell records (s =
    /// [`GridDesc::cells_per_brick`], x fastest, statistics as a brick's over the cell), which a
    /// traversal visits instead of the brick; 0: the brick is not subdivided.
    pub cells: u32,
}

/// 32-bit words of a [`Brick`] record, in field order.
pub const BRICK_WORDS: u32 = 6;
const _: () = assert!(core::mem::size_of::<Brick>() == 4 * BRICK_WORDS as usize);

/// [`Brick::slot`] of a brick whose voxels are all 0 but whose statistics are not (nonzero
/// voxels within one voxel of it, which filtered lookups reach).
pub const EMPTY_BRICK: u32 = u32::MAX;
/// Largest skip level: cubes of up to 2^31 bricks per axis.
pub const MAX_SKIP_LEVEL: u32 = 31;
/// Slots from here up store no voxels ([`EMPTY_BRICK`] and the [`skip_slot`]s); pool indices
/// stay below.
pub const FIRST_EMPTY_SLOT: u32 = EMPTY_BRICK - 1 - MAX_SKIP_LEVEL;
/// [`Brick::skip_level`] of a brick that may not be skipped.
pub const NO_SKIP: u32 = u32::MAX;

/// The slot of an all-zero brick in an all-zero aligned cube of 2^`level` bricks per axis.
#[inline]
pub const fn skip_slot(level: u32) -> u32 {
    EMPTY_BRICK - 1 - level
}

/// Bits per axis of a packed cell coordinate in a cell box record ([`Brick::cell_box`]).
const CELL_BITS: u32 = 10;

/// Cell coordinates (each at most 2^10 - 1) packed x lowest, 10 bits per axis.
#[inline]
const fn pack_cell(c: [u32; 3]) -> u32 {
    c[0] | c[1] << CELL_BITS | c[2] << (2 * CELL_BITS)
}

/// The coordinates of [`pack_cell`].
#[inline]
const fn unpack_cell(v: u32) -> [u32; 3] {
    let m = (1 << CELL_BITS) - 1;
    [v & m, (v >> CELL_BITS) & m, v >> (2 * CELL_BITS)]
}

impl Brick {
    /// All statistics 0 and no voxels: an all-zero brick's record before skip marking, and a
    /// span of zero cells around a subdivided brick's cell box.
    pub const ZERO: Brick = Brick {
        mu_min: 0.0,
        mu_max: 0.0,
        mean: 0.0,
        p: 0.0,
        slot: EMPTY_BRICK,
        cells: 0,
    };

    /// The record that precedes a subdivided brick's cells ([`Brick::cells`]): the box
    /// [lo, hi) of its cells whose statistics are not all 0 (local cell coordinates, each at
    /// most s <= 1023; lo = hi = 0 when there is none), in `slot` and `cells`; statistics 0.
    /// Every cell outside the box has statistics 0 (no importance, control variate or
    /// majorant), so a traversal may pass over them without reading them.
    #[inline]
    pub const fn cell_box_record(lo: [u32; 3], hi: [u32; 3]) -> Brick {
        Brick {
            mu_min: 0.0,
            mu_max: 0.0,
            mean: 0.0,
            p: 0.0,
            slot: pack_cell(lo),
            cells: pack_cell(hi),
        }
    }

    /// The box [lo, hi) of a cell box record ([`Brick::cell_box_record`]).
    #[inline]
    pub const fn cell_box(&self) -> ([u32; 3], [u32; 3]) {
        (unpack_cell(self.slot), unpack_cell(self.cells))
    }

    /// Whether every statistic is 0 (nothing to sample, no control variate, no majorant).
    #[inline]
    pub fn has_zero_statistics(&self) -> bool {
        self.mu_min == 0.0 && self.mu_max == 0.0 && self.mean == 0.0 && self.p == 0.0
    }

    /// Whether the pool holds this brick's voxels.
    #[inline]
    pub fn stores_voxels(&self) -> bool {
        self.slot < FIRST_EMPTY_SLOT
    }

    /// Level L of the all-zero aligned cube of 2^L bricks per axis this brick lies in (see
    /// [`Brick::slot`]), or [`NO_SKIP`].
    #[inline]
    pub fn skip_level(&self) -> u32 {
        if self.slot >= FIRST_EMPTY_SLOT && self.slot != EMPTY_BRICK {
            EMPTY_BRICK - 1 - self.slot
        } else {
            NO_SKIP
        }
    }
}

/// The high-resolution volume and its bricks, borrowed from kernel buffers or host vectors.
#[derive(Clone, Copy)]
pub struct VolumeView<'a, T: Texels = NoTexels> {
    /// The grid's description, by value (kernels copy it out of its buffer once).
    pub desc: GridDesc,
    /// The pool: f16 voxels of the non-empty bricks, two per u32; each brick's voxels x fastest
    /// over its extent clipped to the grid, bricks in order, in pages of 2^`desc.page_log2` words.
    pub voxels: Pages<'a>,
    /// Bricks, x fastest, then the cell records of the subdivided bricks ([`Brick::cells`]).
    pub bricks: &'a [Brick],
    /// The same two tables as texel buffers, read instead of `voxels` (page 0 only: a pool in
    /// one page) and `bricks` where [`Texels::bound`].
    pub texels: T,
}

/// `clamp(floor(v), 0, n - 1)` lane by lane without a float floor: truncation equals floor for
/// v >= 1, and everything below 1 (NaN included) maps to 0.
#[inline(always)]
pub fn floor_index_lanes<L: Lanes>(v: L::F, n: u32) -> L::U {
    let below = !L::f_ge(v, L::f(1.0));
    let above = L::f_ge(v, L::f(n as f32));
    let inside = L::f_to_u(L::f_sel(below | above, L::f(0.0), v));
    L::u_sel(below, L::u(0), L::u_sel(above, L::u(n - 1), inside))
}

/// What the nearest lookup reads of a volume's two tables, lane by lane: a view's records and
/// pool ([`VolumeView`], one lane), or the CPU's wide form of them
/// ([`crate::volume::wide::WideVolume`]).
pub trait Tables<L: Lanes> {
    /// The `slot` word of the record of brick `b` in lanes `m`.
    fn slot(&self, m: L::M, b: [L::U; 3]) -> L::U;
    /// The f16 bits at pool index `index` in lanes `m` (0 elsewhere).
    fn pool_half(&self, m: L::M, index: L::U) -> L::U;
}

/// [`VolumeView::pool_index`] of voxels `v` in lanes `m`, lane by lane (its one body): whether
/// the voxel's brick stores its voxels (false outside `m`), and the index of its f16 value in the
/// pool: the brick's slot plus the voxel's index within the brick's extent (clipped to the grid),
/// x fastest.
#[inline(always)]
pub fn pool_index_lanes<L: Lanes>(
    desc: &GridDesc,
    tables: &impl Tables<L>,
    m: L::M,
    v: [L::U; 3],
) -> (L::M, L::U) {
    // Constant indices only (no bounds checks in the kernels).
    let b = if desc.brick_log2 < BRICK_DIVIDES {
        let sh = L::u(desc.brick_log2);
        [L::u_shr(v[0], sh), L::u_shr(v[1], sh), L::u_shr(v[2], sh)]
    } else {
        let size = L::u(desc.brick_size);
        [
            L::u_div(v[0], size),
            L::u_div(v[1], size),
            L::u_div(v[2], size),
        ]
    };
    let slot = tables.slot(m, b);
    let stores = m & L::u_lt(slot, L::u(FIRST_EMPTY_SLOT));
    let size = L::u(desc.brick_size);
    let origin = [
        L::u_mul(b[0], size),
        L::u_mul(b[1], size),
        L::u_mul(b[2], size),
    ];
    // Voxels of the brick along x and y inside the grid: B, or fewer in the last brick.
    let rest_x = L::u_sub(L::u(desc.dims[0]), origin[0]);
    let rest_y = L::u_sub(L::u(desc.dims[1]), origin[1]);
    let w = L::u_sel(L::u_lt(rest_x, size), rest_x, size);
    let h = L::u_sel(L::u_lt(rest_y, size), rest_y, size);
    let local = [
        L::u_sub(v[0], origin[0]),
        L::u_sub(v[1], origin[1]),
        L::u_sub(v[2], origin[2]),
    ];
    let inner = L::u_add(local[1], L::u_mul(h, local[2]));
    let index = L::u_add(slot, L::u_add(local[0], L::u_mul(w, inner)));
    (stores, index)
}

/// [`VolumeView::voxel`] of voxels `v` in lanes `m` (0 elsewhere), lane by lane (its one body):
/// 0 in a brick without stored voxels, else its f16 value in the pool times the density scale.
#[inline(always)]
pub fn voxel_lanes<L: Lanes>(
    desc: &GridDesc,
    tables: &impl Tables<L>,
    m: L::M,
    v: [L::U; 3],
) -> L::F {
    let (stores, index) = pool_index_lanes::<L>(desc, tables, m, v);
    let half = tables.pool_half(stores, index);
    let mu = L::f(desc.density_scale) * f16_to_f32_lanes::<L>(half);
    L::f_sel(stores, mu, L::f(0.0))
}

/// [`VolumeView::mu_nearest`] at points `p` in lanes `m` (0 elsewhere), lane by lane (its one
/// body).
#[inline(always)]
pub fn mu_nearest_lanes<L: Lanes>(
    desc: &GridDesc,
    tables: &impl Tables<L>,
    m: L::M,
    p: [L::F; 3],
) -> L::F {
    let d = &desc.dims;
    let v = [
        floor_index_lanes::<L>(p[0], d[0]),
        floor_index_lanes::<L>(p[1], d[1]),
        floor_index_lanes::<L>(p[2], d[2]),
    ];
    voxel_lanes::<L>(desc, tables, m, v)
}

impl<T: Texels> Tables<One> for VolumeView<'_, T> {
    #[inline]
    fn slot(&self, _m: bool, b: [u32; 3]) -> u32 {
        self.brick(b).slot
    }

    #[inline]
    fn pool_half(&self, m: bool, index: u32) -> u32 {
        if m {
            self.half(index)
        } else {
            0
        }
    }
}

impl<'a> VolumeView<'a> {
    /// A view of `voxels` and `bricks` without texel buffers.
    pub fn new(desc: GridDesc, voxels: Pages<'a>, bricks: &'a [Brick]) -> Self {
        VolumeView {
            desc,
            voxels,
            bricks,
            texels: NoTexels,
        }
    }
}

impl<T: Texels> VolumeView<'_, T> {
    /// Extinction of voxel (i, j, k), density scale applied: 0 in an empty brick, else its
    /// f16 value in the pool.
    #[inline]
    pub fn voxel(&self, i: u32, j: u32, k: u32) -> f32 {
        voxel_lanes::<One>(&self.desc, self, true, [i, j, k])
    }

    /// Index in the pool (in f16 values) of voxel (i, j, k), or None in an empty brick.
    #[inline]
    pub fn pool_index(&self, i: u32, j: u32, k: u32) -> Option<usize> {
        let (stores, index) = pool_index_lanes::<One>(&self.desc, self, true, [i, j, k]);
        if stores {
            Some(index as usize)
        } else {
            None
        }
    }

    /// The f16 bits at pool index `index`, from the texel buffer or the pages.
    #[inline]
    fn half(&self, index: u32) -> u32 {
        if self.texels.bound() {
            (self.texels.pool_word(index >> 1) >> ((index & 1) * 16)) & 0xffff
        } else {
            self.voxels.half(self.desc.page_log2, index)
        }
    }

    /// Record `i` of the brick table, from the texel buffer or the slice.
    #[inline]
    fn record(&self, i: usize) -> Brick {
        if self.texels.bound() {
            let w = |k: u32| self.texels.brick_word(BRICK_WORDS * i as u32 + k);
            Brick {
                mu_min: f32::from_bits(w(0)),
                mu_max: f32::from_bits(w(1)),
                mean: f32::from_bits(w(2)),
                p: f32::from_bits(w(3)),
                slot: w(4),
                cells: w(5),
            }
        } else {
            self.bricks[i]
        }
    }

    /// mu at index-space point p, nearest voxel, clamped to the grid's edge.
    #[inline]
    pub fn mu_nearest(&self, p: V3) -> f32 {
        mu_nearest_lanes::<One>(&self.desc, self, true, [p.x, p.y, p.z])
    }

    /// mu at index-space point p by trilinear interpolation of the voxel centres, clamped at the
    /// grid's edge: blended along x, then y, then z, each a two-term weighted sum.
    #[inline]
    pub fn mu_trilinear(&self, p: V3) -> f32 {
        let d = &self.desc.dims;
        let (x0, x1, gx, fx) = trilinear_axis(p.x - 0.5, d[0]);
        let (y0, y1, gy, fy) = trilinear_axis(p.y - 0.5, d[1]);
        let (z0, z1, gz, fz) = trilinear_axis(p.z - 0.5, d[2]);
        let row = |y: u32, z: u32| gx * self.voxel(x0, y, z) + fx * self.voxel(x1, y, z);
        let plane = |z: u32| gy * row(y0, z) + fy * row(y1, z);
        gz * plane(z0) + fz * plane(z1)
    }

    /// Brick (bx, by, bz).
    #[inline]
    pub fn brick(&self, b: [u32; 3]) -> Brick {
        let d = &self.desc.brick_dims;
        self.record(b[0] as usize + d[0] as usize * (b[1] as usize + d[1] as usize * b[2] as usize))
    }

    /// Cell `local` (coordinates within its brick, each below s) of the subdivided brick whose
    /// cell box record is at `first` ([`Brick::cells`]).
    #[inline]
    pub fn cell(&self, first: u32, local: [u32; 3]) -> Brick {
        let s = self.desc.cells_per_brick() as usize;
        let l = local[0] as usize + s * (local[1] as usize + s * local[2] as usize);
        self.record(first as usize + 1 + l)
    }

    /// The box [lo, hi) of the cells with statistics of the subdivided brick whose cell box
    /// record is at `first` ([`Brick::cell_box_record`]).
    #[inline]
    pub fn cell_box(&self, first: u32) -> ([u32; 3], [u32; 3]) {
        self.record(first as usize).cell_box()
    }
}

#[cfg(test)]
mod floor_index_tests {
    use super::floor_index_lanes;
    use crate::lanes::One;

    fn floor_index(v: f32, n: u32) -> u32 {
        floor_index_lanes::<One>(v, n)
    }

    #[test]
    fn equals_clamped_floor() {
        let reference = |v: f32, n: u32| -> u32 {
            let f = crate::math::floor(v);
            if f < 0.0 {
                0
            } else if f >= n as f32 {
                n - 1
            } else {
                f as u32
            }
        };
        let mut v = -70.0f32;
        while v < 70.0 {
            for x in [v, v.next_down(), v.next_up()] {
                for n in [1, 2, 7, 64] {
                    assert_eq!(floor_index(x, n), reference(x, n), "{x} {n}");
                }
            }
            v += 0.125;
        }
        for x in [
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e30,
            -1e30,
            f32::MIN_POSITIVE,
        ] {
            assert_eq!(floor_index(x, 9), reference(x, 9), "{x}");
        }
        assert_eq!(floor_index(f32::NAN, 9), 0);
    }
}
