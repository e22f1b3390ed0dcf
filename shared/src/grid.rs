//! Views of the high-resolution volume (f16 voxels) and of its super-voxel ("brick") grid.

use crate::half::packed_f16;
use crate::math;
use crate::vec3::V3;
use bytemuck::{Pod, Zeroable};

/// How the high-resolution volume is read at a point.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lookup {
    /// The voxel containing the point.
    Nearest = 0,
    /// Stochastic texture filtering: jitter by (PCG3D - 0.5) voxels, then nearest (Sec. 4.3).
    Stochastic = 1,
}

impl Lookup {
    /// From the `u32` stored in [`GridDesc`] (unknown values read as nearest).
    #[inline]
    pub fn from_u32(v: u32) -> Self {
        if v == 1 {
            Lookup::Stochastic
        } else {
            Lookup::Nearest
        }
    }
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
    pub _pad: u32,
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
}

/// The high-resolution volume and its bricks, borrowed from kernel buffers or host vectors.
#[derive(Clone, Copy)]
pub struct VolumeView<'a> {
    pub desc: &'a GridDesc,
    /// f16 voxels packed two per u32, x fastest.
    pub voxels: &'a [u32],
    /// Bricks, x fastest.
    pub bricks: &'a [Brick],
}

/// Clamps a floor'd coordinate to [0, n-1] (NaN-free inputs only).
#[inline]
fn clamp_index(v: f32, n: u32) -> u32 {
    if v < 0.0 {
        0
    } else if v >= n as f32 {
        n - 1
    } else {
        v as u32
    }
}

impl VolumeView<'_> {
    /// Extinction of voxel (i, j, k), density scale applied.
    #[inline]
    pub fn voxel(&self, i: u32, j: u32, k: u32) -> f32 {
        let d = &self.desc.dims;
        let index = i as usize + d[0] as usize * (j as usize + d[1] as usize * k as usize);
        self.desc.density_scale * packed_f16(self.voxels, index)
    }

    /// mu at index-space point p, nearest voxel, clamped to the grid's edge.
    #[inline]
    pub fn mu_nearest(&self, p: V3) -> f32 {
        let d = &self.desc.dims;
        self.voxel(
            clamp_index(math::floor(p.x), d[0]),
            clamp_index(math::floor(p.y), d[1]),
            clamp_index(math::floor(p.z), d[2]),
        )
    }

    /// Brick (bx, by, bz).
    #[inline]
    pub fn brick(&self, b: [u32; 3]) -> Brick {
        let d = &self.desc.brick_dims;
        self.bricks[b[0] as usize + d[0] as usize * (b[1] as usize + d[1] as usize * b[2] as usize)]
    }
}
