//! Ray/box clipping and Amanatides-Woo traversal of the brick grid, in voxel index space, with
//! empty-space skipping: a traversal of the bricks jumps over the all-zero aligned cubes the
//! brick table marks ([`crate::volume::grid::Brick::skip_level`]) to exactly the cell and t it
//! would have reached by stepping, so the estimators see the same non-empty segments, bit for
//! bit, in fewer iterations.

use crate::geometry::{Ray, V3};
use crate::lanes::One;
use crate::math;
use crate::volume::grid::{traversal_budget, Brick, GridDesc, VolumeView, BRICK_DIVIDES, NO_SKIP};
use crate::volume::texels::Texels;
use crate::volume::walk::{cell_of, start_of, valid, Walk};

/// Clips [t_lo, t_hi] to the box [0, hi] (slab test). Returns (t_enter, t_exit); the ray misses
/// when `!(t_enter < t_exit)`. Axis-parallel rays are handled without 0 * inf. Degenerate input
/// misses: a zero, infinite or NaN direction, a non-finite origin, or a NaN or empty range
/// (`t_hi` may be +inf).
#[inline]
pub fn clip_to_box(ray: &Ray, hi: V3, t_lo: f32, t_hi: f32) -> (f32, f32) {
    if !is_usable(ray) || !(t_lo < t_hi) {
        return (1.0, 0.0);
    }
    // The three slabs in axis order, written out: a SIMD device (lavapipe) runs a loop's
    // carried values through memory.
    let (t0, t1, x) = clip_slab(ray.o.x, ray.d.x, hi.x, t_lo, t_hi);
    let (t0, t1, y) = clip_slab(ray.o.y, ray.d.y, hi.y, t0, t1);
    let (t0, t1, z) = clip_slab(ray.o.z, ray.d.z, hi.z, t0, t1);
    if x & y & z {
        (t0, t1)
    } else {
        (1.0, 0.0)
    }
}

/// One slab [0, h] of [`clip_to_box`] along an axis with origin o and direction d: [t0, t1]
/// narrowed to it, and false where the ray runs parallel to the slab outside it.
#[inline]
#[allow(clippy::manual_range_contains)] // plain compares, the same on every backend
fn clip_slab(o: f32, d: f32, h: f32, t0: f32, t1: f32) -> (f32, f32, bool) {
    if d == 0.0 {
        return (t0, t1, o >= 0.0 && o <= h);
    }
    let inv = 1.0 / d;
    let ta = (0.0 - o) * inv;
    let tb = (h - o) * inv;
    let (near, far) = if ta < tb { (ta, tb) } else { (tb, ta) };
    let t0 = if near > t0 { near } else { t0 };
    let t1 = if far < t1 { far } else { t1 };
    (t0, t1, true)
}

/// Whether a ray has a finite origin and a finite, non-zero direction (false for any NaN).
#[inline]
#[allow(clippy::manual_range_contains)] // two plain compares, the same on every backend
pub fn is_usable(ray: &Ray) -> bool {
    let finite = |v: f32| v >= -f32::MAX && v <= f32::MAX;
    let len2 = ray.d.dot(ray.d);
    finite(ray.o.x) && finite(ray.o.y) && finite(ray.o.z) && len2 > 0.0 && finite(len2)
}

/// A traversal after [`skip_cube_of`], and whether it skipped.
#[derive(Clone, Copy)]
struct Skipped {
    dda: GridDda,
    skipped: bool,
}

/// [`GridDda::skip_cube`] by value and out of line: one body in the SPIR-V module that every
/// traversal calls, instead of a copy inlined into each estimator of each kernel (free of
/// pointer arguments and of panics, so rust-gpu keeps it a function).
#[inline(never)]
fn skip_cube_of(dda: GridDda, level: u32) -> Skipped {
    dda.skipped(level)
}

/// One cell crossed by the ray: parameter range [t0, t1] and cell coordinates.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Segment {
    pub t0: f32,
    pub t1: f32,
    pub cell: [u32; 3],
}

