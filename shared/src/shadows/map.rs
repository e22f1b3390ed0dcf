//! An orthographic moment shadow map of a directional light over a volume: texel (i, j) holds
//! the four moments b_1 .. b_4 of the absorption depth distribution along the light ray through
//! its centre (exact for the nearest-neighbour grid: per voxel segment, the light absorbed there,
//! e^-tau0 - e^-tau1, as an atom at the segment's midpoint; the light left at the far plane as an
//! atom at depth 1). Moments are linear in the distribution, so the map filters: a lookup
//! interpolates the moments of the four nearest texel centres bilinearly before the
//! reconstruction.

use super::msm::{add_atom, bias, shadow_estimate, Moments4, ALPHA_F32, TARGET_F32};
use crate::geometry::{to_index_space, Affine3x4, Ray, V3};
use crate::math::{exp, floor};
use crate::volume::dda::{clip_to_box, GridDda};
use crate::volume::grid::VolumeView;
use bytemuck::{Pod, Zeroable};

/// The light-space frame of a map: texel (i, j) covers origin + [i, i+1)/width axis_u +
/// [j, j+1)/height axis_v on the near plane; depth runs along `dir` (the direction the light
/// travels, unit, orthogonal to both axes, which are orthogonal) over `depth_len` world units.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MsmDesc {
    pub origin: V3,
    pub width: u32,
    pub axis_u: V3,
    pub height: u32,
    pub axis_v: V3,
    pub depth_len: f32,
    pub dir: V3,
    pub _pad: u32,
}

impl MsmDesc {
    /// The world ray of texel centre (i, j), from the near plane along `dir`.
    #[inline]
    pub fn texel_ray(&self, i: u32, j: u32) -> Ray {
        let u = (i as f32 + 0.5) / self.width as f32;
        let v = (j as f32 + 0.5) / self.height as f32;
        Ray {
            o: self.origin + self.axis_u * u + self.axis_v * v,
            d: self.dir,
        }
    }

    /// World point x as (u, v) in texels (texel centres at k + 0.5) and signed depth in [-1, 1].
    #[inline]
    pub fn project(&self, x: V3) -> (f32, f32, f32) {
        let r = x - self.origin;
        let u = r.dot(self.axis_u) / self.axis_u.dot(self.axis_u) * self.width as f32;
        let v = r.dot(self.axis_v) / self.axis_v.dot(self.axis_v) * self.height as f32;
        let z = 2.0 * r.dot(self.dir) / self.depth_len - 1.0;
        (u, v, z)
    }
}

/// Signed depth of distance s along a texel ray.
#[inline]
fn depth(desc: &MsmDesc, s: f32) -> f32 {
    2.0 * s / desc.depth_len - 1.0
}

/// Moments b_0 .. b_4 of texel (i, j) (b_0 = 1), by a voxel DDA along its light ray.
pub fn build_texel(
    vol: &VolumeView,
    world_to_index: &Affine3x4,
    desc: &MsmDesc,
    i: u32,
    j: u32,
) -> Moments4 {
    let world = desc.texel_ray(i, j);
    let ray = to_index_space(&world, world_to_index);
    let d = &vol.desc.dims;
    let hi = V3::new(d[0] as f32, d[1] as f32, d[2] as f32);
    let (t0, t1) = clip_to_box(&ray, hi, 0.0, desc.depth_len);
    let mut b: Moments4 = [0.0; 5];
    let mut transmittance = 1.0f32;
    if t0 < t1 {
        let cap = d[0] + d[1] + d[2] + 4;
        let mut tau = 0.0f32;
        let mut visited = 0u32;
        let mut dda = GridDda::voxels(vol.desc, &ray, t0, t1);
        while !dda.done && visited < cap {
            let seg = dda.step();
            tau += (seg.t1 - seg.t0) * vol.voxel(seg.cell[0], seg.cell[1], seg.cell[2]);
            let next = exp(-tau);
            let absorbed = transmittance - next;
            if absorbed > 0.0 {
                b = add_atom(b, depth(desc, 0.5 * (seg.t0 + seg.t1)), absorbed);
            }
            transmittance = next;
            visited += 1;
        }
    }
    add_atom(b, 1.0, transmittance)
}

/// The moments at texel coordinates (u, v), bilinear between texel centres (clamped at the
/// edges); `map` holds b_1 .. b_4 per texel, row-major.
pub fn filtered_moments(desc: &MsmDesc, map: &[f32], u: f32, v: f32) -> Moments4 {
    let (i0, fu) = split(u - 0.5, desc.width);
    let (j0, fv) = split(v - 0.5, desc.height);
    let i1 = if i0 + 1 < desc.width { i0 + 1 } else { i0 };
    let j1 = if j0 + 1 < desc.height { j0 + 1 } else { j0 };
    let mut b: Moments4 = [1.0, 0.0, 0.0, 0.0, 0.0];
    let corners = [
        (i0, j0, (1.0 - fu) * (1.0 - fv)),
        (i1, j0, fu * (1.0 - fv)),
        (i0, j1, (1.0 - fu) * fv),
        (i1, j1, fu * fv),
    ];
    let mut c = 0;
    while c < 4 {
        let (i, j, w) = corners[c];
        let k = 4 * (j * desc.width + i) as usize;
        let mut m = 0;
        while m < 4 {
            b[m + 1] += w * map[k + m];
            m += 1;
        }
        c += 1;
    }
    b
}

/// floor(x) clamped to 0..n-1 and the fraction (0 at the clamped edges).
#[inline]
fn split(x: f32, n: u32) -> (u32, f32) {
    let f = floor(x);
    if !(f >= 0.0) {
        return (0, 0.0);
    }
    if f >= (n - 1) as f32 {
        return (n - 1, 0.0);
    }
    (f as u32, x - f)
}

/// Transmittance toward the light at world point x from a four-moment map: 1 minus the midpoint
/// (beta = 1/2) of the shadow bounds of the filtered, biased moments.
pub fn transmittance4(desc: &MsmDesc, map: &[f32], x: V3) -> f32 {
    let (u, v, z) = desc.project(x);
    let b = bias(filtered_moments(desc, map, u, v), ALPHA_F32, TARGET_F32);
    1.0 - shadow_estimate(b, z, 0.5)
}
