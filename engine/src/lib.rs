//! The render engine of the jackknife transmittance renderer: scenes (volumes, bricks,
//! super-voxels, camera), lighting, shadow maps, the CPU backend, the render jobs the Vulkan
//! backend runs, and `host render` as a library call. No command-line parsing: the `host` crate
//! turns flags into these options.
#![feature(portable_simd)]

pub mod backend;
pub mod bricks;
pub mod cpu;
pub mod diagnostics;
pub mod estimators;
pub mod exact;
pub mod gpu;
pub mod integrators;
pub mod job;
pub mod lighting;
pub mod procedural;
pub mod progressive;
pub mod render;
pub mod render_job;
pub mod restir;
pub mod scene;
pub mod schedule;
pub mod shadow_map;
pub mod supervoxel_info;
pub mod totals;
pub mod traversal;
pub mod wide;

pub use backend::{Backend, BackendChoice};
/// Output planning and writing, re-exported from the `output` crate.
pub use output;
pub use scene::defaults;
/// Volume loaders (`.vdb`, `.nvdb`), re-exported from the `volume-io` crate.
pub use volume_io as io;
/// Dense and sparse volumes, re-exported from the `volume-io` crate.
pub use volume_io::volume;
