//! An orthographic moment shadow map of a directional light over a volume: texel (i, j) holds
//! the moments b_1 .. b_4 (or b_1 .. b_6) of the absorption depth distribution along the light
//! ray through its centre (exact for the nearest-neighbour grid: per voxel segment, the light
//! absorbed there, e^-tau0 - e^-tau1, as an atom at the segment's midpoint; the light left at
//! the far plane as an atom at depth 1). Moments are linear in the distribution, so the map filters: a lookup
//! interpolates the moments of the four nearest texel centres bilinearly before the
//! reconstruction.

use super::msm::{
    add_atom6, bias, bias6, dequantize_u16, quantize_u16, shadow_bounds6_flagged,
    shadow_bounds_flagged, shadow_estimate, Moments4, Moments6, ALPHA6_F32, ALPHA_F32, ALPHA_U16,
    TARGET6, TARGET_F32, TARGET_U16,
};
use crate::geometry::{to_index_space, Affine3x4, Ray, V3};
use crate::math::{exp, floor};
use crate::volume::dda::{clip_to_box, GridDda};
use crate::volume::grid::VolumeView;
use crate::volume::texels::Texels;
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
    /// All bits set (`u32::MAX`): a value no compiler can know, the barrier of
    /// [`crate::math::rounded`] in the 16-bit quantization ([`super::msm::quantize_u16`]).
    pub ones: u32,
    /// [`super::msm::U16_DEQUANT`], read at run time (see [`dequantize_u16`]).
    pub dequant: [f32; 12],
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
        // (2 d - len) / len, not 2 d / len - 1: shader compilers move an added constant
        // outward through later sums, which rounds differently from the CPU.
        let z = (2.0 * r.dot(self.dir) - self.depth_len) / self.depth_len;
        (u, v, z)
    }
}

/// Signed depth of distance s along a texel ray.
#[inline]
fn depth(desc: &MsmDesc, s: f32) -> f32 {
    2.0 * s / desc.depth_len - 1.0
}

/// Moments b_0 .. b_4 of texel (i, j) (b_0 = 1): the first five of [`build_texel6`].
pub fn build_texel(
    vol: &VolumeView<impl Texels>,
    world_to_index: &Affine3x4,
    desc: &MsmDesc,
    i: u32,
    j: u32,
) -> Moments4 {
    let b = build_texel6(vol, world_to_index, desc, i, j);
    [b[0], b[1], b[2], b[3], b[4]]
}

/// Moments b_0 .. b_6 of texel (i, j) (b_0 = 1), by a voxel DDA along its light ray (every
/// voxel the ray crosses is visited: the loop bound, the sum of the grid's sides, is never
/// reached).
pub fn build_texel6(
    vol: &VolumeView<impl Texels>,
    world_to_index: &Affine3x4,
    desc: &MsmDesc,
    i: u32,
    j: u32,
) -> Moments6 {
    let world = desc.texel_ray(i, j);
    let ray = to_index_space(&world, world_to_index);
    let d = &vol.desc.dims;
    let hi = V3::new(d[0] as f32, d[1] as f32, d[2] as f32);
    let (t0, t1) = clip_to_box(&ray, hi, 0.0, desc.depth_len);
    let mut b: Moments6 = [0.0; 7];
    let mut transmittance = 1.0f32;
    if t0 < t1 {
        let cap = d[0] + d[1] + d[2] + 4;
        let mut tau = 0.0f32;
        let mut visited = 0u32;
        let mut dda = GridDda::new(1.0, [d[0], d[1], d[2]], &ray, t0, t1);
        while !dda.done() && visited < cap {
            let seg = dda.step();
            tau += (seg.t1 - seg.t0) * vol.voxel(seg.cell[0], seg.cell[1], seg.cell[2]);
            let next = exp(-tau);
            let absorbed = transmittance - next;
            if absorbed > 0.0 {
                b = add_atom6(b, depth(desc, 0.5 * (seg.t0 + seg.t1)), absorbed);
            }
            transmittance = next;
            visited += 1;
        }
    }
    add_atom6(b, 1.0, transmittance)
}

