//! A directional light: the sun as a uniformly bright disk of angular radius alpha (a cone of
//! directions), or a delta direction when alpha = 0.

use crate::geometry::{cross, frame_from_z, from_frame, V3};
use crate::math::sqrt;
use crate::rgb::Rgb;
use bytemuck::{Pod, Zeroable};
use core::f32::consts::PI;

/// The sun as seen from the volume.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Sun {
    /// World-space unit direction toward the sun.
    pub dir: V3,
    /// 1 - cos(alpha) of the angular radius alpha (computed in f64 on the host: cos(alpha)
    /// alone loses the small difference); 0: a delta direction.
    pub one_minus_cos: f32,
    /// Radiance of the disk, or for a delta sun the irradiance it delivers perpendicular to it.
    pub radiance: Rgb,
    /// 1: the scene has a sun.
    pub present: u32,
}

/// One direction toward the sun.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SunSample {
    pub dir: V3,
    /// Solid-angle density; for a delta sun 1 (with `delta` set).
    pub pdf: f32,
    /// True for a delta sun: `radiance` is irradiance and the sample has no density.
    pub delta: bool,
}

impl Sun {
    /// True for a sun of angular radius 0.
    #[inline]
    pub fn is_delta(&self) -> bool {
        !(self.one_minus_cos > 0.0)
    }

    /// Solid angle of the disk, 2 pi (1 - cos alpha).
    #[inline]
    pub fn solid_angle(&self) -> f32 {
        2.0 * PI * self.one_minus_cos
    }

    /// True when world direction d falls on the disk (never for a delta sun).
    #[inline]
    pub fn covers(&self, d: V3) -> bool {
        // angle(d, dir) <= alpha <= 45 degrees, written as d . dir > 0 and
        // sin^2 = |d x dir|^2 <= sin^2 alpha = (1 - cos alpha)(1 + cos alpha). Not as
        // 1 - d . dir <= 1 - cos alpha: for the real sun 1 - cos alpha is 1.1e-5 and the f32
        // rounding of d . dir (6e-8) refused 0.3% of the directions `sample` draws at the rim.
        let c = cross(d, self.dir);
        let sin2_alpha = self.one_minus_cos * (2.0 - self.one_minus_cos);
        self.present != 0 && !self.is_delta() && d.dot(self.dir) > 0.0 && c.dot(c) <= sin2_alpha
    }

    /// Radiance arriving from direction d: the disk's where it covers d.
    #[inline]
    pub fn radiance_toward(&self, d: V3) -> Rgb {
        if self.covers(d) {
            self.radiance
        } else {
            Rgb::ZERO
        }
    }

    /// Solid-angle density of [`Sun::sample`] drawing d (0 off the disk and for a delta sun).
    #[inline]
    pub fn pdf(&self, d: V3) -> f32 {
        if self.covers(d) {
            1.0 / self.solid_angle()
        } else {
            0.0
        }
    }

    /// A direction uniform over the disk (the cone about `dir`), from two uniform numbers.
    #[inline]
    pub fn sample(&self, u0: f32, u1: f32) -> SunSample {
        if self.is_delta() {
            return SunSample {
                dir: self.dir,
                pdf: 1.0,
                delta: true,
            };
        }
        // 1 - cos(theta) uniform in [0, 1 - cos alpha].
        let omc = u0 * self.one_minus_cos;
        let cos_theta = 1.0 - omc;
        let s2 = omc * (2.0 - omc);
        let sin_theta = sqrt(if s2 > 0.0 { s2 } else { 0.0 });
        let (t, b) = frame_from_z(self.dir);
        let dir = from_frame(t, b, self.dir, sin_theta, cos_theta, 2.0 * PI * u1);
        SunSample {
            dir,
            pdf: 1.0 / self.solid_angle(),
            delta: false,
        }
    }
}
