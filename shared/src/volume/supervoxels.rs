//! Traversal of the super-voxels along a ray: the bricks of the grid, and inside a subdivided
//! brick ([`Brick::cells`], adaptive super-voxels) its cells of B / s voxels per axis, each with
//! the statistics of a brick over the cell. Every estimator that walks the importance or the
//! majorant (Alg. 2, Alg. 1, the majorant sampler of delta and ratio tracking) sees one sequence
//! of segments with constant statistics, from the fixed grid or from the adaptive one alike.
//!
//! In a subdivided brick only the cells inside its cell box ([`Brick::cell_box`]) are visited:
//! the cells around the box have statistics 0, and a span of them adds 0 to every sum (F and
//! the control variate of Alg. 2 and Alg. 1), takes no sample and stops no free flight, so
//! leaving them out changes no estimate, only the number of steps.

use crate::geometry::Ray;
use crate::volume::dda::{Cursor, GridDda, Segment};
use crate::volume::grid::{Brick, GridDesc, VolumeView};
use crate::volume::texels::Texels;
use core::num::NonZeroU32;

/// The super-voxels of one ray segment: a skipping traversal of the bricks that, at a
/// subdivided brick, steps through the cells of the brick's cell box crossed by the brick's
/// segment before it moves on. One call of [`SuperVoxelDda::step`] is one iteration of the
/// caller's loop: a skip, a brick, a cell, or a subdivided brick whose cell box the ray misses.
#[derive(Clone, Copy, Debug)]
pub struct SuperVoxelDda {
    bricks: GridDda,
    /// The cells of the current subdivided brick, while `in_cells`.
    cells: GridDda,
    /// Cell box record of the current subdivided brick ([`Brick::cells`]).
    first_cell: u32,
    /// Its first cell (global cell coordinates): brick coordinates times s.
    lo: [u32; 3],
    in_cells: bool,
    /// Cell steps left ([`GridDesc::cell_budget`]).
    cell_budget: u32,
    /// Whether the cell budget ended the traversal.
    cells_exhausted: bool,
}

impl SuperVoxelDda {
    /// Traversal of the super-voxels of `desc` from t_start (inside the grid box) to t_end, with
    /// at most `desc.brick_budget()` brick iterations and `desc.cell_budget()` cell iterations.
    #[inline]
    pub fn new(desc: &GridDesc, ray: &Ray, t_start: f32, t_end: f32) -> Self {
        let bricks = GridDda::bricks(desc, ray, t_start, t_end);
        SuperVoxelDda {
            bricks,
            cells: bricks,
            first_cell: 0,
            lo: [0; 3],
            in_cells: false,
            cell_budget: desc.cell_budget(),
            cells_exhausted: false,
        }
    }

    /// Whether the traversal has ended: a cell budget ran out, or the bricks are done and no
    /// cell traversal is under way. A method, not a field that copies the bricks' flag: one
    /// value fewer for every loop that carries the traversal.
    #[inline]
    pub fn done(&self) -> bool {
        self.cells_exhausted | (!self.in_cells & self.bricks.done())
    }

    /// What a step of the fixed grid changes ([`GridDda::cursor`] of the bricks): on a grid
    /// without subdivided bricks ([`GridDesc::cells_per_brick`] 1) a step changes nothing else.
    #[inline]
    pub fn brick_cursor(&self) -> Cursor {
        self.bricks.cursor()
    }

    /// Puts back the bricks' state of `c` ([`SuperVoxelDda::brick_cursor`]; the fixed grid only).
    #[inline]
    pub fn restore_bricks(&mut self, c: Cursor) {
        self.bricks.restore(c);
    }

    /// The fixed grid's step ([`GridDesc::cells_per_brick`] 1: the bricks'
    /// [`GridDda::step_brick_after`]), callable after the end too (a meaningless segment that
    /// reads nothing), for a caller that steps unconditionally and puts an untaken step back
    /// ([`SuperVoxelDda::restore_bricks`]).
    #[inline]
    pub fn step_bricks_after_end(&mut self, vol: &VolumeView<impl Texels>) -> (Segment, Brick) {
        self.bricks.step_brick_after(vol, true)
    }

    /// Whether a budget (bricks or cells) ended the traversal before it reached its end: the
    /// caller counts the ray as capped.
    #[inline]
    pub fn exhausted(&self) -> bool {
        self.cells_exhausted || self.bricks.exhausted()
    }

    /// The next super-voxel segment and its statistics (call only while `!done`): a skipped
    /// span of all-zero bricks (statistics 0), a brick, or a cell of a subdivided brick (its
    /// segment's cell in global cell coordinates, brick coordinates times s plus the local
    /// ones). A subdivided brick whose segment is empty (the ray grazes an edge) gives that
    /// empty segment with the brick's own statistics: length 0 adds nothing to any sum.
    #[inline]
    pub fn step(&mut self, vol: &VolumeView<impl Texels>) -> (Segment, Brick) {
        if vol.desc.cells_per_brick() == 1 {
            // The fixed grid: no brick is subdivided, so the cell traversal below is never
            // entered. Said first, so a pipeline specialized to the fixed grid (constant 5)
            // folds it away: SIMD devices run every arm under masks, reachable or not.
            return self.bricks.step_brick(vol);
        }
        if !self.in_cells {
            let (seg, b) = self.bricks.step_brick(vol);
            let s = vol.desc.cells_per_brick();
            if b.cells == 0 || s == 1 {
                return (seg, b);
            }
            let size = match NonZeroU32::new(s) {
                Some(d) => vol.desc.brick_size / d,
                None => vol.desc.brick_size,
            };
            let lo = [seg.cell[0] * s, seg.cell[1] * s, seg.cell[2] * s];
            let hi = [lo[0] + s, lo[1] + s, lo[2] + s];
            if !(seg.t0 < seg.t1) {
                // A graze: an empty segment with the brick's statistics adds nothing.
                return (seg, b);
            }
            // Only the box of the cells with statistics is traversed ([`Brick::cell_box`]):
            // the cells around it are all 0 and add nothing to any sum.
            let (box_lo, box_hi) = vol.cell_box(b.cells);
            let box_lo = [lo[0] + box_lo[0], lo[1] + box_lo[1], lo[2] + box_lo[2]];
            let box_hi = [lo[0] + box_hi[0], lo[1] + box_hi[1], lo[2] + box_hi[2]];
            let size = size as f32;
            let (ta, tb) = self
                .bricks
                .span_in(size, box_lo, box_hi, lo, hi, seg.t0, seg.t1);
            let cells = self
                .bricks
                .within(size, box_lo, box_hi, self.cell_budget, ta, tb);
            if cells.done() {
                // The ray misses the box: the brick's segment holds zero statistics only.
                return (seg, Brick::ZERO);
            }
            self.cells = cells;
            self.first_cell = b.cells;
            self.lo = lo;
            self.in_cells = true;
        }
        let seg = self.cells.step();
        self.cell_budget = self.cells.budget_left();
        let local = [
            seg.cell[0] - self.lo[0],
            seg.cell[1] - self.lo[1],
            seg.cell[2] - self.lo[2],
        ];
        let b = vol.cell(self.first_cell, local);
        if self.cells.done() {
            self.in_cells = false;
            self.cells_exhausted = self.cells.exhausted();
        }
        (seg, b)
    }
}
