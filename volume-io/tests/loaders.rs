//! Volume loaders against fixtures written by OpenVDB 10.0.1 and NanoVDB's `nanovdb_convert`
//! (`scripts/fixtures/make_fixtures.sh`): values, bounding boxes and transforms must match what OpenVDB's
//! own accessors report (the `.expected` sidecars) and the analytic pattern the fixtures hold;
//! broken, unsupported and missing files must give errors that name the file.

use std::path::{Path, PathBuf};
use volume_io::volume::VolumeData;
use volume_io::DenseVolume;
use volume_io::{load_volume, load_volume_capped, load_volume_with};
use volume_io::{LoadOptions, Topology, TopologyCheck};

/// Path of a checked-in fixture.
fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures")
        .join(name)
}

/// A scratch path for files written by a test.
fn scratch(name: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("volume_io_{name}"))
}

/// Loads a fixture that must load.
fn load(name: &str, grid: Option<&str>) -> DenseVolume {
    load_volume(&fixture(name), grid).unwrap_or_else(|e| panic!("{name}: {e:#}"))
}

/// The full error chain of a load that must fail.
fn load_err(path: &Path, grid: Option<&str>) -> String {
    match load_volume(path, grid) {
        Ok(v) => panic!("{} loaded ({:?}) but should fail", path.display(), v.dims),
        Err(e) => format!("{e:#}"),
    }
}

/// Asserts `msg` contains every one of `parts`.
fn assert_mentions(msg: &str, parts: &[&str]) {
    for p in parts {
        assert!(msg.contains(p), "error should mention {p:?}: {msg}");
    }
}

/// What OpenVDB reported for a fixture grid (see `scripts/fixtures/make_fixtures.cpp`).
struct Expected {
    bbox_min: [i32; 3],
    bbox_max: [i32; 3],
    /// World positions of the dense corner and one voxel step along x, y, z from it.
    corners: [[f64; 3]; 4],
    active_sum: f64,
    /// Dense values over the bbox, x fastest (absent for large grids).
    values: Option<Vec<f32>>,
}

