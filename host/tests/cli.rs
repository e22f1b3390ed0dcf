//! End-to-end runs of the `host` binary: device reporting, CPU fallback, forced GPU failure.

use std::process::Command;

fn host() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host"))
}

/// Environment that hides every Vulkan driver from the loader.
fn without_vulkan(cmd: &mut Command) -> &mut Command {
    cmd.env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
}

#[test]
fn default_run_reports_the_device_and_a_less_biased_jackknife() {
    let out = host()
        .args(["probe", "--count", "200000"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("backend: gpu"), "{stdout}");
    let bias = |label: &str| -> f64 {
        let line = stdout.lines().find(|l| l.contains(label)).unwrap();
        line.split("bias ").nth(1).unwrap().trim().parse().unwrap()
    };
    // tau = 2, sigma = 1: the naive mean is exp(-2 + 1/4), bias +0.0385; the jackknife is unbiased
    // for normal inputs. 200k pairs give a standard error of about 0.00025 for the jackknife.
    assert!(bias("jackknife").abs() < 0.0015, "{stdout}");
    assert!((bias("naive") - 0.0385).abs() < 0.0015, "{stdout}");
}

#[test]
fn cpu_and_gpu_print_identical_numbers() {
    let run = |backend: &str| {
        let out = host()
            .args([
                "probe",
                "--count",
                "100000",
                "--seed",
                "9",
                "--backend",
                backend,
            ])
            .output()
            .unwrap();
        assert!(out.status.success());
        // Drop the backend line and the timing; everything else must match exactly.
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .skip(1)
            .map(|l| l.split(": kernel time").next().unwrap().to_string())
            .collect::<Vec<_>>()
    };
    assert_eq!(run("gpu"), run("cpu"));
}

#[test]
fn without_a_driver_auto_falls_back_to_cpu_with_a_warning() {
    let out = without_vulkan(&mut host())
        .args(["probe", "--count", "1000"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stderr}");
    assert!(stdout.contains("backend: cpu"), "{stdout}");
    let warnings: Vec<_> = stderr
        .lines()
        .filter(|l| l.starts_with("warning:"))
        .collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(
        warnings[0].contains("falling back to the CPU backend"),
        "{stderr}"
    );
}

#[test]
fn without_a_driver_forced_gpu_fails_clearly() {
    let out = without_vulkan(&mut host())
        .args(["probe", "--backend", "gpu", "--count", "1000"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("--backend gpu"), "{stderr}");
    assert!(stderr.contains("mesa-vulkan-drivers"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn bad_flags_get_helpful_errors() {
    for args in [
        &["--count", "0"][..],
        &["--sigma", "-1"],
        &["--backend", "tpu"],
        &["--tau", "nan"],
    ] {
        let out = host().args(args).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(
            stderr.contains(args[0]) || stderr.contains(args[1]),
            "{args:?}: {stderr}"
        );
    }
}

/// A small, fast render of an embedded volume with the given extra flags; returns the JSON.
fn small_render(
    dir: &std::path::Path,
    extra: &[&str],
) -> (std::process::Output, serde_json::Value) {
    let exr = dir.join("r.exr");
    let json = dir.join("r.json");
    // A volume file has its own voxel counts: --resolution sizes the embedded cloud only.
    let file = extra
        .iter()
        .any(|a| a.ends_with(".vdb") || a.ends_with(".nvdb"));
    let resolution: &[&str] = if file { &[] } else { &["--resolution", "64"] };
    let out = host()
        .arg("render")
        .args(resolution)
        .args(["--width", "40", "--height", "32", "--spp", "2", "--quiet"])
        .args([
            "--out",
            exr.to_str().unwrap(),
            "--json",
            json.to_str().unwrap(),
        ])
        .args(extra)
        .output()
        .unwrap();
    let value = std::fs::read_to_string(&json)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or(serde_json::Value::Null);
    (out, value)
}

#[test]
fn render_writes_exr_png_and_a_complete_json_summary() {
    let dir = tempfile::tempdir().unwrap();
    let (out, json) = small_render(dir.path(), &["--backend", "cpu"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for field in [
        "backend",
        "device",
        "volume",
        "estimator",
        "width",
        "height",
        "spp",
        "seed",
        "elapsed_ms",
        "mean_samples_per_ray",
        "mean_T",
    ] {
        assert!(json.get(field).is_some(), "JSON lacks {field}: {json}");
    }
    assert_eq!(json["backend"], "cpu");
    assert_eq!(json["width"], 40);
    let t = json["mean_T"].as_f64().unwrap();
    assert!(t > 0.0 && t < 1.0, "mean_T {t}");
    let spr = json["mean_samples_per_ray"].as_f64().unwrap();
    assert!(spr > 0.0 && spr <= 20.0, "samples per ray {spr}");
    assert!(dir.path().join("r.exr").metadata().unwrap().len() > 0);
    let png = image::open(dir.path().join("r.png")).unwrap();
    assert_eq!((png.width(), png.height()), (40, 32));
    assert_eq!(json["up"], "y");
    let bounds = &json["world_bounds"];
    assert!(
        bounds[0][1].as_f64().unwrap() < bounds[1][1].as_f64().unwrap(),
        "{bounds}"
    );
    assert_eq!(json["camera"]["fov_deg"], 40.0);
}

/// `--up z` turns the volume's +z into the world's +y: the occupied bounds' y extent becomes
/// the z extent of `--up y`, and the summary says so.
#[test]
fn up_z_rotates_the_volume_and_is_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let (_, y_up) = small_render(dir.path(), &["--backend", "cpu", "--volume", "explosion"]);
    let (out, z_up) = small_render(
        dir.path(),
        &["--backend", "cpu", "--volume", "explosion", "--up", "z"],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(z_up["up"], "z");
    let extent = |j: &serde_json::Value, a: usize| {
        j["world_bounds"][1][a].as_f64().unwrap() - j["world_bounds"][0][a].as_f64().unwrap()
    };
    assert_eq!(extent(&z_up, 1), extent(&y_up, 2));
    assert_eq!(extent(&z_up, 2), extent(&y_up, 1));
    assert_eq!(extent(&z_up, 0), extent(&y_up, 0));
}

/// Also: the GPU render's time is reported without the pipeline build it waited for (a new
/// process builds its kernel's pipeline again), which the JSON records apart; the CPU builds none.
#[test]
fn render_on_gpu_and_cpu_writes_identical_exr_files() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    for (dir, backend) in [(&a, "gpu"), (&b, "cpu")] {
        let (out, json) = small_render(
            dir.path(),
            &["--backend", backend, "--volume", "explosion", "--seed", "3"],
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let (builds, build_ms) = (&json["pipeline_builds"], &json["pipeline_build_ms"]);
        if backend == "gpu" {
            assert_eq!(builds, 1, "{json}");
            assert!(build_ms.as_f64().unwrap() > 0.0, "{json}");
        } else {
            assert_eq!(builds, 0, "{json}");
            assert_eq!(build_ms, 0.0, "{json}");
        }
    }
    let ga = std::fs::read(a.path().join("r.exr")).unwrap();
    let gb = std::fs::read(b.path().join("r.exr")).unwrap();
    assert!(ga == gb, "GPU and CPU EXR files differ");
}

#[test]
fn render_rejects_bad_values_with_the_flag_name() {
    let dir = tempfile::tempdir().unwrap();
    for (extra, needle) in [
        (&["--spp", "0"][..], "--spp"),
        (&["--width", "0"], "--width"),
        (&["--estimator", "magic"], "--estimator"),
        (&["--volume", "no-such-volume"], "--volume"),
        (&["--density-scale", "-1"], "--density-scale"),
        (&["--camera", "1,2"], "--camera"),
        (&["--fov", "0"], "--fov"),
    ] {
        let (out, _) = small_render(dir.path(), extra);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{extra:?} succeeded");
        assert!(stderr.contains(needle), "{extra:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{extra:?}: {stderr}");
    }
}

#[test]
fn render_reads_openvdb_and_nanovdb_files_with_identical_results() {
    // The same OpenVDB-written grid as .vdb and as its nanovdb_convert'ed .nvdb.
    let fixtures = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures");
    let mut pngs = Vec::new();
    for file in ["density_zip.vdb", "density.nvdb"] {
        let dir = tempfile::tempdir().unwrap();
        let path = fixtures.join(file);
        let (out, json) = small_render(
            dir.path(),
            &["--volume", path.to_str().unwrap(), "--density-scale", "5"],
        );
        assert!(
            out.status.success(),
            "{file}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            json["mean_samples_per_ray"].as_f64().unwrap() > 0.0,
            "{file}: camera missed the volume"
        );
        pngs.push(std::fs::read(dir.path().join("r.exr")).unwrap());
    }
    assert!(pngs[0] == pngs[1], ".vdb and .nvdb renders differ");
}

#[test]
fn render_without_flags_renders_the_embedded_cloud() {
    // `host render` alone: the default cloud's transmittance, default size, out/render.*
    // (`host` without any argument renders the lit quick start: tests/preview.rs).
    let dir = tempfile::tempdir().unwrap();
    let out = host()
        .current_dir(dir.path())
        .arg("render")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("jackknife 512x512 spp 4"), "{stdout}");
    let png = image::open(dir.path().join("out/render.png")).unwrap();
    assert_eq!((png.width(), png.height()), (512, 512));
    assert!(dir.path().join("out/render.exr").metadata().unwrap().len() > 0);
}
