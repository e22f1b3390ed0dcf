//! `host eval`: per-pixel bias, standard deviation and cost of transmittance estimators against
//! a reference, on the same primary rays (pixel centers), like the paper's Figs. 8-10.

use anyhow::{Context, Result};
use engine::backend::Backend;
use engine::estimators::{by_name, EstimatorSpec};
use engine::output::{write_exr, write_json};
use engine::render::render;
use engine::scene::bricks::PackedVolume;
pub use engine::scene::supervoxel_info::SupervoxelInfo;
use shared::kernels::render::PixelOut;
use shared::params::RenderParams;
use std::path::{Path, PathBuf};

/// Statistics of one estimator over the pixels whose reference transmittance is below 1.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct EstimatorReport {
    pub name: String,
    pub about: String,
    pub unbiased: bool,
    /// Mean over pixels of (pixel mean - reference).
    pub mean_bias: f64,
    /// Mean over pixels of |pixel mean - reference|; includes the Monte Carlo noise of both.
    pub mean_abs_bias: f64,
    /// Expected mean |error| of an unbiased estimator with this std and spp against this
    /// reference: mean of sqrt(2 / pi) * sqrt(std^2 / spp + the reference mean's variance)
    /// (std * sqrt(2 / (pi spp)) against an exact reference). `mean_abs_bias` near this means
    /// bias below the noise.
    pub abs_bias_noise_floor: f64,
    /// Mean over pixels of the per-sample standard deviation.
    pub mean_std: f64,
    /// sqrt(mean over pixels of bias^2 + std^2): error of a single-sample estimate.
    pub rmse: f64,
    /// High-resolution lookups per ray, over the evaluated pixels.
    pub mean_samples_per_ray: f64,
    /// Rays traced, rays a loop bound changed, rays outside the jackknife's regime (all pixels).
    #[serde(flatten)]
    pub flags: engine::render::diagnostics::RayFlags,
    /// Render time of all spp for the whole image, without the GPU pipeline builds it waited
    /// for (`pipeline_build_ms`: a kernel variant compiles on its first use).
    pub elapsed_ms: f64,
    #[serde(default)]
    pub pipeline_build_ms: f64,
    pub bias_exr: String,
    pub bias_png: String,
    pub std_exr: String,
    pub std_png: String,
    pub mean_exr: String,
    /// The mean image as a PNG preview (sRGB, like `reference_png`).
    pub mean_png: String,
}

/// A false-colour map of the bias or std PNGs: values in [`min`, `max`] (clamped outside),
/// with colour stops sampled from the exact function that wrote the PNGs (linear in between).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct ColourMap {
    pub name: String,
    pub min: f64,
    pub max: f64,
    pub stops: Vec<ColourStop>,
}

/// One stop of a [`ColourMap`]: the 8-bit sRGB colour the PNG writer gives `value`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct ColourStop {
    pub value: f64,
    pub rgb: [u8; 3],
}

/// The f64 with the shortest decimal form of an f32 (0.05f32 -> 0.05, not 0.0500000007...).
fn short(v: f32) -> f64 {
    v.to_string().parse().unwrap_or(v as f64)
}

/// Stops of a colour map, sampled at 25 values from `min` to `max`: the bias and std maps are
/// piecewise linear with kinks at multiples of 1/24 of the range (0, 1/3, 1/2, 2/3), so these
/// stops reproduce them up to rounding.
pub fn colour_map(name: &str, min: f32, max: f32, f: impl Fn(f32) -> [u8; 3]) -> ColourMap {
    let stops = (0..=24)
        .map(|k| {
            let value = min + (max - min) * k as f32 / 24.0;
            ColourStop {
                value: short(value),
                rgb: f(value),
            }
        })
        .collect();
    ColourMap {
        name: name.into(),
        min: short(min),
        max: short(max),
        stops,
    }
}

/// The colour map of the bias PNGs for `--bias-scale`.
pub fn bias_colour_map(scale: f32) -> ColourMap {
    colour_map(
        "diverging: blue (under) - white (0) - red (over)",
        -scale,
        scale,
        |v| diverging(v, scale),
    )
}

