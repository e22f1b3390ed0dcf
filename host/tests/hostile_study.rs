//! The `host` binary on hostile input beyond volume files: `host study` flags at and past their
//! documented ranges, broken profile CSVs, non-regular files, and bad environment variables.
//! Every case exits 1 with `error: ` naming the input (or 0 where a fallback is right), never
//! panics, and finishes within seconds.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Exit code, stdout and stderr of `host args` with `env`, killed after 60 s (a hang fails).
fn host(args: &[&str], env: &[(&str, &str)]) -> (Option<i32>, String, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_host"));
    cmd.args(args)
        .envs(env.iter().copied())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let mut child = cmd.spawn().unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(60) {
            child.kill().unwrap();
            panic!("{args:?} ran for over 60 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (out.status.code(), text(&out.stdout), text(&out.stderr))
}

/// Asserts a clean error: exit 1, stderr starting with `error: ` and containing `needle`.
fn assert_clean_error(args: &[&str], env: &[(&str, &str)], needle: &str) {
    let (code, out, err) = host(args, env);
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    assert_eq!(code, Some(1), "{args:?}: {out}{err}");
    assert!(err.starts_with("error: "), "{args:?}: {err}");
    assert!(
        err.contains(needle),
        "{args:?} does not name {needle}: {err}"
    );
}

/// A study's arguments with small sizes and its plot in `dir`.
fn study(dir: &Path, args: &[&str]) -> Vec<String> {
    let plot = dir.join("p.png").display().to_string();
    let mut v: Vec<String> = ["study"]
        .iter()
        .chain(args)
        .map(|s| s.to_string())
        .collect();
    v.extend(["--quiet".into(), "--plot".into(), plot]);
    v
}

#[test]
fn hostile_study_flags_name_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    for (args, needle) in [
        (&["normal", "--sigma", "1e6"][..], "--sigma"),
        (&["normal", "--sigma", "-1"], "--sigma"),
        (&["normal", "--tau", "nan"], "--tau"),
        (&["normal", "--tau", "inf"], "--tau"),
        (&["normal", "--trials", "1"], "--trials"),
        (&["normal", "--sweep-trials", "1"], "--sweep-trials"),
        (&["normal", "--trials", "1e9"], "--trials"),
        (&["normal", "--seed", "-1"], "--seed"),
        (&["--threads", "0", "normal"], "--threads"),
        (&["--threads", "1000000000", "normal"], "--threads"),
        (&["distributions", "--points", "0"], "--points"),
        (&["distributions", "--sigma-max", "0"], "--sigma-max"),
        (&["distributions", "--tau", "-inf"], "--tau"),
        (&["profile", "--m", "1"], "--m"),
        (&["profile", "--n", "0"], "--n"),
        (&["profile", "--bins", "0"], "--bins"),
        (&["table1", "--total", "1000000000"], "--total"),
        (
            &["table1", "--total", "7", "--min-n", "4", "--trials", "10"],
            "--min-n",
        ),
        (&["histogram", "--bins", "1000000000"], "--bins"),
        (&["histogram", "--trials", "1000000000"], "--trials"),
        (&["histogram", "--n", "0"], "--n"),
        (
            &["histogram", "--sampling", "midpoint", "--trials", "10"],
            "midpoint",
        ),
        (&["convergence", "--max-n", "1000000000"], "--max-n"),
        (&["convergence", "--points", "1"], "--points"),
        (&["mis-bias", "--g", "1,0,1"], "--g"),
        (&["mis-bias", "--g", "nan,0,1,0.5"], "--g"),
        (&["mis-bias", "--g", "1,0,0,0", "--trials", "10"], "--g"),
        (&["mis-bias", "--nx", "0"], "--nx"),
        (&["mis-bias", "--tau-max", "1e30"], "--tau-max"),
        (&["mis-bias", "--limit", "nan"], "--limit"),
    ] {
        let argv = study(dir.path(), args);
        let argv: Vec<&str> = argv.iter().map(String::as_str).collect();
        assert_clean_error(&argv, &[], needle);
    }
}

#[test]
fn hostile_profile_csvs_are_clean_errors() {
    let dir = tempfile::tempdir().unwrap();
    let files = [
        ("constant.csv", "t,mu\n0,1\n1,1\n", "constant"),
        ("zero.csv", "t,mu\n0,0\n0.5,0\n1,0\n", "constant"),
        ("empty.csv", "", "two points"),
        ("header.csv", "t,mu\n", "two points"),
        ("one_row.csv", "0,1\n", "two points"),
        ("nan.csv", "0,nan\n1,1\n", "non-finite"),
        ("non_monotone.csv", "0,1\n2,2\n1,3\n", "increase"),
        ("negative.csv", "0,1\n1,-1\n", "non-negative"),
        ("huge.csv", "0,1e308\n1e308,1e308\n", "overflow"),
        // Finite, but tau^4 overflows f64 (NaN skewness and kurtosis at exit 0 before).
        ("deep.csv", "0,0\n1,1e150\n", "above 1e35"),
        // A subnormal span: 1 / h overflows (a panic in the Bessel function before).
        ("subnormal.csv", "0,1\n1e-320,2\n", "too close"),
        ("three_columns.csv", "0,1,2\n1,1,2\n", "t,mu"),
    ];
    for (name, text, needle) in files {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let p = path.to_str().unwrap();
        for sub in [
            &["histogram", "--trials", "100", "--profile", p][..],
            &["profile", "--trials", "100", "--profile", p],
            &[
                "convergence",
                "--trials",
                "10",
                "--max-n",
                "8",
                "--points",
                "3",
                "--profile",
                p,
            ],
        ] {
            let argv = study(dir.path(), sub);
            let argv: Vec<&str> = argv.iter().map(String::as_str).collect();
            assert_clean_error(&argv, &[], name);
            assert_clean_error(&argv, &[], needle);
        }
    }
    // A constant profile still runs where it is meaningful (Table 1: exact estimates).
    let p = dir.path().join("constant.csv");
    let argv = study(
        dir.path(),
        &[
            "table1",
            "--trials",
            "100",
            "--profile",
            p.to_str().unwrap(),
        ],
    );
    let argv: Vec<&str> = argv.iter().map(String::as_str).collect();
    let (code, out, err) = host(&argv, &[]);
    assert_eq!(code, Some(0), "{out}{err}");
}

/// A plot format the studies cannot write is refused before the study runs: no JSON is left
/// beside a plot that was never drawn (issue 43, hostile corpus).
#[test]
fn unknown_plot_formats_are_refused_before_the_study() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("s.json");
    let plot = dir.path().join("s.jpg");
    let (j, p) = (json.to_str().unwrap(), plot.to_str().unwrap());
    assert_clean_error(
        &["study", "normal", "--quiet", "--json", j, "--plot", p],
        &[],
        "plots are .png or .svg",
    );
    assert!(!json.exists() && !plot.exists());
    // And `host study` without a subcommand is an error like any other.
    assert_clean_error(&["study"], &[], "a subcommand is required");
}

