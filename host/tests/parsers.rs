//! Property tests of every parser of user text (flag values and profile CSV files): arbitrary
//! input never panics, and whatever is accepted satisfies the parser's contract. 2048 cases per
//! property, half arbitrary unicode and half near-valid text built from numbers (huge, NaN, inf,
//! negative), separators and noise, drawn from a fixed ChaCha seed.

use engine::integrators::{parse_integrator, parse_light};
use host::cli::{parse_positive, parse_vec3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use studies::profile::Profile;

/// Strings of numbers (some huge, NaN, inf, negative), separators and noise.
fn near_valid() -> impl Strategy<Value = String> {
    let token = prop_oneof![
        any::<f64>().prop_map(|v| v.to_string()),
        (-5i32..5).prop_map(|v| v.to_string()),
        Just("nan".to_string()),
        Just("-inf".to_string()),
        Just("1e39".to_string()),
        Just(String::new()),
        "[ a-z#.+-]{0,4}",
    ];
    let sep = prop_oneof![Just(","), Just(",,"), Just("\n"), Just(" "), Just("\t")];
    prop::collection::vec((token, sep), 0..24)
        .prop_map(|v| v.into_iter().map(|(t, s)| format!("{t}{s}")).collect())
}

/// Arbitrary unicode or near-valid text.
fn text() -> impl Strategy<Value = String> {
    prop_oneof![any::<String>(), near_valid()]
}

fn run(property: impl Fn(String) -> Result<(), TestCaseError>) {
    let config = Config {
        cases: 2048,
        failure_persistence: None,
        ..Config::default()
    };
    let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[7; 32]);
    let mut runner = TestRunner::new_with_rng(config, rng);
    runner.run(&text(), property).unwrap();
}

#[test]
fn flag_parsers_never_panic_and_accept_only_valid_values() {
    run(|s| {
        if let Ok(v) = parse_vec3(&s) {
            prop_assert!(v.iter().all(|x| x.is_finite()), "{s:?} -> {v:?}");
        }
        if let Ok(l) = parse_light(&s) {
            let p = l.position;
            prop_assert!([p.x, p.y, p.z, l.intensity].iter().all(|x| x.is_finite()));
            prop_assert!(l.intensity >= 0.0, "{s:?}");
        }
        if let Ok(v) = parse_positive(&s) {
            prop_assert!(v.is_finite() && v > 0.0, "{s:?} -> {v}");
        }
        let _ = parse_integrator(&s);
        let _ = engine::estimators::parse(&s);
        Ok(())
    });
}

#[test]
fn profile_csv_parser_never_panics_and_accepts_only_valid_profiles() {
    run(|s| {
        if let Ok(p) = Profile::parse("fuzz.csv", &s) {
            let pts: Vec<(f64, f64)> = p.points().collect();
            prop_assert!(pts.len() >= 2);
            prop_assert!(pts.windows(2).all(|w| w[1].0 > w[0].0), "{s:?}");
            prop_assert!(pts
                .iter()
                .all(|(t, m)| t.is_finite() && m.is_finite() && *m >= 0.0));
            // Evaluating an accepted profile stays defined (no NaN from the parser's output).
            let mid = 0.5 * p.t_min() + 0.5 * p.t_max();
            prop_assert!(!p.mu(mid).is_nan(), "{s:?}");
        }
        Ok(())
    });
}

/// Numeric flag values: hostile extremes and arbitrary numbers, as a user might type them.
fn number() -> impl Strategy<Value = String> {
    prop_oneof![
        any::<f64>().prop_map(|v| v.to_string()),
        any::<i64>().prop_map(|v| v.to_string()),
        (-3i64..70000).prop_map(|v| v.to_string()),
        prop::sample::select(vec![
            "0",
            "-0",
            "-1",
            "1",
            "2",
            "nan",
            "NaN",
            "inf",
            "-inf",
            "1e9",
            "1e30",
            "-1e30",
            "1e308",
            "4294967296",
            "18446744073709551616",
            "0.5",
            "",
            " ",
            "1,2",
            "0x10",
        ])
        .prop_map(str::to_string),
    ]
}

