//! `kernel-builder`: builds the `kernels` crate with rust-gpu into the files `vulkan-backend`
//! embeds, or checks committed ones against a fresh build.
//!
//!     kernel-builder --out DIR     build into DIR (created; its kernel files replaced)
//!     kernel-builder --check DIR   build into a temporary folder; exit 1 unless DIR holds the
//!                                  same files, byte for byte
//!
//! The files: one optimized SPIR-V module per entry point (`<entry>.spv`), `kernels.rs` (the
//! typed list, [`reflect::kernel_items`]) and `manifest.toml` (the hash of the sources they were
//! built from, [`source_hash::SOURCES`], and each module's SHA-256). `scripts/build_kernels.sh`
//! runs it on `vulkan-backend/spirv`, the committed copy; `vulkan-backend`'s build script runs
//! it when the sources differ from that copy's manifest.

mod compare;
mod compile;
mod reflect;
#[path = "../../vulkan-backend/build/source_hash.rs"]
mod source_hash;
mod undef_arms;

use std::path::{Path, PathBuf};

type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// The name of the manifest in a kernel folder.
const MANIFEST: &str = "manifest.toml";

fn main() -> std::process::ExitCode {
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("kernel-builder: error: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run() -> Result<(), BoxError> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: kernel-builder --out DIR | --check DIR";
    let [mode, dir] = args.as_slice() else {
        return Err(usage.into());
    };
    let dir = PathBuf::from(dir);
    let root = workspace_root();
    match mode.as_str() {
        "--out" => {
            build_into(&root, &dir)?;
            eprintln!("kernel-builder: wrote the kernels to {}", dir.display());
            Ok(())
        }
        "--check" => {
            let fresh = tempdir(&root)?;
            let result = build_into(&root, &fresh).and_then(|()| {
                compare::same_files(&dir, &fresh).map_err(|e| {
                    format!(
                        "the committed kernels in {} differ from a fresh build of the sources: {e}; \
                         run scripts/build_kernels.sh and commit {}",
                        dir.display(),
                        dir.display()
                    )
                    .into()
                })
            });
            let _ = std::fs::remove_dir_all(&fresh);
            result?;
            eprintln!(
                "kernel-builder: {} holds exactly a fresh build of the sources",
                dir.display()
            );
            Ok(())
        }
        _ => Err(usage.into()),
    }
}

/// The workspace root (this crate's parent folder).
fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("kernel-builder lives in the workspace root")
        .to_path_buf()
}

/// A fresh folder for a build to compare, under the workspace's `target`.
fn tempdir(root: &Path) -> Result<PathBuf, BoxError> {
    let dir = root
        .join("target")
        .join(format!("kernel-check-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

/// Builds the kernels and writes every file of a kernel folder into `out`: the modules,
/// `kernels.rs` and the manifest (written last, so a folder with a manifest is complete). Files
/// of an earlier build that this one does not write are removed.
fn build_into(root: &Path, out: &Path) -> Result<(), BoxError> {
    let hash = source_hash::source_hash(root)?;
    let result = compile::compile(&root.join("kernels"))?;
    std::fs::create_dir_all(out)?;
    let _ = std::fs::remove_file(out.join(MANIFEST));
    let jobs = std::thread::available_parallelism().map_or(1, |n| n.get());
    let modules = compile::optimize_all(&result, out, jobs)?;
    let code = reflect::kernel_items(&result, &modules)?;
    std::fs::write(out.join("kernels.rs"), code)?;
    let mut names: Vec<&String> = modules.keys().collect();
    names.sort();
    let mut manifest = String::from(
        "# The kernels' SPIR-V modules in this folder, written by kernel-builder\n\
         # (scripts/build_kernels.sh); do not edit. source_hash: SHA-256 of the sources they were\n\
         # built from (vulkan-backend/build/source_hash.rs); modules: SHA-256 of each module.\n",
    );
    manifest += &format!("source_hash = \"{hash}\"\n\n[modules]\n");
    for name in &names {
        let bytes = std::fs::read(&modules[*name])?;
        manifest += &format!("{name} = \"{}\"\n", source_hash::sha256_hex(&bytes));
    }
    // Leftovers of entry points that no longer exist.
    for entry in std::fs::read_dir(out)? {
        let path = entry?.path();
        let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned());
        if path.extension().is_some_and(|e| e == "spv")
            && !stem.is_some_and(|s| modules.contains_key(&s))
        {
            std::fs::remove_file(&path)?;
        }
    }
    std::fs::write(out.join(MANIFEST), manifest)?;
    Ok(())
}
