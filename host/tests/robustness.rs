//! The `host` binary on bad input and at limits: every malformed volume file exits with a clear
//! error (never a panic), bad flag values name the flag, images larger than a GPU buffer are
//! tiled, volumes larger than one are refused or fall back, and a seed fixes the image bytes
//! across runs, thread counts and backends.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn host() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host"))
}

fn malformed_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/malformed")
}

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// `host render` of a tiny image (of a 48^3 volume unless `extra` sets `--resolution` or a file) with
/// `extra` flags into `dir`; returns the output.
fn render(dir: &Path, extra: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = host();
    cmd.arg("render");
    let file = extra
        .iter()
        .any(|a| a.ends_with(".vdb") || a.ends_with(".nvdb"));
    if !extra.contains(&"--resolution") && !file {
        cmd.args(["--resolution", "48"]);
    }
    cmd.args([
        "--width", "33", "--height", "21", "--spp", "3", "--quiet", "--out",
    ])
    .arg(dir.join("r.exr"))
    .arg("--json")
    .arg(dir.join("r.json"))
    .args(extra);
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().unwrap()
}

#[test]
fn every_malformed_file_is_a_clean_cli_error() {
    let manifest = std::fs::read_to_string(malformed_dir().join("EXPECTED")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut checked = 0;
    for line in manifest.lines().filter(|l| !l.starts_with('#')) {
        let mut cols = line.split('\t');
        let (name, grid) = (cols.next().unwrap(), cols.next().unwrap());
        let path = malformed_dir().join(name);
        let mut args = vec!["--backend", "cpu", "--volume", path.to_str().unwrap()];
        if grid != "-" {
            args.extend(["--grid", grid]);
        }
        let out = render(dir.path(), &args, &[]);
        let all = text(&out);
        assert_eq!(out.status.code(), Some(1), "{name}: {all}");
        assert!(!all.contains("panicked"), "{name}: {all}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.starts_with("error: ") && err.contains(name),
            "{name}: {err}"
        );
        checked += 1;
    }
    assert!(checked >= 40, "{checked} files");
}

#[test]
fn clamp_negative_renders_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let file = malformed_dir().join("negative_density.vdb");
    let base = ["--backend", "cpu", "--volume", file.to_str().unwrap()];
    let out = render(dir.path(), &base, &[]);
    assert!(!out.status.success());
    assert!(text(&out).contains("--clamp-negative"), "{}", text(&out));
    let out = render(
        dir.path(),
        &[&base[..], &["--clamp-negative"]].concat(),
        &[],
    );
    assert!(out.status.success(), "{}", text(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("warning: --clamp-negative set 1 negative densities"),
        "{err}"
    );
}

#[test]
fn bad_flag_values_name_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    for (extra, needle) in [
        (&["--spp", "-1"][..], "--spp"),
        (&["--spp", "1.5"], "--spp"),
        (&["--height", "0"], "--height"),
        (&["--width", "100000"], "--width"),
        (&["--n", "0"], "--n"),
        (&["--brick-size", "1"], "--brick-size"),
        (&["--cell-size", "4"], "--cell-size"),
        (&["--split-ratio", "0.5"], "--split-ratio"),
        (
            &["--supervoxels", "adaptive", "--cell-size", "5"],
            "--cell-size",
        ),
        (
            &["--supervoxels", "adaptive", "--cell-size", "16"],
            "--cell-size",
        ),
        (
            &["--supervoxels", "adaptive", "--split-ratio", "0"],
            "--split-ratio",
        ),
        (
            &["--supervoxels", "adaptive", "--split-ratio", "1.5"],
            "--split-ratio",
        ),
        (&["--supervoxels", "octree"], "--supervoxels"),
        (&["--split-occupancy", "0.2"], "--split-occupancy"),
        (
            &["--supervoxels", "adaptive", "--split-occupancy", "0"],
            "--split-occupancy",
        ),
        (&["--resolution", "4"], "--resolution"),
        (&["--seed", "-3"], "--seed"),
        (&["--lookup", "bicubic"], "--lookup"),
        (&["--backend", "tpu"], "--backend"),
        (&["--integrator", "magic"], "--integrator"),
        (&["--albedo", "2"], "--albedo"),
        (&["--hg-g", "1"], "--hg-g"),
        (&["--exposure", "0"], "--exposure"),
        (&["--light", "1,2"], "--light"),
        (&["--camera", "nan,0,0"], "--camera"),
        (&["--fov", "nan"], "--fov"),
        (&["--density-scale", "inf"], "--density-scale"),
        (&["--f-delta", "0"], "--f-delta"),
        (&["--volume", "missing.vdb"], "missing.vdb"),
        (&["--camera", "0,0,0", "--look-at", "0,0,0"], "--look-at"),
    ] {
        let out = render(dir.path(), &[&["--backend", "cpu"], extra].concat(), &[]);
        let all = text(&out);
        assert!(!out.status.success(), "{extra:?} succeeded: {all}");
        assert!(
            all.contains(needle),
            "{extra:?} does not name {needle}: {all}"
        );
        assert!(!all.contains("panicked"), "{extra:?}: {all}");
    }
}

