//! Random numbers with explicit state: PCG32 (the exact stream of `rand_pcg::Pcg32`) and the
//! stateless PCG hash and PCG3D of Jarzynski & Olano 2020 for per-pixel seeds and 3D jitter.
//!
//! State is passed in and returned, so the CPU and every GPU invocation draw identical streams.

use crate::lanes::{Lanes, One};
use bytemuck::{Pod, Zeroable};

/// PCG32 multiplier (O'Neill's 64-bit LCG constant, as in `rand_pcg`).
const PCG_MULTIPLIER: u64 = 6_364_136_223_846_793_005;
/// 2^-24: turns the top 24 bits of a u32 into a float in [0, 1) exactly.
pub const INV_2_POW_24: f32 = 1.0 / 16_777_216.0;

/// PCG-XSH-RR 64/32 generator; `Pcg32::new(s, q)` equals `rand_pcg::Pcg32::new(s, q)` bit for bit.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct Pcg32 {
    pub state: u64,
    pub increment: u64,
}

impl Pcg32 {
    /// Seeds a generator from a state and a stream selector (`rand_pcg::Pcg32::new`).
    pub fn new(state: u64, stream: u64) -> Self {
        let increment = (stream << 1) | 1;
        let rng = Pcg32 {
            state: state.wrapping_add(increment),
            increment,
        };
        rng.step()
    }

    /// Advances the LCG by one step.
    #[inline]
    fn step(self) -> Self {
        Pcg32 {
            state: self
                .state
                .wrapping_mul(PCG_MULTIPLIER)
                .wrapping_add(self.increment),
            increment: self.increment,
        }
    }

    /// Next 32 random bits and the advanced generator (XSH-RR output of the old state).
    #[inline]
    pub fn next_u32(self) -> (u32, Self) {
        let old = self.state;
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        (rotate_right(xorshifted, rot), self.step())
    }

    /// Uniform float in [0, 1) with 24 random bits, and the advanced generator.
    #[inline]
    pub fn next_f32(self) -> (f32, Self) {
        let (bits, rng) = self.next_u32();
        (unit_f32(bits), rng)
    }
}

/// The paper's `rand()` (Sec. 4.3): a PCG-hash chain, state = pcg_hash(state), one u32 of state.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct HashRng {
    pub state: u32,
}

impl HashRng {
    /// A generator for one (pixel, sample, seed) triple: the three are hashed together.
    #[inline]
    pub fn for_sample(pixel: u32, sample: u32, seed: u32) -> Self {
        HashRng {
            state: pcg_hash(pixel ^ pcg_hash(sample ^ pcg_hash(seed))),
        }
    }

    /// Next 32 random bits and the advanced generator.
    #[inline]
    pub fn next_u32(self) -> (u32, Self) {
        let s = pcg_hash(self.state);
        (s, HashRng { state: s })
    }

    /// Uniform in [0, 1) (24 bits).
    #[inline]
    pub fn next_f32(self) -> (f32, Self) {
        let (bits, rng) = self.next_u32();
        (unit_f32(bits), rng)
    }

    /// Uniform in (0, 1]: never 0, so a stratum offset k + xi never falls into stratum k - 1.
    #[inline]
    pub fn next_f32_open0(self) -> (f32, Self) {
        let (u, rng) = self.next_f32();
        (1.0 - u, rng)
    }
}

/// `x.rotate_right(r)` written with shifts that stay in range for r = 0 on every target.
#[inline]
pub fn rotate_right(x: u32, r: u32) -> u32 {
    (x >> (r & 31)) | (x << (r.wrapping_neg() & 31))
}

/// Maps 32 random bits to [0, 1) using the top 24 (exact in f32).
#[inline]
pub fn unit_f32(bits: u32) -> f32 {
    unit_f32_lanes::<One>(bits)
}

/// [`unit_f32`] lane by lane (its one body).
#[inline(always)]
pub fn unit_f32_lanes<L: Lanes>(bits: L::U) -> L::F {
    L::u_to_f(L::u_shr(bits, L::u(8))) * L::f(INV_2_POW_24)
}