/// The colour map of the std PNGs for `--std-scale`.
pub fn std_colour_map(scale: f32) -> ColourMap {
    colour_map(
        "sequential: black (0) - orange - yellow - white",
        0.0,
        scale,
        |v| sequential(v, scale),
    )
}

/// What every evaluation was run on: volume, backend, image size, spp and seed.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct EvalHeader {
    pub volume: String,
    pub backend: String,
    pub device: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u32,
    /// The importance structure the estimators traversed (absent in older reports).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub supervoxels: Option<SupervoxelInfo>,
    /// The shard files the reference was added up from (`--reference-from`; absent when the
    /// evaluation rendered it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub reference_shards: Vec<String>,
}

/// The whole evaluation, as written to `--json`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct EvalReport {
    /// Volume, backend, image size, spp and seed (their keys come first in the JSON).
    #[serde(flatten)]
    pub header: EvalHeader,
    pub n: u32,
    pub lookup: String,
    pub reference: String,
    pub evaluated_pixels: usize,
    /// The reference transmittance: linear EXR and sRGB PNG.
    pub reference_exr: String,
    pub reference_png: String,
    /// Colour map of every `bias_png` (`--bias-scale`).
    pub bias_colour_map: ColourMap,
    /// Colour map of every `std_png` (`--std-scale`).
    pub std_colour_map: ColourMap,
    pub estimators: Vec<EstimatorReport>,
}

/// Diverging false colour for signed values in [-scale, scale]: blue, white, red.
fn diverging(v: f32, scale: f32) -> [u8; 3] {
    let x = if v.is_nan() {
        0.0
    } else {
        (v / scale).clamp(-1.0, 1.0)
    };
    let a = x.abs();
    let fade = |c: f32| ((1.0 - a) * 255.0 + a * c * 255.0).round() as u8;
    if x >= 0.0 {
        [255, fade(0.1), fade(0.1)]
    } else {
        [fade(0.1), fade(0.3), 255]
    }
}

/// Sequential false colour for values in [0, scale]: black through orange to yellow-white.
fn sequential(v: f32, scale: f32) -> [u8; 3] {
    let x = if v.is_nan() {
        0.0
    } else {
        (v / scale).clamp(0.0, 1.0)
    };
    let r = (x * 3.0).min(1.0);
    let g = (x * 3.0 - 1.0).clamp(0.0, 1.0);
    let b = (x * 3.0 - 2.0).clamp(0.0, 1.0);
    [(r * 255.0) as u8, (g * 255.0) as u8, (b * 255.0) as u8]
}

fn write_false_colour(
    path: &Path,
    w: u32,
    h: u32,
    values: &[f32],
    f: impl Fn(f32) -> [u8; 3],
) -> Result<()> {
    let bytes: Vec<u8> = values.iter().flat_map(|&v| f(v)).collect();
    engine::output::write_rgb_png(path, w, h, &bytes)
}

/// E|X - R| of a pixel mean X with per-sample std `std` over `spp` samples and a reference mean
/// R of variance `ref_var`, both unbiased and normal: sqrt(2 / pi) * sqrt(std^2 / spp + ref_var),
/// written std * sqrt(2 / (pi spp)) for an exact reference (ref_var = 0; the former floor's bits).
fn abs_error_floor(std: f64, spp: u32, ref_var: f64) -> f64 {
    let pi = std::f64::consts::PI;
    if ref_var == 0.0 {
        std * (2.0 / (pi * f64::from(spp))).sqrt()
    } else {
        (2.0 / pi).sqrt() * (std * std / f64::from(spp) + ref_var).sqrt()
    }
}

/// Per-sample standard deviation of one pixel (Bessel-corrected).
fn pixel_std(p: &PixelOut, spp: u32) -> f64 {
    let var = (p.t2_mean as f64 - (p.t_mean as f64).powi(2)).max(0.0);
    let n = spp as f64;
    if n > 1.0 {
        (var * n / (n - 1.0)).sqrt()
    } else {
        0.0
    }
}

/// The image file `name_suffix` of an evaluated estimator in `out_dir` (suffix "bias.exr", ...).
pub fn estimator_file(out_dir: &Path, name: &str, suffix: &str) -> PathBuf {
    out_dir.join(format!("{name}_{suffix}"))
}