/// Every numeric flag of every subcommand, with the arguments that make it parse on its own.
const NUMERIC_FLAGS: &[(&[&str], &str)] = &[
    (&["render"], "--resolution"),
    (&["render"], "--density-scale"),
    (&["render"], "--brick-size"),
    (&["render"], "--cell-size"),
    (&["render"], "--split-ratio"),
    (&["render"], "--split-occupancy"),
    (&["render"], "--fov"),
    (&["render"], "--n"),
    (&["render"], "--f-delta"),
    (&["render"], "--albedo"),
    (&["render"], "--hg-g"),
    (&["render"], "--exposure"),
    (&["render"], "--env-scale"),
    (&["render"], "--env-rotate"),
    (&["render"], "--rr-depth"),
    (&["render"], "--max-depth"),
    (&["render"], "--width"),
    (&["render"], "--height"),
    (&["render"], "--spp"),
    (&["render"], "--seed"),
    (&["eval"], "--n"),
    (&["eval"], "--f-delta"),
    (&["eval"], "--albedo"),
    (&["eval"], "--exposure"),
    (&["eval"], "--env-scale"),
    (&["eval"], "--env-rotate"),
    (&["eval"], "--rr-depth"),
    (&["eval"], "--max-depth"),
    (&["eval"], "--width"),
    (&["eval"], "--height"),
    (&["eval"], "--spp"),
    (&["eval"], "--reference-spp"),
    (&["eval"], "--seed"),
    (&["eval"], "--bias-scale"),
    (&["eval"], "--std-scale"),
    (&["eval"], "--hg-g"),
    (&["report"], "--resolution"),
    (&["report"], "--n"),
    (&["report"], "--width"),
    (&["report"], "--height"),
    (&["report"], "--spp"),
    (&["report"], "--integrator-spp"),
    (&["report"], "--seed"),
    (&["report"], "--bias-scale"),
    (&["report"], "--std-scale"),
    (&["report"], "--density-scale"),
    (&["report"], "--fov"),
    (&["probe"], "--count"),
    (&["probe"], "--tau"),
    (&["probe"], "--sigma"),
    (&["probe"], "--seed"),
    (&["bench"], "--width"),
    (&["bench"], "--height"),
    (&["bench"], "--spp"),
    (&["bench"], "--n"),
    (&["bench"], "--seed"),
    (&["bench"], "--reps"),
    (&["bench"], "--warmup"),
    (&["study", "normal"], "--tau"),
    (&["study", "normal"], "--sigma"),
    (&["study", "normal"], "--trials"),
    (&["study", "normal"], "--sweep-trials"),
    (&["study", "normal"], "--seed"),
    (&["study", "normal"], "--threads"),
    (&["study", "distributions"], "--tau"),
    (&["study", "distributions"], "--sigma-max"),
    (&["study", "distributions"], "--points"),
    (&["study", "distributions"], "--trials"),
    (&["study", "profile"], "--m"),
    (&["study", "profile"], "--n"),
    (&["study", "profile"], "--trials"),
    (&["study", "profile"], "--bins"),
    (&["study", "table1"], "--total"),
    (&["study", "table1"], "--min-n"),
    (&["study", "table1"], "--trials"),
    (&["study", "histogram"], "--n"),
    (&["study", "histogram"], "--trials"),
    (&["study", "histogram"], "--bins"),
    (&["study", "convergence"], "--max-n"),
    (&["study", "convergence"], "--points"),
    (&["study", "convergence"], "--trials"),
    (&["study", "mis-bias"], "--g"),
    (&["study", "mis-bias"], "--tau-max"),
    (&["study", "mis-bias"], "--sigma-max"),
    (&["study", "mis-bias"], "--nx"),
    (&["study", "mis-bias"], "--ny"),
    (&["study", "mis-bias"], "--trials"),
    (&["study", "mis-bias"], "--limit"),
];

