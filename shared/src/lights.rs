//! Point lights, equiangular distance sampling toward them (Kulla & Fajardo 2012) and light
//! selection by importance (REFERENCE.md: intensity / d_min * subtended angle, 30% uniform).

use crate::math;
use crate::vec3::V3;
use bytemuck::{Pod, Zeroable};

/// An isotropic point light in world space with radiant intensity `intensity`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PointLight {
    pub position: V3,
    pub intensity: f32,
}

/// Most lights a scene may hold (selection runs over all of them per sample).
pub const MAX_LIGHTS: u32 = 16;
/// Share of uniform light selection mixed into importance selection.
const UNIFORM_SHARE: f32 = 0.3;
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
        let mut d = crate::camera::sqrt(q.dot(q));
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

/// Selection weight of one light for a ray segment: intensity / D * subtended angle.
#[inline]
pub fn light_importance(light: &PointLight, o: V3, dir: V3, ta: f32, tb: f32) -> f32 {
    let eq = Equiangular::new(o, dir, light.position, ta, tb);
    let w = light.intensity / eq.d * eq.angle();
    if math::is_finite(w) && w > 0.0 {
        w
    } else {
        0.0
    }
}

/// Picks a light: 70% by importance, 30% uniformly. Returns (index, probability).
pub fn select_light(
    lights: &[PointLight],
    count: u32,
    o: V3,
    dir: V3,
    ta: f32,
    tb: f32,
    u: f32,
) -> (u32, f32) {
    let n = if count > MAX_LIGHTS {
        MAX_LIGHTS
    } else {
        count
    };
    if n == 0 {
        return (0, 0.0);
    }
    let mut total = 0.0f32;
    let mut i = 0;
    while i < n {
        total += light_importance(&lights[i as usize], o, dir, ta, tb);
        i += 1;
    }
    let share = if total > 0.0 {
        1.0 - UNIFORM_SHARE
    } else {
        0.0
    };
    let uniform = (1.0 - share) / n as f32;
    // Walk the CDF of the mixture.
    let mut acc = 0.0f32;
    let mut chosen = n - 1;
    let mut prob = 0.0f32;
    let mut found = false;
    i = 0;
    while i < n {
        let imp = if total > 0.0 {
            light_importance(&lights[i as usize], o, dir, ta, tb) / total
        } else {
            0.0
        };
        let p = share * imp + uniform;
        acc += p;
        if !found && (u < acc || i == n - 1) {
            chosen = i;
            prob = p;
            found = true;
        }
        i += 1;
    }
    (chosen, prob)
}

/// Henyey-Greenstein phase function value for cos(theta) between directions (g = 0: isotropic).
#[inline]
pub fn phase_hg(cos_theta: f32, g: f32) -> f32 {
    let inv_4pi = 1.0 / (4.0 * core::f32::consts::PI);
    let denom = 1.0 + g * g + 2.0 * g * cos_theta;
    let d = denom * crate::camera::sqrt(denom);
    if !(d > 0.0) {
        return inv_4pi;
    }
    inv_4pi * (1.0 - g * g) / d
}
