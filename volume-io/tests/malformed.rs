//! Every file in `tests/fixtures/malformed/` (written by `scripts/fixtures/make_malformed.py`, plus the
//! inputs fuzzing found, `fuzz_*`) must fail to load with an error that names the file and
//! contains the words its line of `EXPECTED` lists: never a panic, never a silent success.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use volume_io::VolumeData;
use volume_io::{load_volume_with, LoadOptions};

/// The malformed-file directory.
fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/malformed")
}

/// One line of `EXPECTED`: the grid to request and the words of the error.
struct Expectation {
    grid: Option<String>,
    words: Vec<String>,
}

/// `EXPECTED`, by file name.
fn expectations() -> BTreeMap<String, Expectation> {
    let text = std::fs::read_to_string(dir().join("EXPECTED")).expect("EXPECTED");
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|line| {
            let mut cols = line.split('\t');
            let (name, grid, words) = (cols.next(), cols.next(), cols.next());
            let (Some(name), Some(grid), Some(words)) = (name, grid, words) else {
                panic!("EXPECTED: malformed line {line:?}");
            };
            let grid = (grid != "-").then(|| grid.to_owned());
            let words = words.split(" | ").map(str::to_owned).collect();
            (name.to_owned(), Expectation { grid, words })
        })
        .collect()
}

#[test]
fn every_malformed_file_fails_with_its_expected_error() {
    let expected = expectations();
    let files: Vec<String> = std::fs::read_dir(dir())
        .expect("malformed dir")
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n != "EXPECTED")
        .collect();
    for f in &files {
        assert!(expected.contains_key(f), "{f} has no line in EXPECTED");
    }
    assert!(files.len() >= 40, "only {} malformed files", files.len());
    let mut failures = Vec::new();
    for (name, e) in &expected {
        let path = dir().join(name);
        assert!(path.exists(), "EXPECTED lists {name}, which is missing");
        // Dense and sparse loads must refuse a file with the same words.
        let mut messages = Vec::new();
        for sparse in [false, true] {
            let options = LoadOptions {
                grid: e.grid.as_deref(),
                sparse,
                ..LoadOptions::default()
            };
            let outcome = std::panic::catch_unwind(|| load_volume_with(&path, &options));
            messages.push(match outcome {
                Err(_) => {
                    failures.push(format!("{name} (sparse {sparse}): PANICKED"));
                    continue;
                }
                Ok(Ok(v)) => {
                    failures.push(format!(
                        "{name} (sparse {sparse}): loaded {:?} but must fail",
                        v.volume.dims()
                    ));
                    continue;
                }
                Ok(Err(err)) => format!("{err:#}"),
            });
        }
        let [dense, sparse] = messages.as_slice() else {
            continue;
        };
        if dense != sparse {
            failures.push(format!(
                "{name}: dense and sparse loads disagree:\n  {dense}\n  {sparse}"
            ));
        }
        let msg = sparse.clone();
        let mut missing: Vec<&str> = e
            .words
            .iter()
            .map(String::as_str)
            .filter(|w| !msg.contains(w))
            .collect();
        if !msg.contains(name.as_str()) {
            missing.push("<the file's path>");
        }
        if !missing.is_empty() {
            failures.push(format!("{name}: error lacks {missing:?}: {msg}"));
        }
    }
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
}

#[test]
fn clamp_negative_loads_the_negative_file_with_zeros() {
    for ext in ["vdb", "nvdb"] {
        let path = dir().join(format!("negative_density.{ext}"));
        let options = LoadOptions {
            clamp_negative: true,
            ..LoadOptions::default()
        };
        let loaded = load_volume_with(&path, &options).unwrap_or_else(|e| panic!("{e:#}"));
        assert_eq!(loaded.clamped_negative, 1, "{ext}");
        let v = &loaded.volume;
        let mut all = Vec::new();
        if v.fill([0; 3], v.dims(), &mut all) {
            assert!(all.iter().all(|&x| x >= 0.0));
        }
        assert_eq!(v.density(3, 4, 5), 0.0, "{ext}");
        assert_eq!(v.density(0, 0, 0), 1.0, "{ext}");
        assert_eq!(v.density(7, 7, 7), 1.0, "{ext}");
    }
    // NaN stays an error with the flag: it is no density at all.
    let options = LoadOptions {
        clamp_negative: true,
        ..LoadOptions::default()
    };
    let err = load_volume_with(&dir().join("nan_density.vdb"), &options).unwrap_err();
    assert!(format!("{err:#}").contains("NaN"), "{err:#}");
}