/// The part of a [`GridDda`] that its steps change ([`GridDda::cursor`]).
#[derive(Clone, Copy, Debug)]
pub struct Cursor {
    cell: [i32; 3],
    t: f32,
    budget: u32,
    exhausted: bool,
    done: bool,
}

/// Amanatides-Woo DDA over a grid of cubic cells of `size` voxels (bricks, or voxels with size 1
/// for regular tracking). Boundary parameters are computed from the plane each time
/// ((plane - o) / d), never accumulated, so two traversals of one ray agree on every t.
#[derive(Clone, Copy, Debug)]
pub struct GridDda {
    /// Where the traversal stands: cell, step, 1/d and origin per axis, t and t_end, the
    /// iterations left before it is forced to end (see [`GridDesc::brick_steps`]), whether that
    /// budget ended it before its end, whether it ended.
    walk: Walk<One>,
    d: V3,
    size: f32,
    /// The traversed cells are [lo, dims) per axis (lo 0 but in the cells of one brick).
    lo: [i32; 3],
    dims: [i32; 3],
    /// Cells per brick along each axis (1 for the brick traversal, B for the voxels): skip
    /// levels count bricks, so a cube of level L is `unit << L` cells per axis.
    unit: i32,
    /// log2 of `unit` when it is a power of two, else [`BRICK_DIVIDES`] (see [`GridDda::cube_last`]).
    unit_log2: u32,
}

/// Along one axis, where a ray moving by `step` from cell c enters and leaves the slab of cells
/// [l, h) of `size` voxels ([`GridDda::span_in`]): (entry, exit, whether it meets the slab);
/// -inf / +inf where the slab does not bound it (already inside, or not moving).
#[inline]
fn axis_span(size: f32, c: i32, l: u32, h: u32, step: i32, o: f32, inv: f32) -> (f32, f32, bool) {
    let (l, h) = (l as i32, h as i32);
    let plane = |k: i32| (k as f32 * size - o) * inv;
    if step == 0 {
        (f32::NEG_INFINITY, f32::INFINITY, c >= l && c < h)
    } else if step > 0 {
        let entry = if c < l { plane(l) } else { f32::NEG_INFINITY };
        (entry, plane(h), c < h)
    } else {
        let entry = if c >= h { plane(h) } else { f32::NEG_INFINITY };
        (entry, plane(l), c >= l)
    }
}

/// The largest of four values (comparisons in a fixed order).
#[inline]
fn max4(a: f32, x: f32, y: f32, z: f32) -> f32 {
    let m = if x > a { x } else { a };
    let m = if y > m { y } else { m };
    if z > m {
        z
    } else {
        m
    }
}

/// The smallest of four values (comparisons in a fixed order).
#[inline]
fn min4(a: f32, x: f32, y: f32, z: f32) -> f32 {
    let m = if x < a { x } else { a };
    let m = if y < m { y } else { m };
    if z < m {
        z
    } else {
        m
    }
}

impl GridDda {
    /// Traversal of the bricks of `desc` from t_start (inside the grid box) to t_end, with at
    /// most `desc.brick_steps` iterations ([`GridDda::exhausted`] tells whether they ended it).
    #[inline]
    pub fn bricks(desc: &GridDesc, ray: &Ray, t_start: f32, t_end: f32) -> Self {
        let dims = [desc.brick_dims[0], desc.brick_dims[1], desc.brick_dims[2]];
        let size = desc.brick_size as f32;
        Self::with(size, dims, 1, 0, desc.brick_budget(), ray, t_start, t_end)
    }

    /// Traversal of the voxels of `desc` (regular tracking) from t_start to t_end that skips
    /// all-zero cubes of bricks ([`GridDda::step_voxel`]), with at most `desc.voxel_steps`
    /// iterations.
    #[inline]
    pub fn voxels(desc: &GridDesc, ray: &Ray, t_start: f32, t_end: f32) -> Self {
        let dims = [desc.dims[0], desc.dims[1], desc.dims[2]];
        let unit = desc.brick_size as i32;
        let budget = desc.voxel_budget();
        Self::with(
            1.0,
            dims,
            unit,
            desc.brick_log2,
            budget,
            ray,
            t_start,
            t_end,
        )
    }

