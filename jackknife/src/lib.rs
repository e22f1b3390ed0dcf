//! Jackknife transmittance and MIS weight estimation (C. Peters, ACM TOG 44(6), 2025) as a
//! library: the estimators of the paper and its baselines, and a builder of the brick grid they
//! traverse, on stable Rust. The same functions run on the GPU in the `jackknife` renderer (the
//! `shared` crate compiled to SPIR-V by rust-gpu); depending on this crate builds no shader.
//!
//! ```
//! use jackknife::{GridBuilder, Lookup, Ray, SegmentEstimator, V3};
//! // A 16^3 constant medium of extinction 0.5 per voxel length.
//! let grid = GridBuilder::from_fn([16; 3], |_, _, _| 0.5).build().unwrap();
//! let ray = Ray { o: V3::new(-1.0, 8.5, 8.5), d: V3::new(1.0, 0.0, 0.0) };
//! let (t0, t1) = grid.clip(&ray);
//! let est = SegmentEstimator::jackknife(10);
//! let (t, _tally) = est.estimate(&grid, &ray, t0, t1, 7);
//! assert!((t - (-8.0f32).exp()).abs() < 1e-4);
//! ```
#![deny(missing_docs)]

mod adaptive;
pub mod bc4;
mod builder;
mod segment;
mod stats;

pub use adaptive::{
    occupancy, Supervoxels, DEFAULT_CELL_SIZE, DEFAULT_SPLIT_OCCUPANCY, DEFAULT_SPLIT_RATIO,
};
pub use builder::{
    BuildError, Grid, GridBuilder, SupervoxelFormat, Underflow, DEFAULT_BRICK_SIZE, FALLBACK_STEPS,
    MAX_AXIS, MAX_OPTICAL_DEPTH, MAX_PAGE_LOG2,
};
pub use segment::SegmentEstimator;
pub use shared::estimators::transmittance::{jackknife, naive, s, x_bar};
pub use shared::geometry::{Ray, V3};
pub use shared::params::Estimator;
pub use shared::params::{Importance, Jitter};
pub use shared::rng::HashRng;
pub use shared::volume::grid::{Brick, GridDesc, Lookup, VolumeView};
pub use shared::Tally;

/// The `no_std` core these functions come from, for everything this facade does not re-export
/// (optical depth estimates of Alg. 1 and 2, tracking, ray marching, MIS weights, integrators).
pub use shared as core_estimators;
