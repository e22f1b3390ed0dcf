//! Outputs are never lost or mislabelled: clashing or unwritable output paths are refused before
//! any work, integrator renders are labelled and recorded as radiance, flags that would be ignored
//! are errors, and the volume actually rendered (grid, f16 range) is named and checked.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn host() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host"))
}

/// A small CPU render with `extra` flags (outputs are given by the caller); the embedded cloud
/// at 32^3 unless `extra` names a volume file.
fn render(extra: &[&str]) -> Output {
    let file = extra
        .iter()
        .any(|a| a.ends_with(".vdb") || a.ends_with(".nvdb"));
    let resolution: &[&str] = if file { &[] } else { &["--resolution", "32"] };
    host()
        .arg("render")
        .args(resolution)
        .args([
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            "1",
            "--backend",
            "cpu",
            "--quiet",
        ])
        .args(extra)
        .output()
        .unwrap()
}

/// Asserts that `out` failed cleanly (exit 1, `error:`) with all `words` in stderr.
fn assert_refused(out: &Output, words: &[&str]) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(1), "expected failure: {stderr}");
    assert!(stderr.starts_with("error:"), "{stderr}");
    for w in words {
        assert!(stderr.contains(w), "stderr lacks {w:?}: {stderr}");
    }
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

/// Asserts success and returns stdout.
fn assert_ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).to_string()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures")
        .join(name)
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn json_equal_to_out_or_its_preview_is_refused_without_touching_either() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("r.exr");
    let png = dir.path().join("r.png");
    std::fs::write(&exr, b"precious exr").unwrap();
    std::fs::write(&png, b"precious png").unwrap();
    let same = render(&["--out", s(&exr), "--json", s(&exr)]);
    assert_refused(&same, &["--out", "--json", "same path"]);
    // A different spelling of the same file is the same path.
    let dotted = dir.path().join(".").join("r.png");
    let preview = render(&["--out", s(&exr), "--json", s(&dotted)]);
    assert_refused(&preview, &["PNG preview", "--json", "same path"]);
    assert_eq!(std::fs::read(&exr).unwrap(), b"precious exr");
    assert_eq!(std::fs::read(&png).unwrap(), b"precious png");
}

#[test]
fn out_that_is_not_an_exr_is_refused_instead_of_overwritten_by_the_preview() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("r.png");
    let out = render(&["--out", s(&png)]);
    assert_refused(&out, &["--out", "must end in .exr", ".png"]);
    assert!(!png.exists(), "a file was written");
}

#[test]
fn out_over_the_input_volume_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let vol = dir.path().join("v.vdb");
    std::fs::copy(fixture("density_zip.vdb"), &vol).unwrap();
    let before = std::fs::read(&vol).unwrap();
    let out = render(&[
        "--volume",
        s(&vol),
        "--out",
        s(&dir.path().join("r.exr")),
        "--json",
        s(&vol),
    ]);
    assert_refused(&out, &["--json", "input --volume"]);
    assert_eq!(std::fs::read(&vol).unwrap(), before);
}

/// Outputs that are an input under another name (a symbolic link to it, named like the EXR,
/// the JSON or the PNG preview, or a hard link) are refused by file identity, and the input keeps
/// its bytes (issue 43, item 1: each case wrote over the volume and exited 0).
#[cfg(unix)]
#[test]
fn outputs_linked_to_an_input_are_refused_and_the_input_survives() {
    let dir = tempfile::tempdir().unwrap();
    let vol = dir.path().join("v.vdb");
    std::fs::copy(fixture("density_zip.vdb"), &vol).unwrap();
    let before = std::fs::read(&vol).unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    std::os::unix::fs::symlink(&vol, p("link.exr")).unwrap();
    std::os::unix::fs::symlink(&vol, p("link.json")).unwrap();
    std::os::unix::fs::symlink(&vol, p("pre.png")).unwrap();
    std::fs::hard_link(&vol, p("hard.exr")).unwrap();
    let (link, r, json, pre, hard) = (
        p("link.exr"),
        p("r.exr"),
        p("link.json"),
        p("pre.exr"),
        p("hard.exr"),
    );
    let cases: [(&[&str], &str); 4] = [
        (&["--out", &link], "--out"),
        (&["--out", &r, "--json", &json], "--json"),
        (&["--out", &pre], "PNG preview"),
        (&["--out", &hard], "--out"),
    ];
    for (flags, what) in cases {
        let mut args = vec!["--volume", s(&vol)];
        args.extend_from_slice(flags);
        let out = render(&args);
        assert_refused(&out, &[what, "input --volume", "same file"]);
        assert_eq!(std::fs::read(&vol).unwrap(), before, "{flags:?}");
    }
    assert!(!Path::new(&r).exists() && !Path::new(&pre).exists());
}

