//! Sampling: distances along a ray (exponential against the brick majorants, equiangular toward
//! a point), lights (a pmf over point lights), phase.

pub mod equiangular;
pub mod exponential;
pub mod lights;
pub mod phase;
