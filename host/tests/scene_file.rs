//! Scene files (`host render SCENE`, `--scene`, `--write-scene`) and the `scene` of a render's
//! JSON summary: the same flags through a scene file or a summary give the same bytes, the flags
//! given override the file, and a bad file is refused naming its key and line.

use std::path::Path;
use std::process::Command;

fn host() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host"))
}

/// A small, fast render on the CPU (procedural 16^3 cloud, 8 x 6 pixels, 1 spp).
const SMALL: &[&str] = &[
    "--backend",
    "cpu",
    "--resolution",
    "16",
    "--width",
    "8",
    "--height",
    "6",
    "--spp",
    "1",
    "--quiet",
];

/// Runs `host` in `dir`, panicking with its output on failure.
fn run(dir: &Path, args: &[&str]) {
    let out = host().current_dir(dir).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "host {args:?}\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Runs `host` in `dir`, expecting failure; returns stderr.
fn refused(dir: &Path, args: &[&str]) -> String {
    let out = host().current_dir(dir).args(args).output().unwrap();
    assert!(!out.status.success(), "host {args:?} should fail");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn bytes(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Each integrator, and transmittance with each estimator family: flags -> EXR equals flags ->
/// `--write-scene` -> `host render SCENE` -> EXR, and equals `--scene THE.json` of the first
/// render, byte for byte.
#[test]
fn flags_scene_files_and_summaries_render_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut cases: Vec<Vec<&str>> = [
        "jackknife",
        "jackknife-adaptive",
        "naive-m1",
        "biased-rm",
        "unbiased-rm",
        "telescoping",
        "telescoping-cycles",
        "track-length",
        "ratio",
        "regular",
    ]
    .iter()
    .map(|e| vec!["--estimator", *e])
    .collect();
    for i in [
        "free-flight",
        "equiangular",
        "mis-jackknife",
        "mis-naive",
        "combined-jackknife",
        "combined-naive",
        "miller",
        "mis-power",
        "direct",
        "path",
        "restir",
    ] {
        cases.push(vec!["--integrator", i]);
    }
    cases.push(vec![
        "--integrator",
        "path",
        "--max-depth",
        "3",
        "--light",
        "0,0,0,4",
    ]);
    cases.push(vec![
        "--integrator",
        "restir",
        "--restir-candidates",
        "3",
        "--restir-passes",
        "1",
    ]);
    for (k, case) in cases.iter().enumerate() {
        let flags: Vec<&str> = SMALL.iter().chain(case.iter()).copied().collect();
        let (a, a_json) = (format!("a{k}.exr"), format!("a{k}.json"));
        let scene = format!("s{k}.toml");
        let mut first = flags.clone();
        first.extend(["--out", &a, "--json", &a_json]);
        run(d, &first);
        let mut write = flags.clone();
        write.extend(["--write-scene", &scene]);
        run(d, &write);
        let b = format!("b{k}.exr");
        run(d, &["render", &scene, "--out", &b]);
        let c = format!("c{k}.exr");
        run(
            d,
            &[
                "render", "--scene", &a_json, "--out", &c, "--json", "c.json",
            ],
        );
        let reference = bytes(&d.join(&a));
        assert!(
            reference == bytes(&d.join(&b)),
            "{case:?}: scene file differs"
        );
        assert!(
            reference == bytes(&d.join(&c)),
            "{case:?}: JSON summary differs"
        );
    }
}

/// The flags given override the file's settings; a flag given several times (`--light`)
/// replaces the file's list instead of adding to it.
#[test]
fn flags_override_the_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("s.toml"),
        "backend = \"cpu\"\nresolution = 16\nwidth = 8\nheight = 6\nspp = 3\n\
         integrator = \"mis-jackknife\"\nlight = [[0, 0, 0, 5], [1, 1, 1, 2]]\n",
    )
    .unwrap();
    run(
        d,
        &[
            "render",
            "s.toml",
            "--spp",
            "1",
            "--light",
            "0.5,0,0,3",
            "--json",
            "o.json",
            "-q",
        ],
    );
    let j: serde_json::Value = serde_json::from_slice(&bytes(&d.join("o.json"))).unwrap();
    assert_eq!(j["spp"], 1);
    assert_eq!(j["scene"]["spp"], 1);
    assert_eq!(j["scene"]["width"], 8);
    assert_eq!(
        j["integrator"]["lights"],
        serde_json::json!([[0.5, 0.0, 0.0, 3.0]])
    );
}

