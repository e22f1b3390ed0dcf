//! All estimator logic of the jackknife transmittance renderer, written once for the CPU and for
//! SPIR-V (rust-gpu). Nothing here may depend on the target: one body per function.
#![cfg_attr(not(test), no_std)]

pub mod complex;
pub mod launch;
pub mod math;
pub mod probe;
pub mod rng;
pub mod transmittance;

pub use complex::Complex;
