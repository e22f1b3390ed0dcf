//! `host eval --integrators direct|path --estimators LIST`: the `direct` (or `path`) integrator
//! with each shadow-ray estimator (entries `direct/<estimator>`, `path/<estimator>`) against a
//! reference made with ratio-tracking shadow rays (unbiased) at `--reference-spp`, as in the
//! paper's Fig. 1.
//!
//! Statistics are of each pixel's luminance: SMAPE (epsilon 0.01), mean bias over the image with
//! its standard error from the per-pixel variances of both images, mean per-sample standard
//! deviation, mean radiance, time and shadow-ray lookups.

use crate::eval::{EvalHeader, EvalSetup};
use crate::lighting::SceneLights;
use crate::output::{write_exr_rgb, write_png_rgb_exposed};
use anyhow::{Context, Result};
use shared::kernels::render::PixelOut;
use shared::params::{Estimator, Integrator};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// SMAPE's epsilon (Fig. 12).
const SMAPE_EPS: f64 = 0.01;

/// One `direct/<estimator>` entry.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct DirectEntry {
    pub name: String,
    pub smape: f64,
    /// Mean over pixels of (L - L_ref), luminance.
    pub mean_bias: f64,
    /// Standard error of `mean_bias` from the per-pixel variances of both images.
    pub mean_bias_se: f64,
    /// Mean over pixels of the standard deviation of one sample's luminance.
    pub mean_std: f64,
    pub mean_radiance: f64,
    pub elapsed_ms: f64,
    /// Lookups of the camera ray's free flight and of the three transmittance estimates, per
    /// camera ray.
    pub lookups_per_ray: f64,
    #[serde(flatten)]
    pub flags: crate::diagnostics::RayFlags,
    /// The tracking loops' collision cap used.
    pub collision_cap: u32,
    pub exr: String,
    pub png: String,
}

/// The `direct` evaluation, as written to `--json`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct DirectEvalReport {
    #[serde(flatten)]
    pub header: EvalHeader,
    pub reference: String,
    pub reference_spp: u32,
    pub reference_exr: String,
    pub reference_png: String,
    /// Probability of sampling the sun, the map and the point lights.
    pub light_pmf: [f32; 3],
    pub entries: Vec<DirectEntry>,
}

/// File stem of an entry's images (`direct-jackknife`, `path-ratio`, ...).
fn stem(integrator: &str, name: &str) -> String {
    format!("{integrator}-{name}")
}

/// Every image [`evaluate_direct`] writes in `out_dir` for these estimators.
pub fn direct_files<'a>(
    out_dir: &Path,
    integrator: &str,
    names: impl Iterator<Item = &'a str>,
) -> Vec<PathBuf> {
    let mut files = vec![out_dir.join("reference.exr"), out_dir.join("reference.png")];
    for name in names {
        files.push(out_dir.join(format!("{}.exr", stem(integrator, name))));
        files.push(out_dir.join(format!("{}.png", stem(integrator, name))));
    }
    files
}

/// Per-pixel luminance mean and variance of one sample.
fn moments(pixels: &[PixelOut]) -> Vec<(f64, f64)> {
    pixels
        .iter()
        .map(|p| {
            let m = p.t_mean as f64;
            (m, (p.t2_mean as f64 - m * m).max(0.0))
        })
        .collect()
}

/// Renders and writes one image; returns its pixels and the render time.
fn render_one(
    setup: &EvalSetup,
    params: &shared::params::RenderParams,
    lights: &SceneLights,
    stem: &str,
    exposure: f32,
) -> Result<(Vec<PixelOut>, f64, String, String)> {
    let start = Instant::now();
    let pixels =
        crate::render::render_lit(setup.backend, setup.volume, params, lights, setup.progress)
            .with_context(|| format!("rendering {stem}"))?;
    let elapsed_ms = start.elapsed().as_secs_f64() * 1e3;
    let rgb: Vec<[f32; 3]> = pixels
        .iter()
        .map(|p| [p.rgb_mean.r, p.rgb_mean.g, p.rgb_mean.b])
        .collect();
    let (exr, png) = (
        setup.out_dir.join(format!("{stem}.exr")),
        setup.out_dir.join(format!("{stem}.png")),
    );
    let (w, h) = (params.width, params.height);
    write_exr_rgb(&exr, w, h, &rgb)?;
    write_png_rgb_exposed(&png, w, h, &rgb, exposure)?;
    Ok((
        pixels,
        elapsed_ms,
        exr.display().to_string(),
        png.display().to_string(),
    ))
}

