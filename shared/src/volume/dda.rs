//! Ray/box clipping and Amanatides-Woo traversal of the brick grid, in voxel index space.

use crate::geometry::{Ray, V3};
use crate::math;
use crate::volume::grid::GridDesc;

/// Clips [t_lo, t_hi] to the box [0, hi] (slab test). Returns (t_enter, t_exit); the ray misses
/// when `!(t_enter < t_exit)`. Axis-parallel rays are handled without 0 * inf. Degenerate input
/// misses: a zero, infinite or NaN direction, a non-finite origin, or a NaN or empty range
/// (`t_hi` may be +inf).
#[inline]
pub fn clip_to_box(ray: &Ray, hi: V3, t_lo: f32, t_hi: f32) -> (f32, f32) {
    if !is_usable(ray) || !(t_lo < t_hi) {
        return (1.0, 0.0);
    }
    let mut t0 = t_lo;
    let mut t1 = t_hi;
    let mut axis = 0;
    while axis < 3 {
        let o = ray.o.get(axis);
        let d = ray.d.get(axis);
        let h = hi.get(axis);
        if d == 0.0 {
            if !(o >= 0.0 && o <= h) {
                return (1.0, 0.0);
            }
        } else {
            let inv = 1.0 / d;
            let ta = (0.0 - o) * inv;
            let tb = (h - o) * inv;
            let (near, far) = if ta < tb { (ta, tb) } else { (tb, ta) };
            if near > t0 {
                t0 = near;
            }
            if far < t1 {
                t1 = far;
            }
        }
        axis += 1;
    }
    (t0, t1)
}

/// Whether a ray has a finite origin and a finite, non-zero direction (false for any NaN).
#[inline]
#[allow(clippy::manual_range_contains)] // two plain compares, the same on every backend
pub fn is_usable(ray: &Ray) -> bool {
    let finite = |v: f32| v >= -f32::MAX && v <= f32::MAX;
    let len2 = ray.d.dot(ray.d);
    finite(ray.o.x) && finite(ray.o.y) && finite(ray.o.z) && len2 > 0.0 && finite(len2)
}

/// One cell crossed by the ray: parameter range [t0, t1] and cell coordinates.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Segment {
    pub t0: f32,
    pub t1: f32,
    pub cell: [u32; 3],
}

/// Amanatides-Woo DDA over a grid of cubic cells of `size` voxels (bricks, or voxels with size 1
/// for regular tracking). Boundary parameters are computed from the plane each time
/// ((plane - o) / d), never accumulated, so two traversals of one ray agree on every t.
#[derive(Clone, Copy, Debug)]
pub struct GridDda {
    cx: i32,
    cy: i32,
    cz: i32,
    sx: i32,
    sy: i32,
    sz: i32,
    inv: V3,
    o: V3,
    t: f32,
    t_end: f32,
    size: f32,
    dims: [i32; 3],
    /// Steps left before the traversal is forced to end (guards against NaN loops).
    budget: u32,
    pub done: bool,
}

/// Sign of d as a step: +1, -1, or 0 for an axis the ray does not move along.
#[inline]
fn step_of(d: f32) -> i32 {
    if d > 0.0 {
        1
    } else if d < 0.0 {
        -1
    } else {
        0
    }
}

/// 1/d, or 0 where d = 0 (that axis never crosses a plane).
#[inline]
fn inv_or_zero(d: f32) -> f32 {
    if d == 0.0 {
        0.0
    } else {
        1.0 / d
    }
}

/// Brick index of coordinate v, clamped to [0, n-1].
#[inline]
fn cell_of(v: f32, size: f32, n: i32) -> i32 {
    let c = math::floor(v / size);
    if c < 0.0 {
        0
    } else if c >= n as f32 {
        n - 1
    } else {
        c as i32
    }
}

impl GridDda {
    /// Traversal of the bricks of `desc` from t_start (inside the grid box) to t_end.
    #[inline]
    pub fn bricks(desc: &GridDesc, ray: &Ray, t_start: f32, t_end: f32) -> Self {
        let dims = [desc.brick_dims[0], desc.brick_dims[1], desc.brick_dims[2]];
        Self::new(desc.brick_size as f32, dims, ray, t_start, t_end)
    }

    /// Traversal of the voxels of `desc` (regular tracking) from t_start to t_end.
    #[inline]
    pub fn voxels(desc: &GridDesc, ray: &Ray, t_start: f32, t_end: f32) -> Self {
        let dims = [desc.dims[0], desc.dims[1], desc.dims[2]];
        Self::new(1.0, dims, ray, t_start, t_end)
    }

    /// Traversal of cells of `size` voxels in a grid of `cells` cells, from t_start to t_end.
    pub fn new(size: f32, cells: [u32; 3], ray: &Ray, t_start: f32, t_end: f32) -> Self {
        let dims = [cells[0] as i32, cells[1] as i32, cells[2] as i32];
        let p = ray.at(t_start);
        let valid = t_start < t_end && math::is_finite(t_start) && math::is_finite(t_end);
        GridDda {
            cx: cell_of(p.x, size, dims[0]),
            cy: cell_of(p.y, size, dims[1]),
            cz: cell_of(p.z, size, dims[2]),
            sx: step_of(ray.d.x),
            sy: step_of(ray.d.y),
            sz: step_of(ray.d.z),
            inv: V3::new(
                inv_or_zero(ray.d.x),
                inv_or_zero(ray.d.y),
                inv_or_zero(ray.d.z),
            ),
            o: ray.o,
            t: t_start,
            t_end,
            size,
            dims,
            budget: (dims[0] + dims[1] + dims[2]) as u32 + 3,
            done: !valid,
        }
    }

    /// Parameter where the ray leaves the current cell along one axis (+inf if it never does).
    #[inline]
    fn exit(&self, c: i32, s: i32, o: f32, inv: f32) -> f32 {
        if s == 0 {
            return f32::INFINITY;
        }
        let plane = (c + if s > 0 { 1 } else { 0 }) as f32 * self.size;
        (plane - o) * inv
    }

    /// The current brick's segment; advances to the next brick. Call only while `!done`.
    pub fn step(&mut self) -> Segment {
        let tx = self.exit(self.cx, self.sx, self.o.x, self.inv.x);
        let ty = self.exit(self.cy, self.sy, self.o.y, self.inv.y);
        let tz = self.exit(self.cz, self.sz, self.o.z, self.inv.z);
        let cell = [self.cx as u32, self.cy as u32, self.cz as u32];
        let t0 = self.t;
        let mut t1 = tx;
        let mut axis = 0;
        if ty < t1 {
            t1 = ty;
            axis = 1;
        }
        if tz < t1 {
            t1 = tz;
            axis = 2;
        }
        if t1 < t0 {
            // A plane behind the start (start exactly on a boundary): zero-length segment.
            t1 = t0;
        }
        if t1 >= self.t_end {
            t1 = self.t_end;
            self.done = true;
        } else {
            if axis == 0 {
                self.cx += self.sx;
            } else if axis == 1 {
                self.cy += self.sy;
            } else {
                self.cz += self.sz;
            }
            if self.cx < 0
                || self.cy < 0
                || self.cz < 0
                || self.cx >= self.dims[0]
                || self.cy >= self.dims[1]
                || self.cz >= self.dims[2]
            {
                self.done = true;
            }
        }
        self.t = t1;
        if self.budget == 0 {
            self.done = true;
        } else {
            self.budget -= 1;
        }
        Segment { t0, t1, cell }
    }
}
