//! Host side of the jackknife transmittance renderer: the ash GPU backend, the CPU backend and
//! the operations both run from the same `shared` code.

pub mod backend;
pub mod bench;
pub mod cli;
pub mod commands;
pub mod cpu;
pub mod diagnostics;
pub mod estimators;
pub mod gpu;
pub mod integrators;
pub mod job;
pub mod lighting;
pub mod procedural;

pub use backend::{Backend, BackendChoice};
/// Volume loaders (`.vdb`, `.nvdb`), re-exported from the `volume-io` crate.
pub use volume_io as io;
/// Dense and sparse volumes, re-exported from the `volume-io` crate.
pub use volume_io::volume;
pub mod bricks;
pub mod eval;
pub mod eval_direct;
/// Output planning and writing, re-exported from the `output` crate.
pub use output;
pub mod render;
pub mod report;
pub mod restir;
pub mod schedule;
pub mod shadow_map;
/// `host study`, re-exported from the `studies` crate.
pub use studies as study;
pub mod traversal;