/// Moments b_1 .. b_6 of texel `k` (row-major) of the map of `desc` into `raw[6 k .. 6 k + 6]`
/// (the first pass of a map build, one texel per invocation).
pub fn build_raw_texel(
    vol: &VolumeView<impl Texels>,
    world_to_index: &Affine3x4,
    desc: &MsmDesc,
    k: u32,
) -> [f32; RAW_PER_TEXEL] {
    let b = build_texel6(vol, world_to_index, desc, k % desc.width, k / desc.width);
    [b[1], b[2], b[3], b[4], b[5], b[6]]
}

/// Floats per texel of a map's first pass (b_1 .. b_6).
pub const RAW_PER_TEXEL: usize = 6;
/// Largest prefilter radius in texels (a (2 R + 1)^2 window per texel; the GPU runs it in one
/// invocation, within lavapipe's loop budget).
pub const MAX_FILTER_RADIUS: u32 = 64;

/// How shadow rays toward the sun get their transmittance (`--shadows`, with the storage of
/// `--msm-storage`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shadows {
    /// Shadow rays through the render's transmittance estimator.
    Rays = 0,
    /// Four moments stored as f32.
    Msm4 = 1,
    /// Four moments after the quantization transform, stored as 16-bit unorm (64 bits a texel).
    Msm4U16 = 2,
    /// Six moments stored as f32.
    Msm6 = 3,
}

impl Shadows {
    /// The mode of a u32 (unknown values read as `Rays`).
    #[inline]
    pub fn from_u32(v: u32) -> Self {
        match v {
            1 => Shadows::Msm4,
            2 => Shadows::Msm4U16,
            3 => Shadows::Msm6,
            _ => Shadows::Rays,
        }
    }

    /// u32 words per stored texel (0 for rays).
    #[inline]
    pub fn words_per_texel(self) -> u32 {
        match self {
            Shadows::Rays => 0,
            Shadows::Msm4 => 4,
            Shadows::Msm4U16 => 2,
            Shadows::Msm6 => 6,
        }
    }
}

/// The prefilter of a map (`--msm-filter`): 0 none, 1 box, 2 Gaussian (standard deviation R/3,
/// truncated at R).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MsmFilter {
    None = 0,
    Box = 1,
    Gauss = 2,
}

impl MsmFilter {
    /// The filter of a u32 (unknown values read as `None`).
    #[inline]
    pub fn from_u32(v: u32) -> Self {
        match v {
            1 => MsmFilter::Box,
            2 => MsmFilter::Gauss,
            _ => MsmFilter::None,
        }
    }
}

/// Weight of the tap (dx, dy) of a prefilter of radius r.
#[inline]
fn filter_weight(filter: MsmFilter, r: u32, dx: i32, dy: i32) -> f32 {
    match filter {
        MsmFilter::Gauss => {
            let sigma = r as f32 * (1.0 / 3.0);
            let d2 = (dx * dx + dy * dy) as f32;
            exp(-d2 / (2.0 * sigma * sigma))
        }
        _ => 1.0,
    }
}

