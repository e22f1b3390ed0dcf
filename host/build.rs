//! Compiles the `kernels` crate to one SPIR-V module with rust-gpu and exposes its path as the
//! `kernels.spv` environment variable for `include_bytes!`.

use spirv_builder::{Capability, SpirvBuilder};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let kernels = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../kernels");
    let mut builder = SpirvBuilder::new(kernels, "spirv-unknown-vulkan1.2")
        // PCG32 (rand_pcg's stream) needs 64-bit integers.
        .capability(Capability::Int64)
        .release(true);
    builder.build_script.defaults = true;
    builder.build_script.env_shader_spv_path = Some(true);
    builder.build()?;
    Ok(())
}
