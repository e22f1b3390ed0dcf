//! An equirectangular environment map (light probe) with importance sampling by a piecewise-
//! constant 2D distribution (pbrt-v4's `PiecewiseConstant2D`): a marginal CDF over rows and one
//! conditional CDF per row, built on the host from luminance x sin(theta), sampled here. Pdfs are
//! per unit solid angle: p(omega) = p(u, v) / (2 pi^2 sin theta).
//!
//! The map's data is one f32 buffer: `width * height` RGB texels (row 0 at the +y pole), then the
//! marginal CDF (`height + 1` values, 0 to 1), then the conditional CDFs (`width + 1` values per
//! row). Directions: theta from +y, phi = atan2(z, x) after rotating the world by `-rotation`
//! about +y.

use crate::geometry::V3;
use crate::math::{atan2, floor, sin_cos, sqrt};
use crate::rgb::Rgb;
use bytemuck::{Pod, Zeroable};
use core::f32::consts::PI;

/// Shape of the environment map in its data buffer (width 0: no map).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct EnvDesc {
    pub width: u32,
    pub height: u32,
    /// cos and sin of the rotation about +y (`--env-rotate`).
    pub cos_rotation: f32,
    pub sin_rotation: f32,
}

/// One direction drawn from the map.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EnvSample {
    /// World-space unit direction toward the map.
    pub dir: V3,
    /// Radiance of the texel.
    pub radiance: Rgb,
    /// Solid-angle density (0: discard the sample).
    pub pdf: f32,
}

impl EnvDesc {
    /// True when a map is present.
    #[inline]
    pub fn present(&self) -> bool {
        self.width > 0 && self.height > 0
    }

    /// True for a 1 x 1 map: one radiance everywhere, sampled uniformly over the sphere.
    #[inline]
    pub fn uniform(&self) -> bool {
        self.width == 1 && self.height == 1
    }

    /// Index of the first marginal CDF value in the data buffer.
    #[inline]
    fn marginal(&self) -> usize {
        3 * (self.width * self.height) as usize
    }

    /// Index of the first value of row j's conditional CDF.
    #[inline]
    fn conditional(&self, j: u32) -> usize {
        self.marginal() + (self.height + 1) as usize + (j * (self.width + 1)) as usize
    }

    /// Length of the data buffer of a `width` x `height` map.
    pub fn data_len(width: u32, height: u32) -> usize {
        let (w, h) = (width as usize, height as usize);
        3 * w * h + (h + 1) + h * (w + 1)
    }

    /// Radiance of texel (i, j).
    #[inline]
    pub fn texel(&self, data: &[f32], i: u32, j: u32) -> Rgb {
        let k = 3 * (j * self.width + i) as usize;
        Rgb::new(data[k], data[k + 1], data[k + 2])
    }

    /// p(u, v) of texel (i, j): the product of its marginal and conditional probabilities
    /// times the texel count (a density on the unit square).
    #[inline]
    pub fn texel_pdf(&self, data: &[f32], i: u32, j: u32) -> f32 {
        let m = self.marginal() + j as usize;
        let c = self.conditional(j) + i as usize;
        let pv = (data[m + 1] - data[m]) * self.height as f32;
        let pu = (data[c + 1] - data[c]) * self.width as f32;
        pv * pu
    }

    /// Local (x, z) of a world direction: R(-rotation) about +y.
    #[inline]
    fn local_xz(&self, d: V3) -> (f32, f32) {
        (
            self.cos_rotation * d.x + self.sin_rotation * d.z,
            self.cos_rotation * d.z - self.sin_rotation * d.x,
        )
    }

    /// sin(theta) of a world direction, as [`EnvDesc::uv`] returns it.
    #[inline]
    fn local_sin_theta(&self, d: V3) -> f32 {
        let (x, z) = self.local_xz(d);
        sqrt(x * x + z * z)
    }

    /// The map's (u, v) in [0, 1)^2 of a world direction, and sin(theta).
    #[inline]
    pub fn uv(&self, d: V3) -> (f32, f32, f32) {
        let (x, z) = self.local_xz(d);
        let phi = atan2(z, x);
        let sin_theta = self.local_sin_theta(d);
        let theta = atan2(sin_theta, d.y);
        let u = phi * (0.5 / PI);
        let u = if u < 0.0 { u + 1.0 } else { u };
        (u, theta * (1.0 / PI), sin_theta)
    }

    /// Texel (i, j) containing (u, v).
    #[inline]
    fn texel_of(&self, u: f32, v: f32) -> (u32, u32) {
        (
            clamp_index(u * self.width as f32, self.width),
            clamp_index(v * self.height as f32, self.height),
        )
    }

    /// Radiance arriving from world direction d (nearest texel; black without a map).
    #[inline]
    pub fn radiance(&self, data: &[f32], d: V3) -> Rgb {
        if !self.present() {
            return Rgb::ZERO;
        }
        if self.uniform() {
            return self.texel(data, 0, 0);
        }
        let (u, v, _) = self.uv(d);
        let (i, j) = self.texel_of(u, v);
        self.texel(data, i, j)
    }