/// The prefiltered moments b_1 .. b_6 of texel `k` from the raw moments of all texels: the
/// weighted mean over the (2 r + 1)^2 window, renormalized over the taps inside the map
/// (moments are linear in the distribution, so this is the moment vector of the mixture).
pub fn filter_texel(
    desc: &MsmDesc,
    raw: &[f32],
    filter: MsmFilter,
    r: u32,
    k: u32,
) -> [f32; RAW_PER_TEXEL] {
    let base = RAW_PER_TEXEL * k as usize;
    if filter == MsmFilter::None || r == 0 {
        return [
            raw[base],
            raw[base + 1],
            raw[base + 2],
            raw[base + 3],
            raw[base + 4],
            raw[base + 5],
        ];
    }
    let (i, j) = ((k % desc.width) as i32, (k / desc.width) as i32);
    let r = if r > MAX_FILTER_RADIUS {
        MAX_FILTER_RADIUS
    } else {
        r
    };
    let ri = r as i32;
    let mut acc = [0.0f32; RAW_PER_TEXEL];
    let mut total = 0.0f32;
    let mut dy = -ri;
    while dy <= ri {
        let y = j + dy;
        let mut dx = -ri;
        while dx <= ri {
            let x = i + dx;
            if x >= 0 && y >= 0 && (x as u32) < desc.width && (y as u32) < desc.height {
                let w = filter_weight(filter, r, dx, dy);
                let t = RAW_PER_TEXEL * (y as u32 * desc.width + x as u32) as usize;
                let mut m = 0;
                while m < RAW_PER_TEXEL {
                    acc[m] += w * raw[t + m];
                    m += 1;
                }
                total += w;
            }
            dx += 1;
        }
        dy += 1;
    }
    let inv = 1.0 / total;
    let mut m = 0;
    while m < RAW_PER_TEXEL {
        acc[m] *= inv;
        m += 1;
    }
    acc
}

/// The stored words of one texel from its (prefiltered) moments b_1 .. b_6, in the layout of
/// `mode` (unused words 0): f32 bits, or four 16-bit unorm values of the quantization transform
/// packed two per word (`ones`: [`MsmDesc::ones`]).
pub fn store_texel(mode: Shadows, m: [f32; RAW_PER_TEXEL], ones: u32) -> [u32; 6] {
    let mut w = [0u32; 6];
    match mode {
        Shadows::Msm4U16 => {
            let q = quantize_u16([1.0, m[0], m[1], m[2], m[3]], ones);
            w[0] = q[0] | (q[1] << 16);
            w[1] = q[2] | (q[3] << 16);
        }
        _ => {
            let n = mode.words_per_texel() as usize;
            let mut c = 0;
            while c < n {
                w[c] = m[c].to_bits();
                c += 1;
            }
        }
    }
    w
}

/// Storage a map's words are read from: a buffer, or an inline array (the probe kernel; SPIR-V
/// cannot turn an array into a slice).
pub trait Words {
    /// Word i.
    fn word(&self, i: usize) -> u32;
}

impl Words for [u32] {
    #[inline]
    fn word(&self, i: usize) -> u32 {
        self[i]
    }
}

impl<const N: usize> Words for [u32; N] {
    #[inline]
    fn word(&self, i: usize) -> u32 {
        self[i]
    }
}

/// The moments b_1 .. b_6 of texel `k` (dequantized from 16 bits; unused entries 0).
#[inline]
fn texel_values<M: Words + ?Sized>(
    mode: Shadows,
    dequant: &[f32; 12],
    map: &M,
    k: u32,
) -> [f32; RAW_PER_TEXEL] {
    let n = mode.words_per_texel() as usize;
    let base = n * k as usize;
    let mut v = [0.0f32; RAW_PER_TEXEL];
    if mode == Shadows::Msm4U16 {
        let (a, b) = (map.word(base), map.word(base + 1));
        let m = dequantize_u16(
            [
                (a & 0xffff) as f32,
                (a >> 16) as f32,
                (b & 0xffff) as f32,
                (b >> 16) as f32,
            ],
            dequant,
        );
        v[0] = m[0];
        v[1] = m[1];
        v[2] = m[2];
        v[3] = m[3];
    } else {
        let mut c = 0;
        while c < n {
            v[c] = f32::from_bits(map.word(base + c));
            c += 1;
        }
    }
    v
}

