//! The lights of a render: `--light` or default point lights for the single-scattering
//! integrators; the environment, the sun and point lights of `direct`, `path` and `restir`.

use super::options::RenderOptions;
use crate::volume::VolumeData;
use anyhow::Result;
use shared::sampling::lights::PointLight;

/// The lights of `--light`, or two default lights inside the volume's occupied bounds.
pub(super) fn scene_lights(args: &RenderOptions, vol: &dyn VolumeData) -> Result<Vec<PointLight>> {
    anyhow::ensure!(
        args.lighting.hg_g.is_finite() && args.lighting.hg_g > -1.0 && args.lighting.hg_g < 1.0,
        "--hg-g must be in (-1, 1) (got {})",
        args.lighting.hg_g
    );
    let [r, g, b] = args.lighting.albedo;
    anyhow::ensure!(
        r == g && g == b,
        "--albedo {r},{g},{b}: the single-scattering integrators are scalar; give one value, or use \
         --integrator direct for an RGB albedo"
    );
    lights_or_default(&args.lighting.lights, r, args.exposure.gain, vol)
}

/// Validates light flags; `--light` values or two default lights inside the occupied bounds.
pub fn lights_or_default(
    lights: &[PointLight],
    albedo: f32,
    exposure: f32,
    vol: &dyn VolumeData,
) -> Result<Vec<PointLight>> {
    anyhow::ensure!(
        albedo.is_finite() && (0.0..=1.0).contains(&albedo),
        "--albedo must be in [0, 1] (got {albedo})"
    );
    anyhow::ensure!(
        exposure.is_finite() && exposure > 0.0,
        "--exposure must be > 0 (got {exposure})"
    );
    anyhow::ensure!(
        lights.len() <= shared::sampling::lights::MAX_LIGHTS as usize,
        "--light: at most {} lights (got {})",
        shared::sampling::lights::MAX_LIGHTS,
        lights.len()
    );
    for (k, l) in lights.iter().enumerate() {
        crate::lighting::check_emission(
            &format!("--light {}: the intensity", k + 1),
            l.intensity as f64,
            "lower it",
        )?;
    }
    if !lights.is_empty() {
        return Ok(lights.to_vec());
    }
    let (lo, hi) = crate::scene::camera::occupied_world_bounds(vol);
    let at = |f: [f64; 3]| {
        shared::geometry::V3::new(
            (lo[0] + f[0] * (hi[0] - lo[0])) as f32,
            (lo[1] + f[1] * (hi[1] - lo[1])) as f32,
            (lo[2] + f[2] * (hi[2] - lo[2])) as f32,
        )
    };
    let size = ((hi[0] - lo[0]) + (hi[1] - lo[1]) + (hi[2] - lo[2])) as f32 / 3.0;
    // Intensity scales with size^2 so images look alike at any world scale.
    Ok(vec![
        PointLight::new(at([0.35, 0.55, 0.45]), 1.5 * size * size),
        PointLight::new(at([0.68, 0.4, 0.55]), 0.8 * size * size),
    ])
}

/// The lights of a `direct` render: `--env` (default: the sky unless only --sun or --light are
/// given), `--sun`, `--light` (no default point lights).
pub fn direct_lights(
    args: &RenderOptions,
    vol: &dyn VolumeData,
) -> Result<crate::lighting::SceneLights> {
    use crate::lighting::{EnvSource, LightingOptions};
    anyhow::ensure!(
        args.lighting.hg_g.is_finite() && args.lighting.hg_g > -1.0 && args.lighting.hg_g < 1.0,
        "--hg-g must be in (-1, 1) (got {})",
        args.lighting.hg_g
    );
    let (lo, hi) = crate::scene::camera::occupied_world_bounds(vol);
    let mut points = args.lighting.lights.clone();
    if let Some(spec) = args.lighting.random_lights {
        points.extend(crate::lighting::random::random_lights(spec, lo, hi)?);
    }
    let env = match &args.lighting.env {
        Some(e) => e.clone(),
        None if args.lighting.sun.is_some() || !points.is_empty() => EnvSource::None,
        None => EnvSource::Sky,
    };
    let center = [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]));
    let radius = 0.5 * (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
    crate::lighting::build(
        &LightingOptions {
            env,
            env_scale: args.lighting.env_scale,
            env_rotate_deg: args.lighting.env_rotate,
            sun: args.lighting.sun,
            points,
            albedo: args.lighting.albedo,
        },
        center,
        radius,
    )
}
