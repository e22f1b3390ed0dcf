//! No output ever lands on an input or a device: a table of every file output flag of every
//! subcommand against every input kind that subcommand reads (volume, light probe, TOML scene,
//! JSON summary as a scene, shard, sweep file, profile), each by its own name and through a
//! symbolic link named as the output flag expects; and outputs that are FIFOs or character
//! devices (made in a scratch folder, never the system's) refused before any work. Every case
//! must be refused (exit 1, `error:`) and leave every input byte for byte as it was, an eval
//! folder's files included. (`host report` into the eval folder it reads reuses the files in
//! place, and its copies go through the same checked writer.)

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn host() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host"))
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures")
        .join(name)
}

/// Runs `host args` in `dir` with a 120 s limit (a FIFO opened by a check would hang it).
fn run_in(dir: &Path, args: &[String]) -> Output {
    let mut child = host()
        .current_dir(dir)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("host {args:?} hung (120 s)");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn ok(dir: &Path, args: &[&str]) {
    let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
    let out = run_in(dir, &args);
    assert!(
        out.status.success(),
        "host {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Writes a 4x2 RGB light probe (.exr).
fn write_probe(path: &Path) {
    exr::prelude::write_rgb_file(path, 4, 2, |x, y| (0.5 + x as f32, 1.0, 0.25 * y as f32))
        .unwrap();
}

/// The inputs every case reads, made once in `root`: (kind, path).
struct Inputs {
    volume: PathBuf,
    sweep: PathBuf,
    probe: PathBuf,
    scene: PathBuf,
    summary: PathBuf,
    shard: PathBuf,
    eval_dir: PathBuf,
    profile: PathBuf,
}

/// Small settings of a CPU render of the volume file.
const SMALL: &[&str] = &[
    "--width",
    "8",
    "--height",
    "8",
    "--spp",
    "1",
    "--backend",
    "cpu",
    "--quiet",
];

fn make_inputs(root: &Path) -> Inputs {
    let volume = root.join("density.vdb");
    std::fs::copy(fixture("density_zip.vdb"), &volume).unwrap();
    let sweep = root.join("sweep.vdb");
    std::fs::copy(fixture("density_raw.vdb"), &sweep).unwrap();
    let probe = root.join("probe.exr");
    write_probe(&probe);
    let scene = root.join("scene.toml");
    std::fs::write(&scene, "spp = 2\nseed = 3\n").unwrap();
    // A render's JSON summary: its scene names the summary itself as `json`.
    let summary = root.join("render.json");
    let mut args = vec!["render", "--volume", "density.vdb", "--out", "render.exr"];
    args.extend(SMALL);
    args.extend(["--json", "render.json"]);
    ok(root, &args);
    let shard = root.join("part.shard");
    let mut args = vec!["render", "--volume", "density.vdb", "--out", "merged.exr"];
    args.extend(SMALL);
    args.extend(["--shard", "part.shard"]);
    ok(root, &args);
    let eval_dir = root.join("evaluated");
    ok(
        root,
        &[
            "eval",
            "--volume",
            "density.vdb",
            "--width",
            "8",
            "--height",
            "8",
            "--spp",
            "2",
            "--reference-spp",
            "4",
            "--estimators",
            "track-length",
            "--backend",
            "cpu",
            "--quiet",
            "--out-dir",
            "evaluated",
        ],
    );
    let profile = root.join("profile.csv");
    std::fs::write(&profile, "t,mu\n0,1\n1,2\n").unwrap();
    Inputs {
        volume,
        sweep,
        probe,
        scene,
        summary,
        shard,
        eval_dir,
        profile,
    }
}

/// One subcommand: its arguments (with `{volume}`-style placeholders for the inputs, split at
/// spaces), the inputs it reads and its output flags, each with the extension its file must
/// have. (`host report --out` and `host view --save-dir` are folders: their files are planned one
/// by one and checked by the same code; `host/tests/outputs.rs` covers them.)
struct Row {
    args: &'static str,
    inputs: &'static [&'static str],
    outputs: &'static [(&'static str, &'static str)],
}

/// Small CPU runs: appended to every row's arguments but the study's and the merge's.
const SMALL_RUN: &str = "--width 8 --height 8 --backend cpu --quiet";

/// The outputs of `host render`.
const RENDER_OUTPUTS: &[(&str, &str)] = &[
    ("--out", "exr"),
    ("--json", "json"),
    ("--write-scene", "toml"),
    ("--shard", "shard"),
];

const ROWS: &[Row] = &[
    Row {
        args: "render --volume {volume} --scene {scene} --integrator direct --env {probe} SMALL",
        inputs: &["volume", "scene", "probe"],
        outputs: RENDER_OUTPUTS,
    },
    Row {
        args: "render --scene {summary} SMALL",
        inputs: &["summary", "volume"],
        outputs: RENDER_OUTPUTS,
    },
    Row {
        args: "eval --volume {volume} --scene {scene} --estimators track-length --out-dir e SMALL",
        inputs: &["volume", "scene"],
        outputs: &[("--json", "json"), ("--reference-shard", "shard")],
    },
    Row {
        args: "eval --integrators direct --env {probe} --volume {volume} --estimators \
               track-length --out-dir e SMALL",
        inputs: &["probe", "volume"],
        outputs: &[("--json", "json"), ("--reference-shard", "shard")],
    },
    Row {
        args: "eval --volume {volume} --estimators track-length --out-dir e \
               --reference-from {shard} SMALL",
        inputs: &["shard", "volume"],
        outputs: &[("--json", "json")],
    },
    Row {
        args: "bench --volume {volume} --scene {scene} SMALL",
        inputs: &["volume", "scene"],
        outputs: &[("--json", "json")],
    },
    Row {
        args: "bench --scene {scene} --sweep --sweep-files {sweep} SMALL",
        inputs: &["scene", "sweep"],
        outputs: &[("--json", "json"), ("--plot", "svg")],
    },
    Row {
        args: "study profile --profile {profile} --trials 100 --quiet",
        inputs: &["profile"],
        outputs: &[("--json", "json"), ("--plot", "svg")],
    },
    Row {
        args: "merge {shard} --quiet",
        inputs: &["shard", "volume"],
        outputs: &[("--out", "exr"), ("--json", "json")],
    },
];

impl Inputs {
    fn path(&self, kind: &str) -> PathBuf {
        match kind {
            "volume" => self.volume.clone(),
            "sweep" => self.sweep.clone(),
            "probe" => self.probe.clone(),
            "scene" => self.scene.clone(),
            "summary" => self.summary.clone(),
            "shard" => self.shard.clone(),
            "eval" => self.eval_dir.join("eval.json"),
            "profile" => self.profile.clone(),
            _ => unreachable!("{kind}"),
        }
    }

    /// Every input file's bytes (the eval folder's files included).
    fn snapshot(&self) -> Vec<(PathBuf, Vec<u8>)> {
        let mut files = vec![
            self.volume.clone(),
            self.sweep.clone(),
            self.probe.clone(),
            self.scene.clone(),
            self.summary.clone(),
            self.shard.clone(),
            self.profile.clone(),
        ];
        for e in std::fs::read_dir(&self.eval_dir).unwrap() {
            files.push(e.unwrap().path());
        }
        files.sort();
        files
            .into_iter()
            .map(|f| {
                let b = std::fs::read(&f).unwrap();
                (f, b)
            })
            .collect()
    }

    fn fill(&self, args: &str) -> Vec<String> {
        args.split_whitespace()
            .flat_map(|a| match a {
                "SMALL" => SMALL_RUN.split_whitespace().collect(),
                other => vec![other],
            })
            .map(|a| match a {
                "{volume}" => self.volume.display().to_string(),
                "{sweep}" => self.sweep.display().to_string(),
                "{probe}" => self.probe.display().to_string(),
                "{scene}" => self.scene.display().to_string(),
                "{summary}" => self.summary.display().to_string(),
                "{shard}" => self.shard.display().to_string(),
                "{eval}" => self.eval_dir.display().to_string(),
                "{profile}" => self.profile.display().to_string(),
                other => other.to_owned(),
            })
            .collect()
    }
}

/// Asserts `out` is a clean refusal; returns stderr.
fn refused(out: &Output, case: &str) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(
        out.status.code(),
        Some(1),
        "{case}: expected a refusal: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "{case}: {stderr}");
    let first = stderr
        .lines()
        .find(|l| !l.starts_with("warning:") && !l.starts_with("note:"))
        .unwrap_or("");
    assert!(first.starts_with("error:"), "{case}: {stderr}");
    stderr
}

/// Every output flag of every subcommand, onto every input that subcommand reads, by the
/// input's own path and through a symbolic link with the output's extension: refused, naming
/// the input where the output's name is acceptable, and every input unchanged.
#[test]
fn every_output_flag_onto_every_input_is_refused() {
    let root = tempfile::tempdir().unwrap();
    let inputs = make_inputs(root.path());
    let before = inputs.snapshot();
    let work = root.path().join("work");
    std::fs::create_dir(&work).unwrap();
    let mut cases = 0;
    for row in ROWS {
        for &(flag, ext) in row.outputs {
            for &kind in row.inputs {
                let input = inputs.path(kind);
                let link = work.join(format!("link-{cases}.{ext}"));
                std::os::unix::fs::symlink(&input, &link).unwrap();
                for (how, target) in [("by its path", &input), ("through a link", &link)] {
                    let mut args = inputs.fill(row.args);
                    args.extend([flag.to_owned(), target.display().to_string()]);
                    let case = format!("host {args:?} ({flag} onto the {kind} input {how})");
                    let stderr = refused(&run_in(&work, &args), &case);
                    let named_right = target.extension().is_some_and(|e| e == ext);
                    if named_right {
                        assert!(
                            stderr.contains("would overwrite the input"),
                            "{case}: {stderr}"
                        );
                    }
                    assert_eq!(inputs.snapshot(), before, "{case} changed an input");
                    cases += 1;
                }
            }
        }
    }
    assert!(cases >= 60, "only {cases} cases");
}

/// `host eval` and `host bench` given a render's JSON summary as their scene do not take its
/// `json` (the summary's own path) as their report's: the summary stays as it was.
#[test]
fn eval_and_bench_of_a_summary_leave_the_summary() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path();
    std::fs::copy(fixture("density_zip.vdb"), dir.join("density.vdb")).unwrap();
    let mut args = vec!["render", "--volume", "density.vdb", "--out", "r.exr"];
    args.extend(SMALL);
    args.extend(["--spp", "2", "--json", "r.json"]);
    ok(dir, &args);
    let summary = std::fs::read(dir.join("r.json")).unwrap();
    ok(
        dir,
        &[
            "eval",
            "--scene",
            "r.json",
            "--estimators",
            "track-length",
            "--reference-spp",
            "4",
            "--out-dir",
            "ev",
        ],
    );
    assert_eq!(std::fs::read(dir.join("r.json")).unwrap(), summary);
    assert!(dir.join("ev/eval.json").is_file());
    ok(
        dir,
        &[
            "bench",
            "--scene",
            "r.json",
            "--estimators",
            "track-length",
            "--reps",
            "1",
            "--warmup",
            "0",
        ],
    );
    assert_eq!(std::fs::read(dir.join("r.json")).unwrap(), summary);
}

/// Makes a FIFO at `path`.
fn mkfifo(path: &Path) {
    let c = std::ffi::CString::new(path.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
}

/// Makes a character device like /dev/null (1, 3) at `path` in a scratch folder; false where
/// this user may not (not root).
fn mknod_null(path: &Path) -> bool {
    let c = std::ffi::CString::new(path.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path; the node is made in a temporary folder.
    unsafe { libc::mknod(c.as_ptr(), libc::S_IFCHR | 0o666, libc::makedev(1, 3)) == 0 }
}

/// Output paths that are FIFOs or character devices are refused before any work, without
/// opening them (a FIFO with no reader would block) and without replacing them.
#[test]
fn fifos_and_devices_as_outputs_are_refused_and_kept() {
    use std::os::unix::fs::FileTypeExt;
    let root = tempfile::tempdir().unwrap();
    let dir = root.path();
    let fifo_json = dir.join("pipe.json");
    let fifo_exr = dir.join("pipe.exr");
    mkfifo(&fifo_json);
    mkfifo(&fifo_exr);
    let null = dir.join("null.json");
    let device = mknod_null(&null);
    let mut specials = vec![fifo_json.clone(), fifo_exr.clone()];
    if device {
        specials.push(null.clone());
    } else {
        eprintln!("note: not root: the character-device cases are skipped (the FIFOs are run)");
    }
    for special in &specials {
        let p = special.display().to_string();
        let base = |more: &[&str]| -> Vec<String> {
            let mut a: Vec<String> = ["render", "--resolution", "16"]
                .iter()
                .map(|s| s.to_string())
                .collect();
            a.extend(SMALL.iter().map(|s| s.to_string()));
            a.extend(more.iter().map(|s| s.to_string()));
            a
        };
        let cases: Vec<Vec<String>> = vec![
            base(&["--out", "a.exr", "--json", &p]),
            base(&["--out", &p]),
            base(&["--write-scene", &p]),
            base(&["--shard", &p]),
            vec![
                "study".into(),
                "profile".into(),
                "--trials".into(),
                "100".into(),
                "--json".into(),
                p.clone(),
            ],
            vec![
                "bench".into(),
                "--resolution".into(),
                "16".into(),
                "--reps".into(),
                "1".into(),
                "--json".into(),
                p.clone(),
            ],
        ];
        for args in cases {
            let case = format!("host {args:?}");
            let stderr = refused(&run_in(dir, &args), &case);
            assert!(
                stderr.contains("not a regular file") || stderr.contains(".exr"),
                "{case}: {stderr}"
            );
            let t = std::fs::symlink_metadata(special).unwrap().file_type();
            assert!(t.is_fifo() || t.is_char_device(), "{case}: replaced");
        }
    }
    assert!(!dir.join("a.exr").exists());
}

/// A file name too long for the temporary file beside it (about 236 bytes and more) is a legal
/// output name: written; one longer than the file system allows is refused before the work.
#[test]
fn long_output_names_are_written_or_refused_before_the_work() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path();
    let long = format!("{}.json", "n".repeat(245));
    let mut args = vec!["render", "--resolution", "16", "--out", "a.exr"];
    args.extend(SMALL);
    args.extend(["--json", &long]);
    ok(dir, &args);
    assert!(dir.join(&long).is_file());
    let too_long = format!("{}.json", "n".repeat(260));
    let mut args: Vec<String> = ["render", "--resolution", "16", "--out", "b.exr"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    args.extend(SMALL.iter().map(|s| s.to_string()));
    args.extend(["--json".to_owned(), too_long]);
    let stderr = refused(&run_in(dir, &args), "too long");
    assert!(stderr.contains("255"), "{stderr}");
    assert!(!dir.join("b.exr").exists());
}

/// SIGINT, SIGTERM and SIGHUP end a run with exit 130 and a message, leaving no temporary file
/// and no output behind (the render is interrupted before its outputs are written).
#[test]
fn signals_end_a_run_cleanly() {
    for signal in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path();
        let child = host()
            .current_dir(dir)
            .args([
                "render",
                "--resolution",
                "64",
                "--width",
                "256",
                "--height",
                "256",
                "--spp",
                "100000",
                "--backend",
                "cpu",
                "--quiet",
                "--out",
                "r.exr",
                "--json",
                "r.json",
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(1500));
        // SAFETY: signalling our own child process.
        assert_eq!(unsafe { libc::kill(child.id() as i32, signal) }, 0);
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(130), "signal {signal}: {stderr}");
        assert!(stderr.contains("interrupted"), "{stderr}");
        let left: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name())
            .collect();
        assert!(left.is_empty(), "signal {signal}: left {left:?}");
    }
}

/// On a full disk, a write fails naming its cause once, and no truncated file is left in place
/// (the PNG encoders' buffered last flush lost the error and left an empty preview). Needs a
/// small tmpfs (`mount`, root); skipped with a note elsewhere.
#[test]
fn a_full_disk_is_reported_once_and_leaves_no_truncated_file() {
    let root = tempfile::tempdir().unwrap();
    let disk = root.path().join("disk");
    std::fs::create_dir(&disk).unwrap();
    let mounted = Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=64k", "tmpfs"])
        .arg(&disk)
        .output()
        .is_ok_and(|o| o.status.success());
    if !mounted {
        eprintln!("note: cannot mount a tmpfs here (not root?): the full-disk case is skipped");
        return;
    }
    // Leave about 4 KiB: the EXR of 16 x 16 pixels fits, its PNG preview does not always; the
    // JSON never does after both.
    std::fs::write(disk.join("fill"), vec![0u8; 60 << 10]).unwrap();
    let args: Vec<String> = [
        "render",
        "--resolution",
        "16",
        "--width",
        "16",
        "--height",
        "16",
        "--spp",
        "1",
        "--backend",
        "cpu",
        "--quiet",
        "--out",
        "s.exr",
        "--json",
        "s.json",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    /// Unmounts the tmpfs however the test ends.
    struct Unmount<'a>(&'a Path);
    impl Drop for Unmount<'_> {
        fn drop(&mut self) {
            let _ = Command::new("umount").arg(self.0).output();
        }
    }
    let _unmount = Unmount(&disk);
    let out = run_in(&disk, &args);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let line = stderr.lines().find(|l| l.starts_with("error:")).unwrap();
    assert_eq!(line.matches("No space left on device").count(), 1, "{line}");
    // What was left in place is whole: no empty or cut file under an output's name, no
    // temporary file.
    let mut names = Vec::new();
    for entry in std::fs::read_dir(&disk).unwrap().flatten() {
        let name = entry.file_name().to_string_lossy().to_string();
        let len = entry.metadata().unwrap().len();
        assert!(name == "fill" || len > 0, "{name} was left empty");
        assert!(!name.contains(".partial-"), "{name} was left");
        names.push(name);
    }
    assert!(
        names.contains(&"fill".to_owned()),
        "not the tmpfs: {names:?}"
    );
}
