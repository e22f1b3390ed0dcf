//! What Alg. 2 and Alg. 1 ([`crate::estimators::wide`]) read of a volume, for the rays of
//! several lanes at once: a traversal of brick (or super-voxel) segments, the importance and
//! control variate of each segment's brick, and the extinction at a point. [`ScalarVolume`] is
//! the one-lane form over any [`VolumeView`] (every layout and lookup; the GPU's kernels and the
//! CPU's scalar paths); [`crate::volume::wide::WideVolume`] the form of several lanes on the
//! layouts where that is a few vector operations.

use crate::estimators::optical_depth::{importance, mu_at, mu_min};
use crate::geometry::Ray;
use crate::lanes::{Lanes, One};
use crate::params::Importance;
use crate::volume::grid::{Brick, Lookup, VolumeView};
use crate::volume::supervoxels::SuperVoxelDda;
use crate::volume::texels::Texels;

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