    /// Solid-angle density of [`EnvDesc::sample`] drawing world direction d.
    #[inline]
    pub fn pdf(&self, data: &[f32], d: V3) -> f32 {
        if !self.present() {
            return 0.0;
        }
        if self.uniform() {
            return UNIFORM_PDF;
        }
        // sin(theta) from the direction itself (not sin(pi v): shader compilers may fold the
        // constants of pi (theta / pi) and round differently from the CPU).
        let (u, v, sin_theta) = self.uv(d);
        let (i, j) = self.texel_of(u, v);
        solid_angle_pdf(self.texel_pdf(data, i, j), sin_theta)
    }

    /// [`EnvDesc::radiance`] and [`EnvDesc::pdf`] of world direction d from one lookup of its
    /// texel (the same values, half the angles).
    #[inline]
    pub fn radiance_pdf(&self, data: &[f32], d: V3) -> (Rgb, f32) {
        if !self.present() {
            return (Rgb::ZERO, 0.0);
        }
        if self.uniform() {
            return (self.texel(data, 0, 0), UNIFORM_PDF);
        }
        let (u, v, sin_theta) = self.uv(d);
        let (i, j) = self.texel_of(u, v);
        (
            self.texel(data, i, j),
            solid_angle_pdf(self.texel_pdf(data, i, j), sin_theta),
        )
    }

    /// A direction with density proportional to luminance x sin(theta) per texel, from two
    /// uniform numbers.
    pub fn sample(&self, data: &[f32], u0: f32, u1: f32) -> EnvSample {
        if !self.present() {
            return EnvSample::default();
        }
        if self.uniform() {
            return EnvSample {
                dir: uniform_sphere(u0, u1),
                radiance: self.texel(data, 0, 0),
                pdf: UNIFORM_PDF,
            };
        }
        let m = self.marginal();
        let (j, dv) = find_interval(data, m, self.height, u0);
        let c = self.conditional(j);
        let (i, du) = find_interval(data, c, self.width, u1);
        let u = (i as f32 + du) / self.width as f32;
        let v = (j as f32 + dv) / self.height as f32;
        let (sin_theta, cos_theta) = sin_cos(PI * v);
        let (sin_phi, cos_phi) = sin_cos(2.0 * PI * u);
        let (x, z) = (sin_theta * cos_phi, sin_theta * sin_phi);
        // World = R(rotation) local.
        let dir = V3::new(
            self.cos_rotation * x - self.sin_rotation * z,
            cos_theta,
            self.sin_rotation * x + self.cos_rotation * z,
        );
        // The density at the generated direction, with sin(theta) computed from `dir` exactly as
        // [`EnvDesc::pdf`] computes it (rotated back: the rounding of the rotation changes it).
        let sin_theta = self.local_sin_theta(dir);
        EnvSample {
            dir,
            radiance: self.texel(data, i, j),
            pdf: solid_angle_pdf(self.texel_pdf(data, i, j), sin_theta),
        }
    }
}

/// Solid-angle density of a direction uniform over the sphere, 1 / (4 pi).
const UNIFORM_PDF: f32 = 1.0 / (4.0 * PI);

/// A direction uniform over the unit sphere from two uniform numbers: cos theta = 1 - 2 u0
/// about +y, phi = 2 pi u1 (pbrt-v4's `SampleUniformSphere`).
#[inline]
pub fn uniform_sphere(u0: f32, u1: f32) -> V3 {
    let y = 1.0 - 2.0 * u0;
    let r2 = 1.0 - y * y;
    let r = if r2 > 0.0 { sqrt(r2) } else { 0.0 };
    let (sin_phi, cos_phi) = sin_cos(2.0 * PI * u1);
    V3::new(r * cos_phi, y, r * sin_phi)
}

/// p(omega) = p(u, v) / (2 pi^2 sin theta); 0 at the poles.
#[inline]
fn solid_angle_pdf(p_uv: f32, sin_theta: f32) -> f32 {
    if sin_theta > 0.0 {
        p_uv / (2.0 * PI * PI * sin_theta)
    } else {
        0.0
    }
}

/// floor(x) as an index in 0..n.
#[inline]
fn clamp_index(x: f32, n: u32) -> u32 {
    let f = floor(x);
    if !(f > 0.0) {
        0
    } else if f >= n as f32 {
        n - 1
    } else {
        f as u32
    }
}

/// Most bisection steps of a CDF search: enough for 2^31 intervals.
const MAX_BISECTIONS: u32 = 32;

/// The interval k of the CDF `data[start..=start + n]` with cdf[k] <= u < cdf[k + 1] (skipping
/// empty intervals), and u's offset (u - cdf[k]) / (cdf[k + 1] - cdf[k]) in [0, 1).
#[inline]
fn find_interval(data: &[f32], start: usize, n: u32, u: f32) -> (u32, f32) {
    // Largest k in [0, n - 1] with cdf[k] <= u, by bisection over [lo, hi).
    let mut lo = 0u32;
    let mut hi = n;
    let mut steps = 0u32;
    while hi - lo > 1 && steps < MAX_BISECTIONS {
        let mid = lo + (hi - lo) / 2;
        if data[start + mid as usize] <= u {
            lo = mid;
        } else {
            hi = mid;
        }
        steps += 1;
    }
    let a = data[start + lo as usize];
    let b = data[start + lo as usize + 1];
    let du = if b > a { (u - a) / (b - a) } else { 0.0 };
    let du = if du < 0.0 {
        0.0
    } else if du >= 1.0 {
        0.999_999_94
    } else {
        du
    };
    (lo, du)
}
