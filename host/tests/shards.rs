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

/// FNV-1a, 64 bits (the shard format's hash).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    })
}

/// The header (JSON) and the totals of a shard file's bytes: `JKSHARD2`, the header's length
/// (u32), the header hash (u64), the header, the totals.
fn shard_parts(bytes: &[u8]) -> (Value, Vec<u8>) {
    assert_eq!(&bytes[..8], b"JKSHARD2");
    let len = u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
    (
        serde_json::from_slice(&bytes[20..20 + len]).unwrap(),
        bytes[20 + len..].to_vec(),
    )
}

/// A shard of header `json` and totals `payload` whose header hash fits: what someone who
/// knows the format can write.
fn forge(json: &Value, payload: &[u8]) -> Vec<u8> {
    let json = serde_json::to_vec(json).unwrap();
    let mut hashed = b"JKSHARD2".to_vec();
    hashed.extend_from_slice(&(json.len() as u32).to_le_bytes());
    hashed.extend_from_slice(&json);
    let mut bytes = b"JKSHARD2".to_vec();
    bytes.extend_from_slice(&(json.len() as u32).to_le_bytes());
    bytes.extend_from_slice(&fnv1a(&hashed).to_le_bytes());
    bytes.extend_from_slice(&json);
    bytes.extend_from_slice(payload);
    bytes
}

/// `bytes` with every `from` replaced by `to` (of the same length: the header's length and
/// hash are left as they were).
fn edited(bytes: &[u8], from: &str, to: &str) -> Vec<u8> {
    assert_eq!(from.len(), to.len());
    let mut out = bytes.to_vec();
    let mut found = false;
    let mut at = 0;
    while let Some(k) = out[at..]
        .windows(from.len())
        .position(|w| w == from.as_bytes())
    {
        out[at + k..at + k + to.len()].copy_from_slice(to.as_bytes());
        at += k + to.len();
        found = true;
    }
    assert!(found, "{from} is not in the shard");
    out
}

/// Runs `host` in `dir`, expecting exit status 1 (an error, not a panic or an abort); returns
/// stderr.
fn refused_cleanly(dir: &Path, args: &[&str]) -> String {
    let out = host().current_dir(dir).args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "host {args:?}: {stderr}");
    assert!(
        stderr.starts_with("error: ") && !stderr.contains("panicked"),
        "{stderr}"
    );
    stderr
}

/// Shards edited in their header (the sample range, the image size in the scene and the
/// header, who rendered them), cut short, of the old format, or forged with a header hash that
/// fits but fields that lie (no images, 100000 x 100000 pixels, an unknown kind, samples past
/// the render's) are refused by `host merge` with exit status 1, naming the shard and saying to
/// render it again: no panic (no images used to index out of bounds) and no abort (the huge
/// image used to allocate terabytes).
#[test]
fn edited_damaged_and_forged_shards_are_refused_without_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut flags: Vec<&str> = SMALL.iter().copied().chain(["--backend", "cpu"]).collect();
    flags.extend(["--samples", "0..512", "--shard", "p0.shard"]);
    run(d, &flags);
    let n = flags.len();
    flags[n - 3] = "512..800";
    flags[n - 1] = "p1.shard";
    run(d, &flags);
    run(d, &["merge", "p0.shard", "p1.shard", "--out", "ok.exr"]);
    let good = bytes(&d.join("p0.shard"));
    let merge_p0 = |shard: &[u8]| {
        std::fs::write(d.join("p0.shard"), shard).unwrap();
        refused_cleanly(d, &["merge", "p0.shard", "p1.shard", "--out", "x.exr"])
    };
    let damaged = |e: &str, what: &str| {
        assert!(
            e.contains("p0.shard")
                && e.contains("changed or damaged")
                && e.contains("render that shard again"),
            "{what}: {e}"
        );
    };
    // Edits that keep the header's length: refused by the header hash.
    for (from, to) in [
        ("\"samples\":[0,512]", "\"samples\":[0,256]"),
        ("\"width\":4", "\"width\":5"),
        ("\"backend\":\"cpu\"", "\"backend\":\"gpu\""),
    ] {
        damaged(&merge_p0(&edited(&good, from, to)), to);
    }
    damaged(&merge_p0(&good[..good.len() - 1]), "cut short");
    let mut flipped = good.clone();
    *flipped.last_mut().unwrap() ^= 0x40;
    damaged(&merge_p0(&flipped), "a flipped bit in the totals");
    // Forgeries whose header hash fits.
    let (json, payload) = shard_parts(&good);
    type Lie = fn(&mut Value);
    let lies: [(&str, Lie); 5] = [
        ("no images", |j| j["images"] = serde_json::json!([])),
        ("100000 x 100000 pixels", |j| {
            for k in ["width", "height"] {
                j[k] = 100000.into();
                j["scene"][k] = 100000.into();
            }
        }),
        ("an unknown kind", |j| j["kind"] = "tiles".into()),
        ("samples past the render's", |j| {
            j["samples"] = serde_json::json!([0, 1024])
        }),
        ("totals of another length", |j| {
            j["payload_bytes"] = (j["payload_bytes"].as_u64().unwrap() + 1).into()
        }),
    ];
    for (what, lie) in lies {
        let mut j = json.clone();
        lie(&mut j);
        damaged(&merge_p0(&forge(&j, &payload)), what);
    }
    // A shard of the old format (JKSHARD1).
    let mut old = good.clone();
    old[7] = b'1';
    let e = merge_p0(&old);
    assert!(
        e.contains("p0.shard") && e.contains("older version") && e.contains("render it again"),
        "{e}"
    );
    // The unchanged shard still merges.
    std::fs::write(d.join("p0.shard"), &good).unwrap();
    run(d, &["merge", "p0.shard", "p1.shard", "--out", "ok.exr"]);
}

