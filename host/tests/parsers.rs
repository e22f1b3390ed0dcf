//! Property tests of every parser of user text (flag values and profile CSV files): arbitrary
//! input never panics, and whatever is accepted satisfies the parser's contract. 2048 cases per
//! property, half arbitrary unicode and half near-valid text built from numbers (huge, NaN, inf,
//! negative), separators and noise, drawn from a fixed ChaCha seed.

use host::cli::{parse_integrator, parse_light, parse_positive, parse_vec3};
use host::study::profile::Profile;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

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
        let _ = host::estimators::parse(&s);
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