/// A study's outputs may not replace its `--profile` CSV through a link either.
#[cfg(unix)]
#[test]
fn a_study_output_linked_to_its_profile_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("p.csv");
    std::fs::write(&csv, "t,mu\n0,1\n1,2\n").unwrap();
    let link = dir.path().join("p.json");
    std::os::unix::fs::symlink(&csv, &link).unwrap();
    let out = host()
        .args(["study", "profile", "--profile", s(&csv), "--trials", "100"])
        .args(["--json", s(&link), "--plot", s(&dir.path().join("p.png"))])
        .output()
        .unwrap();
    assert_refused(&out, &["--json", "input --profile", "same file"]);
    assert_eq!(std::fs::read_to_string(&csv).unwrap(), "t,mu\n0,1\n1,2\n");
}

/// A symbolic link that is not an input is written through (the target gets the image, the link
/// stays); a hard-linked name is replaced alone (the other name keeps the old bytes).
#[cfg(unix)]
#[test]
fn outputs_are_written_through_links_without_touching_other_names() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name);
    std::fs::write(p("target.exr"), b"old").unwrap();
    std::os::unix::fs::symlink(p("target.exr"), p("link.exr")).unwrap();
    assert_ok(&render(&["--out", s(&p("link.exr"))]));
    assert!(std::fs::symlink_metadata(p("link.exr"))
        .unwrap()
        .file_type()
        .is_symlink());
    assert_ne!(std::fs::read(p("target.exr")).unwrap(), b"old");
    std::fs::write(p("a.exr"), b"old").unwrap();
    std::fs::hard_link(p("a.exr"), p("b.exr")).unwrap();
    assert_ok(&render(&["--out", s(&p("a.exr"))]));
    assert_eq!(std::fs::read(p("b.exr")).unwrap(), b"old");
    assert_ne!(std::fs::read(p("a.exr")).unwrap(), b"old");
    // No temporary file is left behind.
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.contains("partial")), "{names:?}");
}