/// Suffixes of the images written per estimator.
const ESTIMATOR_IMAGES: [&str; 6] = [
    "mean.exr", "mean.png", "bias.exr", "bias.png", "std.exr", "std.png",
];

/// Every image `evaluate` writes in `out_dir` for these estimators, the reference first.
pub fn estimator_files<'a>(out_dir: &Path, names: impl Iterator<Item = &'a str>) -> Vec<PathBuf> {
    let mut files = vec![out_dir.join("reference.exr"), out_dir.join("reference.png")];
    for name in names {
        files.extend(
            ESTIMATOR_IMAGES
                .iter()
                .map(|s| estimator_file(out_dir, name, s)),
        );
    }
    files
}

/// Every image `evaluate_integrators` writes in `out_dir` for these integrators.
pub fn integrator_files<'a>(out_dir: &Path, names: impl Iterator<Item = &'a str>) -> Vec<PathBuf> {
    let mut files = vec![out_dir.join("reference.exr"), out_dir.join("reference.png")];
    for name in names {
        files.push(out_dir.join(format!("{name}.exr")));
        files.push(out_dir.join(format!("{name}.png")));
    }
    files
}

/// Prints one progress line to stderr (also when it is not a terminal, where the progress bar
/// stays hidden): render `k` of `total` (0: the reference).
pub fn step(setup: &EvalSetup, k: usize, total: usize, what: &str, spp: u32) {
    if setup.progress {
        let (w, h) = (setup.params.width, setup.params.height);
        tracing::info!("eval [{k}/{total}] rendering {what}: {w}x{h} at {spp} spp");
    }
}

/// Settings of one evaluation.
pub struct EvalSetup<'a> {
    pub backend: &'a Backend,
    pub volume: &'a PackedVolume,
    pub volume_name: String,
    pub params: RenderParams,
    pub reference: &'a EstimatorSpec,
    pub reference_spp: u32,
    pub out_dir: &'a Path,
    pub bias_scale: f32,
    pub std_scale: f32,
    pub progress: bool,
    /// The super-voxel grid, for the report.
    pub supervoxels: Option<SupervoxelInfo>,
    /// Where the reference comes from (rendered, or shards).
    pub reference_source: &'a crate::reference::ReferenceSource,
}

impl EvalSetup<'_> {
    /// The header of its report.
    pub fn header(&self) -> EvalHeader {
        EvalHeader {
            volume: self.volume_name.clone(),
            backend: self.backend.kind().into(),
            device: self.backend.device(),
            width: self.params.width,
            height: self.params.height,
            spp: self.params.spp,
            seed: self.params.seed,
            supervoxels: self.supervoxels.clone(),
            reference_shards: match self.reference_source {
                crate::reference::ReferenceSource::Shards(paths) => {
                    paths.iter().map(|p| p.display().to_string()).collect()
                }
                _ => Vec::new(),
            },
        }
    }
}

