//! Integrator names (`--integrator`, `--integrators`) and point lights (`--light`).

use anyhow::{Context, Result};
use shared::params::Integrator;
use shared::sampling::lights::PointLight;

/// Integrator names of `--integrator`.
pub const INTEGRATORS: &[(&str, Integrator)] = {
    use Integrator as I;
    &[
        ("free-flight", I::FreeFlight),
        ("equiangular", I::Equiangular),
        ("mis-jackknife", I::MisJackknife),
        ("mis-naive", I::MisNaive),
        ("combined-jackknife", I::CombinedJackknife),
        ("combined-naive", I::CombinedNaive),
        ("miller", I::Miller),
        ("mis-power", I::MisPowerJackknife),
        ("direct", I::Direct),
        ("path", I::Path),
        ("restir", I::Restir),
    ]
};

/// True for the integrators `host eval --integrators` compares (single scattering from point
/// lights; `direct` renders are not evaluated there yet).
fn evaluated(i: Integrator) -> bool {
    !i.is_lit()
}

/// Parses an integrator name.
pub fn parse_integrator(s: &str) -> Result<Integrator, String> {
    INTEGRATORS
        .iter()
        .find(|(n, _)| *n == s)
        .map(|(_, i)| *i)
        .ok_or_else(|| {
            let names: Vec<&str> = INTEGRATORS.iter().map(|(n, _)| *n).collect();
            format!(
                "unknown integrator {s:?}; choose one of: {}",
                names.join(", ")
            )
        })
}

/// Name of an integrator.
pub fn integrator_name(i: Integrator) -> &'static str {
    INTEGRATORS
        .iter()
        .find(|(_, x)| *x == i)
        .map(|(n, _)| *n)
        .unwrap_or("transmittance")
}

/// Parses `--integrators`: comma-separated names or "all".
pub fn parse_integrator_list(list: &str) -> Result<Vec<(&'static str, Integrator)>> {
    if list == "all" {
        return Ok(INTEGRATORS
            .iter()
            .copied()
            .filter(|(_, i)| evaluated(*i))
            .collect());
    }
    list.split(',')
        .map(|n| {
            let n = n.trim();
            let found = INTEGRATORS
                .iter()
                .find(|(name, _)| *name == n)
                .copied()
                .with_context(|| format!("--integrators: unknown integrator {n:?}"))?;
            anyhow::ensure!(
                evaluated(found.1),
                "--integrators: {n} is evaluated alone (--integrators {n} --estimators LIST: \
                 one entry per shadow-ray estimator); do not mix it with other integrators"
            );
            Ok(found)
        })
        .collect()
}

/// The comma-separated numbers of a flag value such as "x,y,z,intensity".
pub fn parse_f32_list(s: &str) -> Result<Vec<f32>, String> {
    s.split(',')
        .map(|p| {
            p.trim()
                .parse::<f32>()
                .map_err(|_| format!("{p:?} is not a number in {s:?}"))
        })
        .collect()
}

/// Parses "x,y,z,intensity" into a point light.
pub fn parse_light(s: &str) -> Result<PointLight, String> {
    let v = parse_f32_list(s)?;
    if v.len() != 4 || v.iter().any(|x| !x.is_finite()) || v[3] < 0.0 {
        return Err(format!(
            "expected x,y,z,intensity (finite, intensity >= 0), got {s:?}"
        ));
    }
    Ok(PointLight::new(
        shared::geometry::V3::new(v[0], v[1], v[2]),
        v[3],
    ))
}