/// A view that sees nothing of the volume says so (issue 43, item 8: `--fov 3e-6` rendered
/// T = 1 everywhere with an empty stderr, and `eval` gave statistics over "1" pixel): `render`
/// warns and records `pixels_hit` 0; `eval` refuses statistics over fewer than 16 pixels.
#[test]
fn views_that_miss_the_volume_warn_and_eval_refuses_them() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("r.exr");
    let json_path = dir.path().join("r.json");
    let out = host()
        .args([
            "render",
            "--backend",
            "cpu",
            "--resolution",
            "32",
            "--width",
            "16",
        ])
        .args([
            "--height",
            "16",
            "--spp",
            "1",
            "--fov",
            "3e-6",
            "--out",
            s(&exr),
        ])
        .args(["--json", s(&json_path)])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("no ray of the image read a voxel"),
        "{stderr}"
    );
    assert_eq!(json(&json_path)["pixels_hit"], 0);
    let out = host()
        .args([
            "eval",
            "--backend",
            "cpu",
            "--resolution",
            "32",
            "--width",
            "16",
        ])
        .args(["--height", "16", "--spp", "2", "--fov", "3e-6", "-q"])
        .args([
            "--estimators",
            "jackknife",
            "--out-dir",
            s(&dir.path().join("ev")),
        ])
        .output()
        .unwrap();
    assert_refused(
        &out,
        &["only 0 of 256 reference pixels", "at least 16", "--fov"],
    );
    // Integrator evaluations too: single scattering, and direct under the sky.
    for integrators in ["mis-jackknife", "direct"] {
        let out = host()
            .args(["eval", "--backend", "cpu", "--resolution", "32"])
            .args([
                "--width", "16", "--height", "16", "--spp", "2", "--fov", "3e-6",
            ])
            .args([
                "-q",
                "--estimators",
                "jackknife",
                "--integrators",
                integrators,
            ])
            .args(["--out-dir", s(&dir.path().join(integrators))])
            .output()
            .unwrap();
        assert_refused(
            &out,
            &["only 0 of 256 reference pixels read a voxel", "at least 16"],
        );
        let left = std::fs::read_dir(dir.path().join(integrators))
            .map(|d| d.count())
            .unwrap_or(0);
        assert_eq!(left, 0, "{integrators}: a refused eval left files");
    }
    let left = std::fs::read_dir(dir.path().join("ev"))
        .map(|d| d.count())
        .unwrap_or(0);
    assert_eq!(left, 0, "a refused eval left files");
}

/// `host report` checks its volumes, integrators and `--from-eval` files before evaluating or
/// copying anything: a refused report leaves no files (issue 43, hostile corpus).
#[test]
fn refused_reports_leave_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let rep = dir.path().join("rep");
    let small = [
        "--backend",
        "cpu",
        "--resolution",
        "16",
        "--width",
        "8",
        "--height",
        "8",
    ];
    let files_in = |d: &Path| -> usize { walk(d).len() };
    for (extra, words) in [
        (
            &["--volumes", "cloud", "--integrators", "bogus"][..],
            &["unknown integrator \"bogus\""][..],
        ),
        (
            &["--volumes", "cloud,bogus"],
            &["\"bogus\" is neither a file nor an embedded volume"],
        ),
        (
            &["--volumes", "cloud,missing.vdb"],
            &["missing.vdb: no such file"],
        ),
    ] {
        let out = host()
            .arg("report")
            .args(small)
            .args(extra)
            .args(["--spp", "2", "-q", "--out", s(&rep)])
            .output()
            .unwrap();
        assert_refused(&out, words);
        assert_eq!(files_in(&rep), 0, "{extra:?} left files");
    }
    // An eval whose image was deleted: refused before anything is copied.
    let ev = dir.path().join("ev");
    let out = host()
        .arg("eval")
        .args(small)
        .args([
            "--spp",
            "2",
            "-q",
            "--estimators",
            "jackknife",
            "--out-dir",
            s(&ev),
        ])
        .output()
        .unwrap();
    assert_ok(&out);
    std::fs::remove_file(ev.join("jackknife_std.exr")).unwrap();
    let out = host()
        .args(["report", "--from-eval", s(&ev), "--out", s(&rep)])
        .output()
        .unwrap();
    assert_refused(&out, &["jackknife_std.exr not found"]);
    assert_eq!(files_in(&rep), 0, "a refused --from-eval import left files");
}

/// Every regular file under `d` (none if it does not exist).
fn walk(d: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    if let Ok(entries) = std::fs::read_dir(d) {
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                files.extend(walk(&p));
            } else {
                files.push(p);
            }
        }
    }
    files
}

/// An image whose buffers exceed the memory limit is refused before rendering, naming the size
/// (it aborted in an allocation, issue 43, hostile corpus).
#[test]
fn images_larger_than_memory_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = common::host_under_ulimit(2000000)
        .args([
            "render",
            "--backend",
            "cpu",
            "--resolution",
            "16",
            "--spp",
            "2",
            "-q",
        ])
        .args(["--width", "16384", "--height", "16384", "--out"])
        .arg(dir.path().join("r.exr"))
        .output()
        .unwrap();
    assert_refused(
        &out,
        &[
            "--width 16384 --height 16384",
            "80 bytes per pixel",
            "smaller image",
        ],
    );
}