/// An input path relative to the scene file resolves against the file's folder (run from
/// another folder), and gives the bytes of the same render with the absolute path.
#[test]
fn relative_inputs_resolve_against_the_scene_folder() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("scenes")).unwrap();
    let env = d.join("scenes").join("sky.hdr");
    let mut img = image::Rgb32FImage::new(8, 4);
    for (x, y, p) in img.enumerate_pixels_mut() {
        *p = image::Rgb([0.2 + 0.1 * x as f32, 0.5, 0.1 * y as f32]);
    }
    image::DynamicImage::ImageRgb32F(img).save(&env).unwrap();
    let mut toml = String::new();
    for pair in SMALL.chunks(2).filter(|p| p.len() == 2) {
        let key = pair[0].trim_start_matches("--");
        let v = pair[1];
        let quoted = if v.parse::<f64>().is_ok() {
            v.to_owned()
        } else {
            format!("{v:?}")
        };
        toml.push_str(&format!("{key} = {quoted}\n"));
    }
    toml.push_str("integrator = \"direct\"\nenv = \"sky.hdr\"\n");
    std::fs::write(d.join("scenes").join("s.toml"), toml).unwrap();
    run(d, &["render", "scenes/s.toml", "--out", "rel.exr", "-q"]);
    let mut abs: Vec<&str> = SMALL.to_vec();
    let env_s = env.display().to_string();
    abs.extend([
        "--integrator",
        "direct",
        "--env",
        &env_s,
        "--out",
        "abs.exr",
    ]);
    run(d, &abs);
    assert!(bytes(&d.join("rel.exr")) == bytes(&d.join("abs.exr")));
}

/// Bad scene files are refused before any work, naming the file, the key and its line.
#[test]
fn bad_scene_files_name_the_key_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: &[(&str, &[&str])] = &[
        ("spp = \n", &["bad.toml", "line 1", "TOML"]),
        (
            "spp = 2\ndensty-scale = 3\n",
            &[
                "bad.toml:2",
                "key `densty-scale`",
                "unknown key",
                "density-scale",
            ],
        ),
        (
            "width = 8\nspp = \"abc\"\n",
            &["bad.toml:2", "key `spp`", "abc"],
        ),
        (
            "quiet = 3\n",
            &["bad.toml:1", "key `quiet`", "true or false"],
        ),
        ("[restir]\ncandidates = 3\n", &["key `restir`", "restir-"]),
        (
            "camera = [1, [2], 3]\n",
            &["bad.toml:1", "key `camera`", "list inside a list"],
        ),
        ("volume = \"/dev/zero\"\n", &["/dev/zero"]),
        ("out = \"/dev/full\"\nbackend = \"cpu\"\n", &["/dev/full"]),
        (
            "scene = \"other.toml\"\n",
            &["bad.toml:1", "key `scene`", "unknown key"],
        ),
    ];
    for (text, words) in cases {
        std::fs::write(d.join("bad.toml"), text).unwrap();
        let err = refused(d, &["render", "bad.toml"]);
        for w in *words {
            assert!(err.contains(w), "{text:?}: {w:?} not in {err}");
        }
        assert!(
            !d.join("out/render.exr").exists(),
            "{text:?} wrote an image"
        );
    }
    for device in ["/dev/zero", "/dev/null"] {
        let err = refused(d, &["render", "--scene", device]);
        assert!(err.contains("not a regular file"), "{device}: {err}");
    }
    std::fs::create_dir(d.join("dir.toml")).unwrap();
    let err = refused(d, &["render", "dir.toml"]);
    assert!(err.contains("not a regular file"), "{err}");
    let err = refused(d, &["render", "--scene", "missing.toml"]);
    assert!(
        err.contains("missing.toml") && err.contains("cannot read"),
        "{err}"
    );
    std::fs::write(d.join("old.json"), "{\"spp\": 1}").unwrap();
    let err = refused(d, &["render", "--scene", "old.json"]);
    assert!(err.contains("no `scene`"), "{err}");
}

