//! The CPU backend: the same `shared` kernel bodies over the same ids, on all cores with rayon.

use rayon::prelude::*;

/// Applies `f` to every input on all cores, in id order.
pub fn map<I, O, F>(inputs: &[I], f: F) -> Vec<O>
where
    I: Sync + Copy,
    O: Send,
    F: Fn(I) -> O + Sync,
{
    inputs.par_iter().map(|&x| f(x)).collect()
}

/// Evaluates `f(id)` for ids 0..count on all cores, in id order.
pub fn generate<O, F>(count: u32, f: F) -> Vec<O>
where
    O: Send,
    F: Fn(u32) -> O + Sync,
{
    (0..count).into_par_iter().map(&f).collect()
}