/// The stored values at texel coordinates (u, v), bilinear between the four nearest texel
/// centres (clamped at the edges), as a texture unit filters them.
fn bilinear_values<M: Words + ?Sized>(
    desc: &MsmDesc,
    mode: Shadows,
    map: &M,
    u: f32,
    v: f32,
) -> [f32; 6] {
    let (i0, gu, fu) = split(u - 0.5, desc.width);
    let (j0, gv, fv) = split(v - 0.5, desc.height);
    let i1 = if i0 + 1 < desc.width { i0 + 1 } else { i0 };
    let j1 = if j0 + 1 < desc.height { j0 + 1 } else { j0 };
    let corners = [
        (i0, j0, gu * gv),
        (i1, j0, fu * gv),
        (i0, j1, gu * fv),
        (i1, j1, fu * fv),
    ];
    let mut out = [0.0f32; RAW_PER_TEXEL];
    let mut c = 0;
    while c < 4 {
        let (i, j, w) = corners[c];
        let t = texel_values(mode, &desc.dequant, map, j * desc.width + i);
        let mut m = 0;
        while m < RAW_PER_TEXEL {
            out[m] += w * t[m];
            m += 1;
        }
        c += 1;
    }
    out
}

/// Transmittance toward the light at world point x from a stored map: 1 minus the midpoint
/// (beta = 1/2) of the shadow bounds of the filtered, biased moments, and 1 where the
/// reconstruction fell back ([`shadow_bounds_flagged`]).
pub fn map_transmittance<M: Words + ?Sized>(
    desc: &MsmDesc,
    mode: Shadows,
    map: &M,
    x: V3,
) -> (f32, u32) {
    let (u, v, z) = desc.project(x);
    let s = bilinear_values(desc, mode, map, u, v);
    let (lower, upper, fell_back) = match mode {
        Shadows::Msm6 => {
            let b = bias6(
                [1.0, s[0], s[1], s[2], s[3], s[4], s[5]],
                ALPHA6_F32,
                TARGET6,
            );
            shadow_bounds6_flagged(b, z)
        }
        Shadows::Msm4U16 => {
            let b = bias([1.0, s[0], s[1], s[2], s[3]], ALPHA_U16, TARGET_U16);
            shadow_bounds_flagged(b, z)
        }
        _ => {
            let b = bias([1.0, s[0], s[1], s[2], s[3]], ALPHA_F32, TARGET_F32);
            shadow_bounds_flagged(b, z)
        }
    };
    // The midpoint as a mean, not lower + (upper - lower) / 2: shader compilers fuse that lerp
    // pattern differently from the CPU.
    (1.0 - 0.5 * (lower + upper), fell_back)
}

/// The moments at texel coordinates (u, v), bilinear between texel centres (clamped at the
/// edges); `map` holds b_1 .. b_4 per texel, row-major.
pub fn filtered_moments(desc: &MsmDesc, map: &[f32], u: f32, v: f32) -> Moments4 {
    let (i0, gu, fu) = split(u - 0.5, desc.width);
    let (j0, gv, fv) = split(v - 0.5, desc.height);
    let i1 = if i0 + 1 < desc.width { i0 + 1 } else { i0 };
    let j1 = if j0 + 1 < desc.height { j0 + 1 } else { j0 };
    let mut b: Moments4 = [1.0, 0.0, 0.0, 0.0, 0.0];
    let corners = [
        (i0, j0, gu * gv),
        (i1, j0, fu * gv),
        (i0, j1, gu * fv),
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

/// floor(x) clamped to 0..n-1 and the linear weights of it and the next texel, (f + 1 - x,
/// x - f) ((1, 0) at the clamped edges). Both weights are computed from x: written as 1 - w1,
/// shader compilers fuse the interpolation into a lerp that rounds differently from the CPU.
#[inline]
fn split(x: f32, n: u32) -> (u32, f32, f32) {
    let f = floor(x);
    if !(f >= 0.0) {
        return (0, 1.0, 0.0);
    }
    if f >= (n - 1) as f32 {
        return (n - 1, 1.0, 0.0);
    }
    (f as u32, (f + 1.0) - x, x - f)
}

/// Transmittance toward the light at world point x from a four-moment map: 1 minus the midpoint
/// (beta = 1/2) of the shadow bounds of the filtered, biased moments.
pub fn transmittance4(desc: &MsmDesc, map: &[f32], x: V3) -> f32 {
    let (u, v, z) = desc.project(x);
    let b = bias(filtered_moments(desc, map, u, v), ALPHA_F32, TARGET_F32);
    1.0 - shadow_estimate(b, z, 0.5)
}
