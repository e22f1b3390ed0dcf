//! Primary-ray transmittance images (like the paper's Fig. 8): one pure function per pixel.

use crate::camera::{to_index_space, Affine3x4, Camera};
use crate::dda::clip_to_box;
use crate::grid::{Lookup, VolumeView};
use crate::optical_depth::{estimate_pair, prepare, Importance, Jitter};
use crate::rng::HashRng;
use crate::transmittance;
use crate::vec3::V3;
use bytemuck::{Pod, Zeroable};

/// Transmittance estimators selectable at run time (u32 in [`RenderParams`]).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Estimator {
    /// Jackknife K = cos(S) exp(-X̄) from Alg. 1's two estimates (Eq. 4).
    Jackknife = 0,
    /// Naive exp(-X̄) from the same two estimates.
    NaiveMean = 1,
}

impl Estimator {
    /// From the stored u32 (unknown values read as the jackknife).
    #[inline]
    pub fn from_u32(v: u32) -> Self {
        if v == 1 {
            Estimator::NaiveMean
        } else {
            Estimator::Jackknife
        }
    }
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
}

/// Per-pixel result: mean transmittance over spp and the high-resolution lookups taken.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PixelOut {
    pub t_mean: f32,
    pub samples: u32,
}

/// Transmittance estimate of one world-space ray through the whole volume, and its lookups.
#[inline]
pub fn ray_transmittance(
    vol: &VolumeView,
    params: &RenderParams,
    world: &crate::dda::Ray,
    rng: HashRng,
) -> (f32, u32, HashRng) {
    let ray = to_index_space(world, &params.world_to_index);
    let d = &vol.desc.dims;
    let hi = V3::new(d[0] as f32, d[1] as f32, d[2] as f32);
    let (t0, t1) = clip_to_box(&ray, hi, 0.0, f32::INFINITY);
    if !(t0 < t1) {
        return (1.0, 0, rng);
    }
    let mode = if params.importance == 1 {
        Importance::Mean
    } else {
        Importance::VarianceAware
    };
    let jitter = if params.jitter == 1 {
        Jitter::Uniform
    } else {
        Jitter::Stratified
    };
    let lookup = Lookup::from_u32(vol.desc.lookup);
    let prep = prepare(vol, &ray, t0, t1, mode);
    let (est, rng) = estimate_pair(vol, &ray, &prep, params.n, mode, jitter, lookup, rng);
    let t = match Estimator::from_u32(params.estimator) {
        Estimator::Jackknife => transmittance::jackknife(est.x0, est.x1),
        Estimator::NaiveMean => transmittance::naive(est.x0, est.x1),
    };
    (t, est.samples, rng)
}

/// Mean transmittance of pixel `id` (row-major) over `spp` jittered primary rays.
pub fn render_pixel(vol: &VolumeView, params: &RenderParams, id: u32) -> PixelOut {
    let x = id % params.width;
    let y = id / params.width;
    let mut sum = 0.0f32;
    let mut samples = 0u32;
    let mut s = 0;
    while s < params.spp {
        let rng = HashRng::for_sample(id, s, params.seed);
        let (jx, rng) = rng.next_f32();
        let (jy, rng) = rng.next_f32();
        let world = params
            .camera
            .world_ray(x, y, jx, jy, params.width, params.height);
        let (t, n, _) = ray_transmittance(vol, params, &world, rng);
        sum += t;
        samples += n;
        s += 1;
    }
    PixelOut {
        t_mean: sum / params.spp as f32,
        samples,
    }
}
