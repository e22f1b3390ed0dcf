//! What Alg. 2 and Alg. 1 ([`crate::estimators::wide`]) read of a volume, for the rays of
//! several lanes at once: a traversal of brick (or super-voxel) segments, the importance and
//! control variate of each segment's brick, and the extinction at a point. [`ScalarVolume`] is
//! the one-lane form over any [`VolumeView`] (every layout and lookup; the GPU's kernels and the
//! CPU's scalar paths); [`crate::volume::wide::WideVolume`] the form of several lanes on the
//! layouts where that is a few vector operations.

use crate::geometry::{Ray, V3};
use crate::lanes::{Lanes, One};
use crate::params::Importance;
use crate::rng::{pcg3d_lanes, unit_f32_lanes};
use crate::volume::grid::{Brick, Lookup, VolumeView};
use crate::volume::supervoxels::SuperVoxelDda;
use crate::volume::texels::Texels;
use crate::volume::wide::{WideDda, WideRays, WideVolume, MEAN, MU_MIN, P};

/// Sampling importance of a brick.
#[inline]
pub fn importance(b: &Brick, mode: Importance) -> f32 {
    match mode {
        Importance::VarianceAware => b.p,
        Importance::Mean => b.mean,
    }
}

/// Control variate mu_min of a brick (0 without a control variate).
#[inline]
pub fn mu_min(b: &Brick, mode: Importance) -> f32 {
    match mode {
        Importance::VarianceAware => b.mu_min,
        Importance::Mean => 0.0,
    }
}

/// Extinction at index-space point p with the chosen lookup; `key` decorrelates the jitter.
#[inline]
pub fn mu_at(vol: &VolumeView<impl Texels>, p: V3, lookup: Lookup, key: [u32; 3]) -> f32 {
    match lookup {
        Lookup::Nearest => vol.mu_nearest(p),
        Lookup::Stochastic => {
            let q = jitter::<One>([p.x, p.y, p.z], key);
            vol.mu_nearest(V3::new(q[0], q[1], q[2]))
        }
        Lookup::Trilinear => vol.mu_trilinear(p),
    }
}

/// The stochastic lookup's point: p moved by a uniform offset in [-1/2, 1/2)^3 from PCG3D of
/// `key`, lane by lane.
#[inline(always)]
pub fn jitter<L: Lanes>(p: [L::F; 3], key: [L::U; 3]) -> [L::F; 3] {
    let h = pcg3d_lanes::<L>(key);
    let half = L::f(0.5);
    [
        p[0] + (unit_f32_lanes::<L>(h[0]) - half),
        p[1] + (unit_f32_lanes::<L>(h[1]) - half),
        p[2] + (unit_f32_lanes::<L>(h[2]) - half),
    ]
}

/// A volume as Alg. 2 and Alg. 1 read it for the rays of `L`'s lanes. Masked lanes (`a`, `m`)
/// are the ones whose values are used; a form may skip the work of the others.
pub trait LaneVolume<L: Lanes> {
    /// The rays in index space, one per lane.
    type Rays: Copy;
    /// A traversal of each lane's segments.
    type Dda;
    /// What a step read of its segment's brick.
    type Brick: Copy;

    /// The traversal of each lane's ray over [t0, t1] (lanes off in `on` need not be
    /// traversed: the estimators never step them).
    fn dda(&self, rays: &Self::Rays, t0: L::F, t1: L::F, on: L::M) -> Self::Dda;
    /// Lanes whose traversal has ended.
    fn done(dda: &Self::Dda) -> L::M;
    /// Lanes whose traversal the iteration budget ended early.
    fn exhausted(dda: &Self::Dda) -> L::M;
    /// The current segment [t0, t1] of the lanes `a` (none of them done) and its brick, and
    /// advances them.
    fn step(&self, dda: &mut Self::Dda, a: L::M) -> (L::F, L::F, Self::Brick);
    /// The sampling importance of brick `b` in lanes `m` ([`importance`]).
    fn importance(&self, m: L::M, b: &Self::Brick, mode: Importance) -> L::F;
    /// The control variate of brick `b` in lanes `m` ([`mu_min`]).
    fn mu_min(&self, m: L::M, b: &Self::Brick, mode: Importance) -> L::F;
    /// The extinction at each lane's point along its ray at `t`, jitter keys `key`, in lanes
    /// `m` ([`mu_at`]; 0 elsewhere).
    fn mu_at(&self, m: L::M, rays: &Self::Rays, t: L::F, key: [L::U; 3]) -> L::F;
}

/// A [`VolumeView`] read one ray at a time, with the lookup the estimators use.
pub struct ScalarVolume<'a, T: Texels> {
    /// By value: a kernel's view holds texel buffers, which SPIR-V may not keep behind a pointer
    /// stored in a struct.
    pub view: VolumeView<'a, T>,
    pub lookup: Lookup,
}

impl<T: Texels> LaneVolume<One> for ScalarVolume<'_, T> {
    type Rays = Ray;
    type Dda = SuperVoxelDda;
    type Brick = Brick;

    #[inline]
    fn dda(&self, ray: &Ray, t0: f32, t1: f32, _on: bool) -> SuperVoxelDda {
        SuperVoxelDda::new(&self.view.desc, ray, t0, t1)
    }

    #[inline]
    fn done(dda: &SuperVoxelDda) -> bool {
        dda.done()
    }

    #[inline]
    fn exhausted(dda: &SuperVoxelDda) -> bool {
        dda.exhausted()
    }

    #[inline]
    fn step(&self, dda: &mut SuperVoxelDda, _a: bool) -> (f32, f32, Brick) {
        let (seg, b) = dda.step(&self.view);
        (seg.t0, seg.t1, b)
    }

    #[inline]
    fn importance(&self, _m: bool, b: &Brick, mode: Importance) -> f32 {
        importance(b, mode)
    }

    #[inline]
    fn mu_min(&self, _m: bool, b: &Brick, mode: Importance) -> f32 {
        mu_min(b, mode)
    }

    #[inline]
    fn mu_at(&self, m: bool, ray: &Ray, t: f32, key: [u32; 3]) -> f32 {
        if m {
            mu_at(&self.view, ray.at(t), self.lookup, key)
        } else {
            0.0
        }
    }
}

/// The importance word of a brick record (see [`importance`]).
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
        dda.done()
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
        let p = rays.at(t);
        let q = if self.lookup == Lookup::Stochastic {
            jitter::<L>(p, key)
        } else {
            p
        };
        self.mu_nearest::<L>(m, q)
    }
}
