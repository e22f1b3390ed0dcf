//! The volume as the kernels see it: grid descriptor, brick statistics, lookups, and the DDA
//! (its step over lanes: `walk`); the brick traversal and lookups over several rays at once
//! (`wide`).

pub mod dda;
pub mod grid;
pub mod pages;
pub mod supervoxels;
pub mod texels;
pub mod walk;
pub mod wide;