#[test]
fn same_seed_gives_identical_exr_across_runs_threads_and_backends() {
    // The GPU in one configuration: each `host` process builds its pipelines anew (seconds to
    // tens of seconds on lavapipe), and the integration suite compares the GPU's and the CPU's
    // bytes for every integrator and estimator in one process.
    for (i, extra) in [
        &["--volume", "explosion", "--seed", "12"][..],
        &["--integrator", "mis-jackknife", "--seed", "5"],
        &["--estimator", "ratio", "--lookup", "nearest", "--seed", "1"],
    ]
    .into_iter()
    .enumerate()
    {
        let mut files = Vec::new();
        let runs = [
            ("cpu", "1"),
            ("cpu", "2"),
            ("cpu", "3"),
            ("cpu", "2"),
            ("gpu", "1"),
        ];
        for (backend, threads) in runs.into_iter().filter(|r| i == 0 || r.0 == "cpu") {
            let dir = tempfile::tempdir().unwrap();
            let args = [&["--backend", backend][..], extra].concat();
            let out = render(dir.path(), &args, &[("RAYON_NUM_THREADS", threads)]);
            assert!(out.status.success(), "{extra:?} {backend}: {}", text(&out));
            let exr = std::fs::read(dir.path().join("r.exr")).unwrap();
            files.push((format!("{backend} x{threads}"), exr));
        }
        for (label, bytes) in &files[1..] {
            assert!(
                *bytes == files[0].1,
                "{extra:?}: {label} differs from {}",
                files[0].0
            );
        }
    }
    // A different seed must change the image (the comparison above can fail).
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    for (dir, seed) in [(&a, "1"), (&b, "2")] {
        let out = render(dir.path(), &["--backend", "cpu", "--seed", seed], &[]);
        assert!(out.status.success());
    }
    let read = |d: &tempfile::TempDir| std::fs::read(d.path().join("r.exr")).unwrap();
    assert!(read(&a) != read(&b), "seeds 1 and 2 gave the same image");
}

/// Issue 43, item 4: under an address-space limit (`ulimit -v 1000000`, 1 GB; free memory is
/// larger) a volume whose brick table needs about 0.9 GiB besides the process's own address space
/// is refused with an error naming the memory, where the allocation aborted the process (exit
/// 134) when only MemAvailable was checked.
#[cfg(target_os = "linux")]
#[test]
fn loads_beyond_the_address_space_limit_are_refused_not_aborted() {
    let dir = tempfile::tempdir().unwrap();
    let huge = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/huge.vdb");
    let out = common::host_under_ulimit(1000000)
        .args(["render", "--volume"])
        .arg(&huge)
        .args([
            "--brick-size",
            "8",
            "--backend",
            "cpu",
            "--width",
            "8",
            "--height",
            "8",
        ])
        .args(["--spp", "1", "--quiet", "--out"])
        .arg(dir.path().join("r.exr"))
        .output()
        .unwrap();
    let stderr = text(&out);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.starts_with("error:") && !stderr.contains("panicked"),
        "{stderr}"
    );
    assert!(
        stderr.contains("huge.vdb") && stderr.contains("of memory available"),
        "{stderr}"
    );
}

/// An environment variable that is not a number is refused naming it (issue 43, item 10: it
/// was ignored), on either backend, before any output is written.
#[test]
fn a_malformed_buffer_limit_in_the_environment_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for v in ["abc", "-1", "1e3", ""] {
        let out = render(
            dir.path(),
            &["--backend", "cpu"],
            &[("JK_GPU_MAX_BUFFER_BYTES", v)],
        );
        let stderr = text(&out);
        assert_eq!(out.status.code(), Some(1), "{v:?}: {stderr}");
        assert!(
            stderr.contains("JK_GPU_MAX_BUFFER_BYTES"),
            "{v:?}: {stderr}"
        );
        assert!(!dir.path().join("r.exr").exists(), "{v:?}");
    }
}

#[test]
fn images_larger_than_a_gpu_buffer_are_tiled_with_identical_results() {
    let (whole, tiled) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let args = ["--backend", "gpu", "--seed", "4", "--resolution", "8"];
    let out = render(whole.path(), &args, &[]);
    assert!(out.status.success(), "{}", text(&out));
    // 2304 bytes hold 64 pixels' sums (36 B each), so the 693-pixel image takes 11 tiles; the
    // 8^3 volume's f16 voxels (1 KiB) still fit.
    let out = render(tiled.path(), &args, &[("JK_GPU_MAX_BUFFER_BYTES", "2304")]);
    assert!(out.status.success(), "{}", text(&out));
    let read = |d: &tempfile::TempDir| std::fs::read(d.path().join("r.exr")).unwrap();
    assert!(read(&whole) == read(&tiled), "tiled GPU image differs");
}

