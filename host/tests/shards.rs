//! Sharded renders: `host render --samples A..B --shard FILE` on any backend, then `host merge`,
//! give the bytes of one render of all samples (EXR, PNG, and the JSON summary but for the
//! fields that say how it ran); bad ranges and bad shard sets are refused with advice.

use serde_json::Value;
use std::path::Path;
use std::process::Command;

fn host() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host"))
}

/// A small render (procedural 16^3 cloud, 4 x 3 pixels) of 800 samples: four shards at the
/// 256-sample blocks, the last one short.
const SMALL: &[&str] = &[
    "--resolution",
    "16",
    "--width",
    "4",
    "--height",
    "3",
    "--spp",
    "800",
    "--quiet",
];

/// The shards' sample ranges.
const RANGES: [&str; 4] = ["0..256", "256..512", "512..768", "768..800"];

/// Runs `host` in `dir`, panicking with its output on failure.
fn run(dir: &Path, args: &[&str]) {
    std::fs::create_dir_all(dir).unwrap();
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
    std::fs::create_dir_all(dir).unwrap();
    let out = host().current_dir(dir).args(args).output().unwrap();
    assert!(!out.status.success(), "host {args:?} should fail");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn bytes(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Fields of a JSON summary that say how a render ran, not what it rendered.
const RUN_FIELDS: &[&str] = &[
    "backend",
    "device",
    "elapsed_ms",
    "pipeline_build_ms",
    "pipeline_builds",
    "prepare_ms",
    "command_line",
    "shards",
    "pool_pages",
    "pool_page_bytes",
];

/// The summary at `p` without [`RUN_FIELDS`] and the shadow map's build time.
fn rendered_summary(p: &Path) -> Value {
    let mut v: Value = serde_json::from_slice(&bytes(p)).unwrap();
    let o = v.as_object_mut().unwrap();
    for f in RUN_FIELDS {
        o.remove(*f);
    }
    if let Some(Value::Object(shadows)) = o.get_mut("integrator").and_then(|i| i.get_mut("shadows"))
    {
        shadows.remove("build_ms");
        if let Some(Value::Object(map)) = shadows.get_mut("map") {
            map.remove("build_ms");
        }
    }
    v
}

/// Whether `host` finds a Vulkan device (lavapipe in CI).
fn gpu_available() -> bool {
    host()
        .args([
            "--backend",
            "gpu",
            "--resolution",
            "8",
            "--width",
            "1",
            "--height",
            "1",
            "--spp",
            "1",
            "--quiet",
            "--out",
        ])
        .arg(std::env::temp_dir().join(format!("jk-gpu-probe-{}.exr", std::process::id())))
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Every integrator and transmittance: one render of 800 samples equals its four shards
/// merged, and its one whole-range shard merged, byte for byte (EXR, PNG, summary). With a GPU,
/// the odd shards of the cases marked so run on it and the rest on the CPU (each GPU process
/// builds its pipelines: on lavapipe, seconds per case).
#[test]
fn four_shards_merge_into_the_bytes_of_one_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let gpu = gpu_available();
    if !gpu {
        eprintln!("no Vulkan device: every shard on the CPU");
    }
    let mut cases: Vec<Vec<&str>> = vec![
        vec!["--estimator", "jackknife"],
        vec!["--estimator", "track-length", "--layers", "stderr,samples"],
    ];
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
    ] {
        cases.push(vec!["--integrator", i]);
    }
    cases.push(vec![
        "--integrator",
        "direct",
        "--layers",
        "camera-transmittance,stderr",
    ]);
    cases.push(vec!["--integrator", "path", "--layers", "albedo,depth"]);
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
        let on_gpu = gpu
            && (k < 2
                || ["direct", "path", "restir"]
                    .iter()
                    .any(|i| case.contains(i)));
        let case_dir = d.join(format!("case{k}"));
        let (one, parts, merged, whole) = (
            case_dir.join("one"),
            case_dir.join("parts"),
            case_dir.join("merged"),
            case_dir.join("whole"),
        );
        let mut single = flags.clone();
        single.extend(["--backend", "cpu", "--out", "img.exr", "--json", "img.json"]);
        run(&one, &single);
        let mut shard_files = Vec::new();
        for (s, range) in RANGES.iter().enumerate() {
            let file = parts.join(format!("p{s}.shard"));
            let backend = if on_gpu && s % 2 == 1 { "gpu" } else { "cpu" };
            let mut shard = flags.clone();
            shard.extend(["--backend", backend, "--samples", range, "--shard"]);
            shard.push(file.to_str().unwrap());
            run(&parts, &shard);
            shard_files.push(file.to_str().unwrap().to_owned());
        }
        // Merged in an order other than the samples'.
        shard_files.reverse();
        let mut merge = vec!["merge"];
        merge.extend(shard_files.iter().map(String::as_str));
        merge.extend(["--out", "img.exr", "--json", "img.json", "--quiet"]);
        run(&merged, &merge);
        let all = whole.join("all.shard");
        let mut shard = flags.clone();
        shard.extend(["--backend", "cpu", "--shard", all.to_str().unwrap()]);
        run(&whole, &shard);
        run(
            &whole,
            &[
                "merge",
                all.to_str().unwrap(),
                "--out",
                "img.exr",
                "--json",
                "img.json",
                "--quiet",
            ],
        );
        for (name, other) in [("four shards", &merged), ("one shard", &whole)] {
            for file in ["img.exr", "img.png"] {
                assert!(
                    bytes(&one.join(file)) == bytes(&other.join(file)),
                    "{case:?}: {file} of {name} differs from one render"
                );
            }
            assert_eq!(
                rendered_summary(&one.join("img.json")),
                rendered_summary(&other.join("img.json")),
                "{case:?}: the summary of {name} differs from one render's"
            );
        }
        let summary: Value = serde_json::from_slice(&bytes(&merged.join("img.json"))).unwrap();
        let listed = summary["shards"]
            .as_array()
            .expect("a merged summary lists its shards");
        assert_eq!(listed.len(), 4);
        assert_eq!(
            listed[0]["samples"],
            serde_json::json!([0, 256]),
            "sample order"
        );
    }
}

