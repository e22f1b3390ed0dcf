//! Where a sample's uniforms come from (`--sampler`): every number from the sample's hash
//! generator (independent samples), or the path's leading dimensions from Owen-scrambled
//! Sobol patterns ([`super::sobol`]), one pattern per quantity in a fixed order: the pixel
//! jitter, then per path vertex the free flight (its first exponential step and its first
//! real-collision test), the light choice, the light's 2D sample, the phase 2D sample and
//! Russian roulette. Every other number of a sample (later tentative collisions, the shadow
//! estimators' samples, restir's candidates) still comes from the hash generator, so those
//! dimensions are independent under both samplers.
//!
//! A quantity takes its uniforms through a [`Lead`]: from the pattern when the sampler is on,
//! else from the generator exactly as before, so `independent` draws every bit it drew
//! without a sampler.

use crate::params::{RenderParams, Sampler};
use crate::rng::{pcg_hash, HashRng};
use crate::sampling::sobol::{pattern_seed, sobol_1d, sobol_2d};

/// Salt of a pixel's Sobol seed (other hashes of the render seed use other salts).
const PIXEL_SALT: u32 = 0x5bd1_e995;

/// Pattern of the pixel jitter.
pub const PIXEL: u32 = 0;
/// Patterns per path vertex, in the order of [`VertexPattern`].
pub const PER_VERTEX: u32 = 5;

/// The patterns of one path vertex (offsets from the vertex's first pattern).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VertexPattern {
    /// The free flight that reaches the vertex: its first step and first collision test (2D).
    Flight = 0,
    /// The light kind (1D).
    LightChoice = 1,
    /// The light's direction or point light (2D).
    Light = 2,
    /// The phase function's direction (2D).
    Phase = 3,
    /// Russian roulette after the vertex (1D).
    Roulette = 4,
}

/// The stratified dimensions of one sample: its pixel's scramble seed and its index within the
/// pixel, or off (`on == 0`: independent samples).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SampleDims {
    pub seed: u32,
    pub index: u32,
    pub on: u32,
}

impl SampleDims {
    /// No stratified dimension: every quantity draws from its generator.
    pub const OFF: SampleDims = SampleDims {
        seed: 0,
        index: 0,
        on: 0,
    };

    /// Sample `s` of pixel `id` under `params`' sampler and seed.
    #[inline]
    pub fn new(params: &RenderParams, id: u32, s: u32) -> Self {
        Self::from_parts(params, pixel_seed(params.seed, id), s)
    }

    /// The dimensions of a sample from its stored pixel seed and index ([`pixel_seed`]).
    #[inline]
    pub fn from_parts(params: &RenderParams, seed: u32, index: u32) -> Self {
        SampleDims {
            seed,
            index,
            on: (Sampler::from_u32(params.sampler) == Sampler::Sobol) as u32,
        }
    }

    /// The first pattern of path vertex `vertex` (0: the camera ray's free flight and the
    /// first scattering vertex), plus `which`.
    #[inline]
    pub fn vertex(vertex: u32, which: VertexPattern) -> u32 {
        1 + vertex.wrapping_mul(PER_VERTEX) + which as u32
    }

    /// The 2D point of `pattern` for this sample ([`sobol_2d`]; only read when on).
    #[inline]
    pub fn get_2d(self, pattern: u32) -> [f32; 2] {
        sobol_2d(self.index, pattern_seed(self.seed, pattern))
    }

    /// The 1D point of `pattern` for this sample.
    #[inline]
    pub fn get_1d(self, pattern: u32) -> f32 {
        sobol_1d(self.index, pattern_seed(self.seed, pattern))
    }

    /// A quantity's two leading uniforms from `pattern` (off when the sampler is).
    #[inline]
    pub fn lead_2d(self, pattern: u32) -> Lead {
        if self.on != 0 {
            let u = self.get_2d(pattern);
            Lead {
                u0: u[0],
                u1: u[1],
                on: 1,
            }
        } else {
            Lead::OFF
        }
    }

    /// The light choice's and the light sample's leads at path vertex `vertex`.
    #[inline]
    pub fn lights(self, vertex: u32) -> (Lead, Lead) {
        (
            self.lead_1d(Self::vertex(vertex, VertexPattern::LightChoice)),
            self.lead_2d(Self::vertex(vertex, VertexPattern::Light)),
        )
    }

    /// A quantity's leading uniform from `pattern` (off when the sampler is).
    #[inline]
    pub fn lead_1d(self, pattern: u32) -> Lead {
        if self.on != 0 {
            Lead {
                u0: self.get_1d(pattern),
                u1: 0.0,
                on: 1,
            }
        } else {
            Lead::OFF
        }
    }
}

/// The Sobol seed of pixel `id` under render seed `seed`.
#[inline]
pub fn pixel_seed(seed: u32, id: u32) -> u32 {
    pcg_hash(id ^ pcg_hash(seed ^ PIXEL_SALT))
}

/// Up to two leading uniforms of one quantity: from the sampler when `on`, else drawn from the
/// quantity's generator (which then advances as it did without a sampler).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lead {
    pub u0: f32,
    pub u1: f32,
    pub on: u32,
}

impl Lead {
    /// Every uniform from the generator.
    pub const OFF: Lead = Lead {
        u0: 0.0,
        u1: 0.0,
        on: 0,
    };

    /// Uniform k (0 or 1) of the quantity: the sampler's when on (the generator is returned
    /// unchanged), else the generator's next.
    #[inline]
    pub fn take(self, k: u32, rng: HashRng) -> (f32, HashRng) {
        if self.on != 0 {
            (if k == 0 { self.u0 } else { self.u1 }, rng)
        } else {
            rng.next_f32()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn off_draws_what_the_generator_draws() {
        let rng = HashRng::for_sample(3, 4, 5);
        let (a, r) = Lead::OFF.take(0, rng);
        let (b, r) = Lead::OFF.take(1, r);
        let (x, s) = rng.next_f32();
        let (y, s) = s.next_f32();
        assert_eq!((a, b, r), (x, y, s));
    }

    #[test]
    fn on_leaves_the_generator() {
        let rng = HashRng::for_sample(3, 4, 5);
        let lead = Lead {
            u0: 0.25,
            u1: 0.75,
            on: 1,
        };
        assert_eq!(lead.take(0, rng), (0.25, rng));
        assert_eq!(lead.take(1, rng), (0.75, rng));
    }

    #[test]
    fn vertices_take_distinct_patterns() {
        let mut seen = std::vec::Vec::new();
        for v in 0..8 {
            for w in [
                VertexPattern::Flight,
                VertexPattern::LightChoice,
                VertexPattern::Light,
                VertexPattern::Phase,
                VertexPattern::Roulette,
            ] {
                seen.push(SampleDims::vertex(v, w));
            }
        }
        seen.push(PIXEL);
        let n = seen.len();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), n);
    }
}
