//! The render engine of the jackknife transmittance renderer: scenes (volumes, bricks,
//! super-voxels, camera), lighting, the CPU backend and the render jobs the Vulkan backend runs,
//! render planning (passes, totals, shadow maps), and `host render` as a library call. No
//! command-line parsing: the `host` crate turns flags into these options.
#![feature(portable_simd)]

pub mod backend;
pub mod estimators;
pub mod integrators;
pub mod lighting;
pub mod render;
pub mod render_job;
pub mod scene;

pub use backend::{Backend, BackendChoice};
/// Output planning and writing, re-exported from the `output` crate.
pub use output;
pub use scene::defaults;
/// Volume loaders (`.vdb`, `.nvdb`), re-exported from the `volume-io` crate.
pub use volume_io as io;
/// Dense and sparse volumes, re-exported from the `volume-io` crate.
pub use volume_io::volume;