    /// Traversal of cells of `size` voxels in a grid of `cells` cells, from t_start to t_end,
    /// stepping through every cell (skip levels, if used, count these cells).
    pub fn new(size: f32, cells: [u32; 3], ray: &Ray, t_start: f32, t_end: f32) -> Self {
        Self::with(
            size,
            cells,
            1,
            0,
            traversal_budget(0, cells),
            ray,
            t_start,
            t_end,
        )
    }

    /// [`GridDda::new`] with `unit` cells per brick (log2 `unit_log2`, or [`BRICK_DIVIDES`]) and
    /// a budget of `budget` iterations.
    #[allow(clippy::too_many_arguments)]
    fn with(
        size: f32,
        cells: [u32; 3],
        unit: i32,
        unit_log2: u32,
        budget: u32,
        ray: &Ray,
        t_start: f32,
        t_end: f32,
    ) -> Self {
        let dims = [cells[0] as i32, cells[1] as i32, cells[2] as i32];
        GridDda {
            walk: Walk::start(ray, t_start, t_end, size, [0; 3], dims, budget),
            d: ray.d,
            size,
            lo: [0; 3],
            dims,
            unit,
            unit_log2,
        }
    }

    /// A stepping traversal of the same ray through the cells [lo, hi) of `size` voxels (the
    /// cells of one brick, [`crate::volume::supervoxels::SuperVoxelDda`]) from t_start to
    /// t_end, with at most `budget` iterations. Its cell planes are computed as this
    /// traversal's, so where they coincide with brick planes the parameters are the same bits.
    #[inline]
    pub fn within(
        &self,
        size: f32,
        lo: [u32; 3],
        hi: [u32; 3],
        budget: u32,
        t_start: f32,
        t_end: f32,
    ) -> Self {
        let lo = [lo[0] as i32, lo[1] as i32, lo[2] as i32];
        let dims = [hi[0] as i32, hi[1] as i32, hi[2] as i32];
        let st = start_of(&self.ray(), t_start, size, lo, dims);
        GridDda {
            walk: Walk {
                c: st.c,
                t: t_start,
                t_end,
                budget,
                exhausted: false,
                done: !valid(t_start, t_end),
                ..self.walk
            },
            size,
            lo,
            dims,
            unit: 1,
            unit_log2: 0,
            ..*self
        }
    }

