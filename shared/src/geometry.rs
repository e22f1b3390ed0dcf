//! Geometry: a 3-vector with explicit, unfused arithmetic (identical on CPU and GPU), rays, and
//! the affine maps between world and voxel index space.

use bytemuck::{Pod, Zeroable};
use core::ops::{Add, Mul, Sub};

/// (x, y, z) in f32.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct V3 {
    pub x: f32,
    pub y: f32,
    pub z: f32,
}

impl V3 {
    #[inline]
    pub const fn new(x: f32, y: f32, z: f32) -> Self {
        V3 { x, y, z }
    }

    /// Component `i` (0 = x, 1 = y, 2 = z).
    #[inline]
    pub fn get(self, i: usize) -> f32 {
        match i {
            0 => self.x,
            1 => self.y,
            _ => self.z,
        }
    }

    /// Dot product, summed x + y + z in that order.
    #[inline]
    pub fn dot(self, o: V3) -> f32 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// Componentwise product.
    #[inline]
    pub fn mul_v(self, o: V3) -> V3 {
        V3::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
}

/// Cross product a x b.
#[inline]
pub fn cross(a: V3, b: V3) -> V3 {
    V3::new(
        a.y * b.z - a.z * b.y,
        a.z * b.x - a.x * b.z,
        a.x * b.y - a.y * b.x,
    )
}

/// Two unit vectors (t, b) that make (t, b, n) a right-handed orthonormal frame around the unit
/// vector n (Duff et al. 2017, "Building an Orthonormal Basis, Revisited", branch on sign only).
#[inline]
pub fn frame_from_z(n: V3) -> (V3, V3) {
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        V3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        V3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// The direction sin(theta) (cos(phi) t + sin(phi) b) + cos(theta) n of a frame (t, b, n).
#[inline]
pub fn from_frame(t: V3, b: V3, n: V3, sin_theta: f32, cos_theta: f32, phi: f32) -> V3 {
    let (s, c) = crate::math::sin_cos(phi);
    t * (sin_theta * c) + b * (sin_theta * s) + n * cos_theta
}

impl Add for V3 {
    type Output = V3;
    #[inline]
    fn add(self, o: V3) -> V3 {
        V3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl Sub for V3 {
    type Output = V3;
    #[inline]
    fn sub(self, o: V3) -> V3 {
        V3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Mul<f32> for V3 {
    type Output = V3;
    #[inline]
    fn mul(self, k: f32) -> V3 {
        V3::new(self.x * k, self.y * k, self.z * k)
    }
}

/// A ray x(t) = o + t d in voxel index space. `d` is the world-space unit direction mapped to
/// index space, so t stays a world-space distance and extinction stays per world unit.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Ray {
    pub o: V3,
    pub d: V3,
}

impl Ray {
    /// The point at parameter t.
    #[inline]
    pub fn at(&self, t: f32) -> V3 {
        self.o + self.d * t
    }
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

/// A world-space unit ray in voxel index space; t keeps measuring world distance.
#[inline]
pub fn to_index_space(world: &Ray, world_to_index: &Affine3x4) -> Ray {
    Ray {
        o: world_to_index.point(world.o),
        d: world_to_index.vector(world.d),
    }
}
