//! Deterministic shadow transmittance from precomputed maps (the alternative to stochastic
//! shadow rays): moment shadow maps (`msm`: moments and their reconstruction; `map`: the
//! orthographic map of a directional light over a volume, built by a voxel DDA per texel).

pub mod map;
pub mod msm;