/// Renders the reference and each estimator and measures them.
pub fn evaluate(setup: &EvalSetup, estimators: &[&'static EstimatorSpec]) -> Result<EvalReport> {
    std::fs::create_dir_all(setup.out_dir)
        .with_context(|| format!("creating {}", setup.out_dir.display()))?;
    let (w, h) = (setup.params.width, setup.params.height);
    let mut ref_params = setup.params;
    setup.reference.apply(&mut ref_params);
    ref_params.spp = setup.reference_spp;
    step(setup, 0, estimators.len(), "the reference", ref_params.spp);
    let resident = engine::render::Resident::new(setup.backend, setup.volume)?;
    let no_lights = engine::lighting::SceneLights::points_only(&[]);
    let reference = crate::reference::reference_pixels(
        setup.reference_source,
        "transmittance reference",
        &resident,
        &ref_params,
        &no_lights,
        setup.progress,
        || engine::render::render_resident(&resident, &ref_params, &[], setup.progress),
    )
    .context("rendering the reference")?;
    engine::render::diagnostics::check_finite(&reference, w).context("rendering the reference")?;
    let ref_t: Vec<f32> = reference.iter().map(|p| p.t_mean).collect();
    // The variance of each reference pixel's mean (0 for an exact reference: one deterministic
    // estimate per pixel), part of the noise floor of every |bias|.
    let ref_var: Vec<f64> = reference
        .iter()
        .map(|p| pixel_std(p, setup.reference_spp).powi(2) / f64::from(setup.reference_spp))
        .collect();
    let mask: Vec<bool> = ref_t.iter().map(|&t| t < 1.0).collect();
    let count = mask.iter().filter(|&&m| m).count();
    anyhow::ensure!(
        count >= MIN_EVAL_PIXELS,
        "only {count} of {} reference pixels see the volume (T < 1); the statistics need at \
         least {MIN_EVAL_PIXELS}: frame the volume (--camera, --look-at, --fov) or raise --width \
         and --height",
        ref_t.len()
    );
    let (reference_exr, reference_png) = (
        setup.out_dir.join("reference.exr"),
        setup.out_dir.join("reference.png"),
    );
    write_exr(&reference_exr, w, h, &ref_t)?;
    engine::output::write_png(&reference_png, w, h, &ref_t)?;

    let reference = Reference {
        t: ref_t,
        var: ref_var,
        mask,
        count,
    };
    let mut reports = Vec::new();
    for (k, spec) in estimators.iter().enumerate() {
        reports.push(evaluate_estimator(
            setup,
            &reference,
            spec,
            k,
            estimators.len(),
        )?);
    }
    Ok(EvalReport {
        header: setup.header(),
        n: setup.params.n,
        lookup: if setup.volume.desc.lookup == 1 {
            "stochastic"
        } else {
            "nearest"
        }
        .into(),
        reference: format!(
            "{} at {} spp: {}",
            setup.reference.name, setup.reference_spp, setup.reference.about
        ),
        evaluated_pixels: reference.count,
        reference_exr: reference_exr.display().to_string(),
        reference_png: reference_png.display().to_string(),
        bias_colour_map: bias_colour_map(setup.bias_scale),
        std_colour_map: std_colour_map(setup.std_scale),
        estimators: reports,
    })
}

/// The reference of a transmittance evaluation: its pixels' means, the variance of each mean,
/// and the pixels that see the volume (T < 1), `count` of them.
struct Reference {
    t: Vec<f32>,
    var: Vec<f64>,
    mask: Vec<bool>,
    count: usize,
}

/// Renders estimator `spec` (number `k` of `of`), writes its images and measures it against
/// `reference`.
fn evaluate_estimator(
    setup: &EvalSetup,
    reference: &Reference,
    spec: &'static EstimatorSpec,
    k: usize,
    of: usize,
) -> Result<EstimatorReport> {
    let (w, h) = (setup.params.width, setup.params.height);
    let mut params = setup.params;
    spec.apply(&mut params);
    step(setup, k + 1, of, spec.name, params.spp);
    let (pixels, elapsed_ms, built) = setup
        .backend
        .timed(|| render(setup.backend, setup.volume, &params, setup.progress))
        .with_context(|| format!("rendering {}", spec.name))?;
    engine::render::diagnostics::check_finite(&pixels, w)
        .with_context(|| format!("rendering {}", spec.name))?;
    let bias: Vec<f32> = pixels
        .iter()
        .zip(&reference.t)
        .map(|(p, &r)| p.t_mean - r)
        .collect();
    let std: Vec<f32> = pixels
        .iter()
        .map(|p| pixel_std(p, params.spp) as f32)
        .collect();
    let masked = |f: &dyn Fn(usize) -> f64| {
        (0..pixels.len())
            .filter(|&i| reference.mask[i])
            .map(f)
            .sum::<f64>()
            / reference.count as f64
    };
    let file = |suffix: &str| {
        estimator_file(setup.out_dir, spec.name, suffix)
            .display()
            .to_string()
    };
    let mean_t: Vec<f32> = pixels.iter().map(|p| p.t_mean).collect();
    write_exr(Path::new(&file("mean.exr")), w, h, &mean_t)?;
    engine::output::write_png(Path::new(&file("mean.png")), w, h, &mean_t)?;
    write_exr(Path::new(&file("bias.exr")), w, h, &bias)?;
    write_exr(Path::new(&file("std.exr")), w, h, &std)?;
    write_false_colour(Path::new(&file("bias.png")), w, h, &bias, |v| {
        diverging(v, setup.bias_scale)
    })?;
    write_false_colour(Path::new(&file("std.png")), w, h, &std, |v| {
        sequential(v, setup.std_scale)
    })?;
    let report = EstimatorReport {
        name: spec.name.into(),
        about: spec.about.into(),
        unbiased: spec.unbiased,
        mean_bias: masked(&|i| bias[i] as f64),
        mean_abs_bias: masked(&|i| (bias[i] as f64).abs()),
        abs_bias_noise_floor: masked(&|i| {
            abs_error_floor(std[i] as f64, params.spp, reference.var[i])
        }),
        mean_std: masked(&|i| std[i] as f64),
        rmse: masked(&|i| (bias[i] as f64).powi(2) + (std[i] as f64).powi(2)).sqrt(),
        mean_samples_per_ray: masked(&|i| pixels[i].samples as f64) / params.spp as f64,
        flags: engine::render::diagnostics::RayFlags::of(&pixels, params.spp),
        elapsed_ms,
        pipeline_build_ms: built.ms(),
        bias_exr: file("bias.exr"),
        bias_png: file("bias.png"),
        std_exr: file("std.exr"),
        std_png: file("std.png"),
        mean_exr: file("mean.exr"),
        mean_png: file("mean.png"),
    };
    println!(
        "{:<20} bias {:+.5}  |bias| {:.5} (noise floor {:.5})  std {:.4}  rmse {:.4}  samples/ray {:7.2}  {:8.1} ms",
        report.name,
        report.mean_bias,
        report.mean_abs_bias,
        report.abs_bias_noise_floor,
        report.mean_std,
        report.rmse,
        report.mean_samples_per_ray,
        report.elapsed_ms
    );
    report.flags.warn(&params);
    Ok(report)
}

/// Parses a comma-separated estimator list ("all" for every one but the reference).
pub fn parse_list(list: &str) -> Result<Vec<&'static EstimatorSpec>> {
    parse_list_of(list, "--estimators")
}

