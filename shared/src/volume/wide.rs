//! The brick traversal and the voxel lookups over several rays at once ([`Lanes`]): each lane
//! steps and reads exactly as [`GridDda::bricks`] and [`VolumeView::mu_nearest`] do for its ray,
//! on the layout where that is a few vector operations: the fixed grid of bricks (no adaptive
//! super-voxels), stepping through all-zero bricks, bricks of a power-of-two size, one pool
//! page, nearest or stochastic lookups ([`WideVolume::of`] says whether a view has it).
//!
//! [`GridDda::bricks`]: crate::volume::dda::GridDda::bricks

use crate::geometry::{Ray, V3};
use crate::lanes::Lanes;
use crate::volume::grid::{
    mu_nearest_lanes, GridDesc, Lookup, Tables, VolumeView, BRICK_DIVIDES, BRICK_WORDS,
};
use crate::volume::texels::Texels;
use crate::volume::walk::{start_of, valid, Start, Walk};

/// Most lanes a wide traversal (and the CPU's wide pass) holds.
pub const MAX_LANES: usize = 16;

/// Word of a [`crate::volume::grid::Brick`] record: `mu_min`.
pub const MU_MIN: u32 = 0;
/// Word of a brick record: `mean`.
pub const MEAN: u32 = 2;
/// Word of a brick record: the variance-aware importance `p`.
pub const P: u32 = 3;
/// Word of a brick record: `slot`.
pub const SLOT: u32 = 4;

/// The tables of a volume as 32-bit words, and the grid's description.
#[derive(Clone, Copy)]
pub struct WideVolume<'a> {
    bricks: &'a [u32],
    pool: &'a [u32],
    pub desc: GridDesc,
    pub lookup: Lookup,
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
            desc: *d,
            lookup,
            budget: d.brick_budget(),
        })
    }

    /// Bricks of the grid along each axis.
    #[inline(always)]
    fn grid(&self) -> [i32; 3] {
        let d = self.desc.brick_dims;
        [d[0] as i32, d[1] as i32, d[2] as i32]
    }

    /// Index of brick `c` in the table.
    #[inline(always)]
    fn brick_index<L: Lanes>(&self, c: [L::U; 3]) -> L::U {
        let d = self.desc.brick_dims;
        let (x, y) = (L::u(d[0]), L::u(d[1]));
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

    /// [`VolumeView::mu_nearest`] at index-space points `p` in lanes `m` (0 elsewhere).
    #[inline(always)]
    pub fn mu_nearest<L: Lanes>(&self, m: L::M, p: [L::F; 3]) -> L::F {
        mu_nearest_lanes::<L>(&self.desc, self, m, p)
    }
}

impl<L: Lanes> Tables<L> for WideVolume<'_> {
    #[inline(always)]
    fn slot(&self, m: L::M, b: [L::U; 3]) -> L::U {
        self.brick_word::<L>(m, b, SLOT)
    }

    #[inline(always)]
    fn pool_half(&self, m: L::M, index: L::U) -> L::U {
        let word = L::gather(self.pool, m, L::u_shr(index, L::u(1)));
        let shift = L::u_mul(L::u_and(index, L::u(1)), L::u(16));
        L::u_and(L::u_shr(word, shift), L::u(0xffff))
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
    walk: Walk<L>,
}

impl<L: Lanes> WideDda<L> {
    /// The traversal of lane l's ray from t_start to t_end (lanes off in `on` are done from
    /// the start).
    #[inline(always)]
    pub fn new(vol: &WideVolume, rays: &WideRays<L>, t_start: L::F, t_end: L::F, on: L::M) -> Self {
        let size = vol.desc.brick_size as f32;
        let grid = vol.grid();
        let none = Start {
            c: [0; 3],
            s: [0; 3],
            inv: [0.0; 3],
        };
        let st: [Start; MAX_LANES] = core::array::from_fn(|l| {
            if l < L::N {
                start_of(&rays.lane(l), L::f_at(t_start, l), size, [0; 3], grid)
            } else {
                none
            }
        });
        let valid = L::m_from(|l| valid(L::f_at(t_start, l), L::f_at(t_end, l)));
        let walk = Walk {
            c: [
                L::i_from(|l| st[l].c[0]),
                L::i_from(|l| st[l].c[1]),
                L::i_from(|l| st[l].c[2]),
            ],
            s: [
                L::i_from(|l| st[l].s[0]),
                L::i_from(|l| st[l].s[1]),
                L::i_from(|l| st[l].s[2]),
            ],
            inv: [
                L::f_from(|l| st[l].inv[0]),
                L::f_from(|l| st[l].inv[1]),
                L::f_from(|l| st[l].inv[2]),
            ],
            o: rays.o,
            t: t_start,
            t_end,
            budget: L::u(vol.budget),
            exhausted: L::m(false),
            done: !(valid & on),
        };
        WideDda { walk }
    }

    /// Lanes whose traversal has ended (or never began).
    #[inline(always)]
    pub fn done(&self) -> L::M {
        self.walk.done
    }

    /// Lanes whose traversal a budget ended before its end.
    #[inline(always)]
    pub fn exhausted(&self) -> L::M {
        self.walk.exhausted
    }

    /// [`crate::volume::dda::GridDda::step`] in lanes `a` (none of them done): each lane's
    /// current brick segment; advances them to their next brick.
    #[inline(always)]
    pub fn step(&mut self, vol: &WideVolume, a: L::M) -> WideSegment<L> {
        let size = vol.desc.brick_size as f32;
        let (t0, t1, cell) = self.walk.step(a, size, [0; 3], vol.grid());
        WideSegment { t0, t1, cell }
    }
}
