//! One transmittance estimate of a ray segment with a chosen estimator: the entry point for
//! renderers that trace their own rays (shadow rays, camera rays).

use crate::builder::Grid;
use shared::estimators::estimate;
use shared::geometry::Ray;
use shared::params::Estimator;
use shared::params::{Config, RenderParams};
use shared::params::{Importance, Jitter};
use shared::rng::HashRng;
use shared::volume::grid::Lookup;
use shared::Tally;

/// An estimator with its settings, as the paper configures it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentEstimator {
    /// Which estimator.
    pub estimator: Estimator,
    /// Importance sampling of Alg. 1 (variance-aware Eq. 5, or the brick means).
    pub importance: Importance,
    /// Jitter of Alg. 1's samples (stratified, or uniform).
    pub jitter: Jitter,
    /// Samples per optical depth estimate N (the paper: 10, two estimates per ray).
    pub n: u32,
    /// CDF step of the adaptive jackknife (the paper's Fig. 8d: 0.6).
    pub f_delta: f32,
    /// Sample-count multiplier of Kettunen et al.'s ray marching (1, or 2 for the doubled
    /// variants).
    pub rm_scale: f32,
    /// Ratio tracking with pbrt-v4's Russian roulette (the paper: without).
    pub roulette: bool,
}

impl SegmentEstimator {
    /// The paper's estimator: jackknife K = cos(S) exp(-X̄) of two interleaved estimates with
    /// `n` samples each, variance-aware importance and stratified jitter (Eq. 4, Alg. 1).
    pub fn jackknife(n: u32) -> Self {
        Self::new(Estimator::Jackknife, n)
    }

    /// `estimator` with the paper's settings (variance-aware importance and stratified jitter
    /// for the jackknife family, mean importance and uniform jitter for ray marching) and `n`
    /// samples per estimate.
    pub fn new(estimator: Estimator, n: u32) -> Self {
        let ray_marching = matches!(
            estimator,
            Estimator::BiasedRayMarching | Estimator::UnbiasedRayMarching
        );
        SegmentEstimator {
            estimator,
            importance: if ray_marching {
                Importance::Mean
            } else {
                Importance::VarianceAware
            },
            jitter: if ray_marching {
                Jitter::Uniform
            } else {
                Jitter::Stratified
            },
            n,
            f_delta: 0.6,
            rm_scale: 1.0,
            roulette: false,
        }
    }

    /// One estimate of the transmittance of the index-space segment [t0, t1] of `ray` (clip it
    /// with [`Grid::clip`]); `seed` selects the random numbers. Returns (T, tally): the
    /// high-resolution lookups and whether a loop bound changed the estimate.
    pub fn estimate(&self, grid: &Grid, ray: &Ray, t0: f32, t1: f32, seed: u32) -> (f32, Tally) {
        if !(t0 < t1) {
            return (1.0, Tally::default());
        }
        let view = grid.view();
        let cfg = Config {
            estimator: self.estimator,
            importance: self.importance,
            jitter: self.jitter,
            lookup: Lookup::from_u32(grid.desc.lookup),
            integrator: shared::params::Integrator::Transmittance,
            t_hat: shared::params::TransmittanceHat::Jackknife,
            roulette: self.roulette,
            max_collisions: shared::params::MAX_TENTATIVE_COLLISIONS,
        };
        let params = RenderParams {
            n: self.n,
            f_delta: self.f_delta,
            rm_scale: self.rm_scale,
            ..Default::default()
        };
        let rng = HashRng::for_sample(seed, 0, 0x6a63_6b6b);
        let (t, tally, _) = estimate::transmittance(&view, &cfg, &params, ray, t0, t1, rng);
        (t, tally)
    }
}
