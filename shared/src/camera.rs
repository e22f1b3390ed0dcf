//! A pinhole camera and the world-to-index transform that puts its rays into the volume's grid.

use crate::dda::Ray;
use crate::vec3::V3;
use bytemuck::{Pod, Zeroable};

/// Pinhole camera in world space. `right` and `up` are pre-scaled by tan(fov/2) (and the aspect
/// ratio), so the ray through NDC (u, v) is forward + u right + v up.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Camera {
    pub origin: V3,
    pub _pad0: f32,
    pub forward: V3,
    pub _pad1: f32,
    pub right: V3,
    pub _pad2: f32,
    pub up: V3,
    pub _pad3: f32,
}

/// Row-major 3x4 affine map applied to points (with translation) and directions (without).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Affine3x4 {
    pub rows: [[f32; 4]; 3],
}

impl Affine3x4 {
    /// M p + t.
    #[inline]
    pub fn point(&self, p: V3) -> V3 {
        let r = &self.rows;
        V3::new(
            r[0][0] * p.x + r[0][1] * p.y + r[0][2] * p.z + r[0][3],
            r[1][0] * p.x + r[1][1] * p.y + r[1][2] * p.z + r[1][3],
            r[2][0] * p.x + r[2][1] * p.y + r[2][2] * p.z + r[2][3],
        )
    }

    /// M d.
    #[inline]
    pub fn vector(&self, d: V3) -> V3 {
        let r = &self.rows;
        V3::new(
            r[0][0] * d.x + r[0][1] * d.y + r[0][2] * d.z,
            r[1][0] * d.x + r[1][1] * d.y + r[1][2] * d.z,
            r[2][0] * d.x + r[2][1] * d.y + r[2][2] * d.z,
        )
    }
}

/// sqrt, correctly rounded on both targets (IEEE sqrt; measured identical on lavapipe).
#[inline]
pub fn sqrt(x: f32) -> f32 {
    core::f32::math::sqrt(x)
}

impl Camera {
    /// Primary ray through pixel (x, y) + (jx, jy) of a w x h image, as a world-space unit ray.
    #[inline]
    pub fn world_ray(&self, x: u32, y: u32, jx: f32, jy: f32, w: u32, h: u32) -> Ray {
        let u = 2.0 * ((x as f32 + jx) / w as f32) - 1.0;
        let v = 1.0 - 2.0 * ((y as f32 + jy) / h as f32);
        let d = self.forward + self.right * u + self.up * v;
        let len = sqrt(d.dot(d));
        Ray {
            o: self.origin,
            d: d * (1.0 / len),
        }
    }
}

/// A world-space unit ray in voxel index space; t keeps measuring world distance.
#[inline]
pub fn to_index_space(world: &Ray, world_to_index: &Affine3x4) -> Ray {
    Ray {
        o: world_to_index.point(world.o),
        d: world_to_index.vector(world.d),
    }
}