    /// The part [ta, tb] of the segment [t_start, t_end] of this ray that lies in the box of
    /// cells [lo, hi) of `size` voxels, as a stepping traversal through the cells [outer_lo,
    /// outer_hi) that holds the box would enter and leave it: a plane parameter where it crosses
    /// one of the box's planes, computed as [`GridDda::step`] computes its exits (the same
    /// bits), t_start where its first cell (clamped into [outer_lo, outer_hi) as
    /// [`GridDda::within`] clamps it) is already inside the box along an axis. ta >= tb: the
    /// ray misses the box.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn span_in(
        &self,
        size: f32,
        lo: [u32; 3],
        hi: [u32; 3],
        outer_lo: [u32; 3],
        outer_hi: [u32; 3],
        t_start: f32,
        t_end: f32,
    ) -> (f32, f32) {
        let p = self.ray().at(t_start);
        let c = |v: f32, a: usize| cell_of(v, size, outer_lo[a] as i32, outer_hi[a] as i32);
        let x = axis_span(
            size,
            c(p.x, 0),
            lo[0],
            hi[0],
            self.walk.s[0],
            self.walk.o[0],
            self.walk.inv[0],
        );
        let y = axis_span(
            size,
            c(p.y, 1),
            lo[1],
            hi[1],
            self.walk.s[1],
            self.walk.o[1],
            self.walk.inv[1],
        );
        let z = axis_span(
            size,
            c(p.z, 2),
            lo[2],
            hi[2],
            self.walk.s[2],
            self.walk.o[2],
            self.walk.inv[2],
        );
        if !(x.2 && y.2 && z.2) {
            return (t_end, t_start);
        }
        let ta = max4(t_start, x.0, y.0, z.0);
        let tb = min4(t_end, x.1, y.1, z.1);
        (ta, tb)
    }

    /// Iterations left of the budget.
    #[inline]
    pub fn budget_left(&self) -> u32 {
        self.walk.budget
    }

    /// Whether the traversal ended because its budget of iterations ran out, before reaching
    /// t_end or the grid's edge: the caller counts the ray as capped. Only a skip that cannot be
    /// verified in closed form (which then steps) can take a traversal past the builder's bound.
    #[inline]
    pub fn exhausted(&self) -> bool {
        self.walk.exhausted
    }

    /// The ray (index space).
    #[inline]
    fn ray(&self) -> Ray {
        let o = self.walk.o;
        Ray {
            o: V3::new(o[0], o[1], o[2]),
            d: self.d,
        }
    }

    /// The current cell (the next segment's, while `!done`).
    #[inline]
    pub fn cell(&self) -> [u32; 3] {
        [
            self.walk.c[0] as u32,
            self.walk.c[1] as u32,
            self.walk.c[2] as u32,
        ]
    }

    /// The next brick segment and its statistics (call only while `!done`). An all-zero brick
    /// whose cube can be skipped ([`GridDda::skip_cube`]) gives the whole skipped span as one
    /// segment with its statistics (all 0: it adds nothing to any sum and takes no sample);
    /// otherwise the brick's own segment. No loop: one call is one iteration of the caller's,
    /// one skip or one step, so a traversal takes at most as many iterations as stepping (GPU
    /// loop budgets count iterations).
    #[inline]
    pub fn step_brick(&mut self, vol: &VolumeView<impl Texels>) -> (Segment, Brick) {
        self.step_brick_after(vol, false)
    }

    /// [`GridDda::step_brick`], callable after the end too when `after_end` (the result is then
    /// meaningless and reads nothing: its cell may lie outside the grid, its brick is
    /// [`Brick::ZERO`]), for a caller that steps unconditionally and keeps the result only while
    /// it was not done. On a SIMD device a step under a branch merges every value it writes at
    /// the branch's end; a step taken always and kept by a select does not. With `after_end`
    /// false (a literal at every call site) the guard folds away.
    #[inline]
    pub fn step_brick_after(
        &mut self,
        vol: &VolumeView<impl Texels>,
        after_end: bool,
    ) -> (Segment, Brick) {
        let cell = self.cell();
        let b = if after_end & self.walk.done {
            Brick::ZERO
        } else {
            vol.brick(cell)
        };
        let level = b.skip_level();
        // A cube of one brick (level 0) is left by one step, which is cheaper than the skip
        // and lands in the same cell at the same t. Only where the ray ends inside the brick do
        // the segments differ (the skip's is empty, the step's ends at t_end), and a segment of
        // zero statistics adds 0 to every sum either way.
        // A pipeline that steps through all-zero bricks (`GridDesc::brick_stepping`, folded by
        // specialization) leaves the skip out entirely.
        if (vol.desc.brick_stepping == 0) & (level != NO_SKIP) & (level != 0) {
            let t0 = self.walk.t;
            if self.skip_cube(level) {
                let t1 = self.walk.t;
                return (Segment { t0, t1, cell }, b);
            }
        }
        (self.step(), b)
    }

    /// What a step changes (cell, t, budget, flags), to put a step back ([`GridDda::restore`]).
    #[inline]
    pub fn cursor(&self) -> Cursor {
        Cursor {
            cell: self.walk.c,
            t: self.walk.t,
            budget: self.walk.budget,
            exhausted: self.walk.exhausted,
            done: self.walk.done,
        }
    }

    /// Puts back the state of `c` (taken by [`GridDda::cursor`] of this traversal): undoes the
    /// steps and skips since.
    #[inline]
    pub fn restore(&mut self, c: Cursor) {
        self.walk.c = c.cell;
        self.walk.t = c.t;
        self.walk.budget = c.budget;
        self.walk.exhausted = c.exhausted;
        self.walk.done = c.done;
    }

    /// The next voxel segment of a voxel traversal ([`GridDda::voxels`]), or, in an all-zero
    /// brick whose cube can be skipped, the whole skipped span as one segment; the flag is true
    /// for a voxel the caller reads (false in an all-zero brick: extinction 0 throughout). One
    /// skip or one step per call, no loop; a pipeline that steps through all-zero bricks
    /// (`GridDesc::brick_stepping`) never skips. Call only while `!done`.
    #[inline]
    pub fn step_voxel(&mut self, vol: &VolumeView<impl Texels>) -> (Segment, bool) {
        let cell = self.cell();
        let d = &vol.desc;
        let level = vol
            .brick([
                d.brick_of(cell[0]),
                d.brick_of(cell[1]),
                d.brick_of(cell[2]),
            ])
            .skip_level();
        let zero = level != NO_SKIP;
        if (vol.desc.brick_stepping == 0) & zero {
            let t0 = self.walk.t;
            if self.skip_cube(level) {
                let t1 = self.walk.t;
                return (Segment { t0, t1, cell }, false);
            }
        }
        (self.step(), !zero)
    }

    /// Skips the aligned cube of 2^`level` bricks per axis (`unit << level` cells, clipped to the
    /// grid) that holds the current cell, leaving the traversal exactly as [`GridDda::step`] would have left it on
    /// leaving the cube (the same cell, t and `done`), without its segments. Returns false,
    /// changing nothing, where that state cannot be verified in closed form (then step). No
    /// loops: one call is one iteration of the caller's (GPU loop budgets count iterations).
    ///
    /// Why it is exact: `step` crosses the planes of each axis in order, their parameters are
    /// computed from the plane alone and do not decrease along the axis, and it takes the
    /// smallest next parameter, the lower axis on ties: its crossings are the merge of the three
    /// axes' sequences ordered by (t, axis). The cube is left at the first crossing of a cube
    /// face, (t*, a*) = the smallest (exit of the cube's last cell, axis); every other axis has
    /// then crossed exactly its planes ordered before (t*, a*), t is t* unless t* < t, and
    /// the traversal has ended if t* >= t_end or the crossing leaves the grid.
    #[inline]
    pub fn skip_cube(&mut self, level: u32) -> bool {
        let after = skip_cube_of(*self, level);
        if after.skipped {
            *self = after.dda;
        }
        after.skipped
    }

    /// [`GridDda::skip_cube`] on a copy (see [`skip_cube_of`]).
    #[allow(clippy::manual_range_contains)] // plain compares, the same on every backend
    fn skipped(mut self, level: u32) -> Skipped {
        let unchanged = Skipped {
            dda: self,
            skipped: false,
        };
        // Non-short-circuit `&` and `|` throughout: every operand is pure, and a SIMD device
        // runs every arm of a branch anyway, so the skip is straight-line code.
        let finite = math::is_finite(self.walk.inv[0])
            & math::is_finite(self.walk.inv[1])
            & math::is_finite(self.walk.inv[2])
            & math::is_finite(self.walk.t);
        // The cube's side, unit << level cells, must stay within 2^30 (i32 arithmetic).
        if (level >= 31) | !finite || self.unit as u32 > (1u32 << 30) >> level {
            return unchanged;
        }
        let (l0, l1, l2) = (
            self.cube_last(0, level),
            self.cube_last(1, level),
            self.cube_last(2, level),
        );
        let (e0, e1, e2) = (
            self.exit_of(0, l0),
            self.exit_of(1, l1),
            self.exit_of(2, l2),
        );
        // The smallest exit, the lower axis on ties (a moving axis always has a finite one).
        let (mut a_star, mut t_star, mut last_star) = (0usize, e0, l0);
        if e1 < t_star {
            (a_star, t_star, last_star) = (1, e1, l1);
        }
        if e2 < t_star {
            (a_star, t_star, last_star) = (2, e2, l2);
        }
        if !math::is_finite(t_star) {
            return unchanged;
        }
        if (t_star >= self.walk.t_end) | (self.walk.t >= self.walk.t_end) {
            self.walk.done = true;
            self.walk.spend(true);
            return Skipped {
                dda: self,
                skipped: true,
            };
        }
        let star = (t_star, a_star);
        let (m0, m1, m2) = (
            self.crossings(0, l0, star),
            self.crossings(1, l1, star),
            self.crossings(2, l2, star),
        );
        if (m0 < 0) | (m1 < 0) | (m2 < 0) {
            return unchanged;
        }
        let (_, s_star, _, _, _) = self.axis(a_star);
        let j = last_star + s_star;
        let mut next = (
            self.walk.c[0] + self.walk.s[0] * m0,
            self.walk.c[1] + self.walk.s[1] * m1,
            self.walk.c[2] + self.walk.s[2] * m2,
        );
        if a_star == 0 {
            next.0 = j;
        } else if a_star == 1 {
            next.1 = j;
        } else {
            next.2 = j;
        }
        if (j < 0) | (j >= self.dim(a_star)) {
            self.walk.done = true;
        } else {
            self.walk.c = [next.0, next.1, next.2];
        }
        // As `step` sets t: the crossing's parameter unless it is below t (so -0 after +0).
        if !(t_star < self.walk.t) {
            self.walk.t = t_star;
        }
        self.walk.spend(true);
        Skipped {
            dda: self,
            skipped: true,
        }
    }

    /// Cells of the grid along axis `a`.
    #[inline]
    fn dim(&self, a: usize) -> i32 {
        if a == 0 {
            self.dims[0]
        } else if a == 1 {
            self.dims[1]
        } else {
            self.dims[2]
        }
    }

    /// Cell, step, origin, direction and 1/direction of axis `a`.
    #[inline]
    fn axis(&self, a: usize) -> (i32, i32, f32, f32, f32) {
        if a == 0 {
            (
                self.walk.c[0],
                self.walk.s[0],
                self.walk.o[0],
                self.d.x,
                self.walk.inv[0],
            )
        } else if a == 1 {
            (
                self.walk.c[1],
                self.walk.s[1],
                self.walk.o[1],
                self.d.y,
                self.walk.inv[1],
            )
        } else {
            (
                self.walk.c[2],
                self.walk.s[2],
                self.walk.o[2],
                self.d.z,
                self.walk.inv[2],
            )
        }
    }

    /// The last cell along axis `a`, in the direction of travel, of the aligned cube of
    /// 2^`level` bricks (`unit << level` cells, at most 2^30; clipped to the grid) that holds
    /// the current cell.
    #[inline]
    fn cube_last(&self, a: usize, level: u32) -> i32 {
        let (c, s, _, _, _) = self.axis(a);
        let side = self.unit << level;
        // A power-of-two side rounds c down by shifts (a vector integer division is a scalar
        // loop on SIMD devices); otherwise division by a NonZero, which cannot panic: this
        // function must stay free of panics (see [`skip_cube_of`]); c >= 0 and side >= 1 (the
        // caller checked the shift, so unit_log2 + level <= 30).
        let lo = if self.unit_log2 < BRICK_DIVIDES {
            let k = self.unit_log2 + level;
            ((c as u32 >> k) << k) as i32
        } else {
            match core::num::NonZeroU32::new(side as u32) {
                Some(d) => ((c as u32 / d) * side as u32) as i32,
                None => c,
            }
        };
        let mut hi = lo + (side - 1);
        if hi > self.dim(a) - 1 {
            hi = self.dim(a) - 1;
        }
        if s > 0 {
            hi
        } else {
            lo
        }
    }

    /// Parameter of the exit plane of cell `k` of axis `a` (+inf if the ray does not move
    /// along it), as `step` computes it.
    #[inline]
    fn exit_of(&self, a: usize, k: i32) -> f32 {
        let (_, s, o, _, inv) = self.axis(a);
        Walk::<One>::exit(k, s, o, inv, self.size)
    }

    /// The number m of axis `b`'s crossings, from the current cell to the cube's `last`, that
    /// `step` takes before (t*, a*), or -1 where it cannot be verified. 0 for a* itself (set
    /// apart) and for an axis the ray does not move along. The candidate is the cell holding
    /// the point at t*, verified and corrected by one cell either way.
    #[inline]
    #[allow(clippy::manual_range_contains)] // plain compares, the same on every backend
    fn crossings(&self, b: usize, last: i32, star: (f32, usize)) -> i32 {
        let (c, s, o, d, _) = self.axis(b);
        if (b == star.1) | (s == 0) {
            return 0;
        }
        let n = (last - c) * s;
        let guess = math::floor((o + star.0 * d) / self.size);
        if !((guess >= -2147483648.0) & (guess <= 2147483520.0)) {
            return -1;
        }
        let g = (guess as i32 - c) * s;
        // Whether the crossings k = g - 2 ..= g + 1 come before (t*, a*), each computed once
        // (crossing k is the exit plane of cell c + s k).
        // Wrapping: values outside 0..=n are computed and then discarded.
        let before = |k: i32| self.crossed_before(b, c.wrapping_add(s.wrapping_mul(k)), star);
        let (g_m2, g_m1, g_p1) = (g.wrapping_sub(2), g.wrapping_sub(1), g.wrapping_add(1));
        let (x_m2, x_m1, x_0, x_p1) = (before(g_m2), before(g_m1), before(g), before(g_p1));
        // Exactly m crossings come before: the m-th does (m > 0), the (m+1)-th not (m < n).
        let exactly = |m: i32, mth: bool, next: bool| {
            (m >= 0) & (m <= n) & ((m == 0) | mth) & ((m == n) | !next)
        };
        if exactly(g, x_m1, x_0) {
            g
        } else if exactly(g_m1, x_m2, x_m1) {
            g_m1
        } else if exactly(g_p1, x_0, x_p1) {
            g_p1
        } else {
            -1
        }
    }

    /// Whether `step` crosses the exit plane of cell `k` of axis `b` before the crossing
    /// (t*, a*): at a smaller t, or at the same t on a lower axis.
    #[inline]
    fn crossed_before(&self, b: usize, k: i32, star: (f32, usize)) -> bool {
        let e = self.exit_of(b, k);
        (e < star.0) | ((e == star.0) & (b < star.1))
    }

    /// The current brick's segment; advances to the next brick. Call only while `!done`. Out
    /// of line on the CPU, where inlined into its callers it ran 7 % slower per tracking ray
    /// (speed.md, "Step"); `#[inline]` in the kernels.
    #[cfg_attr(target_arch = "spirv", inline)]
    #[cfg_attr(not(target_arch = "spirv"), inline(never))]
    pub fn step(&mut self) -> Segment {
        let (t0, t1, cell) = self.walk.step(true, self.size, self.lo, self.dims);
        Segment { t0, t1, cell }
    }

    /// Whether the traversal has ended.
    #[inline]
    pub fn done(&self) -> bool {
        self.walk.done
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{pcg_hash, unit_f32};
    use crate::volume::grid::NO_SKIP;

    /// Deterministic uniform numbers in [0, 1) from a counter.
    struct Draws(u32);

    impl Draws {
        fn next(&mut self) -> f32 {
            self.0 += 1;
            unit_f32(pcg_hash(self.0.wrapping_mul(0x9e37_79b9)))
        }

        fn below(&mut self, n: u32) -> u32 {
            ((self.next() * n as f32) as u32).min(n - 1)
        }
    }

    /// A grid of `dims` cells with a level per cell: the largest marked empty aligned cube holding it
    /// (random cubes of levels 0..=3), or [`NO_SKIP`].
    fn random_levels(dims: [u32; 3], r: &mut Draws) -> Vec<u32> {
        let n = (dims[0] * dims[1] * dims[2]) as usize;
        let mut levels = vec![NO_SKIP; n];
        for _ in 0..(n / 6).max(1) {
            let level = r.below(4);
            let c = [0, 1, 2].map(|a| r.below(dims[a]) >> level << level);
            for z in c[2]..(c[2] + (1 << level)).min(dims[2]) {
                for y in c[1]..(c[1] + (1 << level)).min(dims[1]) {
                    for x in c[0]..(c[0] + (1 << level)).min(dims[0]) {
                        let i = (x + dims[0] * (y + dims[1] * z)) as usize;
                        if levels[i] == NO_SKIP || levels[i] < level {
                            levels[i] = level;
                        }
                    }
                }
            }
        }
        levels
    }

    /// Trials of the traversal test (`JK_SKIP_TRIALS` for a longer hunt).
    fn trials() -> usize {
        std::env::var("JK_SKIP_TRIALS")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(20_000)
    }

    /// Bit patterns of a segment, for exact comparison.
    fn bits(s: &Segment) -> (u32, u32, [u32; 3]) {
        (s.t0.to_bits(), s.t1.to_bits(), s.cell)
    }

    #[test]
    fn skipping_a_cube_lands_where_stepping_through_it_lands() {
        let mut r = Draws(7);
        let mut skips = 0;
        let mut fallbacks = 0;
        for trial in 0..trials() {
            let dims = [0, 1, 2].map(|_| 1 + r.below(24));
            let size = [1.0f32, 4.0, 16.0][trial % 3];
            let levels = random_levels(dims, &mut r);
            let hi = V3::new(
                dims[0] as f32 * size,
                dims[1] as f32 * size,
                dims[2] as f32 * size,
            );
            // Origins on cell boundaries and axis-parallel directions now and then.
            let mut coord = |a: u32| {
                let v = (r.next() * 1.4 - 0.2) * (dims[a as usize] as f32 * size);
                if r.below(4) == 0 {
                    (v / size).round() * size
                } else {
                    v
                }
            };
            let o = V3::new(coord(0), coord(1), coord(2));
            // Axis-parallel rays, slopes that cross edges and corners exactly (ties between
            // axes), tiny components (huge t), and general directions.
            let mut dir = |_: u32| match r.below(8) {
                0 => 0.0,
                1 | 2 => [-1.0, -0.5, 0.25, 0.5, 1.0, 2.0][r.below(6) as usize],
                3 => (r.next() - 0.5) * 1e-6,
                _ => r.next() * 2.0 - 1.0,
            };
            let d = V3::new(dir(0), dir(1), dir(2));
            let ray = Ray { o, d };
            let (t0, t1) = clip_to_box(&ray, hi, 0.0, f32::INFINITY);
            if !(t0 < t1) {
                continue;
            }
            // End some rays inside the grid.
            let t_end = if r.below(3) == 0 {
                t0 + (t1 - t0) * r.next()
            } else {
                t1
            };
            let level_of =
                |c: [u32; 3]| levels[(c[0] + dims[0] * (c[1] + dims[1] * c[2])) as usize];
            let mut stepped = Vec::new();
            let mut dda = GridDda::new(size, dims, &ray, t0, t_end);
            while !dda.done() {
                let s = dda.step();
                if level_of(s.cell) == NO_SKIP {
                    stepped.push(bits(&s));
                }
            }
            let mut skipped = Vec::new();
            let mut dda = GridDda::new(size, dims, &ray, t0, t_end);
            while !dda.done() {
                let level = level_of(dda.cell());
                if level != NO_SKIP {
                    if dda.skip_cube(level) {
                        skips += 1;
                        continue;
                    }
                    fallbacks += 1;
                }
                let s = dda.step();
                if level_of(s.cell) == NO_SKIP {
                    skipped.push(bits(&s));
                }
            }
            assert_eq!(
                stepped, skipped,
                "trial {trial}: dims {dims:?}, size {size}, ray {ray:?}, t {t0}..{t_end}"
            );
        }
        // The closed form is verified, never trusted: it must hold almost always.
        assert!(skips > 10_000, "{skips} skips");
        assert!(fallbacks * 1000 < skips, "{fallbacks} fallbacks of {skips}");
    }
}
