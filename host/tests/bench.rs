//! `host bench` end to end on a tiny scene: the JSON has every estimator on both backends with
//! identical quality numbers (same rays, same bits), the goal ratios, the sweep and its plot.
//! No timing is asserted (timings belong to the benchmark, not to tests).

use std::process::Command;

#[test]
fn bench_reports_every_estimator_on_both_backends_and_the_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    let plot = dir.path().join("sweep.png");
    let out = Command::new(env!("CARGO_BIN_EXE_host"))
        .args([
            "bench",
            "--backend",
            "both",
            "--resolution",
            "16",
            "--width",
            "16",
            "--height",
            "12",
            "--spp",
            "3",
            "--reps",
            "2",
            "--warmup",
            "0",
            "--sweep",
            "--sweep-resolutions",
            "8,16",
            "--sweep-sizes",
            "8,16",
            "--quiet",
        ])
        .arg("--json")
        .arg(&json)
        .arg("--plot")
        .arg(&plot)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("goal cpu") && stdout.contains("goal gpu"),
        "{stdout}"
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = r["rows"].as_array().unwrap();
    let names = [
        "jackknife",
        "naive-m1",
        "biased-rm",
        "unbiased-rm",
        "telescoping",
        "track-length",
        "ratio",
    ];
    assert_eq!(rows.len(), 2 * names.len(), "{rows:?}");
    for name in names {
        let row = |backend: &str| {
            rows.iter()
                .find(|x| x["backend"] == backend && x["estimator"] == name)
                .unwrap_or_else(|| panic!("no {backend} row for {name}"))
        };
        let (cpu, gpu) = (row("cpu"), row("gpu"));
        for field in ["samples_per_ray", "variance"] {
            assert_eq!(cpu[field], gpu[field], "{name} {field}: CPU and GPU differ");
        }
        for r in [cpu, gpu] {
            assert_eq!(r["frame_ms"].as_array().unwrap().len(), 2);
            let ms = r["frame_ms_median"].as_f64().unwrap();
            assert!(ms > 0.0 && ms.is_finite(), "{name}: {ms}");
            assert!(r["variance"].as_f64().unwrap() >= 0.0);
        }
        assert!(cpu["kernel_ms_median"].is_null());
    }
    assert_eq!(r["goals"].as_array().unwrap().len(), 8);
    // 4 sweep estimators x 2 resolutions (or sizes) x 2 backends.
    assert_eq!(r["sweep_resolution"].as_array().unwrap().len(), 16);
    // Each point records its volume's preparation and pool: only occupied bricks are stored.
    for p in r["sweep_resolution"].as_array().unwrap() {
        assert!(p["prepare_ms"].as_f64().unwrap() >= 0.0, "{p}");
        let (all, occupied) = (
            p["bricks"].as_u64().unwrap(),
            p["occupied_bricks"].as_u64().unwrap(),
        );
        assert!(occupied > 0 && occupied <= all, "{p}");
        assert!(p["pool_bytes"].as_u64().unwrap() > 0, "{p}");
    }
    assert_eq!(r["sweep_size"].as_array().unwrap().len(), 16);
    let png = image::open(&plot).unwrap();
    assert_eq!((png.width(), png.height()), (1200, 500));
}

#[test]
fn bench_refuses_a_sweep_of_a_file_before_working() {
    let fixture =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/density_zip.vdb");
    let out = Command::new(env!("CARGO_BIN_EXE_host"))
        .args(["bench", "--sweep", "--backend", "cpu", "--volume"])
        .arg(&fixture)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("--sweep needs an embedded volume"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("ms/frame"),
        "worked before refusing: {stderr}"
    );
}

/// `--sweep-files`: one point per file, backend and sweep estimator, with the volume's grid,
/// preparation time, peak resident memory (Linux), pool and ns/ray; a missing file is refused
/// before any work.
#[test]
fn bench_times_a_series_of_volume_files() {
    let fixtures = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures");
    let files = [
        fixtures.join("sparse_patches.vdb"),
        fixtures.join("density_zip.vdb"),
    ];
    let list = files
        .iter()
        .map(|f| f.display().to_string())
        .collect::<Vec<_>>()
        .join(",");
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    let run_with = |list: &str, quiet: &str| {
        Command::new(env!("CARGO_BIN_EXE_host"))
            .args([
                "bench",
                "--backend",
                "cpu",
                "--resolution",
                "16",
                "--width",
                "8",
                "--height",
                "8",
                "--spp",
                "2",
                "--reps",
                "1",
                "--warmup",
                "0",
                "--estimators",
                "jackknife",
                "--sweep-estimators",
                "jackknife,ratio",
                quiet,
                "--sweep-files",
                list,
            ])
            .arg("--json")
            .arg(&json)
            .output()
            .unwrap()
    };
    let run = |list: &str| run_with(list, "--quiet");
    let out = run(&list);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let points = r["sweep_files"].as_array().unwrap();
    // 2 files x 1 backend x 2 estimators.
    assert_eq!(points.len(), 4, "{points:?}");
    let sparse = &points[0];
    assert!(sparse["volume"]
        .as_str()
        .unwrap()
        .ends_with("sparse_patches.vdb"));
    assert_eq!(sparse["dims"], serde_json::json!([131, 101, 82]));
    for p in points {
        assert!(p["prepare_ms"].as_f64().unwrap() > 0.0, "{p}");
        assert!(p["ns_per_ray"].as_f64().unwrap() > 0.0, "{p}");
        assert!(p["pool_bytes"].as_u64().unwrap() > 0, "{p}");
        if cfg!(target_os = "linux") {
            let before = p["rss_before_bytes"].as_u64().unwrap();
            assert!(before > 1 << 20, "{p}");
            assert!(p["peak_rss_bytes"].as_u64().unwrap() >= before, "{p}");
        }
    }
    // A missing file: refused, naming the flag, before the first frame.
    let missing = dir.path().join("missing.vdb");
    let out = run(&format!("{list},{}", missing.display()));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("--sweep-files") && stderr.contains("missing.vdb"),
        "{stderr}"
    );
    // Before any work (issue 43, item 6: it failed after the whole bench): without --quiet, the
    // bench's first line, printed once the main volume is loaded, never appears; so does a
    // directory or a file of another kind.
    let exr = dir.path().join("image.exr");
    std::fs::write(&exr, b"not a volume").unwrap();
    for bad in [missing.clone(), dir.path().to_owned(), exr] {
        let out = run_with(&format!("{list},{}", bad.display()), "--seed=1");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert!(stderr.starts_with("error: --sweep-files"), "{stderr}");
        assert!(!stderr.contains("bench: "), "{stderr}");
    }
}

/// An unknown estimator is named once with its flag (issue 43, item 10: "--estimators:
/// --estimators: unknown estimator").
#[test]
fn unknown_estimators_are_named_with_their_flag_once() {
    for (flag, extra) in [
        ("--estimators", None),
        ("--sweep-estimators", Some("--sweep")),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_host"))
            .args(["bench", "--backend", "cpu", flag, "foo"])
            .args(extra)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        let expected = format!("error: {flag}: unknown estimator \"foo\"");
        assert!(stderr.starts_with(&expected), "{stderr}");
        assert_eq!(stderr.matches(flag).count(), 1, "{stderr}");
    }
}
