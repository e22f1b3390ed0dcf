//! Host side of the jackknife transmittance renderer: the ash GPU backend, the CPU backend and
//! the operations both run from the same `shared` code.

pub mod backend;
pub mod cpu;
pub mod gpu;
pub mod volume;

pub mod bricks;
pub mod output;
pub mod render;

pub use backend::{Backend, BackendChoice};
