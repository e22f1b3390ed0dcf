//! The volume as the kernels see it: grid descriptor, brick statistics, lookups, and the DDA;
//! what Alg. 1 and 2 read of it over lanes (`lane_volume`), and the brick traversal and lookups
//! over several rays at once (`wide`).

pub mod dda;
pub mod grid;
pub mod lane_volume;
pub mod pages;
pub mod supervoxels;
pub mod texels;
pub mod wide;