#[test]
fn unwritable_outputs_are_refused_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a_file");
    std::fs::write(&file, b"x").unwrap();
    let exr = dir.path().join("r.exr");
    // A parent that is a file: no render may start, no EXR may be written.
    let out = host()
        .args([
            "render",
            "--backend",
            "cpu",
            "--quiet",
            "--width",
            "512",
            "--height",
            "512",
            "--spp",
            "64",
            "--resolution",
            "64",
            "--out",
            s(&exr),
            "--json",
            s(&file.join("r.json")),
        ])
        .output()
        .unwrap();
    assert_refused(&out, &["--json", "a_file", "cannot create directory"]);
    assert!(
        !exr.exists(),
        "the EXR was written before --json was checked"
    );
    let out = render(&["--out", s(&file.join("r.exr"))]);
    assert_refused(&out, &["--out", "a_file"]);
    let out = render(&["--out", s(&exr), "--json", s(dir.path())]);
    assert_refused(&out, &["--json", "is a directory"]);
    assert!(!exr.exists());
    // host eval: --out-dir under a file, and --json under a file.
    let eval = |extra: &[&str]| {
        host()
            .args([
                "eval",
                "--width",
                "8",
                "--height",
                "8",
                "--spp",
                "2",
                "--resolution",
                "32",
                "--backend",
                "cpu",
                "--quiet",
                "--estimators",
                "jackknife",
            ])
            .args(extra)
            .output()
            .unwrap()
    };
    assert_refused(
        &eval(&["--out-dir", s(&file.join("eval"))]),
        &["--out-dir", "a_file"],
    );
    let good = dir.path().join("eval");
    assert_refused(
        &eval(&["--out-dir", s(&good), "--json", s(&file.join("e.json"))]),
        &["--json", "a_file"],
    );
    assert!(!good.join("reference.exr").exists(), "eval rendered first");
    // --json onto one of the eval's own images.
    assert_refused(
        &eval(&[
            "--out-dir",
            s(&good),
            "--json",
            s(&good.join("jackknife_bias.png")),
        ]),
        &["--json", "same path"],
    );
}

#[test]
fn integrator_render_records_radiance_and_everything_to_reproduce_it() {
    let dir = tempfile::tempdir().unwrap();
    let (exr, js) = (dir.path().join("r.exr"), dir.path().join("r.json"));
    let stdout = assert_ok(&render(&[
        "--integrator",
        "mis-jackknife",
        "--albedo",
        "0.5",
        "--hg-g",
        "0.3",
        "--t-hat",
        "ratio",
        "--exposure",
        "2",
        "--light",
        "1,2,3,40",
        "--seed",
        "7",
        "--out",
        s(&exr),
        "--json",
        s(&js),
    ]));
    assert!(stdout.contains("mean L "), "{stdout}");
    assert!(!stdout.contains("mean T"), "{stdout}");
    assert!(!stdout.contains("shadow rays"), "{stdout}");
    let j = json(&js);
    assert!(j.get("mean_T").is_none(), "{j}");
    assert!(j["mean_L"].as_f64().unwrap() > 0.0, "{j}");
    assert_eq!(j["estimator"], "mis-jackknife");
    assert_eq!(j["seed"], 7);
    let i = &j["integrator"];
    assert_eq!(i["name"], "mis-jackknife");
    assert_eq!(i["lights"], serde_json::json!([[1.0, 2.0, 3.0, 40.0]]));
    assert_eq!(i["albedo"], 0.5);
    assert!((i["hg_g"].as_f64().unwrap() - 0.3).abs() < 1e-6);
    assert_eq!(i["t_hat"], "ratio");
    assert_eq!(i["exposure"], 2.0);
    let cmd: Vec<String> = serde_json::from_value(j["command_line"].clone()).unwrap();
    assert!(cmd.iter().any(|a| a == "--hg-g"), "{cmd:?}");
    // Default lights are recorded as resolved.
    let js2 = dir.path().join("r2.json");
    assert_ok(&render(&[
        "--integrator",
        "free-flight",
        "--out",
        s(&exr),
        "--json",
        s(&js2),
    ]));
    assert_eq!(
        json(&js2)["integrator"]["lights"].as_array().unwrap().len(),
        2
    );
}

