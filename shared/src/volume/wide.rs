//! The brick traversal and the voxel lookups over several rays at once ([`Lanes`]): each lane
//! steps and reads exactly as [`GridDda::bricks`] and [`VolumeView::mu_nearest`] do for its ray,
//! on the layout where that is a few vector operations: the fixed grid of bricks (no adaptive
//! super-voxels), stepping through all-zero bricks, bricks of a power-of-two size, one pool
//! page, nearest or stochastic lookups ([`WideVolume::of`] says whether a view has it).
//!
//! [`GridDda::bricks`]: crate::volume::dda::GridDda::bricks

use crate::geometry::{Ray, V3};
use crate::lanes::{f16_to_f32, pcg3d, unit_f32, Lanes};
use crate::math;
use crate::params::Importance;
use crate::volume::dda::{cell_of, inv_or_zero, step_of};
use crate::volume::grid::{Lookup, VolumeView, BRICK_DIVIDES, BRICK_WORDS, FIRST_EMPTY_SLOT};
use crate::volume::lane_volume::LaneVolume;
use crate::volume::texels::Texels;

/// Word of a [`crate::volume::grid::Brick`] record: `mu_min`.
pub const MU_MIN: u32 = 0;
/// Word of a brick record: `mean`.
pub const MEAN: u32 = 2;
/// Word of a brick record: the variance-aware importance `p`.
pub const P: u32 = 3;
/// Word of a brick record: `slot`.
pub const SLOT: u32 = 4;

/// The tables of a volume as 32-bit words, and the grid's shape.
#[derive(Clone, Copy)]
pub struct WideVolume<'a> {
    bricks: &'a [u32],
    pool: &'a [u32],
    brick_dims: [u32; 3],
    dims: [u32; 3],
    brick_size: u32,
    brick_log2: u32,
    density_scale: f32,
    lookup: Lookup,
    budget: u32,
}

impl<'a> WideVolume<'a> {
    /// The wide form of `view`, where its layout is the one this module reads (fixed grid,
    /// stepping, power-of-two bricks, one pool page, tables in slices, nearest or stochastic
    /// lookups); None elsewhere.
    #[inline(always)]
    pub fn of<T: Texels>(view: &VolumeView<'a, T>) -> Option<Self> {
        let d = &view.desc;
        let lookup = Lookup::from_u32(d.lookup);
        let one_page = view.voxels.single || view.voxels.p1.is_empty();
        let fits = (d.cells_per_brick() == 1)
            & (d.brick_stepping == 1)
            & (d.brick_log2 < BRICK_DIVIDES)
            & !view.texels.bound()
            & one_page
            & (lookup != Lookup::Trilinear);
        if !fits {
            return None;
        }
        Some(WideVolume {
            bricks: bytemuck::cast_slice(view.bricks),
            pool: view.voxels.p0,
            brick_dims: [d.brick_dims[0], d.brick_dims[1], d.brick_dims[2]],
            dims: [d.dims[0], d.dims[1], d.dims[2]],
            brick_size: d.brick_size,
            brick_log2: d.brick_log2,
            density_scale: d.density_scale,
            lookup,
            budget: d.brick_budget(),
        })
    }

    /// Index of brick `c` in the table.
    #[inline(always)]
    fn brick_index<L: Lanes>(&self, c: [L::U; 3]) -> L::U {
        let (x, y) = (L::u(self.brick_dims[0]), L::u(self.brick_dims[1]));
        L::u_add(c[0], L::u_mul(x, L::u_add(c[1], L::u_mul(y, c[2]))))
    }

    /// Word `k` of the record of brick `c` in lanes `m` (0 elsewhere).
    #[inline(always)]
    pub fn brick_word<L: Lanes>(&self, m: L::M, c: [L::U; 3], k: u32) -> L::U {
        let i = L::u_add(
            L::u_mul(self.brick_index::<L>(c), L::u(BRICK_WORDS)),
            L::u(k),
        );
        L::gather(self.bricks, m, i)
    }

    /// [`VolumeView::voxel`] of voxel (i, j, k) in lanes `m` (0 elsewhere).
    #[inline(always)]
    fn voxel<L: Lanes>(&self, m: L::M, v: [L::U; 3]) -> L::F {
        let sh = L::u(self.brick_log2);
        let b = [L::u_shr(v[0], sh), L::u_shr(v[1], sh), L::u_shr(v[2], sh)];
        let slot = self.brick_word::<L>(m, b, SLOT);
        let stores = m & L::u_lt(slot, L::u(FIRST_EMPTY_SLOT));
        let size = L::u(self.brick_size);
        let extent = |axis: usize| {
            let rest = L::u_sub(L::u(self.dims[axis]), L::u_mul(b[axis], size));
            L::u_sel(L::u_lt(rest, size), rest, size)
        };
        let (w, h) = (extent(0), extent(1));
        let local = |axis: usize| L::u_sub(v[axis], L::u_mul(b[axis], size));
        let inner = L::u_add(local(1), L::u_mul(h, local(2)));
        let index = L::u_add(slot, L::u_add(local(0), L::u_mul(w, inner)));
        let word = L::gather(self.pool, stores, L::u_shr(index, L::u(1)));
        let shift = L::u_mul(L::u_and(index, L::u(1)), L::u(16));
        let half = L::u_and(L::u_shr(word, shift), L::u(0xffff));
        let mu = L::f(self.density_scale) * f16_to_f32::<L>(half);
        L::f_sel(stores, mu, L::f(0.0))
    }

