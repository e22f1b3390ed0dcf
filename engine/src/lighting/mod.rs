//! The lights of the light-transport integrators, prepared on the host: an environment map
//! (`--env FILE` or the embedded `--env sky`), a sun (`--sun`), point lights (`--light`), the
//! RGB albedo, and the pmf over the three kinds of light.

pub mod env;
pub mod power;
pub mod random;
pub mod sky;

use anyhow::{ensure, Context, Result};
use env::EnvMap;
use shared::geometry::V3;
use shared::rgb::Rgb;
use shared::sampling::env::EnvDesc;
use shared::sampling::lighting::{Lighting, Scene};
use shared::sampling::lights::PointLight;
use shared::sampling::sun::Sun;
use std::path::PathBuf;

/// Angular radius of the sun as seen from the earth, in degrees (the default of `--sun`).
pub const SUN_RADIUS_DEG: f32 = 0.2666;
/// Direction toward the default sun (about 35 degrees above the horizon, in front of the volume
/// and to the left as the default camera sees it): unnormalized.
pub const DEFAULT_SUN: [f32; 3] = [0.7, 0.6, -0.45];
/// Largest radiance (light-probe texels times `--env-scale`, the sun's disk) and point-light
/// intensity accepted. The integrators multiply a light's value by transmittance, albedo, phase
/// and geometry factors and sum each pixel's samples and their squares in f32; at 1e12 the
/// squares of 2^18 samples keep a headroom of 10^9 for those factors. Lights inside the medium
/// can still exceed it (1 / r^2 near a point light): a pixel that is not finite is an error.
pub const MAX_EMISSION: f64 = 1e12;

/// Refuses light `what` whose radiance or intensity `value` is above [`MAX_EMISSION`].
pub fn check_emission(what: &str, value: f64, fix: &str) -> Result<()> {
    ensure!(
        value <= MAX_EMISSION,
        "{what}: {value:.3e} is above {MAX_EMISSION:.0e}, the largest radiance or intensity the \
         renderer accepts (the integrators' f32 sums of squared radiance must stay finite); {fix}"
    );
    Ok(())
}

/// Share of the light pmf spread uniformly over the kinds present (so none is starved).
const UNIFORM_SHARE: f64 = 0.1;
/// Colour of the sun (linear Rec. 709, luminance 1): a slightly warm white.
const SUN_COLOUR: [f64; 3] = [1.0, 0.93, 0.85];

/// Where the environment light comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum EnvSource {
    /// No environment light (black background).
    None,
    /// The embedded Preetham daylight sky, with its sun unless `--sun` says otherwise.
    Sky,
    /// An equirectangular `.exr` or `.hdr` light probe.
    File(PathBuf),
    /// One linear RGB radiance in every direction (`--env constant:R,G,B`; Mitsuba's `constant`
    /// emitter, Blender's world colour), sampled uniformly over the sphere.
    Constant([f32; 3]),
}

impl EnvSource {
    /// The `--env` value that gives this source back (`sky`, `none`, `constant:R,G,B` or the
    /// probe's path).
    pub fn spelling(&self) -> String {
        match self {
            EnvSource::None => "none".into(),
            EnvSource::Sky => "sky".into(),
            EnvSource::File(p) => p.display().to_string(),
            EnvSource::Constant([r, g, b]) => format!("constant:{r},{g},{b}"),
        }
    }

    /// Parses an `--env` value: `sky`, `none`, `constant:V` or `constant:R,G,B` (finite,
    /// >= 0), or a light probe's path.
    pub fn parse(s: &str) -> Result<Self, String> {
        if let Some(rest) = s.strip_prefix("constant:") {
            let v: Vec<f32> = rest
                .split(',')
                .map(|x| x.trim().parse::<f32>())
                .collect::<Result<_, _>>()
                .map_err(|_| format!("constant:{rest}: expected constant:V or constant:R,G,B"))?;
            let rgb = match v.as_slice() {
                [a] => [*a; 3],
                [r, g, b] => [*r, *g, *b],
                _ => {
                    return Err(format!(
                        "constant:{rest}: expected one value or three (R,G,B)"
                    ))
                }
            };
            if rgb.iter().any(|x| !x.is_finite() || *x < 0.0) {
                return Err(format!(
                    "constant:{rest}: each radiance must be finite and >= 0"
                ));
            }
            return Ok(EnvSource::Constant(rgb));
        }
        match s {
            "sky" => Ok(EnvSource::Sky),
            "none" => Ok(EnvSource::None),
            "" => Err("expected sky, none, constant:R,G,B or a .exr / .hdr file".into()),
            path => Ok(EnvSource::File(path.into())),
        }
    }
}