/// Renders the reference (ratio-tracking shadow rays) and each estimator's image with
/// `integrator` (`direct` or `path`; `setup.params` carries its depths).
pub fn evaluate_direct(
    setup: &EvalSetup,
    integrator: Integrator,
    lights: &SceneLights,
    estimators: &[&'static crate::estimators::EstimatorSpec],
    exposure: f32,
) -> Result<DirectEvalReport> {
    std::fs::create_dir_all(setup.out_dir)
        .with_context(|| format!("creating {}", setup.out_dir.display()))?;
    let mut base = setup.params;
    base.integrator = integrator as u32;
    let label = crate::integrators::integrator_name(integrator);
    base.light_count = lights.points.len() as u32;
    let reference = crate::estimators::by_name("ratio").expect("registered");
    let mut ref_params = base;
    reference.apply(&mut ref_params);
    ref_params.roulette = 0;
    ref_params.spp = setup.reference_spp;
    ref_params.seed = base.seed ^ 0x5eed_0001;
    let ref_params = crate::render::fit_collision_cap(&ref_params, &setup.volume.desc);
    crate::eval::step(setup, 0, estimators.len(), "the reference", ref_params.spp);
    let (ref_px, _, reference_exr, reference_png) =
        render_one(setup, &ref_params, lights, "reference", exposure)?;
    let ref_m = moments(&ref_px);
    let n = ref_m.len() as f64;
    let mut entries = Vec::new();
    for (k, spec) in estimators.iter().enumerate() {
        let name = format!("{label}/{}", spec.name);
        let mut params = base;
        spec.apply(&mut params);
        let params = crate::render::fit_collision_cap(&params, &setup.volume.desc);
        crate::eval::step(setup, k + 1, estimators.len(), &name, params.spp);
        let (px, elapsed_ms, exr, png) =
            render_one(setup, &params, lights, &stem(label, spec.name), exposure)?;
        let m = moments(&px);
        let pairs = m.iter().zip(&ref_m);
        let smape = pairs
            .clone()
            .map(|((a, _), (b, _))| (a - b).abs() / (0.5 * (a.abs() + b.abs()) + SMAPE_EPS))
            .sum::<f64>()
            / n;
        let mean_bias = pairs.clone().map(|((a, _), (b, _))| a - b).sum::<f64>() / n;
        let var_sum: f64 = pairs
            .clone()
            .map(|((_, va), (_, vb))| va / params.spp as f64 + vb / ref_params.spp as f64)
            .sum();
        let entry = DirectEntry {
            name: name.clone(),
            smape,
            mean_bias,
            mean_bias_se: var_sum.sqrt() / n,
            mean_std: m.iter().map(|(_, v)| v.sqrt()).sum::<f64>() / n,
            mean_radiance: m.iter().map(|(a, _)| a).sum::<f64>() / n,
            elapsed_ms,
            lookups_per_ray: px.iter().map(|p| p.samples as f64).sum::<f64>()
                / (n * params.spp as f64),
            flags: crate::diagnostics::RayFlags::of(&px, params.spp),
            collision_cap: crate::render::collision_cap(&params),
            exr,
            png,
        };
        println!(
            "{:<24} SMAPE {:.4}  bias {:+.5} +- {:.5}  std {:.5}  mean L {:.5}  lookups/ray {:6.2}  {:8.1} ms",
            entry.name,
            entry.smape,
            entry.mean_bias,
            entry.mean_bias_se,
            entry.mean_std,
            entry.mean_radiance,
            entry.lookups_per_ray,
            entry.elapsed_ms
        );
        entry.flags.warn(&params);
        entries.push(entry);
    }
    let l = &lights.lighting;
    Ok(DirectEvalReport {
        header: setup.header(),
        reference: format!("{label}/ratio at {} spp", ref_params.spp),
        reference_spp: ref_params.spp,
        reference_exr,
        reference_png,
        light_pmf: [l.p_sun, l.p_env, l.p_points],
        entries,
    })
}

/// Estimators whose three estimates per camera ray exceed one GPU invocation's loop budget.
pub fn too_large_for_direct(e: Estimator) -> bool {
    e == Estimator::UnbiasedRayMarching
}
