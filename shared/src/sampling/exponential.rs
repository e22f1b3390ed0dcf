//! Exponential free-flight distances against a piecewise-constant majorant (pbrt-v4's
//! `DDAMajorantIterator`, and one optical-depth target per flight as in the paper author's
//! `delta_tracking`, as a pull iterator so every loop is flat, bounded and free of closures on
//! the GPU): the distance sampler of delta and ratio tracking.

use crate::geometry::Ray;
use crate::math;
use crate::rng::HashRng;
use crate::volume::dda::{Cursor, Segment};
use crate::volume::grid::{Brick, VolumeView};
use crate::volume::supervoxels::SuperVoxelDda;
use crate::volume::texels::Texels;

/// A piece [t0, t1] of the ray with a constant majorant (pbrt-v4's `RayMajorantSegment`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MajorantSegment {
    pub t0: f32,
    pub t1: f32,
    pub sigma_maj: f32,
}

impl MajorantSegment {
    /// A traversal segment with its brick's maximum as the majorant.
    #[inline]
    fn of((seg, b): (Segment, Brick)) -> Self {
        MajorantSegment {
            t0: seg.t0,
            t1: seg.t1,
            sigma_maj: b.mu_max,
        }
    }
}

/// pbrt-v4's `DDAMajorantIterator` over the super-voxels: segments with majorant mu_max.
#[derive(Clone, Copy, Debug)]
pub struct MajorantIter {
    dda: SuperVoxelDda,
}

impl MajorantIter {
    /// Iterator over the bricks of [t0, t1] (pbrt-v4 `DDAMajorantIterator`).
    #[inline]
    pub fn new(vol: &VolumeView<impl Texels>, ray: &Ray, t0: f32, t1: f32) -> Self {
        MajorantIter {
            dda: SuperVoxelDda::new(&vol.desc, ray, t0, t1),
        }
    }

    /// Whether the traversal has ended ([`SuperVoxelDda::done`]).
    #[inline]
    pub fn done(&self) -> bool {
        self.dda.done()
    }

    /// Next brick segment and its majorant mu_max (pbrt-v4 `Next`); call only while `!done`.
    #[inline]
    pub fn next_segment(&mut self, vol: &VolumeView<impl Texels>) -> MajorantSegment {
        MajorantSegment::of(self.dda.step(vol))
    }

    /// [`MajorantIter::next_segment`] of the fixed grid, callable after the end too (then a
    /// meaningless segment of majorant 0 that reads nothing;
    /// [`SuperVoxelDda::step_bricks_after_end`]).
    #[inline]
    fn next_brick_segment_after_end(&mut self, vol: &VolumeView<impl Texels>) -> MajorantSegment {
        MajorantSegment::of(self.dda.step_bricks_after_end(vol))
    }

    /// [`SuperVoxelDda::brick_cursor`] (the fixed grid only).
    #[inline]
    fn cursor(&self) -> Cursor {
        self.dda.brick_cursor()
    }

    /// [`SuperVoxelDda::restore_bricks`] (the fixed grid only).
    #[inline]
    fn restore(&mut self, c: Cursor) {
        self.dda.restore_bricks(c);
    }

    /// Whether the traversal's iteration budgets ended it early ([`SuperVoxelDda::exhausted`]).
    #[inline]
    pub fn exhausted(&self) -> bool {
        self.dda.exhausted()
    }
}

/// A tentative collision at distance t where the majorant is `sigma_maj`; `found` is false when
/// the free flight escaped past the end of the ray instead.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Collision {
    pub t: f32,
    pub sigma_maj: f32,
    pub found: bool,
}

/// pbrt-v4's `SampleT_maj` as a pull iterator: exponential free flights against the piecewise
/// constant majorant, restarted memorylessly at every segment boundary.
#[derive(Clone, Copy, Debug)]
pub struct MajorantSampler {
    iter: MajorantIter,
    seg: MajorantSegment,
    t: f32,
    /// Bound on segment advances within one call (more than the DDA can produce).
    guard: u32,
    pub done: bool,
}

