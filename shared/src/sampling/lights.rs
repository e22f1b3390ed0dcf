//! Point lights and their selection by importance (REFERENCE.md: intensity / d_min * subtended
//! angle, 30% uniform): a pmf over the lights per ray segment.

use crate::geometry::V3;
use crate::math;
use crate::sampling::equiangular::Equiangular;
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