/// The embedded test volume, a 16^3-ish OpenVDB grid.
fn fixture(name: &str) -> Vec<u8> {
    bytes(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/fixtures")
            .join(name),
    )
}

/// A flat 4 x 2 Radiance .hdr light probe of RGBE texel `texel`.
fn probe(texel: [u8; 4]) -> Vec<u8> {
    let mut b = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 4\n".to_vec();
    for _ in 0..8 {
        b.extend_from_slice(&texel);
    }
    b
}

/// Writes the inputs of a `direct` render into `dir`: `vol.vdb`, `probe.hdr` and `scene.toml`
/// naming them relative to itself.
fn write_inputs(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("vol.vdb"), fixture("density_zip.vdb")).unwrap();
    std::fs::write(dir.join("probe.hdr"), probe([128, 100, 64, 129])).unwrap();
    std::fs::write(
        dir.join("scene.toml"),
        "volume = \"vol.vdb\"\nenv = \"probe.hdr\"\nintegrator = \"direct\"\n\
         density-scale = 5\nwidth = 4\nheight = 3\nspp = 800\nbackend = \"cpu\"\nquiet = true\n",
    )
    .unwrap();
}

/// A shard records its input files (the volume file, the light probe, the scene file) by size
/// and hash: `host merge` refuses the volume file or the light probe changed or missing, naming
/// the file, the shard and the fix, and refuses shards rendered from different files; shards
/// rendered from the same files at other paths (another machine) merge, and the scene file,
/// which the merge does not read, may change or go.
#[test]
fn changed_missing_and_mixed_input_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (one, two) = (d.join("one"), d.join("two"));
    write_inputs(&one);
    write_inputs(&two);
    let shard = |scene: &Path, range: &str, file: &str| {
        run(
            d,
            &[
                "render",
                scene.to_str().unwrap(),
                "--samples",
                range,
                "--shard",
                file,
            ],
        );
    };
    shard(&one.join("scene.toml"), "0..512", "p0.shard");
    shard(&one.join("scene.toml"), "512..800", "p1.shard");
    // The same files elsewhere.
    shard(&two.join("scene.toml"), "512..800", "q1.shard");
    let merge = ["merge", "p0.shard", "p1.shard", "--out", "m.exr"];
    run(d, &merge);
    run(d, &["merge", "p0.shard", "q1.shard", "--out", "q.exr"]);
    assert!(bytes(&d.join("m.exr")) == bytes(&d.join("q.exr")));
    let changes: [(&str, &str, Vec<u8>); 2] = [
        ("vol.vdb", "volume file", fixture("density_half_zip.vdb")),
        ("probe.hdr", "light probe", probe([128, 100, 64, 130])),
    ];
    for (file, what, changed) in changes {
        let path = one.join(file);
        let original = bytes(&path);
        std::fs::write(&path, &changed).unwrap();
        let e = refused_cleanly(d, &merge);
        assert!(
            e.contains(&format!("{}: the {what}", path.display()))
                && e.contains("changed since shard p0.shard")
                && e.contains("render every shard again"),
            "{file}: {e}"
        );
        std::fs::remove_file(&path).unwrap();
        let e = refused_cleanly(d, &merge);
        assert!(
            e.contains(&path.display().to_string())
                && e.contains("missing")
                && e.contains("p0.shard"),
            "{file} missing: {e}"
        );
        std::fs::write(&path, &original).unwrap();
    }
    run(d, &merge);
    assert!(bytes(&d.join("m.exr")) == bytes(&d.join("q.exr")));
    // The merge reads the scene the shards record (covered by their header hash), not the scene
    // file: an edited or removed scene file changes nothing.
    let scene = one.join("scene.toml");
    let original = bytes(&scene);
    std::fs::write(&scene, b"volume = \"cloud\"\n").unwrap();
    run(d, &merge);
    std::fs::remove_file(&scene).unwrap();
    run(d, &merge);
    assert!(bytes(&d.join("m.exr")) == bytes(&d.join("q.exr")));
    std::fs::write(&scene, original).unwrap();
    // Another volume in one shard of a merge.
    std::fs::write(two.join("vol.vdb"), fixture("density_half_zip.vdb")).unwrap();
    shard(&two.join("scene.toml"), "512..800", "r1.shard");
    let e = refused_cleanly(d, &["merge", "p0.shard", "r1.shard", "--out", "r.exr"]);
    assert!(
        e.contains("r1.shard: rendered from other input files than p0.shard")
            && e.contains("volume file"),
        "{e}"
    );
}