/// PCG hash of one u32 (Jarzynski & Olano 2020, "pcg"): a well-mixed seed per pixel.
#[inline]
pub fn pcg_hash(v: u32) -> u32 {
    pcg_hash_lanes::<One>(v)
}

/// [`pcg_hash`] lane by lane (its one body).
#[inline(always)]
pub fn pcg_hash_lanes<L: Lanes>(v: L::U) -> L::U {
    let state = L::u_add(L::u_mul(v, L::u(747_796_405)), L::u(2_891_336_453));
    let shift = L::u_add(L::u_shr(state, L::u(28)), L::u(4));
    let word = L::u_mul(L::u_xor(L::u_shr(state, shift), state), L::u(277_803_737));
    L::u_xor(L::u_shr(word, L::u(22)), word)
}

/// PCG3D (Jarzynski & Olano 2020): three well-mixed u32 from three, for 3D jitter.
#[inline]
pub fn pcg3d(v: [u32; 3]) -> [u32; 3] {
    pcg3d_lanes::<One>(v)
}

/// [`pcg3d`] lane by lane (its one body).
#[inline(always)]
pub fn pcg3d_lanes<L: Lanes>(v: [L::U; 3]) -> [L::U; 3] {
    let (a, c) = (L::u(1_664_525), L::u(1_013_904_223));
    let mut x = L::u_add(L::u_mul(v[0], a), c);
    let mut y = L::u_add(L::u_mul(v[1], a), c);
    let mut z = L::u_add(L::u_mul(v[2], a), c);
    x = L::u_add(x, L::u_mul(y, z));
    y = L::u_add(y, L::u_mul(z, x));
    z = L::u_add(z, L::u_mul(x, y));
    x = L::u_xor(x, L::u_shr(x, L::u(16)));
    y = L::u_xor(y, L::u_shr(y, L::u(16)));
    z = L::u_xor(z, L::u_shr(z, L::u(16)));
    x = L::u_add(x, L::u_mul(y, z));
    y = L::u_add(y, L::u_mul(z, x));
    z = L::u_add(z, L::u_mul(x, y));
    [x, y, z]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::RngCore;

    #[test]
    fn pcg32_equals_rand_pcg() {
        for (seed, stream) in [
            (0u64, 0u64),
            (42, 54),
            (u64::MAX, u64::MAX),
            (0xdead_beef, 7),
        ] {
            let mut reference = rand_pcg::Pcg32::new(seed, stream);
            let mut ours = Pcg32::new(seed, stream);
            for i in 0..10_000 {
                let (v, next) = ours.next_u32();
                ours = next;
                assert_eq!(
                    v,
                    reference.next_u32(),
                    "seed {seed} stream {stream} draw {i}"
                );
            }
        }
    }

    #[test]
    fn pcg_hash_and_pcg3d_match_an_independent_python_model() {
        // Values from a Python transcription of the GLSL listings in Jarzynski & Olano 2020.
        assert_eq!(pcg_hash(0), 129_708_002);
        assert_eq!(pcg_hash(1), 2_831_084_092);
        assert_eq!(pcg_hash(12_345), 4_099_845_390);
        assert_eq!(pcg_hash(u32::MAX), 3_861_530_882);
        assert_eq!(
            pcg3d([0, 0, 0]),
            [2_611_992_518, 2_833_812_075, 1_058_359_340]
        );
        assert_eq!(
            pcg3d([1, 2, 3]),
            [4_204_755_366, 1_223_881_804, 1_500_469_937]
        );
    }

    #[test]
    fn pcg_hash_is_collision_free_on_consecutive_seeds() {
        // The hash is a permutation of u32 (LCG step, then an invertible output function).
        let mut seen: std::vec::Vec<u32> = (0..1u32 << 20).map(pcg_hash).collect();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), 1 << 20);
    }

    #[test]
    fn rotate_matches_core() {
        for r in 0..64 {
            assert_eq!(rotate_right(0x8000_0001, r), 0x8000_0001u32.rotate_right(r));
        }
    }

    #[test]
    fn unit_f32_range() {
        assert_eq!(unit_f32(0), 0.0);
        assert!(unit_f32(u32::MAX) < 1.0);
    }
}
