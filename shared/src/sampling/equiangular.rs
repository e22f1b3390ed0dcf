//! Equiangular distance sampling toward a point (Kulla & Fajardo 2012), with its pdf.

use crate::geometry::V3;
use crate::math;

/// Floor for the light-to-ray distance, so rays through a light stay finite.
const MIN_DISTANCE: f32 = 1e-4;

/// Equiangular sampling of [ta, tb] on a unit world ray toward one point (Kulla & Fajardo 2012).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Equiangular {
    /// Ray parameter of the point closest to the light.
    pub tc: f32,
    /// Distance from the light to the ray's line (>= MIN_DISTANCE).
    pub d: f32,
    /// Angle of ta seen from the light, relative to the closest point.
    pub theta_a: f32,
    /// Angle the segment [ta, tb] subtends at the light, theta_b - theta_a.
    pub angle: f32,
}

impl Equiangular {
    /// Setup for a light at `p` and the unit ray o + t dir over [ta, tb].
    #[inline]
    pub fn new(o: V3, dir: V3, p: V3, ta: f32, tb: f32) -> Self {
        let tc = (p - o).dot(dir);
        let q = p - (o + dir * tc);
        let mut d = crate::math::sqrt(q.dot(q));
        if d < MIN_DISTANCE {
            d = MIN_DISTANCE;
        }
        let (a, b) = ((ta - tc) / d, (tb - tc) / d);
        Equiangular {
            tc,
            d,
            theta_a: math::atan(a),
            angle: atan_difference(a, b),
        }
    }

    /// Angle the segment subtends at the light.
    #[inline]
    pub fn angle(&self) -> f32 {
        self.angle
    }

    /// A distance t = tc + D tan(theta_a + u angle) and its density.
    ///
    /// The density uses the offset D tan(theta) directly, not t - tc: Mesa's NIR folds
    /// `(tc + x) - tc` to `x` in shaders (no NoContraction from rust-gpu), the CPU does not.
    #[inline]
    pub fn sample(&self, u: f32) -> (f32, f32) {
        let theta = self.theta_a + u * self.angle;
        let x = self.d * math::tan(theta);
        (self.tc + x, self.pdf_offset(x))
    }

    /// Density at offset x = t - tc from the closest point.
    #[inline]
    pub fn pdf_offset(&self, x: f32) -> f32 {
        let angle = self.angle;
        if !(angle > 0.0) {
            return 0.0;
        }
        self.d / (angle * (self.d * self.d + x * x))
    }

    /// Density of `sample` at t: D / ((theta_b - theta_a) (D^2 + (t - tc)^2)).
    #[inline]
    pub fn pdf(&self, t: f32) -> f32 {
        self.pdf_offset(t - self.tc)
    }
}

/// atan(b) - atan(a) for b >= a as atan((b - a) / (1 + ab)) (+ pi when ab < -1).
///
/// Not the plain difference: `theta_a + u (theta_b - theta_a)` is a lerp that Mesa's NIR turns
/// into `flrp` and lowers with different rounding (no NoContraction from rust-gpu), so the GPU
/// and the CPU would sample different distances.
#[inline]
fn atan_difference(a: f32, b: f32) -> f32 {
    let den = 1.0 + a * b;
    if den > 0.0 {
        math::atan((b - a) / den)
    } else if den < 0.0 {
        core::f32::consts::PI + math::atan((b - a) / den)
    } else {
        core::f32::consts::FRAC_PI_2
    }
}