#[test]
fn ignored_flags_are_errors_not_labels() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("r.exr");
    let o = s(&exr);
    for estimator in ["ratio", "jackknife"] {
        let out = render(&[
            "--integrator",
            "mis-jackknife",
            "--estimator",
            estimator,
            "--out",
            o,
        ]);
        assert_refused(
            &out,
            &["--estimator", "no effect with --integrator", "jackknife"],
        );
    }
    let out = render(&["--integrator", "miller", "--f-delta", "0.2", "--out", o]);
    assert_refused(&out, &["--f-delta", "no effect"]);
    for flag in [
        &["--albedo", "0.5"][..],
        &["--hg-g", "0.2"],
        &["--t-hat", "ratio"],
        &["--exposure", "2"],
        &["--light", "0,0,0,1"],
    ] {
        let mut args = flag.to_vec();
        args.extend(["--out", o]);
        let out = render(&args);
        assert_refused(&out, &[flag[0], "--integrator"]);
    }
    // --ratio-roulette only changes ratio tracking.
    for args in [
        &["--ratio-roulette"][..],
        &["--ratio-roulette", "--integrator", "miller"],
    ] {
        let mut args = args.to_vec();
        args.extend(["--out", o]);
        assert_refused(&render(&args), &["--ratio-roulette", "no effect"]);
    }
    assert!(!exr.exists());
    let mut ok = vec!["--ratio-roulette", "--estimator", "ratio", "--out", o];
    assert_ok(&render(&ok));
    ok = vec![
        "--ratio-roulette",
        "--integrator",
        "miller",
        "--t-hat",
        "ratio",
        "--out",
        o,
    ];
    assert_ok(&render(&ok));
}

/// `--resolution` with a volume file is refused, not ignored (issue 43, item 10), in render, eval
/// and report (where it is refused only when no volume of the list is embedded).
#[test]
fn resolution_with_a_volume_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let vdb = fixture("density_zip.vdb");
    let exr = dir.path().join("r.exr");
    let out = host()
        .args([
            "render",
            "--backend",
            "cpu",
            "--resolution",
            "32",
            "--volume",
        ])
        .args([s(&vdb), "--out", s(&exr)])
        .output()
        .unwrap();
    assert_refused(&out, &["--resolution 32", "density_zip.vdb", "drop it"]);
    assert!(!exr.exists());
    let out = host()
        .args(["eval", "--backend", "cpu", "--resolution", "32", "--volume"])
        .args([s(&vdb), "--out-dir", s(dir.path())])
        .output()
        .unwrap();
    assert_refused(&out, &["--resolution 32", "density_zip.vdb"]);
    let out = host()
        .args([
            "report",
            "--backend",
            "cpu",
            "--resolution",
            "32",
            "--volumes",
        ])
        .args([s(&vdb), "--out", s(&dir.path().join("report"))])
        .output()
        .unwrap();
    assert_refused(&out, &["--resolution 32", "no volume to evaluate is one"]);
    let out = host()
        .args(["report", "--backend", "cpu", "--grid", "density"])
        .args(["--out", s(&dir.path().join("report"))])
        .output()
        .unwrap();
    assert_refused(&out, &["--grid \"density\"", "drop --grid"]);
    assert!(!dir.path().join("report").join("index.html").exists());
}

