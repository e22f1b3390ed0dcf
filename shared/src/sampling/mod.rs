//! Sampling: distances along a ray (exponential against the brick majorants, equiangular toward
//! a point), lights (a pmf over point lights; an environment map, a sun and the pmf over light
//! kinds), phase; the sample's uniforms (independent or Owen-scrambled Sobol).

pub mod env;
pub mod equiangular;
pub mod exponential;
pub mod lighting;
pub mod lights;
pub mod phase;
pub mod sampler;
pub mod sobol;
pub mod sun;