#[cfg(unix)]
#[test]
fn non_regular_files_are_refused_unread() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("fifo.vdb");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let zero = dir.path().join("zero.vdb");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    let zero_csv = dir.path().join("zero.csv");
    std::os::unix::fs::symlink("/dev/zero", &zero_csv).unwrap();
    let out = dir.path().join("r.exr").display().to_string();
    for path in [&fifo, &zero] {
        let p = path.to_str().unwrap();
        let args = [
            "render",
            "--backend",
            "cpu",
            "--quiet",
            "--volume",
            p,
            "--out",
            &out,
        ];
        assert_clean_error(&args, &[], p);
        assert_clean_error(&args, &[], "not a regular file");
    }
    let p = zero_csv.to_str().unwrap();
    let argv = study(
        dir.path(),
        &["histogram", "--trials", "100", "--profile", p],
    );
    let argv: Vec<&str> = argv.iter().map(String::as_str).collect();
    assert_clean_error(&argv, &[], "not a regular file");
}

#[test]
fn bad_jk_vulkan_device_falls_back_under_auto_and_fails_under_gpu() {
    for value in ["5", "-1", "abc", "99999999999999999999999"] {
        let env = [("JK_VULKAN_DEVICE", value)];
        let probe = ["probe", "--count", "64", "--backend"];
        let (code, out, err) = host(&[&probe[..], &["auto"]].concat(), &env);
        assert_eq!(code, Some(0), "JK_VULKAN_DEVICE={value} auto: {out}{err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(
            out.contains("backend: cpu"),
            "JK_VULKAN_DEVICE={value} auto: {out}"
        );
        assert!(
            err.starts_with("warning: ") && err.contains("falling back to the CPU"),
            "JK_VULKAN_DEVICE={value} auto: {err}"
        );
        // Without any Vulkan driver the error says so instead of naming the variable.
        let (code, out, err) = host(&[&probe[..], &["gpu"]].concat(), &env);
        assert!(!err.contains("panicked"), "{err}");
        assert_eq!(code, Some(1), "JK_VULKAN_DEVICE={value} gpu: {out}{err}");
        assert!(err.starts_with("error: "), "{err}");
        assert!(
            err.contains("JK_VULKAN_DEVICE") || err.contains("no Vulkan"),
            "JK_VULKAN_DEVICE={value} gpu: {err}"
        );
    }
}

/// A `JK_VULKAN_DEVICE` that is not UTF-8 is a bad index like any other (it was read as unset,
/// silently choosing the default device): `--backend gpu` refuses it naming the variable.
#[test]
fn a_non_utf8_jk_vulkan_device_is_refused_not_ignored() {
    use std::os::unix::ffi::OsStrExt;
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_host"))
        .args(["probe", "--count", "64", "--backend", "gpu"])
        .env("JK_VULKAN_DEVICE", std::ffi::OsStr::from_bytes(b"\xff"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    // Without any Vulkan driver the error says so instead of naming the variable.
    assert!(
        err.contains("JK_VULKAN_DEVICE") || err.contains("no Vulkan"),
        "{err}"
    );
}
