//! `host study` on the command line: every study writes its JSON and a plot (the studies
//! themselves: studies/tests/studies.rs).

use std::process::Command;

#[test]
fn every_study_writes_json_and_a_plot() {
    let dir = tempfile::tempdir().unwrap();
    let studies: [&[&str]; 7] = [
        &["normal", "--trials", "20000", "--sweep-trials", "2000"],
        &["distributions", "--trials", "2000", "--points", "3"],
        &["profile", "--trials", "5000", "--m", "3", "--n", "4"],
        &["table1", "--trials", "5000", "--profile", "cloud"],
        &[
            "histogram",
            "--trials",
            "5000",
            "--n",
            "5,10",
            "--profile",
            "sparse",
        ],
        &[
            "convergence",
            "--trials",
            "500",
            "--max-n",
            "50",
            "--points",
            "5",
        ],
        &["mis-bias", "--trials", "200", "--nx", "8", "--ny", "6"],
    ];
    for (i, args) in studies.iter().enumerate() {
        let ext = if i % 2 == 0 { "png" } else { "svg" };
        let (json, plot) = (
            dir.path().join(format!("{i}.json")),
            dir.path().join(format!("{i}.{ext}")),
        );
        let out = Command::new(env!("CARGO_BIN_EXE_host"))
            .arg("study")
            .args(*args)
            .args([
                "--quiet",
                "--threads",
                "2",
                "--json",
                json.to_str().unwrap(),
                "--plot",
                plot.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let value: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert!(!value.is_null());
        let bytes = std::fs::read(&plot).unwrap();
        if ext == "png" {
            let img = image::load_from_memory(&bytes).unwrap();
            assert!(img.width() > 300 && img.height() > 200);
        } else {
            assert!(String::from_utf8(bytes).unwrap().contains("<svg"));
        }
    }
}
