//! Host side of the jackknife transmittance renderer: the ash GPU backend, the CPU backend and
//! the operations both run from the same `shared` code.

pub mod backend;
pub mod cli;
pub mod commands;
pub mod cpu;
pub mod estimators;
pub mod gpu;
pub mod io;
pub mod procedural;
pub mod volume;

pub use backend::{Backend, BackendChoice};
pub mod bricks;
pub mod eval;
pub mod output;
pub mod render;
pub mod report;
pub mod study;