    /// `clamp(floor(v), 0, n - 1)` as [`VolumeView::mu_nearest`] takes it.
    #[inline(always)]
    fn floor_index<L: Lanes>(v: L::F, n: u32) -> L::U {
        let below = !L::f_ge(v, L::f(1.0));
        let above = L::f_ge(v, L::f(n as f32));
        let inside = L::f_to_u(L::f_sel(below | above, L::f(0.0), v));
        L::u_sel(below, L::u(0), L::u_sel(above, L::u(n - 1), inside))
    }

    /// [`crate::estimators::optical_depth::mu_at`] at index-space points `p` in lanes `m` (0
    /// elsewhere), jitter keys `key`.
    #[inline(always)]
    pub fn mu_at_points<L: Lanes>(&self, m: L::M, p: [L::F; 3], key: [L::U; 3]) -> L::F {
        let q = if self.lookup == Lookup::Stochastic {
            let h = pcg3d::<L>(key);
            let half = L::f(0.5);
            [
                p[0] + (unit_f32::<L>(h[0]) - half),
                p[1] + (unit_f32::<L>(h[1]) - half),
                p[2] + (unit_f32::<L>(h[2]) - half),
            ]
        } else {
            p
        };
        let v = [
            Self::floor_index::<L>(q[0], self.dims[0]),
            Self::floor_index::<L>(q[1], self.dims[1]),
            Self::floor_index::<L>(q[2], self.dims[2]),
        ];
        self.voxel::<L>(m, v)
    }
}

/// Rays in index space, one per lane.
#[derive(Clone, Copy)]
pub struct WideRays<L: Lanes> {
    pub o: [L::F; 3],
    pub d: [L::F; 3],
}

impl<L: Lanes> WideRays<L> {
    /// Lane l's ray.
    #[inline(always)]
    pub fn lane(&self, l: usize) -> Ray {
        Ray {
            o: V3::new(
                L::f_at(self.o[0], l),
                L::f_at(self.o[1], l),
                L::f_at(self.o[2], l),
            ),
            d: V3::new(
                L::f_at(self.d[0], l),
                L::f_at(self.d[1], l),
                L::f_at(self.d[2], l),
            ),
        }
    }

    /// Lane l holds `rays[l]`.
    #[inline(always)]
    pub fn of(rays: &[Ray]) -> Self {
        WideRays {
            o: [
                L::f_from(|l| rays[l].o.x),
                L::f_from(|l| rays[l].o.y),
                L::f_from(|l| rays[l].o.z),
            ],
            d: [
                L::f_from(|l| rays[l].d.x),
                L::f_from(|l| rays[l].d.y),
                L::f_from(|l| rays[l].d.z),
            ],
        }
    }

    /// [`Ray::at`] lane by lane.
    #[inline(always)]
    pub fn at(&self, t: L::F) -> [L::F; 3] {
        [
            self.o[0] + self.d[0] * t,
            self.o[1] + self.d[1] * t,
            self.o[2] + self.d[2] * t,
        ]
    }
}

/// One brick segment per lane: [t0, t1] in brick `cell`.
#[derive(Clone, Copy)]
pub struct WideSegment<L: Lanes> {
    pub t0: L::F,
    pub t1: L::F,
    pub cell: [L::U; 3],
}

/// [`crate::volume::dda::GridDda::bricks`], stepping, one traversal per lane.
#[derive(Clone, Copy)]
pub struct WideDda<L: Lanes> {
    c: [L::I; 3],
    s: [L::I; 3],
    inv: [L::F; 3],
    o: [L::F; 3],
    t: L::F,
    t_end: L::F,
    budget: L::U,
    exhausted: L::M,
    /// Lanes whose traversal has ended (or never began).
    pub done: L::M,
}