/// The parsed value of the one numeric flag set on `cli`, as f64 (every value a flag accepts).
fn numeric_values(cli: &host::cli::Cli) -> Vec<f64> {
    use host::cli::Command as C;
    use host::cli::StudyCommand as S;
    let Some(command) = &cli.command else {
        return Vec::new();
    };
    match command {
        C::Render(a) => {
            let s = &a.scene;
            let mut v = vec![s.brick_size as f64, s.view.fov as f64];
            v.extend(s.resolution.map(f64::from));
            v.extend(s.density_scale.map(f64::from));
            v.extend(s.cell_size.map(f64::from));
            v.extend(s.split_ratio.map(f64::from));
            v.extend(s.split_occupancy.map(f64::from));
            v.extend([a.n, a.width, a.height, a.spp].map(f64::from));
            v.extend([a.f_delta, a.hg_g, a.exposure, a.env_scale, a.env_rotate].map(f64::from));
            v.extend(a.albedo.map(f64::from));
            v.extend([a.rr_depth, a.max_depth].map(f64::from));
            v
        }
        C::View(a) => {
            let mut v: Vec<f64> = [a.max_spp, a.scale].map(f64::from).to_vec();
            v.extend(a.frame_spp.map(f64::from));
            v.push(f64::from(a.preview_ms));
            v
        }
        C::Eval(a) => {
            let mut v: Vec<f64> = [a.n, a.width, a.height, a.spp].map(f64::from).to_vec();
            v.extend(a.reference_spp.map(f64::from));
            v.extend([a.f_delta, a.albedo, a.exposure, a.bias_scale, a.std_scale].map(f64::from));
            v.extend([a.env_scale, a.env_rotate].map(f64::from));
            v.extend([a.rr_depth, a.max_depth].map(f64::from));
            v.extend(a.hg_g.map(f64::from));
            v
        }
        C::Report(a) => a
            .resolution
            .into_iter()
            .chain([a.n, a.width, a.height, a.spp, a.integrator_spp])
            .map(f64::from)
            .chain([a.bias_scale, a.std_scale, a.view.fov].map(f64::from))
            .chain(a.density_scale.map(f64::from))
            .collect(),
        C::Probe(a) => vec![a.count as f64, a.tau as f64, a.sigma as f64],
        C::Bench(a) => [a.width, a.height, a.spp, a.n, a.reps, a.warmup]
            .map(f64::from)
            .to_vec(),
        // `host merge` has no numeric flags.
        C::Merge(_) => Vec::new(),
        C::Study(s) => {
            let mut v: Vec<f64> = s.threads.iter().map(|&t| t as f64).collect();
            v.extend(match &s.command {
                S::Normal(a) => vec![a.tau, a.sigma, a.trials as f64, a.sweep_trials as f64],
                S::Distributions(a) => vec![a.tau, a.sigma_max, a.points as f64, a.trials as f64],
                S::Profile(a) => [a.m, a.n, a.bins].map(|x| x as f64).to_vec(),
                S::Table1(a) => vec![a.total as f64, a.min_n as f64, a.trials as f64],
                S::Histogram(a) => {
                    a.n.iter()
                        .map(|&n| n as f64)
                        .chain([a.bins as f64])
                        .collect()
                }
                S::Convergence(a) => vec![a.max_n as f64, a.points as f64, a.trials as f64],
                S::MisBias(a) => {
                    let mut v: Vec<f64> = a.g.iter().map(|&g| g as f64).collect();
                    v.extend([a.tau_max, a.sigma_max, a.limit, a.nx as f64, a.ny as f64]);
                    v
                }
            });
            v
        }
    }
}

#[test]
fn every_numeric_flag_of_every_subcommand_parses_or_errors_cleanly() {
    use clap::Parser;
    let config = Config {
        cases: 64,
        failure_persistence: None,
        ..Config::default()
    };
    for &(command, flag) in NUMERIC_FLAGS {
        let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[11; 32]);
        let mut runner = TestRunner::new_with_rng(config.clone(), rng);
        let result = runner.run(&number(), |value| {
            let mut argv = vec!["host"];
            argv.extend(command);
            argv.extend([flag, value.as_str()]);
            match host::cli::Cli::try_parse_from(&argv) {
                Ok(cli) => {
                    let values = numeric_values(&cli);
                    // Whatever a flag accepts is finite: no NaN or infinity reaches a run.
                    prop_assert!(values.iter().all(|v| v.is_finite()), "{argv:?}: {values:?}");
                }
                Err(e) => {
                    let text = e.to_string();
                    prop_assert!(text.starts_with("error: "), "{argv:?}: {text}");
                    prop_assert!(text.contains(flag), "{argv:?} does not name {flag}: {text}");
                }
            }
            Ok(())
        });
        result.unwrap_or_else(|e| panic!("{command:?} {flag}: {e}"));
    }
}

/// Paths that are not UTF-8 are refused naming the flag and the fix (clap's own message named
/// neither), and `--samples` with a negative start gets the flag's own message.
#[test]
fn non_utf8_paths_and_negative_samples_name_their_flag() {
    use std::os::unix::ffi::OsStrExt;
    let bad = std::ffi::OsStr::from_bytes(b"v\xff.vdb");
    for (args, flag) in [
        (vec!["render", "--volume"], "--volume"),
        (vec!["render", "--integrator", "direct", "--env"], "--env"),
        (vec!["eval", "--volume"], "--volume"),
        (vec!["report", "--volumes"], "--volumes"),
        (vec!["study", "profile", "--profile"], "--profile"),
    ] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_host"))
            .args(&args)
            .arg(bad)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains(flag) && err.contains("UTF-8"),
            "{args:?}: {err}"
        );
    }
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_host"))
        .args(["render", "--samples", "-256..0", "--shard", "x.shard"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("--samples") && err.contains("not a sample index"),
        "{err}"
    );
}
