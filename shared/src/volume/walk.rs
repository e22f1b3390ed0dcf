//! The stepping state of an Amanatides-Woo traversal over lanes ([`Lanes`]) and its step: the one
//! body of [`crate::volume::dda::GridDda::step`] (one lane) and of the CPU's wide brick traversal
//! ([`crate::volume::wide::WideDda`], several). Boundary parameters are computed from the plane
//! each time ((plane - o) / d), never accumulated, so two traversals of one ray agree on every t.

use crate::geometry::Ray;
use crate::lanes::{Lanes, One};
use crate::math;

/// Whether [`Walk::step`] guards the moves with `if L::any(advance)`, which changes no bit: on
/// the CPU one lane then branches, and its next step runs ahead on the predicted path instead of
/// waiting on this step's compares through a chain of selects; in the kernels the guard folds
/// away, since lavapipe runs an `if` under masks and merges what its arm writes through memory
/// (speed.md, section "Step").
const GUARDS: bool = !cfg!(target_arch = "spirv");

/// Sign of d as a step: +1, -1, or 0 for an axis the ray does not move along.
#[inline]
pub(crate) fn step_of(d: f32) -> i32 {
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
pub(crate) fn inv_or_zero(d: f32) -> f32 {
    if d == 0.0 {
        0.0
    } else {
        1.0 / d
    }
}

/// Cell index of coordinate v, clamped to [lo, n-1].
#[inline]
pub(crate) fn cell_of(v: f32, size: f32, lo: i32, n: i32) -> i32 {
    let c = math::floor(v / size);
    if !(c >= lo as f32) {
        lo
    } else if c >= n as f32 {
        n - 1
    } else {
        c as i32
    }
}

/// Where each lane's traversal stands: its cell `c`, step `s` and 1/d per axis, origin `o`, the
/// parameter `t` it reached and its end, the iterations left, and whether the budget ended it
/// before its end (`exhausted`) or it ended (`done`).
#[derive(Clone, Copy, Debug)]
pub struct Walk<L: Lanes> {
    pub c: [L::I; 3],
    pub s: [L::I; 3],
    pub inv: [L::F; 3],
    pub o: [L::F; 3],
    pub t: L::F,
    pub t_end: L::F,
    pub budget: L::U,
    pub exhausted: L::M,
    pub done: L::M,
}

/// Where one ray's traversal of the cells [lo, n) of `size` voxels starts at t_start: its cell,
/// and per axis its step and 1/d. Constant indices only (no bounds checks in the kernels).
#[inline]
pub(crate) fn start_of(ray: &Ray, t_start: f32, size: f32, lo: [i32; 3], n: [i32; 3]) -> Start {
    let p = ray.at(t_start);
    Start {
        c: [
            cell_of(p.x, size, lo[0], n[0]),
            cell_of(p.y, size, lo[1], n[1]),
            cell_of(p.z, size, lo[2], n[2]),
        ],
        s: [step_of(ray.d.x), step_of(ray.d.y), step_of(ray.d.z)],
        inv: [
            inv_or_zero(ray.d.x),
            inv_or_zero(ray.d.y),
            inv_or_zero(ray.d.z),
        ],
    }
}

/// [`start_of`]'s result.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Start {
    pub c: [i32; 3],
    pub s: [i32; 3],
    pub inv: [f32; 3],
}

/// Whether a traversal of [t_start, t_end] has anything to traverse (non-empty, finite).
#[inline]
pub(crate) fn valid(t_start: f32, t_end: f32) -> bool {
    t_start < t_end && math::is_finite(t_start) && math::is_finite(t_end)
}

impl Walk<One> {
    /// One ray's traversal of the cells [lo, n) of `size` voxels from t_start to t_end, with
    /// `budget` iterations (an empty or non-finite range is done from the start).
    #[inline]
    pub fn start(
        ray: &Ray,
        t_start: f32,
        t_end: f32,
        size: f32,
        lo: [i32; 3],
        n: [i32; 3],
        budget: u32,
    ) -> Self {
        let st = start_of(ray, t_start, size, lo, n);
        Walk {
            c: st.c,
            s: st.s,
            inv: st.inv,
            o: [ray.o.x, ray.o.y, ray.o.z],
            t: t_start,
            t_end,
            budget,
            exhausted: false,
            done: !valid(t_start, t_end),
        }
    }
}

