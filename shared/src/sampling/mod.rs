//! Sampling: distances along a ray (equiangular), lights (a pmf over point lights), phase.

pub mod equiangular;
pub mod lights;
pub mod phase;
