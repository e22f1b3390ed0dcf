//! A second way for a [`crate::volume::grid::VolumeView`] to read its two tables, the voxel
//! pool and the brick records: as texel buffers of 32-bit words. On a SIMD device that loads a
//! storage buffer lane by lane (lavapipe: Mesa's `emit_load_mem` loops over its 8 lanes), a
//! texel fetch is one vector gather; the words are the same, so every lookup reads the same
//! bits either way. The CPU has none ([`NoTexels`]); the kernels bind both forms and pick one
//! per pipeline.

/// The pool (page 0, the whole pool) and the brick table as arrays of 32-bit words.
pub trait Texels: Copy {
    /// Whether the view reads its tables here (else from its slices).
    fn bound(&self) -> bool;
    /// Word `w` of the voxel pool.
    fn pool_word(&self, w: u32) -> u32;
    /// Word `w` of the brick table (record `i` is words `6 i .. 6 i + 6`, as in memory).
    fn brick_word(&self, w: u32) -> u32;
}

/// No texel buffers: the view reads its slices (the CPU, and kernels whose tables do not fit a
/// texel buffer).
#[derive(Clone, Copy, Debug, Default)]
pub struct NoTexels;

impl Texels for NoTexels {
    #[inline]
    fn bound(&self) -> bool {
        false
    }

    #[inline]
    fn pool_word(&self, _w: u32) -> u32 {
        0
    }

    #[inline]
    fn brick_word(&self, _w: u32) -> u32 {
        0
    }
}