/// Every estimator but regular tracking (the deterministic reference): `--estimators all`.
pub fn every_estimator() -> Vec<&'static EstimatorSpec> {
    engine::estimators::ESTIMATORS
        .iter()
        .filter(|s| s.name != "regular")
        .collect()
}

/// [`parse_list`] of the flag `flag` (named in the error).
pub fn parse_list_of(list: &str, flag: &str) -> Result<Vec<&'static EstimatorSpec>> {
    if list == "all" {
        return Ok(every_estimator());
    }
    list.split(',')
        .map(|n| {
            by_name(n.trim()).with_context(|| {
                format!(
                    "{flag}: unknown estimator {n:?}; choose from: {}",
                    engine::estimators::names()
                )
            })
        })
        .collect()
}

/// Fewest reference pixels with T < 1 over which `host eval` computes its statistics.
pub const MIN_EVAL_PIXELS: usize = 16;

/// Refuses integrator statistics whose reference has fewer than [`MIN_EVAL_PIXELS`] pixels
/// whose rays read a voxel: over the rest every estimator agrees trivially.
pub fn check_reference_sees_the_volume(reference: &[PixelOut]) -> Result<()> {
    let count = reference.iter().filter(|p| p.samples > 0).count();
    anyhow::ensure!(
        count >= MIN_EVAL_PIXELS,
        "only {count} of {} reference pixels read a voxel of the volume; the statistics need at \
         least {MIN_EVAL_PIXELS}: frame the volume (--camera, --look-at, --fov) or raise --width \
         and --height",
        reference.len()
    );
    Ok(())
}

/// Writes the report as JSON.
pub fn write_report(path: &Path, report: &EvalReport) -> Result<()> {
    engine::output::ensure_parent(path)?;
    write_json(path, report)
}

