//! All estimator logic of the jackknife transmittance renderer, written once for the CPU and for
//! SPIR-V (rust-gpu). Nothing here may depend on the target: one body per function.
//!
//! Layers, each using only those above it (`scripts/module_cycles.py shared/src` checks):
//! `math`, `rng`, `lanes`, `rgb`, `half`, `complex`, `geometry`, `camera`, `tally` -> `volume` (grid, lookups,
//! DDA) -> `shadows` (moment shadow maps) -> `params` (the render's launch parameters, the enums that cross the GPU boundary, and
//! their one decode) -> `sampling` (exponential and equiangular distances, lights, environment map, sun, phase) ->
//! `estimators` (Eq. 4, Alg. 1/2, tracking, ray marching, one `estimate::transmittance` for every
//! ray) -> `mis` -> `integrators` -> `kernels` (launch headers, pixel passes, probes).
#![cfg_attr(not(test), no_std)]

pub mod camera;
pub mod complex;
pub mod estimators;
pub mod geometry;
pub mod half;
pub mod integrators;
pub mod kernels;
pub mod lanes;
pub mod math;
pub mod mis;
pub mod params;
pub mod rgb;
pub mod rng;
pub mod sampling;
pub mod shadows;
pub mod spec;
pub mod tally;
pub mod volume;

pub use complex::Complex;
pub use tally::Tally;
