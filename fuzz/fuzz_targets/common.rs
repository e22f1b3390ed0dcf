//! Shared by the targets: load the input as a volume file of a given extension.

use std::path::PathBuf;
use volume_io::VolumeData;

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
        let dense = volume_io::load_volume_capped(&path, grid, FUZZ_MAX_VOXELS);
        if let Ok(v) = &dense {
            assert!(v.values.iter().all(|x| x.is_finite() && *x >= 0.0));
            assert_eq!(
                v.values.len() as u64,
                v.dims.iter().map(|&d| u64::from(d)).product::<u64>()
            );
        }
        // The sparse load reads the same voxels or refuses the file with the same error.
        // A sparse load has no cap on its box's voxels (only on memory): cap the box here.
        let small_box = |t: &volume_io::Topology| {
            let voxels = t.dims.iter().fold(1u64, |n, &d| n.saturating_mul(d));
            anyhow::ensure!(voxels <= FUZZ_MAX_VOXELS, "box above the fuzzing cap");
            Ok(())
        };
        let options = volume_io::LoadOptions {
            grid,
            max_voxels: FUZZ_MAX_VOXELS,
            check_topology: Some(volume_io::TopologyCheck(&small_box)),
            ..volume_io::LoadOptions::default()
        };
        let sparse = volume_io::load_volume_with(&path, &options);
        match (&dense, &sparse) {
            (Ok(d), Ok(s)) => {
                let mut values = Vec::new();
                if s.volume.fill([0; 3], s.volume.dims(), &mut values) {
                    assert!(values.iter().zip(&d.values).all(|(a, b)| a.to_bits() == b.to_bits()));
                } else {
                    assert!(d.values.iter().all(|x| *x == 0.0));
                }
            }
            // Above the dense cap the sparse load stops at the fuzzing cap's check instead.
            (Err(d), Err(s)) if format!("{s:#}").contains("box above the fuzzing cap") => {
                assert!(format!("{d:#}").contains("a dense grid may hold"), "{d:#}");
            }
            (Err(d), Err(s)) => assert_eq!(format!("{d:#}"), format!("{s:#}")),
            _ => panic!("dense and sparse loads disagree: {:?} vs {:?}", dense.err(), sparse.err()),
        }
    }
}
