//! Point lights and their selection: by importance per ray segment for single scattering
//! (REFERENCE.md: intensity / d_min * subtended angle, 30% uniform), and by power through an
//! alias table for the light-transport integrators (any number of lights, O(1) per draw).

use crate::geometry::V3;
use crate::math;
use crate::math::sqrt;
use crate::rgb::Rgb;
use crate::sampling::equiangular::Equiangular;
use crate::sampling::phase::phase_hg;
use bytemuck::{Pod, Zeroable};

/// An isotropic point light in world space with radiant intensity `intensity` (luminance) and
/// colour `tint` (luminance 1), and its entry of the power alias table (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PointLight {
    pub position: V3,
    pub intensity: f32,
    /// Colour of the intensity, normalised to luminance 1 (white: 1, 1, 1).
    pub tint: Rgb,
    /// 1 / P(this light) under power selection: total intensity / own intensity (set by the
    /// host's table builder; equal intensities give exactly the light count).
    pub inv_pmf: f32,
    /// Walker/Vose alias table: probability of keeping this column's light...
    pub alias_prob: f32,
    /// ...else the light taken instead.
    pub alias: u32,
    pub _pad: [u32; 2],
}

impl PointLight {
    /// A white light, alone in its alias column (the host builds the table over all lights).
    pub const fn new(position: V3, intensity: f32) -> Self {
        PointLight {
            position,
            intensity,
            tint: Rgb::splat(1.0),
            inv_pmf: 1.0,
            alias_prob: 1.0,
            alias: 0,
            _pad: [0; 2],
        }
    }
}

/// Light arriving at x from a point light, before transmittance: the unit direction toward it,
/// its distance and phase(wo, w) I / d^2 (luminance; all 0 if x is at the light).
#[inline]
pub fn unshadowed(light: &PointLight, x: V3, wo: V3, g: f32) -> (V3, f32, f32) {
    let to = light.position - x;
    let d2 = to.dot(to);
    if !(d2 > 0.0) {
        return (V3::new(0.0, 0.0, 1.0), 0.0, 0.0);
    }
    let dist = sqrt(d2);
    let w = to * (1.0 / dist);
    (w, dist, phase_hg(wo.dot(w), g) * light.intensity / d2)
}

/// Draws one of `n` lights by power from the alias table (Walker 1977, Vose 1991): column
/// floor(u0 n), kept with its probability by u1, else its alias. Returns (index, 1 / pmf).
/// Equal intensities give column floor(u0 n) and 1 / pmf = n exactly.
#[inline]
pub fn sample_power(lights: &[PointLight], n: u32, u0: f32, u1: f32) -> (u32, f32) {
    let k = (u0 * n as f32) as u32;
    let k = if k >= n { n - 1 } else { k };
    let column = lights[k as usize];
    let chosen = if u1 < column.alias_prob {
        k
    } else if column.alias < n {
        column.alias
    } else {
        k
    };
    (chosen, lights[chosen as usize].inv_pmf)
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