/// Parses `<stem>.<grid>.expected`.
fn expected(stem: &str, grid: &str) -> Expected {
    let path = fixture(&format!("{stem}.{grid}.expected"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut e = Expected {
        bbox_min: [0; 3],
        bbox_max: [0; 3],
        corners: [[0.0; 3]; 4],
        active_sum: 0.0,
        values: None,
    };
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    for line in lines.by_ref() {
        let mut words = line.split_whitespace();
        let key = words.next().unwrap_or_default();
        let nums: Vec<f64> = words.map(|w| w.parse().unwrap_or(f64::NAN)).collect();
        let v3 = || [nums[0], nums[1], nums[2]];
        match key {
            "bbox_min" => e.bbox_min = v3().map(|v| v as i32),
            "bbox_max" => e.bbox_max = v3().map(|v| v as i32),
            "world_corner" => e.corners[0] = v3(),
            "world_corner_x1" => e.corners[1] = v3(),
            "world_corner_y1" => e.corners[2] = v3(),
            "world_corner_z1" => e.corners[3] = v3(),
            "active_sum" => e.active_sum = nums[0],
            "values" => break,
            _ => {}
        }
    }
    let values: Vec<f32> = lines.map(|l| l.parse::<f64>().unwrap() as f32).collect();
    e.values = (!values.is_empty()).then_some(values);
    e
}

/// Applies the volume's index-to-world map to dense index point `p`.
fn world(v: &DenseVolume, p: [f64; 3]) -> [f64; 3] {
    v.index_to_world.0.map(|row| {
        f64::from(row[0]) * p[0]
            + f64::from(row[1]) * p[1]
            + f64::from(row[2]) * p[2]
            + f64::from(row[3])
    })
}

/// Asserts a loaded volume matches OpenVDB's report voxel for voxel, with the same placement.
fn assert_matches(v: &DenseVolume, e: &Expected, what: &str) {
    let dims: [u32; 3] = std::array::from_fn(|a| (e.bbox_max[a] - e.bbox_min[a] + 1) as u32);
    assert_eq!(v.dims, dims, "{what}: dims");
    let steps = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for (step, corner) in steps.iter().zip(&e.corners) {
        let got = world(v, *step);
        for a in 0..3 {
            assert!(
                (got[a] - corner[a]).abs() <= 1e-5 * (1.0 + corner[a].abs()),
                "{what}: dense point {step:?} maps to {got:?}, OpenVDB says {corner:?}"
            );
        }
    }
    if let Some(values) = &e.values {
        assert_eq!(v.values.len(), values.len(), "{what}: value count");
        for (i, (got, want)) in v.values.iter().zip(values).enumerate() {
            assert_eq!(
                got.to_bits(),
                want.to_bits(),
                "{what}: voxel {i}: {got} vs OpenVDB {want}"
            );
        }
    }
    let sum: f64 = v.values.iter().map(|&x| f64::from(x)).sum();
    assert!(
        (sum - e.active_sum).abs() <= 1e-6 * e.active_sum.abs().max(1.0),
        "{what}: sum {sum} vs {}",
        e.active_sum
    );
}

/// The pattern grid's value at bbox-local voxel (i, j, k), as the generator computes it.
fn pattern(i: u32, j: u32, k: u32) -> f32 {
    if (i * 7 + j * 3 + k) % 11 == 5 {
        0.0 // a hole: set inactive (with value 0.7) by the generator
    } else {
        0.01f32 * (i + 2 * j + 3 * k) as f32
    }
}

/// Asserts a volume is the 20x12x9 pattern grid at index (-4, 3, -5), unit voxels.
fn assert_pattern(v: &DenseVolume, half: bool, what: &str) {
    assert_eq!(v.dims, [20, 12, 9], "{what}");
    assert_eq!(
        v.index_to_world,
        volume_io::Affine::scale_translate([1.0; 3], [-4.5, 2.5, -5.5]),
        "{what}"
    );
    for k in 0..9 {
        for j in 0..12 {
            for i in 0..20 {
                let mut want = pattern(i, j, k);
                if half {
                    want = half::f16::from_f32(want).to_f32();
                }
                assert_eq!(v.at(i, j, k), want, "{what}: voxel ({i}, {j}, {k})");
            }
        }
    }
}

#[test]
fn vdb_float_grids_match_openvdb_in_every_compression() {
    for (stem, half) in [
        ("density_blosc", false),
        ("density_zip", false),
        ("density_raw", false),
        ("density_half_blosc", true),
        ("density_half_zip", true),
    ] {
        let v = load(&format!("{stem}.vdb"), None);
        assert_matches(&v, &expected(stem, "density"), stem);
        assert_pattern(&v, half, stem);
        assert!(v.name.ends_with(&format!("{stem}.vdb")), "{}", v.name);
    }
}

#[test]
fn nvdb_matches_the_vdb_it_was_converted_from() {
    let v = load("density.nvdb", None);
    assert_matches(&v, &expected("density_blosc", "density"), "density.nvdb");
    assert_pattern(&v, false, "density.nvdb");
    for stem in ["scale_translate", "affine", "tiles"] {
        let v = load(&format!("{stem}.nvdb"), None);
        assert_matches(&v, &expected(stem, "density"), &format!("{stem}.nvdb"));
    }
}

#[test]
fn transforms_place_dense_voxels_where_openvdb_does() {
    let v = load("scale_translate.vdb", None);
    assert_matches(
        &v,
        &expected("scale_translate", "density"),
        "scale_translate.vdb",
    );
    // Voxel size (0.5, 0.25, 2), translation (1.5, -2, 3), bbox min (2, -1, 7): the dense
    // corner is file index (1.5, -1.5, 6.5).
    let want = volume_io::Affine::scale_translate([0.5, 0.25, 2.0], [2.25, -2.375, 16.0]);
    assert_eq!(v.index_to_world, want);

    // Scale (0.1, 0.2, 0.3), then a quarter turn about z, then translation (10, 20, 30).
    let v = load("affine.vdb", None);
    assert_matches(&v, &expected("affine", "density"), "affine.vdb");
    let a = v.index_to_world.0;
    assert!(
        (a[0][1] + 0.2).abs() < 1e-6 && (a[1][0] - 0.1).abs() < 1e-6,
        "rotation lost: {a:?}"
    );
}

#[test]
fn active_tiles_are_filled_and_inactive_tiles_are_background() {
    let v = load("tiles.vdb", None);
    assert_matches(&v, &expected("tiles", "density"), "tiles.vdb");
    assert_eq!(v.dims, [21, 21, 8]);
    assert_eq!(v.at(0, 0, 0), 0.5, "lower-node tile from fill()");
    assert_eq!(v.at(15, 15, 7), 0.5);
    assert_eq!(v.at(16, 0, 0), 0.0);
    assert_eq!(v.at(20, 3, 2), 1.25);
    assert_eq!(v.at(2, 20, 1), 0.3);
    assert_eq!(
        v.at(0, 16, 0),
        0.0,
        "inactive tile of 0.9 must read as background"
    );

    let v = load("upper_tile.vdb", None);
    assert_matches(&v, &expected("upper_tile", "density"), "upper_tile.vdb");
    assert_eq!(v.dims, [131, 128, 128]);
    assert_eq!(
        (v.at(0, 0, 0), v.at(127, 127, 127)),
        (0.25, 0.25),
        "upper-node 128^3 tile"
    );
    assert_eq!(
        (v.at(128, 1, 2), v.at(130, 1, 2), v.at(130, 0, 0)),
        (0.0, 1.0, 0.0)
    );
}

#[test]
fn default_grid_falls_back_to_the_first_float_grid() {
    // multi.vdb holds velocity (vec3s), temperature, flames (float) and precise (double), in
    // that order; nanovdb_convert wrote multi.nvdb's grids sorted by name (flames first).
    let temperature = expected("multi", "temperature");
    let flames = expected("multi", "flames");
    assert_matches(&load("multi.vdb", None), &temperature, "multi.vdb default");
    assert_matches(
        &load("multi.vdb", Some("flames")),
        &flames,
        "multi.vdb flames",
    );
    assert_matches(&load("multi.nvdb", None), &flames, "multi.nvdb default");
    assert_matches(
        &load("multi.nvdb", Some("temperature")),
        &temperature,
        "multi.nvdb temperature",
    );

    let precise = load("multi.vdb", Some("precise"));
    assert_eq!(
        (precise.dims, precise.values.as_slice()),
        ([3, 1, 1], [0.125, 0.0, 2.5].as_slice())
    );
    let msg = load_err(&fixture("multi.nvdb"), Some("precise"));
    assert_mentions(&msg, &["multi.nvdb", "'precise'", "Double"]);
}

#[test]
fn missing_grid_errors_list_the_available_grids() {
    let msg = load_err(&fixture("multi.vdb"), Some("smoke"));
    assert_mentions(
        &msg,
        &[
            "multi.vdb",
            "no grid named 'smoke'",
            "velocity (vec3s), temperature (float), flames (float), precise (double)",
        ],
    );
    let msg = load_err(&fixture("multi.nvdb"), Some("smoke"));
    assert_mentions(
        &msg,
        &["multi.nvdb", "no grid named 'smoke'", "velocity (Vec3f)"],
    );
}

#[test]
fn vector_and_integer_grids_are_refused() {
    for (file, grid, parts) in [
        ("vec3.vdb", None, ["no float grid", "velocity (vec3s)"]),
        (
            "vec3.vdb",
            Some("velocity"),
            ["'velocity' holds vec3s values", "pick a float grid"],
        ),
        (
            "int.vdb",
            None,
            ["'density' holds int32 values", "density (int32)"],
        ),
        ("vec3.nvdb", None, ["no float grid", "velocity (Vec3f)"]),
        (
            "int.nvdb",
            None,
            ["'density' holds Int32 values", "density (Int32)"],
        ),
    ] {
        let msg = load_err(&fixture(file), grid);
        assert_mentions(&msg, &[file]);
        assert_mentions(&msg, &parts);
    }
}

#[test]
fn empty_and_oversized_grids_are_refused_before_allocating() {
    assert_mentions(
        &load_err(&fixture("empty.vdb"), None),
        &["empty.vdb", "no active voxels"],
    );
    let msg = load_err(&fixture("huge.vdb"), None);
    assert_mentions(&msg, &["huge.vdb", "2001x2001x2001", "crop"]);
    let msg = load_err(&fixture("root_tile.vdb"), None);
    assert_mentions(&msg, &["root_tile.vdb", "4096x4096x4096"]);
    let err = load_volume_capped(&fixture("density.nvdb"), None, 1000).unwrap_err();
    assert_mentions(
        &format!("{err:#}"),
        &["density.nvdb", "20x12x9 = 2160 voxels"],
    );
}

#[test]
fn unsupported_nvdb_encodings_are_refused_with_advice() {
    let msg = load_err(&fixture("density_blosc.nvdb"), None);
    assert_mentions(&msg, &["density_blosc.nvdb", "Blosc", "nanovdb_convert"]);
    let msg = load_err(&fixture("density_fp16.nvdb"), None);
    assert_mentions(&msg, &["density_fp16.nvdb", "'density' holds Fp16 values"]);
}

#[test]
fn truncated_files_are_errors_naming_the_file() {
    for name in [
        "density_blosc.vdb",
        "density_zip.vdb",
        "density_half_blosc.vdb",
        "tiles.vdb",
        "density.nvdb",
    ] {
        let bytes = std::fs::read(fixture(name)).unwrap();
        for len in [
            0,
            7,
            8,
            100,
            500,
            bytes.len() / 2,
            bytes.len() - 100,
            bytes.len() - 1,
        ] {
            let path = scratch(&format!("truncated_{len}_{name}"));
            std::fs::write(&path, &bytes[..len]).unwrap();
            let msg = load_err(&path, None);
            assert_mentions(&msg, &[&path.display().to_string()]);
            assert!(!msg.contains("panicked"), "{msg}");
        }
    }
}

/// `density_zip.vdb` with its last 300 bytes (inside the leaf buffers) cut, the descriptor's end
/// offset patched so that the parser gets that far.
fn truncated_leaves() -> PathBuf {
    let bytes = std::fs::read(fixture("density_zip.vdb")).unwrap();
    let cut = bytes.len() - 300;
    let mut short = bytes[..cut].to_vec();
    let end = bytes.len() as u64;
    let at = short
        .windows(8)
        .position(|w| w == end.to_le_bytes())
        .expect("descriptor end offset");
    short[at..at + 8].copy_from_slice(&(cut as u64).to_le_bytes());
    let path = scratch("truncated_leaves.vdb");
    std::fs::write(&path, &short).unwrap();
    path
}

#[test]
fn truncation_inside_the_grid_is_reported_as_truncation() {
    assert_mentions(
        &load_err(&truncated_leaves(), None),
        &["truncated_leaves.vdb", "leaf", "truncated"],
    );
}

/// A load with a topology check that records the box it sees and refuses.
fn refused_by_topology_check(path: &Path, sparse: bool) -> (Vec<Topology>, String) {
    let seen = std::sync::Mutex::new(Vec::new());
    let check = |t: &Topology| -> anyhow::Result<()> {
        seen.lock().unwrap().push(*t);
        anyhow::bail!("refused by the check")
    };
    let options = LoadOptions {
        sparse,
        check_topology: Some(TopologyCheck(&check)),
        ..LoadOptions::default()
    };
    let err = match load_volume_with(path, &options) {
        Ok(_) => panic!("{} loaded past a refusing check", path.display()),
        Err(e) => format!("{e:#}"),
    };
    (seen.into_inner().unwrap(), err)
}

/// The topology check sees the bounding box that will be built, exactly once, and its refusal
/// comes before any voxel value is read or any grid is allocated: a file whose leaf buffers are
/// cut gives the check's error instead of the truncation, and a box above the dense cap gives
/// the check's error instead of the cap's.
#[test]
fn the_topology_check_sees_the_box_before_any_value_is_read() {
    for sparse in [true, false] {
        for (file, dims) in [
            ("density_zip.vdb", [20, 12, 9]),
            ("density.nvdb", [20, 12, 9]),
            ("huge.vdb", [2001, 2001, 2001]),
            ("sparse_patches.nvdb", [131, 101, 82]),
        ] {
            let (seen, err) = refused_by_topology_check(&fixture(file), sparse);
            let seen_dims: Vec<_> = seen.iter().map(|t| t.dims).collect();
            assert_eq!(seen_dims, vec![dims], "{file} (sparse {sparse})");
            assert_mentions(&err, &[file, "refused by the check"]);
        }
        let (seen, err) = refused_by_topology_check(&truncated_leaves(), sparse);
        assert_eq!(
            seen[..],
            [Topology {
                dims: [20, 12, 9],
                tile_voxels: 0
            }]
        );
        assert_mentions(&err, &["truncated_leaves.vdb", "refused by the check"]);
        assert!(!err.contains("truncated,"), "{err}");
    }
    // Without a check the same files load (or fail) as before.
    assert!(load_volume_with(&fixture("density_zip.vdb"), &LoadOptions::default()).is_ok());
    // Active tiles of nonzero value are counted before any leaf is read: `root_tile.vdb`'s
    // one 4096^3 root tile, `tiles.vdb`'s 8^3 and 128^3 tiles (see scripts/fixtures/make_fixtures.cpp).
    let (seen, _) = refused_by_topology_check(&fixture("root_tile.vdb"), true);
    assert_eq!(
        seen[..],
        [Topology {
            dims: [4096; 3],
            tile_voxels: 1 << 36
        }]
    );
    let (seen, _) = refused_by_topology_check(&fixture("tiles.vdb"), true);
    assert!(seen[0].tile_voxels >= 512, "{:?}", seen[0]);
}

/// A sparse load takes a bounding box above the dense cap of 2^31 voxels (`huge.vdb`: two voxels
/// at opposite corners of 2001^3 = 8.0e9 voxels), holding only its two leaves and the cell
/// table; the dense load still refuses it. A box longer than 2^31 along an axis (`wide.vdb`) is
/// refused by both, with the same words.
#[test]
fn sparse_loads_take_boxes_above_the_dense_cap() {
    let loaded = load_volume_with(&fixture("huge.vdb"), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e:#}"));
    let v = &loaded.volume;
    assert_eq!(v.dims(), [2001; 3]);
    assert_eq!(v.storage(), "sparse");
    // 252^3 cells of a u32 (64 MB) and two leaves; a dense f32 box would take 32 GB.
    assert!(v.stored_bytes() < 70_000_000, "{}", v.stored_bytes());
    let mut one = Vec::new();
    for (at, value) in [([0, 0, 0], 1.0), ([2000; 3], 1.0), ([1000; 3], 0.0)] {
        let hi = at.map(|c| c + 1);
        let stored = v.fill(at, hi, &mut one);
        assert_eq!(if stored { one[0] } else { 0.0 }, value, "{at:?}");
    }
    assert_mentions(
        &load_err(&fixture("huge.vdb"), None),
        &["2001x2001x2001", "crop"],
    );
    for sparse in [true, false] {
        let options = LoadOptions {
            sparse,
            ..LoadOptions::default()
        };
        let err = format!(
            "{:#}",
            load_volume_with(&fixture("wide.vdb"), &options).unwrap_err()
        );
        assert_mentions(
            &err,
            &["wide.vdb", "4294967296x1x1", "more than 2^31 along an axis"],
        );
    }
}

#[test]
fn corrupted_files_never_panic() {
    // Deterministic byte mutations; each load may succeed or fail but must not panic or allocate
    // more than the small cap.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for name in [
        "density_blosc.vdb",
        "density_zip.vdb",
        "density_half_zip.vdb",
        "tiles.vdb",
    ] {
        let original = std::fs::read(fixture(name)).unwrap();
        for round in 0..150 {
            let mut bytes = original.clone();
            for _ in 0..1 + next() % 4 {
                let at = (next() % bytes.len() as u64) as usize;
                bytes[at] = next() as u8;
            }
            let path = scratch(&format!("corrupt_{round}_{name}"));
            std::fs::write(&path, &bytes).unwrap();
            if let Err(e) = load_volume_capped(&path, None, 1 << 20) {
                let msg = format!("{e:#}");
                assert!(!msg.contains("panicked"), "{msg}");
                assert_mentions(&msg, &[&path.display().to_string()]);
            }
        }
    }
}

#[test]
fn garbage_missing_and_unknown_files_are_errors_naming_the_path() {
    let garbage: Vec<u8> = (0..4096u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    for (name, what) in [
        ("garbage.vdb", "not an OpenVDB file"),
        ("garbage.nvdb", "not a NanoVDB file"),
    ] {
        let path = scratch(name);
        std::fs::write(&path, &garbage).unwrap();
        assert_mentions(&load_err(&path, None), &[&path.display().to_string(), what]);
    }
    for name in ["no_such_volume.vdb", "no_such_volume.nvdb"] {
        let path = fixture(name);
        assert_mentions(
            &load_err(&path, None),
            &[&path.display().to_string(), "No such file"],
        );
    }
    let path = scratch("volume.raw");
    assert_mentions(
        &load_err(&path, None),
        &["volume.raw", "expected .vdb (OpenVDB) or .nvdb (NanoVDB)"],
    );
}
