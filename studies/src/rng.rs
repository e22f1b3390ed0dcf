//! Random numbers of the studies: the shared PCG32 stream, one generator per chunk of trials, with
//! 53-bit f64 uniforms and Box-Muller normals on top.

use shared::rng::Pcg32;

/// 2^-53: turns 53 random bits into an f64 in [0, 1) exactly.
const INV_2_POW_53: f64 = 1.0 / 9_007_199_254_740_992.0;

/// SplitMix64 finaliser: spreads a seed and a key over all 64 bits.
pub fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A seed for one part of a study (one grid cell, one sample count), derived from the user's seed.
pub fn sub_seed(seed: u64, key: u64) -> u64 {
    splitmix64(seed ^ splitmix64(key))
}

/// PCG32 with its state kept inside (the studies never leave the host).
#[derive(Clone, Debug)]
pub struct Rng(Pcg32);

impl Rng {
    /// The generator of chunk `chunk`: its own stream and a scrambled start state.
    pub fn for_chunk(seed: u64, chunk: u64) -> Self {
        Rng(Pcg32::new(sub_seed(seed, chunk), chunk))
    }

    /// Next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let (bits, next) = self.0.next_u32();
        self.0 = next;
        bits
    }

    /// Uniform in [0, 1) with 53 random bits.
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        let hi = (self.next_u32() >> 5) as u64;
        let lo = (self.next_u32() >> 6) as u64;
        ((hi << 26) | lo) as f64 * INV_2_POW_53
    }

    /// Uniform in (0, 1]: safe to take the logarithm of.
    #[inline]
    pub fn uniform_open0(&mut self) -> f64 {
        1.0 - self.uniform()
    }

    /// Two independent standard normal numbers (Box-Muller); the tails are cut at 8.57 sigma,
    /// where ln(2^-53) ends, which no study with fewer than 10^16 trials can see.
    #[inline]
    pub fn normal_pair(&mut self) -> (f64, f64) {
        let r = (-2.0 * self.uniform_open0().ln()).sqrt();
        let (s, c) = (std::f64::consts::TAU * self.uniform()).sin_cos();
        (r * c, r * s)
    }
}