impl<L: Lanes> WideDda<L> {
    /// The traversal of lane l's ray from t_start to t_end (lanes off in `on` are done from
    /// the start).
    #[inline(always)]
    pub fn new(vol: &WideVolume, rays: &WideRays<L>, t_start: L::F, t_end: L::F, on: L::M) -> Self {
        let size = vol.brick_size as f32;
        let cell = |a: usize| {
            L::i_from(|l| {
                let p = rays.lane(l).at(L::f_at(t_start, l));
                let v = [p.x, p.y, p.z][a];
                cell_of(v, size, 0, vol.brick_dims[a] as i32)
            })
        };
        let step = |a: usize| L::i_from(|l| step_of(L::f_at(rays.d[a], l)));
        let inv = |a: usize| L::f_from(|l| inv_or_zero(L::f_at(rays.d[a], l)));
        let valid = L::m_from(|l| {
            let (a, b) = (L::f_at(t_start, l), L::f_at(t_end, l));
            a < b && math::is_finite(a) && math::is_finite(b)
        });
        WideDda {
            c: [cell(0), cell(1), cell(2)],
            s: [step(0), step(1), step(2)],
            inv: [inv(0), inv(1), inv(2)],
            o: rays.o,
            t: t_start,
            t_end,
            budget: L::u(vol.budget),
            exhausted: L::m(false),
            done: !(valid & on),
        }
    }

    /// Lanes whose traversal a budget ended before its end.
    #[inline(always)]
    pub fn exhausted(&self) -> L::M {
        self.exhausted
    }

    /// [`crate::volume::dda::GridDda::step`] in lanes `a` (none of them done): each lane's
    /// current brick segment; advances them to their next brick.
    #[inline(always)]
    pub fn step(&mut self, vol: &WideVolume, a: L::M) -> WideSegment<L> {
        let size = L::f(vol.brick_size as f32);
        let exit = |k: usize| {
            let up = L::i_sel(L::i_gt(self.s[k], L::i(0)), L::i(1), L::i(0));
            let plane = L::i_to_f(L::i_add(self.c[k], up)) * size;
            let e = (plane - self.o[k]) * self.inv[k];
            L::f_sel(L::i_eq(self.s[k], L::i(0)), L::f(f32::INFINITY), e)
        };
        let (tx, ty, tz) = (exit(0), exit(1), exit(2));
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
        t1 = L::f_sel(L::f_lt(t1, t0), t0, t1);
        let end = L::f_ge(t1, self.t_end);
        t1 = L::f_sel(end, self.t_end, t1);
        let advance = a & !end;
        let mut outside = L::m(false);
        for k in 0..3 {
            let moves = advance & L::i_eq(axis, L::i(k as i32));
            self.c[k] = L::i_sel(moves, L::i_add(self.c[k], self.s[k]), self.c[k]);
            let n = L::i(vol.brick_dims[k] as i32);
            outside = outside | L::i_lt(self.c[k], L::i(0)) | L::i_ge(self.c[k], n);
        }
        let done = self.done | (a & (end | (advance & outside)));
        self.t = L::f_sel(a, t1, self.t);
        let spent = a & L::u_eq(self.budget, L::u(0));
        self.exhausted = (spent & !done) | (!spent & self.exhausted);
        self.done = done | spent;
        let left = L::u_sub(self.budget, L::u(1));
        self.budget = L::u_sel(a & !spent, left, self.budget);
        WideSegment { t0, t1, cell }
    }
}

/// The importance word of a brick record (see [`crate::estimators::optical_depth::importance`]).
#[inline(always)]
fn importance_word(mode: Importance) -> u32 {
    match mode {
        Importance::VarianceAware => P,
        Importance::Mean => MEAN,
    }
}

impl<L: Lanes> LaneVolume<L> for WideVolume<'_> {
    type Rays = WideRays<L>;
    type Dda = WideDda<L>;
    /// The brick's cell (its record is read where a word of it is used).
    type Brick = [L::U; 3];

    #[inline(always)]
    fn dda(&self, rays: &WideRays<L>, t0: L::F, t1: L::F, on: L::M) -> WideDda<L> {
        WideDda::new(self, rays, t0, t1, on)
    }

    #[inline(always)]
    fn done(dda: &WideDda<L>) -> L::M {
        dda.done
    }

    #[inline(always)]
    fn exhausted(dda: &WideDda<L>) -> L::M {
        dda.exhausted()
    }

    #[inline(always)]
    fn step(&self, dda: &mut WideDda<L>, a: L::M) -> (L::F, L::F, [L::U; 3]) {
        let seg = dda.step(self, a);
        (seg.t0, seg.t1, seg.cell)
    }

    #[inline(always)]
    fn importance(&self, m: L::M, cell: &[L::U; 3], mode: Importance) -> L::F {
        L::f_from_bits(self.brick_word::<L>(m, *cell, importance_word(mode)))
    }

    #[inline(always)]
    fn mu_min(&self, m: L::M, cell: &[L::U; 3], mode: Importance) -> L::F {
        match mode {
            Importance::VarianceAware => L::f_from_bits(self.brick_word::<L>(m, *cell, MU_MIN)),
            Importance::Mean => L::f(0.0),
        }
    }

    #[inline(always)]
    fn mu_at(&self, m: L::M, rays: &WideRays<L>, t: L::F, key: [L::U; 3]) -> L::F {
        self.mu_at_points::<L>(m, rays.at(t), key)
    }
}
