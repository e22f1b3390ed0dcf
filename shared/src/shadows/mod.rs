//! Deterministic shadow transmittance from precomputed maps (the alternative to stochastic
//! shadow rays): moment shadow maps (`msm`).

pub mod msm;