#[test]
fn volumes_larger_than_a_gpu_buffer_are_refused_or_fall_back_to_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let cap = [("JK_GPU_MAX_BUFFER_BYTES", "4096")];
    let out = render(dir.path(), &["--backend", "gpu"], &cap);
    let all = text(&out);
    assert_eq!(out.status.code(), Some(1), "{all}");
    assert!(
        all.contains("maxStorageBufferRange") && all.contains("--backend cpu"),
        "{all}"
    );
    let out = render(dir.path(), &["--backend", "auto"], &cap);
    assert!(out.status.success(), "{}", text(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("warning:") && err.contains("falling back to the CPU backend"),
        "{err}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("r.json")).unwrap()).unwrap();
    assert_eq!(json["backend"], "cpu");
}

/// A brick table the GPU cannot hold is refused before any voxel is read or generated, with
/// `--backend gpu` only: `huge.vdb` (two voxels at the corners of a 2001^3 box, 8.0e9 voxels:
/// above the dense cap, loaded sparse) is refused for its table (126^3 bricks, 48 MB, above a
/// 4096-byte buffer limit), renders on the CPU, and under `auto` falls back to the CPU after
/// packing; an embedded volume is refused before it is generated.
#[test]
fn brick_tables_a_gpu_cannot_hold_are_refused_before_loading() {
    let dir = tempfile::tempdir().unwrap();
    let cap = [("JK_GPU_MAX_BUFFER_BYTES", "4096")];
    let huge = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/huge.vdb");
    let huge = huge.to_str().unwrap();
    let out = render(dir.path(), &["--backend", "gpu", "--volume", huge], &cap);
    let all = text(&out);
    assert_eq!(out.status.code(), Some(1), "{all}");
    for part in [
        "huge.vdb",
        "2001x2001x2001",
        "48009024-byte storage buffer",
        "before any voxel is read",
        "--backend cpu",
    ] {
        assert!(all.contains(part), "{part:?} missing: {all}");
    }
    for backend in ["cpu", "auto"] {
        let out = render(dir.path(), &["--backend", backend, "--volume", huge], &cap);
        let all = text(&out);
        assert!(out.status.success(), "{all}");
        assert_eq!(
            all.contains("falling back to the CPU backend"),
            backend == "auto",
            "{all}"
        );
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join("r.json")).unwrap())
                .unwrap();
        assert_eq!(json["backend"], "cpu", "{json}");
        assert_eq!(json["volume_storage"], "sparse", "{json}");
        assert_eq!(json["bricks"], 126 * 126 * 126, "{json}");
    }
    // 24^3 bricks of 2^3 voxels: a 331776-byte table.
    let small = ["--backend", "gpu", "--brick-size", "2"];
    let out = render(dir.path(), &small, &cap);
    let all = text(&out);
    assert_eq!(out.status.code(), Some(1), "{all}");
    assert!(
        all.contains("48x48x48") && all.contains("331776-byte") && all.contains("before any voxel"),
        "{all}"
    );
}

/// A box longer than 2^31 along an axis is refused as such before the brick grid's memory is
/// estimated, also under a memory limit: the advice of a larger --brick-size could not load it
/// (issue 43, hostile corpus).
#[test]
fn boxes_no_load_takes_are_refused_before_the_brick_advice() {
    let dir = tempfile::tempdir().unwrap();
    let wide = malformed_dir().join("unsupported_wide.vdb");
    let out = common::host_under_ulimit(2000000)
        .args([
            "render",
            "--backend",
            "cpu",
            "--width",
            "8",
            "--height",
            "8",
            "-q",
        ])
        .args(["--volume", wide.to_str().unwrap(), "--out"])
        .arg(dir.path().join("r.exr"))
        .output()
        .unwrap();
    let all = text(&out);
    assert_eq!(out.status.code(), Some(1), "{all}");
    assert!(all.contains("more than 2^31 along an axis"), "{all}");
    assert!(!all.contains("--brick-size"), "{all}");
}

/// A closed stdout pipe ends `host` quietly (SIGPIPE, as any Unix tool), never with a panic in
/// println! (issue 43, hostile corpus).
#[cfg(unix)]
#[test]
fn a_closed_stdout_pipe_is_not_a_panic() {
    use std::os::unix::process::ExitStatusExt;
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_host"))
        .args(["probe", "--backend", "cpu"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        out.status.success() || out.status.signal() == Some(13),
        "{:?}: {stderr}",
        out.status
    );
}
