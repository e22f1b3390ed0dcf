//! The volume as the kernels see it: grid descriptor, brick statistics, lookups, and the DDA.

pub mod dda;
pub mod grid;
pub mod pages;
pub mod supervoxels;
pub mod texels;