/// `eval --hg-g` reaches the integrators' phase function and is refused without them (issue 43,
/// item 10).
#[test]
fn eval_hg_g_needs_integrators() {
    let dir = tempfile::tempdir().unwrap();
    let out = host()
        .args(["eval", "--backend", "cpu", "--hg-g", "0.5"])
        .args(["--out-dir", s(dir.path())])
        .output()
        .unwrap();
    assert_refused(&out, &["--hg-g 0.5", "--integrators"]);
    let out = host()
        .args(["eval", "--backend", "cpu", "--hg-g", "1"])
        .args(["--out-dir", s(dir.path())])
        .output()
        .unwrap();
    assert_refused(&out, &["--hg-g", "must be in (-1, 1)"]);
}

/// `--grid` with an embedded volume is refused, not ignored (issue 43, item 10).
#[test]
fn grid_with_an_embedded_volume_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = render(&["--grid", "density", "--out", s(&dir.path().join("r.exr"))]);
    assert_refused(
        &out,
        &["--grid \"density\"", "embedded volume \"cloud\"", ".vdb"],
    );
    assert!(!dir.path().join("r.exr").exists());
}

#[test]
fn the_grid_read_is_named_in_stdout_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let (exr, js) = (dir.path().join("r.exr"), dir.path().join("r.json"));
    let multi = fixture("multi.vdb");
    let stdout = assert_ok(&render(&[
        "--volume",
        s(&multi),
        "--grid",
        "temperature",
        "--out",
        s(&exr),
        "--json",
        s(&js),
    ]));
    assert!(stdout.contains("grid 'temperature'"), "{stdout}");
    assert_eq!(json(&js)["grid"], "temperature");
    // Without --grid: the default chosen by the loader is named.
    let stdout = assert_ok(&render(&[
        "--volume",
        s(&fixture("density_zip.vdb")),
        "--out",
        s(&exr),
        "--json",
        s(&js),
    ]));
    assert!(stdout.contains("grid 'density'"), "{stdout}");
    assert_eq!(json(&js)["grid"], "density");
}

#[test]
fn level_sets_are_refused_with_fog_volume_advice() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("r.exr");
    for file in ["level_set.vdb", "level_set.nvdb"] {
        let path = fixture(&format!("malformed/{file}"));
        let out = render(&["--volume", s(&path), "--out", s(&exr)]);
        let err = assert_refused(&out, &["level set", "fog volume", file]);
        assert!(!err.contains("--clamp-negative"), "{err}");
    }
}

#[test]
fn extinction_ranges_are_checked_after_the_density_scale_at_file_coordinates() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("r.exr");
    let vol = fixture("density_zip.vdb");
    // Densities of the fixture are O(1). A scale of 1e6 was refused as f16 overflow although
    // f32 extinctions of 1e6 are fine: the f16 voxels are now prescaled by a power of two.
    let out = render(&[
        "--volume",
        s(&vol),
        "--density-scale",
        "1e6",
        "--out",
        s(&exr),
    ]);
    assert_ok(&out);
    // 3e38 overflows the optical depths' f32 sums: mean T was NaN; now refused at the densest
    // voxel's file coordinates.
    let exr = dir.path().join("r2.exr");
    let out = render(&[
        "--volume",
        s(&vol),
        "--density-scale",
        "3e38",
        "--out",
        s(&exr),
    ]);
    assert_refused(
        &out,
        &["--density-scale", "optical depth", "file index coordinates"],
    );
    assert!(!exr.exists());
}

#[test]
fn extinction_underflow_is_counted_never_silent() {
    let dir = tempfile::tempdir().unwrap();
    let (exr, js) = (dir.path().join("r.exr"), dir.path().join("r.json"));
    let vol = fixture("density_zip.vdb");
    // Times 1e-45 (f32's smallest subnormal) most densities become 0: a counted warning naming
    // the first one in file coordinates, and the count in the JSON.
    let out = render(&[
        "--volume",
        s(&vol),
        "--density-scale",
        "1e-45",
        "--out",
        s(&exr),
        "--json",
        s(&js),
    ]);
    assert_ok(&out);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("warning:")
            && stderr.contains("become 0")
            && stderr.contains("file index coordinates"),
        "{stderr}"
    );
    let count = json(&js)["underflowed_voxels"].as_u64().unwrap();
    assert!(count > 0, "{count}");
    assert!(stderr.contains(&format!("{count} of ")), "{stderr}");
}

