//! Shared by the targets: load the input as a volume file of a given extension.

use std::path::PathBuf;

/// Dense-grid cap while fuzzing: small enough that no input can take seconds to fill.
const FUZZ_MAX_VOXELS: u64 = 1 << 22;

/// Writes `data` to a per-process scratch file ending in `.ext` and loads it; any error is fine,
/// a panic, abort or hang is a bug.
pub fn load(data: &[u8], ext: &str) {
    let dir = std::env::var_os("FUZZ_SCRATCH")
        .map(PathBuf::from)
        .unwrap_or_else(std::env::temp_dir);
    let path = dir.join(format!("volume-io-fuzz-{}.{ext}", std::process::id()));
    std::fs::write(&path, data).expect("scratch file");
    for grid in [None, Some("density")] {
        if let Ok(v) = volume_io::load_volume_capped(&path, grid, FUZZ_MAX_VOXELS) {
            assert!(v.values.iter().all(|x| x.is_finite() && *x >= 0.0));
            assert_eq!(
                v.values.len() as u64,
                v.dims.iter().map(|&d| u64::from(d)).product::<u64>()
            );
        }
    }
}