/// A render never writes onto its scene file, and `--write-scene` never onto its input.
#[test]
fn outputs_never_replace_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut first: Vec<&str> = SMALL.to_vec();
    first.extend(["--out", "a.exr", "--json", "a.json"]);
    run(d, &first);
    let before = bytes(&d.join("a.json"));
    let err = refused(d, &["render", "--scene", "a.json"]);
    assert!(
        err.contains("--json a.json would overwrite the input --scene"),
        "{err}"
    );
    let err = refused(
        d,
        &["render", "--scene", "a.json", "--write-scene", "a.json"],
    );
    assert!(err.contains("overwrite"), "{err}");
    assert!(before == bytes(&d.join("a.json")));
}

/// `host eval --scene` takes the keys it has flags for (the same images as those flags) and
/// notes the `host render` keys it does not use; `host bench --scene` runs the scene's size.
#[test]
fn eval_and_bench_take_the_keys_they_have() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("s.toml"),
        "volume = \"cloud\"\nresolution = 16\nwidth = 12\nheight = 10\nspp = 8\nbackend = \"cpu\"\n\
         estimator = \"ratio\"\nout = \"x.exr\"\n",
    )
    .unwrap();
    let common = ["--estimators", "jackknife", "--reference-spp", "16", "-q"];
    let mut a = vec!["eval", "--scene", "s.toml", "--out-dir", "a"];
    a.extend(common);
    let out = host().current_dir(d).args(&a).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no flags for the scene keys estimator, out"),
        "{err}"
    );
    let mut b = vec!["eval", "--out-dir", "b"];
    b.extend([
        "--volume",
        "cloud",
        "--resolution",
        "16",
        "--width",
        "12",
        "--height",
        "10",
        "--spp",
        "8",
        "--backend",
        "cpu",
    ]);
    b.extend(common);
    run(d, &b);
    for f in ["jackknife_mean.exr", "reference.exr"] {
        assert!(
            bytes(&d.join("a").join(f)) == bytes(&d.join("b").join(f)),
            "{f}"
        );
    }
    run(
        d,
        &[
            "bench",
            "--scene",
            "s.toml",
            "--estimators",
            "jackknife",
            "--reps",
            "1",
            "--json",
            "b.json",
        ],
    );
    let j: serde_json::Value = serde_json::from_slice(&bytes(&d.join("b.json"))).unwrap();
    assert_eq!(
        (j["width"].clone(), j["height"].clone()),
        (12.into(), 10.into())
    );
}

/// `host report --scene` takes the keys it has flags for, `volume` as its `--volumes`, and not
/// `out` (a render's image, where the report's --out is a folder): the same images as the flags.
#[test]
fn report_takes_the_scene_keys_it_has() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("s.toml"),
        "volume = \"cloud\"\nresolution = 16\nwidth = 12\nheight = 10\nspp = 8\nbackend = \"cpu\"\n\
         out = \"x.exr\"\n",
    )
    .unwrap();
    let out = host()
        .current_dir(d)
        .args([
            "report",
            "--scene",
            "s.toml",
            "--out",
            "a",
            "--estimators",
            "jackknife",
            "-q",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no flags for the scene keys out"), "{err}");
    run(
        d,
        &[
            "report",
            "--volumes",
            "cloud",
            "--resolution",
            "16",
            "--width",
            "12",
            "--height",
            "10",
            "--spp",
            "8",
            "--backend",
            "cpu",
            "--out",
            "b",
            "--estimators",
            "jackknife",
            "-q",
        ],
    );
    let mut images = Vec::new();
    let mut stack = vec![d.join("a")];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "exr") {
                images.push(p.strip_prefix(d.join("a")).unwrap().to_owned());
            }
        }
    }
    assert!(!images.is_empty(), "the report wrote no images");
    for rel in images {
        assert!(
            bytes(&d.join("a").join(&rel)) == bytes(&d.join("b").join(&rel)),
            "{}: the scene file's report differs from the flags'",
            rel.display()
        );
    }
}

