//! Picks the kernels' SPIR-V modules that `src/kernels.rs` embeds: the committed ones in
//! `spirv/` when their manifest names the hash of today's sources (no rust-gpu build at all,
//! and no rust-gpu crate compiled), else a fresh build of the kernels by `kernel-builder` into
//! OUT_DIR, with a warning that says so (rust-gpu's backend and the kernels take 15-30 minutes
//! on 2 cores the first time). `scripts/build_kernels.sh` updates the committed modules;
//! `JK_REBUILD_KERNELS=1` forces the fresh build. The folder's `kernels.rs` (the typed list of
//! entry points) includes each module from `JK_SPIRV_DIR`, set here.

#[path = "build/source_hash.rs"]
mod source_hash;

use std::path::{Path, PathBuf};
use std::process::Command;

type BoxError = Box<dyn std::error::Error>;

fn main() -> Result<(), BoxError> {
    let manifest_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let root = manifest_dir
        .parent()
        .ok_or("vulkan-backend has no parent folder")?
        .to_path_buf();
    for s in source_hash::SOURCES {
        println!("cargo:rerun-if-changed={}", root.join(s).display());
    }
    let committed = manifest_dir.join("spirv");
    println!("cargo:rerun-if-changed={}", committed.display());
    println!("cargo:rerun-if-env-changed=JK_REBUILD_KERNELS");
    let hash = source_hash::source_hash(&root)?;
    let manifest = std::fs::read_to_string(committed.join("manifest.toml")).unwrap_or_default();
    let forced = std::env::var("JK_REBUILD_KERNELS").is_ok_and(|v| v == "1");
    let dir = if !forced && value(&manifest, "source_hash").as_deref() == Some(hash.as_str()) {
        check_modules(&committed, &manifest)?;
        committed
    } else {
        let why = if forced {
            "JK_REBUILD_KERNELS=1".to_owned()
        } else {
            format!(
                "the kernels' sources (hash {}) differ from those of the committed SPIR-V \
                 (vulkan-backend/spirv/manifest.toml)",
                &hash[..12]
            )
        };
        println!(
            "cargo:warning={why}: building the kernels with rust-gpu (kernel-builder; 15-30 \
             minutes on 2 cores the first time); scripts/build_kernels.sh updates the committed \
             modules"
        );
        let out = PathBuf::from(std::env::var("OUT_DIR")?).join("spirv");
        rebuild(&root, &out)?;
        out
    };
    println!("cargo:rustc-env=JK_SPIRV_DIR={}", dir.display());
    Ok(())
}

/// The quoted value of `key = "..."` in a manifest (None if absent).
fn value(manifest: &str, key: &str) -> Option<String> {
    manifest.lines().find_map(|l| {
        let (k, v) = l.split_once('=')?;
        (k.trim() == key).then(|| v.trim().trim_matches('"').to_owned())
    })
}

/// Every module of the folder has the SHA-256 its manifest names, and the manifest names no
/// module the folder lacks: a committed module edited by hand (or cut short) is refused.
fn check_modules(dir: &Path, manifest: &str) -> Result<(), BoxError> {
    let listed: Vec<(String, String)> = manifest
        .split_once("[modules]")
        .map(|(_, m)| m)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| {
            let (k, v) = l.split_once('=')?;
            Some((k.trim().to_owned(), v.trim().trim_matches('"').to_owned()))
        })
        .collect();
    if listed.is_empty() {
        return Err(format!("{}: the manifest lists no module", dir.display()).into());
    }
    let fix = "run scripts/build_kernels.sh to build them again";
    for (name, want) in &listed {
        let path = dir.join(format!("{name}.spv"));
        let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}; {fix}", path.display()))?;
        if source_hash::sha256_hex(&bytes) != *want {
            return Err(format!(
                "{} does not match its manifest (edited or damaged); {fix}",
                path.display()
            )
            .into());
        }
    }
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned());
        if path.extension().is_some_and(|e| e == "spv")
            && !listed.iter().any(|(n, _)| Some(n) == stem.as_ref())
        {
            return Err(format!("{} is not in the manifest; {fix}", path.display()).into());
        }
    }
    Ok(())
}

/// Builds the kernels into `out` with `cargo run -p kernel-builder`, in a target folder of its
/// own (this build holds the workspace's).
fn rebuild(root: &Path, out: &Path) -> Result<(), BoxError> {
    // rust-gpu builds against the compiler's own crates and rebuilds `core` for SPIR-V: the
    // components rust-toolchain.toml leaves out (a missing rustup leaves it to cargo's error).
    let _ = Command::new("rustup")
        .current_dir(root)
        .args(["component", "add", "rust-src", "rustc-dev", "llvm-tools"])
        .status();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .current_dir(root)
        .args(["run", "--release", "-p", "kernel-builder", "--target-dir"])
        .arg(root.join("target").join("kernel-builder"))
        .arg("--")
        .arg("--out")
        .arg(out)
        // Flags of this build script's own compilation, not of the builder's.
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .env_remove("RUSTC_WORKSPACE_WRAPPER")
        .env_remove("CARGO_TARGET_DIR")
        .status()
        .map_err(|e| format!("running cargo to build the kernels: {e}"))?;
    if !status.success() {
        return Err(format!("building the kernels (kernel-builder) failed: {status}").into());
    }
    Ok(())
}
