//! All estimator logic of the jackknife transmittance renderer, written once for the CPU and for
//! SPIR-V (rust-gpu). Nothing here may depend on the target: one body per function.
#![cfg_attr(not(test), no_std)]
#![feature(core_float_math)]

pub mod camera;
pub mod complex;
pub mod dda;
pub mod grid;
pub mod half;
pub mod integrator;
pub mod launch;
pub mod lights;
pub mod math;
pub mod mis;
pub mod optical_depth;
pub mod probe;
pub mod ray_marching;
pub mod render;
pub mod rng;
pub mod tally;
pub mod tracking;
pub mod transmittance;
pub mod vec3;

pub use complex::Complex;
pub use tally::Tally;