/// `host render SCENE` takes the scene file anywhere among the flags: after them it renders the
/// same bytes as first.
#[test]
fn a_positional_scene_may_follow_the_flags() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), "seed = 9\nspp = 2\n").unwrap();
    let mut first = vec!["render", "s.toml"];
    first.extend(SMALL.iter().filter(|a| **a != "--spp" && **a != "1"));
    first.extend(["--out", "a.exr"]);
    run(d, &first);
    let mut last = vec!["render"];
    last.extend(SMALL.iter().filter(|a| **a != "--spp" && **a != "1"));
    last.extend(["--out", "b.exr", "s.toml"]);
    run(d, &last);
    assert_eq!(bytes(&d.join("a.exr")), bytes(&d.join("b.exr")));
    // Without a subcommand too.
    let mut bare: Vec<&str> = SMALL
        .iter()
        .filter(|a| **a != "--spp" && **a != "1")
        .copied()
        .collect();
    bare.extend(["--out", "c.exr", "s.toml"]);
    run(d, &bare);
    assert_eq!(bytes(&d.join("a.exr")), bytes(&d.join("c.exr")));
}

/// A render's summary (which holds `json`) shards: the scene's `json` is a run key, not a
/// `--json` typed with `--shard`; the merge writes the summary there.
#[test]
fn a_summary_with_json_shards_and_merges_into_its_json() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut args = vec!["render"];
    args.extend(SMALL);
    args.extend(["--out", "r.exr", "--json", "r.json"]);
    run(d, &args);
    let summary = bytes(&d.join("r.json"));
    run(d, &["render", "r.json", "--shard", "all.shard", "--quiet"]);
    assert_eq!(bytes(&d.join("r.json")), summary, "the scene was changed");
    let e = refused(
        d,
        &["render", "r.json", "--shard", "x.shard", "--json", "x.json"],
    );
    assert!(e.contains("--json"), "{e}");
    std::fs::rename(d.join("r.json"), d.join("first.json")).unwrap();
    run(d, &["merge", "all.shard", "--out", "m.exr", "--quiet"]);
    assert_eq!(bytes(&d.join("m.exr")), bytes(&d.join("r.exr")));
    assert!(
        d.join("r.json").is_file(),
        "the merge wrote no summary to the scene's json"
    );
}

/// `--write-scene` refuses what `host render` of the written scene would refuse, so every
/// written scene renders.
#[test]
fn written_scenes_always_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let e = refused(d, &["render", "--hg-g", "0.5", "--write-scene", "w.toml"]);
    assert!(e.contains("--hg-g"), "{e}");
    assert!(!d.join("w.toml").exists());
    let mut args = vec!["render", "--integrator", "path", "--hg-g", "0.5"];
    args.extend(SMALL);
    args.extend(["--write-scene", "w.toml"]);
    run(d, &args);
    run(d, &["render", "w.toml", "--out", "w.exr"]);
}

/// A scene file is read through a bound, whatever size the file system reports: /proc files
/// report 0 bytes.
#[test]
fn scene_reads_are_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let e = refused(dir.path(), &["render", "--scene", "/proc/self/maps"]);
    assert!(e.contains("/proc/self/maps"), "{e}");
    assert!(!e.contains("panicked"), "{e}");
}
