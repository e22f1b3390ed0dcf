//! The Vulkan backend (the `vulkan-backend` crate, re-exported) and [`render`], the render jobs
//! it runs for the engine ([`crate::backend::schedule::RenderBackend`]).

pub mod render;

pub use vulkan_backend::*;
