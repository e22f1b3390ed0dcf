//! What the kernels run per invocation: launch headers, pixel passes of a render, and the probe
//! kernels' functions (math, rng, Eq. 4, equiangular sampling on given inputs), and the CPU's
//! pass over several pixels per instruction (`wide`).

pub mod launch;
pub mod probe;
pub mod render;
pub mod shadow_map;
pub mod wide;