/// Statistics of one integrator against the reference radiance image.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct IntegratorReport {
    pub name: String,
    /// Mean over pixels of |L - L_ref| / ((L + L_ref) / 2 + 0.01) (Fig. 12's SMAPE).
    pub smape: f64,
    /// Mean over pixels of (L - L_ref).
    pub mean_bias: f64,
    /// Mean over pixels of |L - L_ref|.
    pub mean_abs_error: f64,
    /// Mean radiance of the image.
    pub mean_radiance: f64,
    /// Time to render all spp of the image, without the GPU pipeline builds it waited for
    /// (`pipeline_build_ms`: a kernel variant compiles on its first use).
    pub elapsed_ms: f64,
    #[serde(default)]
    pub pipeline_build_ms: f64,
    /// Time per spp (one frame of 1 spp).
    pub ms_per_frame: f64,
    pub mean_samples_per_ray: f64,
    /// Rays traced, rays a loop bound changed, rays outside the jackknife's regime.
    #[serde(flatten)]
    pub flags: engine::render::diagnostics::RayFlags,
    pub exr: String,
    pub png: String,
}

/// The integrator evaluation, as written to `--json`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct IntegratorEvalReport {
    /// Volume, backend, image size, spp and seed (their keys come first in the JSON).
    #[serde(flatten)]
    pub header: EvalHeader,
    pub lights: usize,
    pub reference: String,
    /// The reference radiance: linear EXR and PNG (tone-mapped like every `png`).
    pub reference_exr: String,
    pub reference_png: String,
    /// `--exposure`: the PNGs show radiance times `preview_gain` (this times the reference's
    /// automatic exposure), filmic, sRGB-encoded (`engine::render_job::preview`).
    pub exposure: f32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preview_gain: Option<f32>,
    pub integrators: Vec<IntegratorReport>,
}

/// SMAPE epsilon of Fig. 12.
const SMAPE_EPS: f64 = 0.01;