impl MajorantSampler {
    /// Sampler over [t0, t1]; starts on an empty segment so the first call enters the first brick.
    #[inline]
    pub fn new(vol: &VolumeView<impl Texels>, ray: &Ray, t0: f32, t1: f32) -> Self {
        let iter = MajorantIter::new(vol, ray, t0, t1);
        MajorantSampler {
            iter,
            seg: MajorantSegment {
                t0,
                t1: t0,
                sigma_maj: 0.0,
            },
            t: t0,
            guard: {
                let g = vol.desc.supervoxel_budget();
                if g > u32::MAX - 8 {
                    u32::MAX
                } else {
                    g + 8
                }
            },
            done: iter.done(),
        }
    }

    /// Whether the brick traversal's iteration budget ended the flight early (the ray is counted
    /// as capped).
    #[inline]
    pub fn capped(&self) -> bool {
        self.iter.exhausted()
    }

    /// Next tentative collision: one exponential optical depth tau = -ln(1 - u) against the
    /// majorant, walked segment by segment until the majorant's optical depth from the current
    /// t reaches it (the author's `delta_tracking`; pbrt-v4's `SampleT_maj` draws one distance
    /// per segment instead, the same distribution at a logarithm and a draw per segment).
    /// Segments with zero majorant add nothing; a flight that met no majorant optical depth
    /// returns `rng` unchanged (its draw decided nothing), so zero majorants take no random
    /// number, as they take no sample. Sets `done` (and returns `found == false`) once past the
    /// end of the ray.
    #[inline]
    pub fn next_collision(
        &mut self,
        vol: &VolumeView<impl Texels>,
        rng: HashRng,
    ) -> (Collision, HashRng) {
        let (u, next) = rng.next_f32();
        let (c, drew) = self.next_collision_at(vol, u);
        (c, if drew { next } else { rng })
    }

    /// [`MajorantSampler::next_collision`] with its uniform `u` given; also says whether `u`
    /// decided anything (false: the flight met no majorant optical depth, so a generator's draw
    /// is put back).
    pub fn next_collision_at(
        &mut self,
        vol: &VolumeView<impl Texels>,
        u: f32,
    ) -> (Collision, bool) {
        let target = -math::ln(1.0 - u);
        // Majorant optical depth from the flight's start to self.t (at most `target`).
        let mut depth = 0.0f32;
        let mut found = false;
        let mut steps = 0u32;
        // On the fixed grid the loop body has no branch around the traversal step: a SIMD
        // device (lavapipe) runs every arm of a branch under masks and merges every value the
        // arm writes through memory, so the next segment is read in every iteration (after the
        // end too, reading nothing) and the step is put back where it is not taken (a select).
        // On subdivided grids a step changes more than the bricks' cursor: it runs under the
        // branch.
        let fixed = vol.desc.cells_per_brick() == 1;
        while !found & !self.done & (steps < self.guard) {
            steps += 1;
            let sigma = self.seg.sigma_maj;
            let rest = sigma * (self.seg.t1 - self.t);
            let over = depth + rest > target;
            // The collision, if this segment holds it (sigma > 0 wherever `over` holds, since
            // depth <= target).
            let t_hit = self.t + (target - depth) / sigma;
            found = over & (t_hit < self.seg.t1);
            // Rounded onto the segment's end: the collision is the next one's start.
            depth = if over { target } else { depth + rest };
            let ended = self.iter.done();
            let advance = !found & !ended;
            let seg = if fixed {
                let saved = self.iter.cursor();
                let seg = self.iter.next_brick_segment_after_end(vol);
                if !advance {
                    self.iter.restore(saved);
                }
                seg
            } else if advance {
                self.iter.next_segment(vol)
            } else {
                self.seg
            };
            if advance {
                self.seg = seg;
            }
            self.t = if found {
                t_hit
            } else if advance {
                seg.t0
            } else {
                self.t
            };
            self.done |= !found & ended;
        }
        if !found {
            self.done = true;
        }
        let out = if found {
            Collision {
                t: self.t,
                sigma_maj: self.seg.sigma_maj,
                found: true,
            }
        } else {
            Collision::default()
        };
        let drew = out.found || depth > 0.0;
        (out, drew)
    }
}
