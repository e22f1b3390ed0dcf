//! The lights of a scene for the light-transport integrators: an environment map, a sun and
//! point lights, with a pmf over the three kinds (chosen on the host from their power).
//!
//! The map and the sun together are one directional light L(omega) = L_env(omega) + L_sun(omega),
//! drawn from the mixture p_dir(omega) = P(env) p_env(omega) + P(sun) p_sun(omega); a delta sun
//! and the point lights have no density and are never reached by phase sampling.

use crate::geometry::V3;
use crate::rgb::Rgb;
use crate::sampling::env::EnvDesc;
use crate::sampling::lights::PointLight;
use crate::sampling::sun::Sun;
use crate::shadows::map::MsmDesc;
use bytemuck::{Pod, Zeroable};

/// Everything about the lights besides the point lights and the map's texels (one per render).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Lighting {
    pub sun: Sun,
    pub env: EnvDesc,
    /// Single-scattering albedo per channel (`--albedo`).
    pub albedo: Rgb,
    /// Probability of sampling the sun, the map and the point lights (summing to 1, or all 0
    /// without lights).
    pub p_sun: f32,
    pub p_env: f32,
    pub p_points: f32,
    /// How light samples of the sun get their shadow transmittance
    /// ([`crate::shadows::map::Shadows`] as u32; 0: shadow rays).
    pub shadows: u32,
    pub _pad: u32,
    /// The frame of the sun's moment shadow map (unused with shadow rays).
    pub shadow_map: MsmDesc,
}

/// The lights as the integrators see them: the [`Lighting`], the point lights and the map.
#[derive(Clone, Copy)]
pub struct Scene<'a> {
    pub lighting: &'a Lighting,
    pub points: &'a [PointLight],
    /// Valid entries of `points`.
    pub point_count: u32,
    /// The map's data buffer (see [`crate::sampling::env`]).
    pub env: &'a [f32],
    /// The sun's moment shadow map (words of [`crate::shadows::map::store_texel`]; one unused
    /// word with shadow rays).
    pub shadow_map: &'a [u32],
}

/// The kind of light one light sample went to (`u32`: SPIR-V has no 8-bit integers here).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightKind {
    Sun,
    Env,
    Points,
    None,
}

impl Scene<'_> {
    /// Picks a kind of light by the pmf, from one uniform number.
    #[inline]
    pub fn select_kind(&self, u: f32) -> LightKind {
        let l = self.lighting;
        if u < l.p_sun {
            LightKind::Sun
        } else if u < l.p_sun + l.p_env {
            LightKind::Env
        } else if l.p_points > 0.0 && self.point_count > 0 {
            LightKind::Points
        } else {
            LightKind::None
        }
    }

    /// Radiance arriving from world direction d from the map and the sun's disk.
    #[inline]
    pub fn directional_radiance(&self, d: V3) -> Rgb {
        let l = self.lighting;
        l.env.radiance(self.env, d) + l.sun.radiance_toward(d)
    }

    /// [`Scene::directional_radiance`] of direction d and the density of the light sampler
    /// producing d (the mixture of map and disk), the map looked up once.
    #[inline]
    pub fn directional(&self, d: V3) -> (Rgb, f32) {
        let l = self.lighting;
        let (env_radiance, env_pdf) = l.env.radiance_pdf(self.env, d);
        let env = if l.p_env > 0.0 {
            l.p_env * env_pdf
        } else {
            0.0
        };
        let sun = if l.p_sun > 0.0 {
            l.p_sun * l.sun.pdf(d)
        } else {
            0.0
        };
        (env_radiance + l.sun.radiance_toward(d), env + sun)
    }
}
