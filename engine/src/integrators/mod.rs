//! Integrator names (`--integrator`, `--integrators`), read from the integrator table, and
//! point lights (`--light`).

pub mod restir;

use anyhow::{Context, Result};
use shared::integrators::unit::{Family, OwnSettings, UNITS};
use shared::params::Integrator;
use shared::sampling::lights::PointLight;

/// The integrators `--integrator` takes, in enum order: every row of the integrator table
/// (`shared::integrators::unit::UNITS`) but transmittance, which is the render without one.
pub fn integrators() -> impl Iterator<Item = Integrator> {
    UNITS
        .iter()
        .map(|u| u.integrator)
        .filter(|i| i.family() != Family::Transmittance)
}

/// The names of the integrators whose own settings are `settings`, joined by " or " (for
/// messages).
pub fn reading(settings: OwnSettings) -> String {
    let names: Vec<&str> = integrators()
        .filter(|i| i.unit().settings == settings)
        .map(|i| i.unit().name)
        .collect();
    names.join(" or ")
}

/// True for the integrators `host eval --integrators` compares with each other (single
/// scattering from point lights; each lit integrator is evaluated alone).
fn evaluated(i: Integrator) -> bool {
    !i.is_lit()
}

/// Parses an integrator name.
pub fn parse_integrator(s: &str) -> Result<Integrator, String> {
    integrators().find(|i| i.unit().name == s).ok_or_else(|| {
        let names: Vec<&str> = integrators().map(|i| i.unit().name).collect();
        format!(
            "unknown integrator {s:?}; choose one of: {}",
            names.join(", ")
        )
    })
}

/// Name of an integrator ("transmittance" for the render without one).
pub fn integrator_name(i: Integrator) -> &'static str {
    i.unit().name
}

/// Parses `--integrators`: comma-separated names or "all".
pub fn parse_integrator_list(list: &str) -> Result<Vec<(&'static str, Integrator)>> {
    if list == "all" {
        return Ok(integrators()
            .filter(|i| evaluated(*i))
            .map(|i| (i.unit().name, i))
            .collect());
    }
    list.split(',')
        .map(|n| {
            let n = n.trim();
            let found = integrators()
                .find(|i| i.unit().name == n)
                .with_context(|| format!("--integrators: unknown integrator {n:?}"))?;
            anyhow::ensure!(
                evaluated(found),
                "--integrators: {n} is evaluated alone (--integrators {n} --estimators LIST: \
                 one entry per shadow-ray estimator); do not mix it with other integrators"
            );
            Ok((found.unit().name, found))
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