impl<L: Lanes> Walk<L> {
    /// Parameter where a ray with step `s`, origin `o` and 1/d `inv` along an axis leaves its
    /// cell `c` there (cells of `size` voxels), +inf where it does not move along the axis.
    #[inline(always)]
    pub fn exit(c: L::I, s: L::I, o: L::F, inv: L::F, size: f32) -> L::F {
        let up = L::i_sel(L::i_gt(s, L::i(0)), L::i(1), L::i(0));
        let plane = L::i_to_f(L::i_add(c, up)) * L::f(size);
        let e = (plane - o) * inv;
        L::f_sel(L::i_eq(s, L::i(0)), L::f(f32::INFINITY), e)
    }

    /// One iteration of the budget in lanes `a` (the guard against endless loops): a lane with
    /// none left ends, exhausted unless it had ended anyway.
    #[inline(always)]
    pub fn spend(&mut self, a: L::M) {
        let spent = a & L::u_eq(self.budget, L::u(0));
        self.exhausted = (spent & !self.done) | (!spent & self.exhausted);
        self.done = self.done | spent;
        let left = L::u_sub(self.budget, L::u(1));
        self.budget = L::u_sel(a & !spent, left, self.budget);
    }

    /// The current cell's segment [t0, t1] and the cell in lanes `a` (none of them done), and
    /// advances them to the next cell of the cells [lo, n) of `size` voxels: the crossing with
    /// the smallest parameter, the lower axis on ties; a segment ends at t_end.
    #[inline(always)]
    pub fn step(
        &mut self,
        a: L::M,
        size: f32,
        lo: [i32; 3],
        n: [i32; 3],
    ) -> (L::F, L::F, [L::U; 3]) {
        let (c, st, o, inv) = (self.c, self.s, self.o, self.inv);
        let tx = Self::exit(c[0], st[0], o[0], inv[0], size);
        let ty = Self::exit(c[1], st[1], o[1], inv[1], size);
        let tz = Self::exit(c[2], st[2], o[2], inv[2], size);
        let cell = [
            L::i_to_u(self.c[0]),
            L::i_to_u(self.c[1]),
            L::i_to_u(self.c[2]),
        ];
        let t0 = self.t;
        let mut t1 = tx;
        let mut axis = L::i(0);
        let m = L::f_lt(ty, t1);
        t1 = L::f_sel(m, ty, t1);
        axis = L::i_sel(m, L::i(1), axis);
        let m = L::f_lt(tz, t1);
        t1 = L::f_sel(m, tz, t1);
        axis = L::i_sel(m, L::i(2), axis);
        // A plane behind the start (start exactly on a boundary): a zero-length segment.
        t1 = L::f_sel(L::f_lt(t1, t0), t0, t1);
        let end = L::f_ge(t1, self.t_end);
        t1 = L::f_sel(end, self.t_end, t1);
        let advance = a & !end;
        // The guard changes no bit (a lane that does not advance keeps its cell): see
        // [`GUARDS`].
        let mut outside = L::m(false);
        if !GUARDS || L::any(advance) {
            let moves_x = advance & L::i_eq(axis, L::i(0));
            let moves_y = advance & L::i_eq(axis, L::i(1));
            let moves_z = advance & L::i_eq(axis, L::i(2));
            self.c = [
                L::i_sel(moves_x, L::i_add(c[0], st[0]), c[0]),
                L::i_sel(moves_y, L::i_add(c[1], st[1]), c[1]),
                L::i_sel(moves_z, L::i_add(c[2], st[2]), c[2]),
            ];
            let c = self.c;
            outside = L::i_lt(c[0], L::i(lo[0]))
                | L::i_lt(c[1], L::i(lo[1]))
                | L::i_lt(c[2], L::i(lo[2]))
                | L::i_ge(c[0], L::i(n[0]))
                | L::i_ge(c[1], L::i(n[1]))
                | L::i_ge(c[2], L::i(n[2]));
        }
        self.done = self.done | (a & (end | (advance & outside)));
        self.t = L::f_sel(a, t1, self.t);
        self.spend(a);
        (t0, t1, cell)
    }
}
