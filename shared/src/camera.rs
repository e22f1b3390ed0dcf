//! A pinhole camera in world space.

use crate::geometry::{Ray, V3};
use crate::math::sqrt;
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
