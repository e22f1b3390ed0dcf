//! The parameters of a render as they cross the GPU boundary: `RenderParams` with its enums as
//! u32s, the enums themselves (`#[repr(u32)]`), and their one decode (`Config`).

use crate::camera::Camera;
use crate::geometry::Affine3x4;
use crate::volume::grid::{GridDesc, Lookup};
use bytemuck::{Pod, Zeroable};

/// Most tentative collisions per tracking loop; at the cap the rest of the ray is completed by
/// regular tracking (`estimators::tracking::complete_exactly`) and the ray is counted as capped.
/// Each collision costs two loop iterations (the collision loop and the sampler's), and lavapipe
/// (gallivm) silently ends a shader after 65535 loop iterations summed over all loops: an
/// integrator ray runs two tracking loops, so 4 x 10,000 plus its traversals must fit
/// (`host::render::LOOP_BUDGET`); `direct` runs four and lowers the cap
/// ([`RenderParams::max_collisions`]).
pub const MAX_TENTATIVE_COLLISIONS: u32 = 10_000;

/// Transmittance estimators selectable at run time (u32 in [`RenderParams`]).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Estimator {
    /// Jackknife K = cos(S) exp(-X̄) from Alg. 1's two estimates (Eq. 4).
    Jackknife = 0,
    /// Naive exp(-X̄) from the same two estimates (m = 2).
    NaiveMean = 1,
    /// Naive exp(-X) from one estimate with all 2N samples (m = 1).
    NaiveSingle = 2,
    /// Jackknife with a constant CDF step F_delta instead of F / N (Fig. 8d).
    JackknifeAdaptive = 3,
    /// Kettunen et al.'s biased ray marching, exp(-X) with N_CMF mean-importance samples.
    BiasedRayMarching = 4,
    /// Kettunen et al.'s unbiased ray marching (power series, roulette, U-statistics).
    UnbiasedRayMarching = 5,
    /// exp(-tau) with tau exact for the nearest-neighbour grid (voxel DDA): the reference.
    RegularTracking = 6,
    /// Track-length estimate (delta tracking over per-brick majorants): 0 or 1.
    TrackLength = 7,
    /// Ratio tracking over per-brick majorants (Russian roulette only with `RenderParams::roulette`).
    RatioTracking = 8,
    /// Not a transmittance estimator of its own: the camera ray's first collision by delta
    /// tracking, whose distance the `depth` layer's pass sums ([`crate::kernels::render`]); as
    /// a transmittance estimate, track-length's. Not in [`Estimator::ALL`].
    FirstCollision = 9,
    /// Misso et al.'s telescoping series over nested stratified estimates with Alg. 2's
    /// importance and control variate, unbiased ([`crate::estimators::telescoping::telescoping`]).
    Telescoping = 10,
    /// Blender Cycles 5.0's telescoping shadow rays, truncated at order 4: biased
    /// ([`crate::estimators::telescoping::telescoping_cycles`]).
    TelescopingCycles = 11,
}

impl Estimator {
    /// Every estimator, in enum order.
    pub const ALL: [Estimator; 11] = [
        Estimator::Jackknife,
        Estimator::NaiveMean,
        Estimator::NaiveSingle,
        Estimator::JackknifeAdaptive,
        Estimator::BiasedRayMarching,
        Estimator::UnbiasedRayMarching,
        Estimator::RegularTracking,
        Estimator::TrackLength,
        Estimator::RatioTracking,
        Estimator::Telescoping,
        Estimator::TelescopingCycles,
    ];

    /// From the stored u32 (unknown values read as the jackknife).
    #[inline]
    pub fn from_u32(v: u32) -> Self {
        match v {
            1 => Estimator::NaiveMean,
            2 => Estimator::NaiveSingle,
            3 => Estimator::JackknifeAdaptive,
            4 => Estimator::BiasedRayMarching,
            5 => Estimator::UnbiasedRayMarching,
            6 => Estimator::RegularTracking,
            7 => Estimator::TrackLength,
            8 => Estimator::RatioTracking,
            9 => Estimator::FirstCollision,
            10 => Estimator::Telescoping,
            11 => Estimator::TelescopingCycles,
            _ => Estimator::Jackknife,
        }
    }
}

/// Which super-voxel statistic drives importance sampling and whether mu_min is subtracted.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Importance {
    /// P of Eq. 5 with the mu_min control variate (the paper's method).
    VarianceAware = 0,
    /// Mean extinction, no control variate (Kettunen et al. 2021; ablation of Fig. 9).
    Mean = 1,
}