/// Ranges off the sample blocks, shard sets with a gap, an overlap or another render's shard,
/// a non-shard file and a summary asked of a shard are refused, each naming the fix.
#[test]
fn bad_ranges_and_shard_sets_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let base: Vec<&str> = SMALL.iter().copied().chain(["--backend", "cpu"]).collect();
    let with = |extra: &[&str]| -> Vec<String> {
        base.iter()
            .chain(extra.iter())
            .map(|s| s.to_string())
            .collect()
    };
    let refuse = |extra: &[&str]| {
        let args = with(extra);
        refused(d, &args.iter().map(String::as_str).collect::<Vec<_>>())
    };
    let e = refuse(&["--samples", "100..300", "--shard", "x.shard"]);
    assert!(
        e.contains("multiple of 256") && e.contains("--samples 0..512"),
        "{e}"
    );
    let e = refuse(&["--samples", "512..900", "--shard", "x.shard"]);
    assert!(e.contains("within the render's --spp 800"), "{e}");
    let e = refuse(&["--samples", "0..256"]);
    assert!(e.contains("--shard"), "{e}");
    let e = refuse(&["--samples", "9..3", "--shard", "x.shard"]);
    assert!(e.contains("empty"), "{e}");
    let e = refuse(&["--shard", "x.shard", "--json", "x.json"]);
    assert!(e.contains("a shard writes no summary"), "{e}");
    for (k, range) in ["0..256", "256..512", "512..800"].iter().enumerate() {
        let args = with(&["--samples", range, "--shard", &format!("p{k}.shard")]);
        run(d, &args.iter().map(String::as_str).collect::<Vec<_>>());
    }
    let e = refused(d, &["merge", "p0.shard", "p2.shard"]);
    assert!(
        e.contains("samples 256..512") && e.contains("no shard"),
        "{e}"
    );
    let e = refused(
        d,
        &["merge", "p0.shard", "p1.shard", "p2.shard", "p1.shard"],
    );
    assert!(e.contains("overlaps"), "{e}");
    let args = with(&[
        "--seed",
        "7",
        "--samples",
        "256..512",
        "--shard",
        "q1.shard",
    ]);
    run(d, &args.iter().map(String::as_str).collect::<Vec<_>>());
    let e = refused(d, &["merge", "p0.shard", "q1.shard", "p2.shard"]);
    assert!(e.contains("differ in seed"), "{e}");
    std::fs::write(d.join("fake.shard"), b"not a shard at all").unwrap();
    let e = refused(d, &["merge", "fake.shard"]);
    assert!(e.contains("not a shard file"), "{e}");
    // A merge never writes onto a shard.
    let e = refused(
        d,
        &[
            "merge", "p0.shard", "p1.shard", "p2.shard", "--out", "p1.shard",
        ],
    );
    assert!(e.contains("p1.shard"), "{e}");
    run(
        d,
        &[
            "merge", "p0.shard", "p1.shard", "p2.shard", "--out", "ok.exr",
        ],
    );
    assert!(d.join("ok.exr").is_file() && d.join("ok.png").is_file());
}

