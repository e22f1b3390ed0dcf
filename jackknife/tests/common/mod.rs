//! Helpers shared by the jackknife crate's statistical tests.

use jackknife::{HashRng, Importance, Jitter, Lookup, Ray, VolumeView};
use shared::estimators::optical_depth::{estimate_pair, prepare};
use shared::estimators::tracking::ratio_tracking;

/// Mean and standard error of `xs`.
pub fn mean_se(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let m = xs.iter().sum::<f64>() / n;
    let v = xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m, (v / n).sqrt())
}

/// Deepest optical depth at which ratio tracking's mean is z-tested. Its relative variance is
/// exp(integral of mu^2 / mu_max) - 1 <= exp(tau) - 1 (mu <= mu_max): at tau = 6 at most 402, so
/// the mean of a few thousand estimates is near normal; deeper the estimates are so heavy-tailed
/// that the sample's standard error is no longer a standard error (tau 13.5, 4000 trials: z of
/// -7.7 for one seed, while 400,000 trials give |z| < 1.2 for each of four seeds).
pub const RATIO_Z_MAX_TAU: f32 = 6.0;

/// Asserts that on `ray` over [t0, t1], whose exact optical depth is `tau`, the mean of `trials`
/// optical-depth estimates (Alg. 2 + Alg. 1, N = 10, the pair's mean per trial: x0 and x1 share
/// the ray's traversal) matches tau and, where tau <= [`RATIO_Z_MAX_TAU`], ratio tracking's mean
/// matches exp(-tau), both at |z| < 4.5; no estimate may be capped (ratio tracking runs on every
/// ray). Sample k uses `HashRng::for_sample(ray_id, k, seed)`. Returns whether ratio tracking's
/// mean was tested.
#[allow(clippy::too_many_arguments)]
pub fn assert_unbiased_on_ray(
    vol: &VolumeView,
    ray: &Ray,
    t0: f32,
    t1: f32,
    tau: f32,
    trials: u32,
    ray_id: u32,
    seed: u32,
    what: &str,
) -> bool {
    let prep = prepare(vol, ray, t0, t1, Importance::VarianceAware);
    let (mut xs, mut ts) = (Vec::new(), Vec::new());
    for k in 0..trials {
        let rng = HashRng::for_sample(ray_id, k, seed);
        let (e, _) = estimate_pair(
            vol,
            ray,
            &prep,
            10,
            Importance::VarianceAware,
            Jitter::Stratified,
            Lookup::Nearest,
            rng,
        );
        assert!(!e.capped, "{what}: capped estimate");
        xs.push(0.5 * (e.x0 as f64 + e.x1 as f64));
        let (t, tally, _) = ratio_tracking(vol, ray, t0, t1, Lookup::Nearest, false, rng);
        assert_eq!(tally.capped, 0, "{what}: capped ratio tracking");
        ts.push(t as f64);
    }
    let (m, se) = mean_se(&xs);
    let z = (m - tau as f64) / se.max(1e-9 * tau as f64);
    assert!(z.abs() < 4.5, "{what}: mean X {m} vs tau {tau} (z {z})");
    if tau > RATIO_Z_MAX_TAU {
        return false;
    }
    let (m, se) = mean_se(&ts);
    let exact = (-(tau as f64)).exp();
    let z = (m - exact) / se.max(1e-9);
    assert!(z.abs() < 4.5, "{what}: mean T {m} vs {exact} (z {z})");
    true
}