/// How the N samples of one estimate are jittered within their strata (Sec. 4.1).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Jitter {
    /// One independent offset per stratum (the paper's choice).
    Stratified = 0,
    /// One offset shared by all strata of an estimate.
    Uniform = 1,
}

/// Where a sample's uniforms come from ([`crate::sampling::sampler`]).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampler {
    /// Every number from the sample's hash generator: independent samples.
    Independent = 0,
    /// The pixel jitter and each path vertex's leading dimensions from Owen-scrambled Sobol
    /// patterns (stratified within a pixel); the rest independent.
    Sobol = 1,
}

impl Sampler {
    /// From the stored u32 (unknown values read as independent).
    #[inline]
    pub fn from_u32(v: u32) -> Self {
        if v == Sampler::Sobol as u32 {
            Sampler::Sobol
        } else {
            Sampler::Independent
        }
    }
}

/// Light transport integrators selectable at run time (`RenderParams::integrator`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Integrator {
    /// No integrator: the image is primary-ray transmittance.
    Transmittance = 0,
    /// Free-flight distance sampling (delta tracking) only.
    FreeFlight = 1,
    /// Equiangular sampling toward the selected light only, with an estimate T̂(t0).
    Equiangular = 2,
    /// Eq. 9 with jackknife MIS weights Re g(X̄ + iS) and an independent T̂(t0).
    MisJackknife = 3,
    /// Eq. 9 with naive MIS weights g(X) from one estimate with N samples (m = 1, Fig. 12d).
    MisNaive = 4,
    /// Eq. 10 (MIS weight times transmittance estimated at once), jackknife; biased.
    CombinedJackknife = 5,
    /// Eq. 10 with naive g(X̄); biased.
    CombinedNaive = 6,
    /// Miller et al. 2019 reduced to the balance heuristic with ratio-tracking densities.
    Miller = 7,
    /// Eq. 9 with the power heuristic (exponent 2) through Re g (beyond the paper).
    MisPowerJackknife = 8,
    /// Direct illumination from the map, the sun and point lights (RGB): a free-flight vertex,
    /// light and phase sampling by MIS, shadow rays by the chosen estimator (Fig. 1).
    Direct = 9,
    /// Multiple scattering (RGB): a volumetric path tracer with next-event estimation at every
    /// vertex, shadow rays by the chosen estimator.
    Path = 10,
    /// `direct` whose point lights are resampled (RIS over M candidates drawn by power, target
    /// p̂ = I phase T̂ / d^2 with a cheap transmittance estimate T̂), shadow rays by the chosen
    /// estimator.
    Restir = 11,
}

/// The transmittance factor of `restir`'s target function p̂.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RestirTarget {
    /// A jackknife estimate with `restir_n` samples (Eq. 4), clamped to [floor, 1].
    Jackknife = 0,
    /// None: T̂ = 1 (the unshadowed contribution).
    Unshadowed = 1,
    /// Ratio tracking (unbiased, costlier), clamped to [floor, 1].
    Ratio = 2,
}

impl RestirTarget {
    /// From the stored u32 (unknown values read as the jackknife).
    #[inline]
    pub fn from_u32(v: u32) -> Self {
        if v == RestirTarget::Unshadowed as u32 {
            RestirTarget::Unshadowed
        } else if v == RestirTarget::Ratio as u32 {
            RestirTarget::Ratio
        } else {
            RestirTarget::Jackknife
        }
    }
}

/// The resampling MIS weights of `restir`'s spatial reuse (GRIS Sec. 5.6).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RestirMis {
    /// Generalized pairwise MIS (Eq. 37 with confidence weights): O(k) target evaluations.
    Pairwise = 0,
    /// Generalized balance heuristic (Talbot, Eq. 36 with confidence weights): O(k^2).
    Balance = 1,
}

impl RestirMis {
    /// From the stored u32 (unknown values read as pairwise).
    #[inline]
    pub fn from_u32(v: u32) -> Self {
        if v == RestirMis::Balance as u32 {
            RestirMis::Balance
        } else {
            RestirMis::Pairwise
        }
    }
}