/// Renders the reference and each integrator; measures SMAPE, bias and time.
pub fn evaluate_integrators(
    setup: &EvalSetup,
    lights: &[shared::sampling::lights::PointLight],
    integrators: &[(&'static str, shared::params::Integrator)],
    exposure: f32,
) -> Result<IntegratorEvalReport> {
    use shared::params::{Integrator, TransmittanceHat};
    std::fs::create_dir_all(setup.out_dir)
        .with_context(|| format!("creating {}", setup.out_dir.display()))?;
    let (w, h) = (setup.params.width, setup.params.height);
    let mut ref_params = setup.params;
    ref_params.integrator = Integrator::MisJackknife as u32;
    ref_params.t_hat = TransmittanceHat::Ratio as u32;
    ref_params.spp = setup.reference_spp;
    ref_params.seed = setup.params.seed ^ 0x5eed_0001;
    step(setup, 0, integrators.len(), "the reference", ref_params.spp);
    let resident = engine::render::Resident::new(setup.backend, setup.volume)?;
    let scene_lights = engine::lighting::SceneLights::points_only(lights);
    let reference = crate::reference::reference_pixels(
        setup.reference_source,
        "single-scattering reference",
        &resident,
        &ref_params,
        &scene_lights,
        setup.progress,
        || engine::render::render_resident(&resident, &ref_params, lights, setup.progress),
    )
    .context("rendering the reference")?;
    check_reference_sees_the_volume(&reference)?;
    // One gain for every image of the evaluation: the reference's automatic exposure.
    let view = engine::render_job::preview::Preview::of(
        Some(Integrator::MisJackknife),
        exposure,
        true,
        &reference,
    );
    let tone = |v: &[f32]| -> Vec<f32> { v.iter().map(|&x| view.grey(x)).collect() };
    let ref_l: Vec<f32> = reference.iter().map(|p| p.t_mean).collect();
    let (reference_exr, reference_png) = (
        setup.out_dir.join("reference.exr"),
        setup.out_dir.join("reference.png"),
    );
    write_exr(&reference_exr, w, h, &ref_l)?;
    engine::output::write_png(&reference_png, w, h, &tone(&ref_l))?;
    let mut reports = Vec::new();
    for (k, &(name, integrator)) in integrators.iter().enumerate() {
        let mut params = setup.params;
        params.integrator = integrator as u32;
        step(setup, k + 1, integrators.len(), name, params.spp);
        let (pixels, elapsed_ms, built) = setup
            .backend
            .timed(|| {
                engine::render::render_scene(
                    setup.backend,
                    setup.volume,
                    &params,
                    lights,
                    setup.progress,
                )
            })
            .with_context(|| format!("rendering {name}"))?;
        let l: Vec<f32> = pixels.iter().map(|p| p.t_mean).collect();
        let exr = setup.out_dir.join(format!("{name}.exr"));
        let png = setup.out_dir.join(format!("{name}.png"));
        write_exr(&exr, w, h, &l)?;
        engine::output::write_png(&png, w, h, &tone(&l))?;
        let report = integrator_report(
            name,
            &pixels,
            &ref_l,
            &params,
            (elapsed_ms, built.ms()),
            &exr,
            &png,
        );
        println!(
            "{:<20} SMAPE {:.4}  bias {:+.5}  |err| {:.5}  mean L {:.5}  samples/ray {:6.2}  {:8.1} ms/spp",
            report.name, report.smape, report.mean_bias, report.mean_abs_error, report.mean_radiance, report.mean_samples_per_ray, report.ms_per_frame
        );
        report.flags.warn(&params);
        reports.push(report);
    }
    Ok(IntegratorEvalReport {
        header: setup.header(),
        lights: lights.len(),
        reference: format!(
            "mis-jackknife with ratio-tracking T(t0) (unbiased up to the shadow-ray estimator shared by all) at {} spp, independent seed",
            setup.reference_spp
        ),
        reference_exr: reference_exr.display().to_string(),
        reference_png: reference_png.display().to_string(),
        exposure,
        preview_gain: view.gain(),
        integrators: reports,
    })
}

/// One integrator's image (its `pixels`, luminance `l`) measured against the reference's
/// `ref_l`; `ms`: its render time and pipeline build time.
fn integrator_report(
    name: &str,
    pixels: &[shared::kernels::render::PixelOut],
    ref_l: &[f32],
    params: &shared::params::RenderParams,
    (elapsed_ms, build_ms): (f64, f64),
    exr: &Path,
    png: &Path,
) -> IntegratorReport {
    let l: Vec<f32> = pixels.iter().map(|p| p.t_mean).collect();
    let n = ref_l.len() as f64;
    let pairs = l.iter().zip(ref_l).map(|(&a, &b)| (a as f64, b as f64));
    let smape = pairs
        .clone()
        .map(|(a, b)| (a - b).abs() / (0.5 * (a.abs() + b.abs()) + SMAPE_EPS))
        .sum::<f64>()
        / n;
    IntegratorReport {
        name: name.into(),
        smape,
        mean_bias: pairs.clone().map(|(a, b)| a - b).sum::<f64>() / n,
        mean_abs_error: pairs.map(|(a, b)| (a - b).abs()).sum::<f64>() / n,
        mean_radiance: l.iter().map(|&v| v as f64).sum::<f64>() / n,
        elapsed_ms,
        pipeline_build_ms: build_ms,
        ms_per_frame: elapsed_ms / params.spp as f64,
        mean_samples_per_ray: pixels.iter().map(|p| p.samples as f64).sum::<f64>()
            / (n * params.spp as f64),
        flags: engine::render::diagnostics::RayFlags::of(pixels, params.spp),
        exr: exr.display().to_string(),
        png: png.display().to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::abs_error_floor;

    /// An exact reference leaves the floor at std * sqrt(2 / (pi spp)); a reference mean as
    /// noisy as the estimate's raises it by sqrt(2) (the difference of two such means).
    #[test]
    fn the_noise_floor_counts_the_reference_noise() {
        let (std, spp) = (0.3, 64);
        let noise = (2.0 / (std::f64::consts::PI * f64::from(spp))).sqrt();
        let exact = abs_error_floor(std, spp, 0.0);
        assert_eq!(exact, std * noise);
        let noisy = abs_error_floor(std, spp, std * std / f64::from(spp));
        assert!(
            (noisy / exact - 2f64.sqrt()).abs() < 1e-12,
            "{noisy} vs {exact}"
        );
    }
}