/// `host eval --reference-from` refuses the reference's shards when the volume file changed
/// since they were rendered (naming it, the shard and the fix), and takes them with the same
/// volume at another path.
#[test]
fn eval_reference_from_refuses_a_changed_volume() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("vol.vdb"), fixture("density_zip.vdb")).unwrap();
    std::fs::write(d.join("same.vdb"), fixture("density_zip.vdb")).unwrap();
    let eval = |volume: &str, extra: &[&str]| -> Vec<String> {
        [
            "eval",
            "--backend",
            "cpu",
            "--volume",
            volume,
            "--density-scale",
            "5",
            "--width",
            "12",
            "--height",
            "10",
            "--lookup",
            "stochastic",
            "--spp",
            "8",
            "--reference-spp",
            "520",
            "--estimators",
            "jackknife",
            "--quiet",
        ]
        .iter()
        .chain(extra)
        .map(|s| s.to_string())
        .collect()
    };
    let go = |args: Vec<String>| run(d, &args.iter().map(String::as_str).collect::<Vec<_>>());
    for (file, range) in [("r0.shard", "0..256"), ("r1.shard", "256..520")] {
        go(eval(
            "vol.vdb",
            &[
                "--out-dir",
                "scratch",
                "--reference-shard",
                file,
                "--reference-samples",
                range,
            ],
        ));
    }
    let from = [
        "--out-dir",
        "out",
        "--reference-from",
        "r0.shard",
        "r1.shard",
    ];
    go(eval("vol.vdb", &from));
    go(eval("same.vdb", &from));
    std::fs::write(d.join("vol.vdb"), fixture("density_half_zip.vdb")).unwrap();
    let args = eval("vol.vdb", &from);
    let e = refused_cleanly(d, &args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(
        e.contains(&format!(
            "{}: the volume file changed since shard r0.shard",
            d.join("vol.vdb").display()
        )) && e.contains("render every shard again"),
        "{e}"
    );
}

/// Shards whose scenes spell one value differently (`40` and `40.0`, `1000` and `1e3`) are of
/// one render: they merge into the bytes of one render. Another value is still refused.
#[test]
fn scenes_compare_by_value_not_spelling() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let with = |extra: &[&str]| -> Vec<String> {
        let mut a: Vec<String> = ["render", "--backend", "cpu"].map(String::from).to_vec();
        a.extend(SMALL.iter().map(|s| s.to_string()));
        a.extend(["--spp", "512"].map(String::from));
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let run_s = |v: Vec<String>| {
        let r: Vec<&str> = v.iter().map(String::as_str).collect();
        run(d, &r);
    };
    run_s(with(&[
        "--fov",
        "40",
        "--density-scale",
        "1000",
        "--out",
        "one.exr",
    ]));
    run_s(with(&[
        "--fov",
        "40",
        "--density-scale",
        "1000",
        "--samples",
        "0..256",
        "--shard",
        "a.shard",
    ]));
    run_s(with(&[
        "--fov",
        "40.0",
        "--density-scale",
        "1e3",
        "--samples",
        "256..512",
        "--shard",
        "b.shard",
    ]));
    run(
        d,
        &["merge", "a.shard", "b.shard", "--out", "m.exr", "--quiet"],
    );
    assert_eq!(bytes(&d.join("m.exr")), bytes(&d.join("one.exr")));
    run_s(with(&[
        "--fov",
        "41",
        "--density-scale",
        "1000",
        "--samples",
        "256..512",
        "--shard",
        "c.shard",
    ]));
    let e = refused(d, &["merge", "a.shard", "c.shard", "--out", "n.exr"]);
    assert!(e.contains("fov"), "{e}");
}

/// An evaluation's reference shard records who rendered it (backend and device), as a render's
/// shard does.
#[test]
fn reference_shards_record_their_backend_and_device() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    run(
        d,
        &[
            "eval",
            "--backend",
            "cpu",
            "--resolution",
            "16",
            "--width",
            "4",
            "--height",
            "3",
            "--spp",
            "2",
            "--reference-spp",
            "4",
            "--estimators",
            "jackknife",
            "--quiet",
            "--out-dir",
            "ev",
            "--reference-shard",
            "r.shard",
        ],
    );
    let text = String::from_utf8_lossy(&bytes(&d.join("r.shard"))).to_string();
    assert!(
        text.contains("\"backend\":\"cpu\""),
        "{}",
        &text[..text.len().min(2000)]
    );
    assert!(
        !text.contains("\"device\":\"\""),
        "{}",
        &text[..text.len().min(2000)]
    );
}