#[test]
fn bench_report_and_study_outputs_are_checked_before_work() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a_file");
    std::fs::write(&file, b"x").unwrap();
    let under = file.join("x.json");
    let run = |args: &[&str]| host().args(args).output().unwrap();
    let plot = dir.path().join("p.png");
    let out = run(&[
        "study",
        "normal",
        "--quiet",
        "--json",
        s(&under),
        "--plot",
        s(&plot),
    ]);
    assert_refused(&out, &["--json", "a_file"]);
    assert!(!plot.exists(), "the study ran before --json was checked");
    let out = run(&[
        "study",
        "normal",
        "--quiet",
        "--json",
        s(&plot),
        "--plot",
        s(&plot),
    ]);
    assert_refused(&out, &["--json", "--plot", "same path"]);
    let out = run(&["report", "--out", s(&file.join("r")), "--quiet"]);
    assert_refused(&out, &["--out", "a_file"]);
    let out = run(&[
        "bench",
        "--backend",
        "cpu",
        "--quiet",
        "--resolution",
        "32",
        "--width",
        "8",
        "--height",
        "8",
        "--json",
        s(&under),
    ]);
    assert_refused(&out, &["--json", "a_file"]);
}

/// The help says what the lights do (issue 43, item 9): --light and --lights replace the default
/// sky, `path` and `restir` take --albedo r,g,b, --env and --sun, the sun's colour is stated; and
/// a shadow map without a sun says why there is none.
#[test]
fn light_help_names_every_lit_integrator_and_the_sky_rule() {
    let out = host().args(["render", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout).to_string();
    for words in [
        "Like --light, it replaces the default sky unless --env is given",
        "(RGB: `direct`, `path`, `restir`)",
        "Environment light of `direct`, `path`, `restir`",
        "Sun of `direct`, `path`, `restir`",
        "(1, 0.93, 0.85)",
    ] {
        assert!(help.contains(words), "--help lacks {words:?}");
    }
    let out = render(&[
        "--integrator",
        "restir",
        "--lights",
        "random:4",
        "--shadows",
        "msm4",
    ]);
    assert_refused(
        &out,
        &["--light and --lights replace the default sky", "--sun"],
    );
}

/// `jackknife-adaptive` with a CDF step above most rays' importance integral (issue 43, item 7:
/// `--f-delta 10` gave mean T 0.892 against 0.697, silently): a ray whose estimate took no sample
/// counts as outside the jackknife's regime, so the JSON counts most rays and the warning names
/// --f-delta; at the default step few rays are outside.
#[test]
fn adaptive_estimates_without_samples_are_counted_outside_the_regime() {
    let dir = tempfile::tempdir().unwrap();
    let outside = |f_delta: &str| {
        let (exr, js) = (dir.path().join("a.exr"), dir.path().join("a.json"));
        let out = render(&[
            "--estimator",
            "jackknife-adaptive",
            "--f-delta",
            f_delta,
            "--out",
            s(&exr),
            "--json",
            s(&js),
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(out.status.success(), "{stderr}");
        let j = json(&js);
        let frac = j["jackknife_outside_rays"].as_f64().unwrap() / j["rays"].as_f64().unwrap();
        (frac, stderr)
    };
    let (wide, stderr) = outside("10");
    assert!(wide > 0.5, "{wide}");
    assert!(
        stderr.contains("took no sample") && stderr.contains("--f-delta"),
        "{stderr}"
    );
    let (default, _) = outside("0.6");
    assert!(default < 0.1, "{default}");
}
