//! The hash of the sources the kernels' SPIR-V modules are built from, in the committed
//! manifest (`vulkan-backend/spirv/manifest.toml`) and computed again by every build of
//! `vulkan-backend` (its build script) and by `kernel-builder`: the same file in both
//! (`#[path]`), so they cannot disagree on what counts.

use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// What the modules are built from, relative to the workspace root: the shader crates, the
/// builder (its passes and flags), the dependency versions, the workspace's profiles and the
/// toolchain. A folder counts with every file below it.
pub const SOURCES: [&str; 9] = [
    "shared/Cargo.toml",
    "shared/src",
    "kernels/Cargo.toml",
    "kernels/src",
    "kernel-builder/Cargo.toml",
    "kernel-builder/src",
    "Cargo.toml",
    "Cargo.lock",
    "rust-toolchain.toml",
];

/// SHA-256 (hex) over every file of [`SOURCES`] under `root`, in the order of their relative
/// paths (with `/`): each file's path, its length and its bytes.
pub fn source_hash(root: &Path) -> std::io::Result<String> {
    let mut files = Vec::new();
    for s in SOURCES {
        collect(&root.join(s), &mut files)?;
    }
    let mut named: Vec<(String, PathBuf)> = files
        .into_iter()
        .map(|f| {
            let rel = f.strip_prefix(root).unwrap_or(&f);
            let name: Vec<String> = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            (name.join("/"), f)
        })
        .collect();
    named.sort();
    let mut h = Sha256::new();
    for (name, path) in &named {
        let bytes = std::fs::read(path)?;
        h.update(name.as_bytes());
        h.update([0]);
        h.update((bytes.len() as u64).to_le_bytes());
        h.update(&bytes);
    }
    Ok(hex(&h.finalize()))
}

/// SHA-256 (hex) of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

fn hex(d: &[u8]) -> String {
    d.iter().map(|b| format!("{b:02x}")).collect()
}

/// `path` if it is a file, else every file below it (hidden entries left out).
fn collect(path: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
    let meta = std::fs::metadata(path)?;
    if meta.is_file() {
        out.push(path.to_path_buf());
        return Ok(());
    }
    for entry in std::fs::read_dir(path)? {
        let entry = entry?;
        if entry.file_name().to_string_lossy().starts_with('.') {
            continue;
        }
        collect(&entry.path(), out)?;
    }
    Ok(())
}