/// `--sun x,y,z[,intensity[,angular_radius_deg]]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunSpec {
    /// Direction toward the sun (any length > 0).
    pub dir: [f32; 3],
    /// Irradiance perpendicular to the sun (None: from the sky, or 1 without one).
    pub irradiance: Option<f32>,
    /// Angular radius in degrees (0: a delta direction).
    pub radius_deg: f32,
}

/// The light options of a `direct` render.
#[derive(Debug, Clone)]
pub struct LightingOptions {
    pub env: EnvSource,
    /// Multiplies the map's radiance.
    pub env_scale: f32,
    /// Rotation of the map about +y, in degrees.
    pub env_rotate_deg: f32,
    pub sun: Option<SunSpec>,
    pub points: Vec<PointLight>,
    pub albedo: [f32; 3],
}

/// The lights as the backends upload them: the `Lighting` block, the point lights and the map.
#[derive(Debug, Clone)]
pub struct SceneLights {
    pub lighting: Lighting,
    pub points: Vec<PointLight>,
    /// The map's data buffer (one 0 without a map: GPU buffers may not be empty).
    pub env: Vec<f32>,
    /// The sun's moment shadow map (one 0 with shadow rays), set by [`crate::render::shadow_map`].
    pub shadow_map: Vec<u32>,
}

impl SceneLights {
    /// Point lights only (the single-scattering integrators and transmittance renders).
    pub fn points_only(points: &[PointLight]) -> Self {
        let mut points = points.to_vec();
        power::build_power_table(&mut points);
        SceneLights {
            lighting: Lighting::default(),
            points,
            env: vec![0.0],
            shadow_map: vec![0],
        }
    }

    /// `restir`: the point lights leave the pmf over light kinds (they are resampled on their
    /// own), the sun's and the map's shares are renormalised.
    pub fn resample_points(&mut self) {
        let l = &mut self.lighting;
        let rest = l.p_sun + l.p_env;
        if rest > 0.0 {
            l.p_sun /= rest;
            l.p_env /= rest;
        }
        l.p_points = 0.0;
    }

    /// The view the `shared` integrators take.
    pub fn view(&self) -> Scene<'_> {
        Scene {
            lighting: &self.lighting,
            points: &self.points,
            point_count: self.points.len() as u32,
            env: &self.env,
            shadow_map: &self.shadow_map,
        }
    }
}

/// Unit vector of `d` in f64, refusing the zero vector (`what` names the flag).
fn unit(d: [f32; 3], what: &str) -> Result<[f64; 3]> {
    let d = d.map(|v| v as f64);
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    ensure!(
        len > 0.0 && len.is_finite(),
        "{what}: the direction must be a finite, non-zero vector"
    );
    Ok(d.map(|v| v / len))
}

/// The sun of `spec` with irradiance `e` (luminance): radiance E / solid angle of the disk.
fn make_sun(dir: [f64; 3], e: f64, radius_deg: f64) -> Sun {
    let one_minus_cos = 1.0 - radius_deg.to_radians().cos();
    // 1 - cos in f64, then rounded: tiny disks keep their size.
    let omega = 2.0 * std::f64::consts::PI * one_minus_cos;
    let per = if one_minus_cos > 0.0 { e / omega } else { e };
    Sun {
        dir: V3::new(dir[0] as f32, dir[1] as f32, dir[2] as f32),
        one_minus_cos: one_minus_cos as f32,
        radiance: Rgb::new(
            (SUN_COLOUR[0] * per / lum(SUN_COLOUR)) as f32,
            (SUN_COLOUR[1] * per / lum(SUN_COLOUR)) as f32,
            (SUN_COLOUR[2] * per / lum(SUN_COLOUR)) as f32,
        ),
        present: 1,
    }
}

