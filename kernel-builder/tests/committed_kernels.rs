//! The committed kernels (`vulkan-backend/spirv`) are exactly a fresh rust-gpu build of the
//! sources, byte for byte (`kernel-builder --check`); with `JK_WRITE_KERNELS=1` the fresh build
//! replaces them instead. Ignored in plain test runs (rust-gpu compiles the kernels: about 15
//! minutes on 2 cores): `scripts/build_kernels.sh [--check]` runs it, and CI through
//! `scripts/test.sh`. A test of the workspace, so that its dependencies resolve with the
//! workspace's features and rust-gpu's backend is compiled once for the check and the tests.

use std::path::Path;
use std::process::Command;

#[test]
#[ignore = "builds the kernels with rust-gpu (about 15 minutes); run by scripts/build_kernels.sh"]
fn committed_kernels_equal_a_fresh_build() {
    let folder = Path::new(env!("CARGO_MANIFEST_DIR")).join("../vulkan-backend/spirv");
    let mode = if std::env::var("JK_WRITE_KERNELS").is_ok_and(|v| v == "1") {
        "--out"
    } else {
        "--check"
    };
    let status = Command::new(env!("CARGO_BIN_EXE_kernel-builder"))
        .arg(mode)
        .arg(&folder)
        .status()
        .expect("running kernel-builder");
    assert!(status.success(), "kernel-builder {mode} failed ({status})");
}
