//! The groups of settings that describe a render, shared by `host render`, `host view`,
//! `host eval` and the lab: the image, how transmittance is estimated, what lights the medium,
//! `path`'s depth and the preview's exposure. Their `Default`s are the command line's defaults
//! (host's `render_defaults_are_the_engines` test holds the two together).

use crate::estimators::EstimatorSpec;
use crate::lighting::random::RandomLights;
use crate::lighting::{EnvSource, SunSpec};
use crate::scene::defaults;
use shared::params::{Sampler, TransmittanceHat};
use shared::sampling::lights::PointLight;
use shared::volume::grid::Lookup;

/// The image: its pixels, samples per pixel, seed and sampler.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u32,
    /// Where each sample's uniforms come from (independent or Owen-scrambled Sobol).
    pub sampler: Sampler,
}

impl Default for Image {
    fn default() -> Self {
        Image {
            width: defaults::SIZE,
            height: defaults::SIZE,
            spp: defaults::SPP,
            seed: 0,
            sampler: Sampler::Sobol,
        }
    }
}

/// How transmittance is estimated: the lookup, the estimator and its parameters.
#[derive(Debug, Clone, Copy)]
pub struct Estimation {
    pub lookup: Lookup,
    pub estimator: &'static EstimatorSpec,
    /// Samples per optical-depth estimate.
    pub n: u32,
    pub f_delta: f32,
    /// pbrt-v4's Russian roulette in ratio tracking.
    pub ratio_roulette: bool,
    /// Which estimate of T(t0) the equiangular strategy uses.
    pub t_hat: TransmittanceHat,
}

impl PartialEq for Estimation {
    fn eq(&self, o: &Self) -> bool {
        self.lookup == o.lookup
            && self.estimator.name == o.estimator.name
            && self.n == o.n
            && self.f_delta == o.f_delta
            && self.ratio_roulette == o.ratio_roulette
            && self.t_hat == o.t_hat
    }
}

impl Default for Estimation {
    fn default() -> Self {
        Estimation {
            lookup: Lookup::Stochastic,
            estimator: crate::estimators::by_name("jackknife").expect("registered"),
            n: defaults::N,
            f_delta: defaults::F_DELTA,
            ratio_roulette: false,
            t_hat: TransmittanceHat::Jackknife,
        }
    }
}

/// What lights the medium and how it scatters.
#[derive(Debug, Clone, PartialEq)]
pub struct Lighting {
    pub lights: Vec<PointLight>,
    /// `--lights random:N[,seed]`: point lights scattered in and around the volume (`direct`,
    /// `path`), added to `lights`.
    pub random_lights: Option<RandomLights>,
    /// Albedo per channel (the single-scattering integrators need equal channels).
    pub albedo: [f32; 3],
    /// Environment light of `direct` and `path` (None: the sky unless a sun or a point light is
    /// given).
    pub env: Option<EnvSource>,
    pub env_scale: f32,
    /// Degrees about +y.
    pub env_rotate: f32,
    pub sun: Option<SunSpec>,
    /// Henyey-Greenstein asymmetry g of the phase function.
    pub hg_g: f32,
}

impl Default for Lighting {
    fn default() -> Self {
        Lighting {
            lights: Vec::new(),
            random_lights: None,
            albedo: [defaults::ALBEDO; 3],
            env: None,
            env_scale: 1.0,
            env_rotate: 0.0,
            sun: None,
            hg_g: 0.0,
        }
    }
}

/// `path`'s depth: vertices before Russian roulette and most vertices of a path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PathDepth {
    pub rr_depth: u32,
    pub max_depth: u32,
}

impl Default for PathDepth {
    fn default() -> Self {
        PathDepth {
            rr_depth: defaults::RR_DEPTH,
            max_depth: defaults::MAX_DEPTH,
        }
    }
}

/// The PNG preview's exposure ([`super::preview`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exposure {
    /// Gain before the filmic curve (times the automatic exposure unless `fixed`).
    pub gain: f32,
    /// The gain is `gain` alone (no automatic exposure).
    pub fixed: bool,
}

impl Default for Exposure {
    fn default() -> Self {
        Exposure {
            gain: defaults::EXPOSURE,
            fixed: false,
        }
    }
}