/// Rec. 709 luminance.
fn lum(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Builds the lights of a `direct` render; `center` and `radius` bound the volume (for the
/// point lights' share of the pmf).
pub fn build(opts: &LightingOptions, center: [f64; 3], radius: f64) -> Result<SceneLights> {
    check_options(opts)?;
    let sun_spec = sun_spec_of(opts);
    let sun_dir = match &sun_spec {
        Some(s) => Some(unit(s.dir, "--sun")?),
        None => None,
    };
    let (map, sun_e) = env_map_and_sun(opts, sun_spec, sun_dir)?;
    let mut lighting = Lighting {
        albedo: Rgb::new(opts.albedo[0], opts.albedo[1], opts.albedo[2]),
        ..Default::default()
    };
    let (env_data, w_env) = match map {
        Some(map) => install_env(&mut lighting, map, opts)?,
        None => (vec![0.0f32], 0.0),
    };
    let w_sun = match (sun_spec, sun_dir, sun_e) {
        (Some(spec), Some(dir), Some(e)) => install_sun(&mut lighting, spec, dir, e)?,
        _ => 0.0,
    };
    for (k, l) in opts.points.iter().enumerate() {
        check_emission(
            &format!("point light {} (--light or --lights random)", k + 1),
            l.intensity as f64,
            "lower its intensity",
        )?;
    }
    let w_points = points_weight(&opts.points, center, radius);
    let p = kind_pmf([w_sun, w_env, w_points]);
    lighting.p_sun = p[0] as f32;
    lighting.p_env = p[1] as f32;
    lighting.p_points = p[2] as f32;
    let mut points = opts.points.clone();
    power::build_power_table(&mut points);
    Ok(SceneLights {
        lighting,
        points,
        env: env_data,
        shadow_map: vec![0],
    })
}

/// Refuses too many point lights and non-finite environment settings.
fn check_options(opts: &LightingOptions) -> Result<()> {
    ensure!(
        opts.points.len() <= random::MAX_POINT_LIGHTS,
        "at most {} point lights (got {})",
        random::MAX_POINT_LIGHTS,
        opts.points.len()
    );
    ensure!(
        opts.env_scale.is_finite() && opts.env_scale >= 0.0,
        "--env-scale must be finite and >= 0"
    );
    ensure!(
        opts.env_rotate_deg.is_finite(),
        "--env-rotate must be a finite angle in degrees"
    );
    Ok(())
}

/// `--sun`, or the sky's default sun.
fn sun_spec_of(opts: &LightingOptions) -> Option<SunSpec> {
    match (&opts.sun, &opts.env) {
        (Some(s), _) => Some(*s),
        (None, EnvSource::Sky) => Some(SunSpec {
            dir: DEFAULT_SUN,
            irradiance: None,
            radius_deg: SUN_RADIUS_DEG,
        }),
        (None, _) => None,
    }
}

/// The environment map (a file or the Preetham sky for the sun's direction) and the sun's
/// irradiance (the sky's own unless `--sun` gives one).
fn env_map_and_sun(
    opts: &LightingOptions,
    sun_spec: Option<SunSpec>,
    sun_dir: Option<[f64; 3]>,
) -> Result<(Option<EnvMap>, Option<f64>)> {
    Ok(match &opts.env {
        EnvSource::None => (None, sun_spec.map(|s| s.irradiance.unwrap_or(1.0) as f64)),
        EnvSource::File(p) => (
            Some(EnvMap::load(p)?),
            sun_spec.map(|s| s.irradiance.unwrap_or(1.0) as f64),
        ),
        EnvSource::Constant(rgb) => (
            Some(EnvMap::uniform(*rgb)),
            sun_spec.map(|s| s.irradiance.unwrap_or(1.0) as f64),
        ),
        EnvSource::Sky => {
            let dir = sun_dir.unwrap_or([0.0, 1.0, 0.0]);
            if dir[1] < 1f64.to_radians().sin() {
                tracing::warn!(
                    "--sun is less than 1 degree above the horizon: the Preetham sky is defined \
                     for a sun above it, so the sky is drawn for a sun 1 degree up (the sun \
                     itself stays where --sun puts it)"
                );
            }
            let given = sun_spec.and_then(|s| s.irradiance).map(|e| e as f64);
            let (map, e) = sky::preetham(dir, given);
            (Some(map), Some(e))
        }
    })
}

/// Scales, checks and rotates the environment map into `lighting`; returns its texels (with the
/// sampling tables) and its integral, the environment's weight in the pmf over light kinds.
fn install_env(
    lighting: &mut Lighting,
    map: EnvMap,
    opts: &LightingOptions,
) -> Result<(Vec<f32>, f64)> {
    let brightest = map.texels.iter().flatten().fold(0.0f32, |a, v| a.max(*v));
    let what = match &opts.env {
        EnvSource::File(p) => format!("--env {}", p.display()),
        EnvSource::Constant(_) => format!("--env {}", opts.env.spelling()),
        _ => "the sky".to_owned(),
    };
    check_emission(
        &format!("{what}: its brightest texel times --env-scale"),
        brightest as f64 * opts.env_scale as f64,
        &format!(
            "use --env-scale {:.3e} or less",
            MAX_EMISSION / (brightest as f64).max(f64::MIN_POSITIVE)
        ),
    )?;
    let (width, height) = (map.width, map.height);
    let (data, integral) = map.data(opts.env_scale).with_context(|| what.clone())?;
    ensure!(
        integral.is_finite() && data.iter().all(|v| v.is_finite()),
        "--env-scale {}: the scaled light probe's radiance overflows f32 (brightest texel \
         {brightest:.3e}); use a smaller --env-scale",
        opts.env_scale,
    );
    let rot = (opts.env_rotate_deg as f64).to_radians();
    lighting.env = EnvDesc {
        width,
        height,
        cos_rotation: rot.cos() as f32,
        sin_rotation: rot.sin() as f32,
    };
    Ok((data, integral))
}

/// Checks and installs the sun of irradiance `e` toward `dir` into `lighting`; returns its
/// weight in the pmf over light kinds.
fn install_sun(lighting: &mut Lighting, spec: SunSpec, dir: [f64; 3], e: f64) -> Result<f64> {
    ensure!(
        e.is_finite() && e >= 0.0,
        "--sun: the intensity must be finite and >= 0"
    );
    ensure!(
        spec.radius_deg.is_finite() && (0.0..=45.0).contains(&spec.radius_deg),
        "--sun: the angular radius must be in [0, 45] degrees"
    );
    lighting.sun = make_sun(dir, e, spec.radius_deg as f64);
    let r = lighting.sun.radiance;
    ensure!(
        [r.r, r.g, r.b].iter().all(|v| v.is_finite()),
        "--sun: intensity {e:.3e} over a disk of {} degrees is a radiance beyond f32; lower \
         the intensity or widen the disk",
        spec.radius_deg
    );
    check_emission(
        &format!(
            "--sun: the radiance of intensity {e:.3e} over a disk of {} degrees",
            spec.radius_deg
        ),
        r.r.max(r.g).max(r.b) as f64,
        "lower the intensity or widen the disk",
    )?;
    Ok(e)
}

/// The point lights' weight in the pmf over light kinds: intensity over squared distance to the
/// volume's center, no closer than half its radius.
fn points_weight(points: &[PointLight], center: [f64; 3], radius: f64) -> f64 {
    points
        .iter()
        .map(|l| {
            let p = [l.position.x, l.position.y, l.position.z].map(|v| v as f64);
            let d2: f64 = (0..3).map(|a| (p[a] - center[a]).powi(2)).sum();
            l.intensity as f64 / d2.max(0.25 * radius * radius)
        })
        .sum()
}

/// The pmf over light kinds (sun, environment, points) from their weights, with a uniform share
/// among the kinds present.
fn kind_pmf(weights: [f64; 3]) -> [f64; 3] {
    let present = weights.iter().filter(|w| **w > 0.0).count();
    let total: f64 = weights.iter().sum();
    weights.map(|w| {
        if w > 0.0 {
            (1.0 - UNIFORM_SHARE) * w / total + UNIFORM_SHARE / present as f64
        } else {
            0.0
        }
    })
}