impl Integrator {
    /// From the stored u32 (unknown values read as transmittance).
    #[inline]
    pub fn from_u32(v: u32) -> Self {
        match v {
            1 => Integrator::FreeFlight,
            2 => Integrator::Equiangular,
            3 => Integrator::MisJackknife,
            4 => Integrator::MisNaive,
            5 => Integrator::CombinedJackknife,
            6 => Integrator::CombinedNaive,
            7 => Integrator::Miller,
            8 => Integrator::MisPowerJackknife,
            9 => Integrator::Direct,
            10 => Integrator::Path,
            11 => Integrator::Restir,
            _ => Integrator::Transmittance,
        }
    }
}

/// Which estimate of T(t0) the equiangular strategy of Eq. 9 uses (`RenderParams::t_hat`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransmittanceHat {
    /// Jackknife (Eq. 4; tiny bias).
    Jackknife = 0,
    /// Ratio tracking (unbiased: the whole image is then unbiased up to shadow rays).
    Ratio = 1,
}

/// `restir`'s settings in [`RenderParams`] (read only by `--integrator restir`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RestirParams {
    /// Light candidates per camera sample, M (streaming RIS, GRIS Sec. 6.2).
    pub candidates: u32,
    /// [`RestirTarget`] as u32: the transmittance factor of the target p̂.
    pub target: u32,
    /// Samples per optical depth estimate of the target's T̂ (jackknife: m N lookups).
    pub n: u32,
    /// The target's floor on T̂ (defensive: p̂ > 0 wherever the integrand is).
    pub floor: f32,
    /// Spatial reuse passes over the image (0: none), each a dispatch.
    pub passes: u32,
    /// Neighbours per pixel and reuse pass, k.
    pub neighbours: u32,
    /// Neighbours lie within this many pixels in x and y (a (2r + 1)^2 window).
    pub radius: u32,
    /// [`RestirMis`] as u32.
    pub mis: u32,
    /// Cap on a reused reservoir's confidence M (0: none; GRIS Sec. 6.4).
    pub m_cap: u32,
}

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
    /// [`Integrator`] as u32; 0 renders transmittance.
    pub integrator: u32,
    /// Number of valid entries in the lights buffer.
    pub light_count: u32,
    /// Single-scattering albedo mu_s / mu.
    pub albedo: f32,
    /// Henyey-Greenstein anisotropy g (0: isotropic).
    pub hg_g: f32,
    /// [`TransmittanceHat`] as u32.
    pub t_hat: u32,
    /// 1: ratio tracking uses pbrt-v4's Russian roulette; 0: none, as the paper and the author's
    /// code (Miller et al.'s MIS always runs without it: its weights need the plain product).
    pub roulette: u32,
    /// Collision cap of every tracking loop (0: [`MAX_TENTATIVE_COLLISIONS`]; the host lowers it
    /// where a ray holds several tracking loops, so one GPU invocation stays within its loop
    /// budget; reaching it is counted as capped).
    pub max_collisions: u32,
    /// `path`: vertices before Russian roulette starts.
    pub rr_depth: u32,
    /// `path`: most vertices (scattering events) of a path, at least 1.
    pub max_depth: u32,
    /// `restir`'s resampling settings.
    pub restir: RestirParams,
    /// [`Sampler`] as u32 (0: independent samples).
    pub sampler: u32,
}

use crate::spec::or_keep;
pub use crate::spec::UNSPECIALIZED;

impl RenderParams {
    /// The collision cap of the tracking loops: [`RenderParams::max_collisions`], or
    /// [`MAX_TENTATIVE_COLLISIONS`] where that is 0 or larger.
    #[inline]
    pub fn collision_cap(&self) -> u32 {
        if self.max_collisions == 0 || self.max_collisions > MAX_TENTATIVE_COLLISIONS {
            MAX_TENTATIVE_COLLISIONS
        } else {
            self.max_collisions
        }
    }

    /// `self` with `integrator`, `estimator` and `importance` replaced by a pipeline's
    /// specialization constants ([`UNSPECIALIZED`] keeps the field): the driver folds them, so a
    /// pipeline compiles only the code of one integrator, estimator and importance instead of
    /// the whole render kernel.
    #[inline]
    pub fn specialized(&self, integrator: u32, estimator: u32, importance: u32) -> RenderParams {
        RenderParams {
            integrator: or_keep(integrator, self.integrator),
            estimator: or_keep(estimator, self.estimator),
            importance: or_keep(importance, self.importance),
            ..*self
        }
    }
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
    /// Collision cap of the tracking loops, 1 to [`MAX_TENTATIVE_COLLISIONS`].
    pub max_collisions: u32,
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
            max_collisions: params.collision_cap(),
        }
    }
}