/// `host eval --reference-from`: a reference rendered as two shards (`--reference-shard`,
/// `--reference-samples`) gives every image of the evaluation byte for byte, for a transmittance
/// evaluation and a `direct` one; shards of another evaluation and eval shards given to
/// `host merge` are refused.
#[test]
fn eval_references_add_up_from_shards() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: [&[&str]; 2] = [
        &["--lookup", "stochastic", "--spp", "8"],
        &["--integrators", "direct", "--spp", "4"],
    ];
    for (k, case) in cases.iter().enumerate() {
        let mut flags = vec![
            "eval",
            "--backend",
            "cpu",
            "--volume",
            "cloud",
            "--resolution",
            "32",
            "--width",
            "12",
            "--height",
            "10",
            "--reference-spp",
            "520",
            "--estimators",
            "jackknife",
            "--quiet",
        ];
        flags.extend(case.iter());
        let (one, two) = (format!("one{k}"), format!("two{k}"));
        let (s0, s1) = (format!("r{k}_0.shard"), format!("r{k}_1.shard"));
        let with = |extra: &[&str]| -> Vec<String> {
            flags
                .iter()
                .chain(extra.iter())
                .map(|s| s.to_string())
                .collect()
        };
        let go = |extra: &[&str]| {
            let args = with(extra);
            run(d, &args.iter().map(String::as_str).collect::<Vec<_>>());
        };
        go(&["--out-dir", &one]);
        go(&[
            "--out-dir",
            "scratch",
            "--reference-shard",
            &s0,
            "--reference-samples",
            "0..256",
        ]);
        go(&[
            "--out-dir",
            "scratch",
            "--reference-shard",
            &s1,
            "--reference-samples",
            "256..520",
        ]);
        go(&["--out-dir", &two, "--reference-from", &s1, &s0]);
        let mut images = 0;
        for entry in std::fs::read_dir(d.join(&one)).unwrap() {
            let name = entry.unwrap().file_name();
            if name.to_string_lossy().ends_with(".exr") {
                assert!(
                    bytes(&d.join(&one).join(&name)) == bytes(&d.join(&two).join(&name)),
                    "{case:?}: {name:?} differs with the reference from shards"
                );
                images += 1;
            }
        }
        assert!(images >= 2, "{case:?}: {images} images");
        let report: Value =
            serde_json::from_slice(&bytes(&d.join(&two).join("eval.json"))).unwrap();
        assert_eq!(report["reference_shards"].as_array().map(Vec::len), Some(2));
        // Another evaluation's shards (another seed) are refused, naming the reference.
        let args = with(&[
            "--seed",
            "5",
            "--out-dir",
            "three",
            "--reference-from",
            &s0,
            &s1,
        ]);
        let e = refused(d, &args.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(e.contains("render the shards with the same flags"), "{e}");
        let e = refused(d, &["merge", &s0, &s1]);
        assert!(e.contains("an evaluation's reference"), "{e}");
    }
}
