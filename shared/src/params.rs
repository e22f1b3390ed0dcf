//! The parameters of a render as they cross the GPU boundary (u32 enums), and their one decode.

use crate::camera::Camera;
use crate::estimators::estimate::Estimator;
use crate::estimators::optical_depth::{Importance, Jitter};
use crate::geometry::Affine3x4;
use crate::integrators::{Integrator, TransmittanceHat};
use crate::volume::grid::{GridDesc, Lookup};
use bytemuck::{Pod, Zeroable};

/// Everything a render kernel needs besides the volume buffers.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RenderParams {
    pub camera: Camera,
    pub world_to_index: Affine3x4,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u32,
    /// Samples per optical depth estimate, N (default 10, so m N = 20 per ray).
    pub n: u32,
    /// [`Estimator`] as u32.
    pub estimator: u32,
    /// [`Importance`] as u32.
    pub importance: u32,
    /// [`Jitter`] as u32.
    pub jitter: u32,
    /// Sample-count multiplier of Kettunen et al.'s ray marching (1 as published, 2 doubled).
    pub rm_scale: f32,
    /// CDF step of the adaptive jackknife variant (author's default 0.3).
    pub f_delta: f32,
    /// 1: jitter rays within their pixel (anti-aliasing); 0: every sample uses the pixel center,
    /// so per-pixel statistics measure the transmittance estimator alone (`host eval`).
    pub pixel_jitter: u32,
    /// [`crate::integrators::Integrator`] as u32; 0 renders transmittance.
    pub integrator: u32,
    /// Number of valid entries in the lights buffer.
    pub light_count: u32,
    /// Single-scattering albedo mu_s / mu.
    pub albedo: f32,
    /// Henyey-Greenstein anisotropy g (0: isotropic).
    pub hg_g: f32,
    /// [`crate::integrators::TransmittanceHat`] as u32.
    pub t_hat: u32,
    /// 1: ratio tracking uses pbrt-v4's Russian roulette; 0: none, as the paper and the author's
    /// code (Miller et al.'s MIS always runs without it: its weights need the plain product).
    pub roulette: u32,
    pub _pad: u32,
}

/// The enums of [`RenderParams`] (and the volume's lookup), decoded once per pixel pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    pub estimator: Estimator,
    pub importance: Importance,
    pub jitter: Jitter,
    pub lookup: Lookup,
    pub integrator: Integrator,
    pub t_hat: TransmittanceHat,
    /// Ratio tracking with Russian roulette.
    pub roulette: bool,
}

impl Config {
    /// Decodes the u32 fields of `params` and `desc` (unknown values read as the defaults).
    #[inline]
    pub fn decode(params: &RenderParams, desc: &GridDesc) -> Self {
        Config {
            estimator: Estimator::from_u32(params.estimator),
            importance: if params.importance == 1 {
                Importance::Mean
            } else {
                Importance::VarianceAware
            },
            jitter: if params.jitter == 1 {
                Jitter::Uniform
            } else {
                Jitter::Stratified
            },
            lookup: Lookup::from_u32(desc.lookup),
            integrator: Integrator::from_u32(params.integrator),
            t_hat: if params.t_hat == TransmittanceHat::Ratio as u32 {
                TransmittanceHat::Ratio
            } else {
                TransmittanceHat::Jackknife
            },
            roulette: params.roulette != 0,
        }
    }
}
