//! `host eval --integrators direct|path --estimators LIST`: the `direct` (or `path`) integrator
//! with each shadow-ray estimator (entries `direct/<estimator>`, `path/<estimator>`) against a
//! reference made with ratio-tracking shadow rays (unbiased) at `--reference-spp`, as in the
//! paper's Fig. 1.
//!
//! Statistics are of each pixel's luminance: SMAPE (epsilon 0.01), mean bias over the image with
//! its standard error from the per-pixel variances of both images, mean per-sample standard
//! deviation, mean radiance, time and shadow-ray lookups.
//!
//! Entries `msm4[:RES]` and `msm6[:RES]` take the sun's transmittance from its moment shadow
//! map (`--shadows msm4|msm6` at RES texels per side, default 512; every other shadow ray uses
//! the jackknife); their time includes the map's build. When any map entry is present, an image
//! with exact shadows (regular tracking, deterministic) at the entries' seed is rendered too:
//! every entry then also gets its paired error, the RMS and mean of its per-pixel difference
//! to that image. The camera samples are the same in both (the shadow estimates of the map and
//! of regular tracking draw no random numbers), so for a map the paired error is its shadow
//! bias alone, free of the camera's noise.

use crate::eval::{EvalHeader, EvalSetup};
use anyhow::{Context, Result};
use engine::estimators::EstimatorSpec;
use engine::lighting::SceneLights;
use engine::output::write_exr_rgb;
use engine::render::shadow_map::{self, MapSummary, ShadowKind, ShadowOptions};
use engine::render::Resident;
use engine::render_job::preview::Preview;
use shared::integrators::unit::OwnSettings;
use shared::kernels::render::PixelOut;
use shared::params::{Integrator, RenderParams};
use std::path::{Path, PathBuf};

/// SMAPE's epsilon (Fig. 12).
const SMAPE_EPS: f64 = 0.01;

/// One `direct/<estimator>` entry.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct DirectEntry {
    pub name: String,
    pub smape: f64,
    /// Mean over pixels of (L - L_ref), luminance.
    pub mean_bias: f64,
    /// Standard error of `mean_bias` from the per-pixel variances of both images (with spatial
    /// reuse, whose pixels share samples, a bound: its pixels taken as fully correlated).
    pub mean_bias_se: f64,
    /// Mean over pixels of the standard deviation of one sample's luminance.
    pub mean_std: f64,
    pub mean_radiance: f64,
    /// Render time, without the GPU pipeline builds it waited for.
    pub elapsed_ms: f64,
    /// Those builds' wall time (a kernel variant compiles on its first use; 0 on the CPU).
    #[serde(default)]
    pub pipeline_build_ms: f64,
    /// Samples per pixel of this entry (`--spp`, or with `--equal-time` the calibrated count).
    #[serde(default)]
    pub spp: u32,
    /// `--equal-time`: the short timing run that set `spp` (its spp and milliseconds).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<Calibration>,
    /// Lookups of the camera ray's free flight and of the three transmittance estimates, per
    /// camera ray.
    pub lookups_per_ray: f64,
    #[serde(flatten)]
    pub flags: engine::render::diagnostics::RayFlags,
    /// The tracking loops' collision cap used.
    pub collision_cap: u32,
    /// Map entries: the sun's moment shadow map (its build time is part of `elapsed_ms`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shadow_map: Option<MapSummary>,
    /// RMS over pixels of the difference to the exact-shadow image with the same camera
    /// samples (present when the evaluation has map entries).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paired_rms: Option<f64>,
    /// Mean over pixels of that difference.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paired_mean: Option<f64>,
    pub exr: String,
    pub png: String,
}

/// `--equal-time`: an entry's timing run and the budget it was fitted to.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct Calibration {
    /// Samples per pixel of the timing run.
    pub spp: u32,
    /// Its render time.
    pub ms: f64,
    /// The budget: the first entry's render time at `--spp`.
    pub budget_ms: f64,
    /// The entry's SMAPE moved to exactly the budget: smape x sqrt(elapsed_ms / budget_ms),
    /// i.e. as if its error were all noise (falling as 1 / sqrt(time)); corrects for the timing
    /// run's miss of the budget (a short run on a busy machine misses by 10-20 %). An estimate:
    /// an entry's bias does not shrink with time.
    #[serde(default)]
    pub smape_at_budget: f64,
}

/// [`Calibration::smape_at_budget`] of an entry with `smape` that took `elapsed_ms`.
pub fn smape_at_budget(smape: f64, elapsed_ms: f64, budget_ms: f64) -> f64 {
    if elapsed_ms > 0.0 && budget_ms > 0.0 {
        smape * (elapsed_ms / budget_ms).sqrt()
    } else {
        smape
    }
}

/// Samples per pixel of the timing run of `--equal-time` (an eighth of --spp, at least 1).
fn calibration_spp(spp: u32) -> u32 {
    (spp / 8).max(1)
}

/// Most samples per pixel `--equal-time` gives an entry.
pub const MAX_EQUAL_TIME_SPP: u32 = 1 << 20;

/// Samples per pixel that fit `budget_ms` at `ms_per_spp`, in 1..=[`MAX_EQUAL_TIME_SPP`], and
/// whether that range clamped it (the entry then misses the budget).
pub fn equal_time_spp(budget_ms: f64, ms_per_spp: f64) -> (u32, bool) {
    if !(ms_per_spp > 0.0 && budget_ms.is_finite()) {
        return (1, true);
    }
    let spp = (budget_ms / ms_per_spp).round();
    let clamped = spp.clamp(1.0, MAX_EQUAL_TIME_SPP as f64);
    (clamped as u32, clamped != spp)
}

/// How one entry's shadow rays toward the sun get their transmittance.
#[derive(Clone, Copy, Debug)]
pub enum ShadowEntry {
    /// Shadow rays through this estimator.
    Rays(&'static EstimatorSpec),
    /// The sun's moment shadow map (the other shadow rays: the jackknife).
    Map { kind: ShadowKind, resolution: u32 },
}

impl ShadowEntry {
    /// The entry's name: the estimator, or `msm4-512`.
    pub fn name(&self) -> String {
        match self {
            ShadowEntry::Rays(spec) => spec.name.into(),
            ShadowEntry::Map { kind, resolution } => {
                format!("{}-{resolution}", shadow_map::name(*kind))
            }
        }
    }
}

/// `--estimators` of `host eval --integrators direct|path`: estimators, `all`, and `msm4[:RES]`,
/// `msm6[:RES]` (the sun's moment shadow map at RES texels per side).
pub fn parse_entries(list: &str) -> Result<Vec<ShadowEntry>> {
    if list == "all" {
        return Ok(crate::eval::parse_list(list)?
            .into_iter()
            .map(ShadowEntry::Rays)
            .collect());
    }
    list.split(',')
        .map(|item| {
            let item = item.trim();
            let (head, res) = match item.split_once(':') {
                Some((h, r)) => (h, Some(r)),
                None => (item, None),
            };
            let kind = match head {
                "msm4" => Some(ShadowKind::Msm4),
                "msm6" => Some(ShadowKind::Msm6),
                _ => None,
            };
            match kind {
                Some(kind) => {
                    let resolution = match res {
                        None => shadow_map::DEFAULT_RESOLUTION,
                        Some(r) => r
                            .parse::<u32>()
                            .ok()
                            .filter(|r| {
                                (shadow_map::MIN_RESOLUTION..=shadow_map::MAX_RESOLUTION)
                                    .contains(r)
                            })
                            .with_context(|| {
                                format!(
                                    "--estimators: {item:?}: the map resolution must be {} to {} \
                                      texels per side (e.g. msm4:512)",
                                    shadow_map::MIN_RESOLUTION,
                                    shadow_map::MAX_RESOLUTION
                                )
                            })?,
                    };
                    Ok(ShadowEntry::Map { kind, resolution })
                }
                None => {
                    anyhow::ensure!(
                        res.is_none(),
                        "--estimators: {item:?}: only msm4 and msm6 take a :RES suffix"
                    );
                    Ok(ShadowEntry::Rays(
                        crate::eval::parse_list(head)?
                            .into_iter()
                            .next()
                            .context("--estimators: an empty name")?,
                    ))
                }
            }
        })
        .collect()
}

/// The reference image of one integrator.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct ReferenceImage {
    pub integrator: String,
    /// What it is (`direct/ratio at 1024 spp`).
    pub reference: String,
    pub spp: u32,
    pub exr: String,
    pub png: String,
    /// Crops of the reference and every entry of the integrator, side by side (in entry
    /// order, each 2x enlarged).
    pub insets: String,
}

/// The `direct` / `path` evaluation, as written to `--json`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct DirectEvalReport {
    #[serde(flatten)]
    pub header: EvalHeader,
    pub references: Vec<ReferenceImage>,
    /// Probability of sampling the sun, the map and the point lights.
    pub light_pmf: [f32; 3],
    pub entries: Vec<DirectEntry>,
    /// The gain of every PNG: `--exposure` times the first reference's automatic exposure,
    /// before the filmic curve and sRGB (`engine::render_job::preview`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preview_gain: Option<f32>,
}

/// File stem of an entry's images (`direct-jackknife`, `path-ratio`, ...).
fn stem(integrator: &str, name: &str) -> String {
    format!("{integrator}-{name}")
}

/// Every image [`evaluate_direct`] writes in `out_dir` for these integrators and estimators.
pub fn direct_files(out_dir: &Path, integrators: &[Integrator], names: &[&str]) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for &i in integrators {
        let integrator = engine::integrators::integrator_name(i);
        for name in ["reference", "exact"]
            .into_iter()
            .chain(names.iter().copied())
        {
            files.push(out_dir.join(format!("{}.exr", stem(integrator, name))));
            files.push(out_dir.join(format!("{}.png", stem(integrator, name))));
        }
        files.push(out_dir.join(format!("{}.png", stem(integrator, "insets"))));
        if reference_of(i) != i {
            // Its reference is another integrator's (`restir`'s is `direct`'s).
            let other = engine::integrators::integrator_name(reference_of(i));
            files.push(out_dir.join(format!("{}.exr", stem(other, "reference"))));
            files.push(out_dir.join(format!("{}.png", stem(other, "reference"))));
        }
    }
    files.sort();
    files.dedup();
    files
}

/// Crops the centre third of each PNG, enlarges it 2x (nearest) and writes them side by side
/// with 4-pixel white gaps: the paper's insets.
fn write_insets(pngs: &[String], out: &Path) -> Result<()> {
    let images: Vec<image::RgbImage> = pngs
        .iter()
        .map(|p| image::open(p).map(|i| i.to_rgb8()))
        .collect::<Result<_, _>>()
        .context("reading the images for the insets")?;
    let Some(first) = images.first() else {
        return Ok(());
    };
    let side = (first.width().min(first.height()) / 3).max(1);
    let (x0, y0) = ((first.width() - side) / 2, (first.height() - side) / 2);
    let (cell, gap) = (2 * side, 4);
    let n = images.len() as u32;
    let mut out_img =
        image::RgbImage::from_pixel(n * cell + (n - 1) * gap, cell, image::Rgb([255; 3]));
    for (k, img) in images.iter().enumerate() {
        let left = k as u32 * (cell + gap);
        for y in 0..cell {
            for x in 0..cell {
                let p = *img.get_pixel(x0 + x / 2, y0 + y / 2);
                out_img.put_pixel(left + x, y, p);
            }
        }
    }
    // Encoded in memory, then one checked write (`output::write_bytes`).
    let mut png = std::io::Cursor::new(Vec::new());
    out_img
        .write_to(&mut png, image::ImageFormat::Png)
        .map_err(|e| anyhow::anyhow!("encoding {}: {e}", out.display()))?;
    engine::output::write_bytes(out, png.get_ref())
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

/// One rendered and written image: its pixels, its render time without the GPU pipeline builds
/// it waited for, those builds' time, and its EXR and PNG paths.
struct Rendered {
    /// The preview's gain of the image.
    gain: f32,
    pixels: Vec<PixelOut>,
    elapsed_ms: f64,
    pipeline_build_ms: f64,
    exr: String,
    png: String,
}

/// How an evaluation's PNGs show radiance: `--exposure` times the automatic exposure of the
/// first reference, the same gain for every image (so they compare), filmic, sRGB
/// ([`engine::render_job::preview`]).
#[derive(Clone, Copy, Debug)]
pub struct View {
    pub exposure: f32,
    /// The gain once the first reference set it.
    pub gain: Option<f32>,
}

/// Renders and writes one image.
fn render_one(
    setup: &EvalSetup,
    resident: &Resident,
    params: &shared::params::RenderParams,
    lights: &SceneLights,
    stem: &str,
    view: View,
    reference: bool,
) -> Result<Rendered> {
    // Without the GPU pipeline builds (a kernel variant compiles on first use): the equal-time
    // calibration and the reported times compare renders, not the driver's compiler.
    let render = || engine::render::render_resident_lit(resident, params, lights, setup.progress);
    let (pixels, elapsed_ms, built) = setup
        .backend
        .timed(|| {
            if !reference {
                return render();
            }
            crate::reference::reference_pixels(
                setup.reference_source,
                stem,
                resident,
                params,
                lights,
                setup.progress,
                render,
            )
        })
        .with_context(|| format!("rendering {stem}"))?;
    engine::render::diagnostics::check_finite(&pixels, params.width)
        .with_context(|| format!("rendering {stem}"))?;
    if reference {
        // Before its files are written: statistics over a view that misses the volume are refused.
        crate::eval::check_reference_sees_the_volume(&pixels)?;
    }
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
    let tone = match view.gain {
        Some(g) => Preview::Rgb(g),
        None => Preview::of(
            Some(Integrator::from_u32(params.integrator)),
            view.exposure,
            true,
            &pixels,
        ),
    };
    engine::output::write_rgb_png(&png, w, h, &tone.rgb_bytes(&pixels))?;
    Ok(Rendered {
        gain: tone.gain().unwrap_or(view.exposure),
        pixels,
        elapsed_ms,
        pipeline_build_ms: built.ms(),
        exr: exr.display().to_string(),
        png: png.display().to_string(),
    })
}

/// The reference of an integrator: per-pixel moments, its parameters, its EXR and PNG.
type Reference = (Vec<(f64, f64)>, RenderParams, String, String);

/// The integrator whose converged image is `i`'s reference (the integrator table's: `restir`
/// estimates the same integral as `direct`, whose reference is rendered once when both are
/// evaluated).
fn reference_of(i: Integrator) -> Integrator {
    i.unit().reference
}

/// One evaluation of lit integrators under way: the volume on the backend, the lights, the
/// progress through its renders and the equal-time budget once the first entry set it.
struct DirectRun<'a> {
    setup: &'a EvalSetup<'a>,
    resident: Resident<'a>,
    bounds: ([f64; 3], [f64; 3]),
    view: View,
    equal_time: bool,
    budget_ms: Option<f64>,
    done: usize,
    total: usize,
}

impl DirectRun<'_> {
    /// Announces the next render (progress line) and counts it.
    fn step(&mut self, what: &str, spp: u32) {
        crate::eval::step(self.setup, self.done, self.total, what, spp);
        self.done += 1;
    }

    /// The reference of `integrator`: ratio-tracking shadow rays at `--reference-spp`.
    fn reference(
        &mut self,
        base: &RenderParams,
        integrator: Integrator,
        lights: &SceneLights,
    ) -> Result<Reference> {
        let label = engine::integrators::integrator_name(integrator);
        let reference = engine::estimators::by_name("ratio").expect("registered");
        let mut ref_params = *base;
        ref_params.integrator = integrator as u32;
        reference.apply(&mut ref_params);
        ref_params.roulette = 0;
        ref_params.spp = self.setup.reference_spp;
        ref_params.seed = base.seed ^ 0x5eed_0001;
        let ref_params = engine::render::fit_collision_cap(&ref_params, &self.setup.volume.desc);
        self.step(&format!("the {label} reference"), ref_params.spp);
        let rendered = render_one(
            self.setup,
            &self.resident,
            &ref_params,
            lights,
            &stem(label, "reference"),
            self.view,
            true,
        )?;
        self.view.gain.get_or_insert(rendered.gain);
        Ok((
            moments(&rendered.pixels),
            ref_params,
            rendered.exr,
            rendered.png,
        ))
    }

    /// Exact shadows (regular tracking) with the entries' camera samples, for the paired
    /// errors of the shadow-map entries.
    fn exact(
        &mut self,
        base: &RenderParams,
        label: &str,
        lights: &SceneLights,
    ) -> Result<Vec<PixelOut>> {
        let mut p = *base;
        engine::estimators::by_name("regular")
            .expect("registered")
            .apply(&mut p);
        let p = engine::render::fit_collision_cap(&p, &self.setup.volume.desc);
        self.step(&format!("{label} with exact shadows (paired)"), p.spp);
        let rendered = render_one(
            self.setup,
            &self.resident,
            &p,
            lights,
            &stem(label, "exact"),
            self.view,
            false,
        )?;
        Ok(rendered.pixels)
    }

    /// `--equal-time`: for every entry after the first, a short timing run and the spp that
    /// fits the first entry's time (None for the first entry or without `--equal-time`).
    fn calibrate(
        &mut self,
        name: &str,
        params: &mut RenderParams,
        lights: &SceneLights,
    ) -> Result<Option<Calibration>> {
        let (true, Some(budget)) = (self.equal_time, self.budget_ms) else {
            return Ok(None);
        };
        let spp = calibration_spp(params.spp);
        let timing = RenderParams { spp, ..*params };
        crate::eval::step(
            self.setup,
            self.done,
            self.total,
            &format!("{name} (timing run)"),
            spp,
        );
        // The entry's first render: without its pipeline builds (GPU), which would otherwise
        // count against its budget.
        let (_, ms, _) = self
            .setup
            .backend
            .timed(|| engine::render::render_resident_lit(&self.resident, &timing, lights, false))
            .with_context(|| format!("timing {name}"))?;
        let (fitted, clamped) = equal_time_spp(budget, ms / spp as f64);
        if clamped {
            tracing::warn!(
                "--equal-time: {name} takes {:.3} ms per sample against a budget of \
                 {budget:.1} ms; it runs at {fitted} spp and misses the budget (its JSON entry \
                 records spp and elapsed_ms)",
                ms / spp as f64
            );
        }
        params.spp = fitted;
        Ok(Some(Calibration {
            spp,
            ms,
            budget_ms: budget,
            smape_at_budget: f64::NAN,
        }))
    }

    /// One entry of `integrator` (label `label`): its shadow rays or map, its image, its errors
    /// against the reference.
    fn entry(
        &mut self,
        base: &RenderParams,
        label: &str,
        entry: &ShadowEntry,
        lights: &SceneLights,
        reference: &Reference,
        exact: Option<&[PixelOut]>,
    ) -> Result<DirectEntry> {
        let mut params = *base;
        let mut entry_lights = lights.clone();
        let spec = match entry {
            ShadowEntry::Rays(spec) => spec,
            ShadowEntry::Map { .. } => {
                engine::estimators::by_name("jackknife").expect("registered")
            }
        };
        spec.apply(&mut params);
        let mut params = engine::render::fit_collision_cap(&params, &self.setup.volume.desc);
        let name = format!("{label}/{}", entry.name());
        let calibration = self.calibrate(&name, &mut params, &entry_lights)?;
        self.step(&name, params.spp);
        let map = match entry {
            ShadowEntry::Rays(_) => None,
            ShadowEntry::Map { kind, resolution } => {
                let opts = ShadowOptions {
                    kind: *kind,
                    resolution: *resolution,
                    ..Default::default()
                };
                let bounds = self.bounds;
                shadow_map::build_into(&self.resident, &params, &mut entry_lights, bounds, &opts)?
                    .map
            }
        };
        let (ref_m, ref_params, _, _) = reference;
        let mut e = measure(
            self.setup,
            &self.resident,
            &params,
            &entry_lights,
            ref_m,
            ref_params,
            label,
            &entry.name(),
            self.view,
            exact,
        )?;
        if let Some(m) = &map {
            e.elapsed_ms += m.build_ms;
        }
        e.calibration = calibration.map(|c| Calibration {
            smape_at_budget: smape_at_budget(e.smape, e.elapsed_ms, c.budget_ms),
            ..c
        });
        if self.equal_time && self.budget_ms.is_none() {
            self.budget_ms = Some(e.elapsed_ms);
        }
        e.shadow_map = map;
        Ok(e)
    }
}

/// Renders, for each of `integrators` (`direct`, `path`; `setup.params` carries the depths), the
/// reference (ratio-tracking shadow rays), the exact-shadow image if any entry is a map, each
/// entry's image, and the insets. `bounds` is the world box of the volume's density (the
/// maps' frame).
pub fn evaluate_direct(
    setup: &EvalSetup,
    integrators: &[Integrator],
    lights: &SceneLights,
    entries_in: &[ShadowEntry],
    bounds: ([f64; 3], [f64; 3]),
    exposure: f32,
    equal_time: bool,
) -> Result<DirectEvalReport> {
    let any_map = entries_in
        .iter()
        .any(|e| matches!(e, ShadowEntry::Map { .. }));
    anyhow::ensure!(
        !equal_time || !any_map,
        "--equal-time gives entries different sample counts, but a moment-shadow-map entry is \
         compared sample by sample with an exact-shadow image of --spp samples; drop \
         --equal-time or the msm entries"
    );
    std::fs::create_dir_all(setup.out_dir)
        .with_context(|| format!("creating {}", setup.out_dir.display()))?;
    let mut distinct: Vec<Integrator> = integrators.iter().map(|&i| reference_of(i)).collect();
    distinct.sort_by_key(|&i| i as u32);
    distinct.dedup();
    let mut run = DirectRun {
        setup,
        resident: Resident::new(setup.backend, setup.volume)?,
        bounds,
        view: View {
            exposure,
            gain: None,
        },
        equal_time,
        budget_ms: None,
        done: 0,
        total: distinct.len() + integrators.len() * (entries_in.len() + any_map as usize),
    };
    let mut references: Vec<ReferenceImage> = Vec::new();
    let mut entries = Vec::new();
    // References by integrator: one integrator's serves every other that names it.
    let mut rendered: Vec<(Integrator, Reference)> = Vec::new();
    for &integrator in integrators {
        let mut base = setup.params;
        base.integrator = integrator as u32;
        base.light_count = lights.points.len() as u32;
        let label = engine::integrators::integrator_name(integrator);
        let ref_integrator = reference_of(integrator);
        let reference = match rendered.iter().find(|(i, _)| *i == ref_integrator) {
            Some((_, r)) => r.clone(),
            None => {
                let r = run.reference(&base, ref_integrator, lights)?;
                rendered.push((ref_integrator, r.clone()));
                r
            }
        };
        // An integrator that resamples the point lights (restir) takes them out of the pmf
        // over kinds.
        let mut own = lights.clone();
        if integrator.unit().resamples_points {
            own.resample_points();
        }
        let exact = if any_map {
            Some(run.exact(&base, label, &own)?)
        } else {
            None
        };
        let mut pngs = vec![reference.3.clone()];
        for entry in entries_in {
            let e = run.entry(&base, label, entry, &own, &reference, exact.as_deref())?;
            pngs.push(e.png.clone());
            entries.push(e);
        }
        let insets = setup.out_dir.join(format!("{}.png", stem(label, "insets")));
        write_insets(&pngs, &insets)?;
        let (_, ref_params, exr, png) = reference;
        references.push(ReferenceImage {
            integrator: label.into(),
            reference: format!(
                "{}/ratio at {} spp",
                engine::integrators::integrator_name(ref_integrator),
                ref_params.spp
            ),
            spp: ref_params.spp,
            exr,
            png,
            insets: insets.display().to_string(),
        });
    }
    let l = &lights.lighting;
    Ok(DirectEvalReport {
        header: setup.header(),
        references,
        light_pmf: [l.p_sun, l.p_env, l.p_points],
        entries,
        preview_gain: run.view.gain,
    })
}

/// Renders one entry and measures it against the reference's per-pixel moments.
#[allow(clippy::too_many_arguments)]
fn measure(
    setup: &EvalSetup,
    resident: &Resident,
    params: &shared::params::RenderParams,
    lights: &SceneLights,
    ref_m: &[(f64, f64)],
    ref_params: &shared::params::RenderParams,
    label: &str,
    estimator: &str,
    view: View,
    exact: Option<&[PixelOut]>,
) -> Result<DirectEntry> {
    let name = format!("{label}/{estimator}");
    let Rendered {
        pixels: px,
        elapsed_ms,
        pipeline_build_ms,
        exr,
        png,
        ..
    } = render_one(
        setup,
        resident,
        params,
        lights,
        &stem(label, estimator),
        view,
        false,
    )?;
    let paired: Option<(f64, f64)> = exact.map(|ex| {
        let n = px.len() as f64;
        let d = px
            .iter()
            .zip(ex)
            .map(|(a, b)| a.t_mean as f64 - b.t_mean as f64);
        let mean = d.clone().sum::<f64>() / n;
        let rms = (d.map(|x| x * x).sum::<f64>() / n).sqrt();
        (rms, mean)
    });
    let m = moments(&px);
    let n = m.len() as f64;
    let pairs = m.iter().zip(ref_m);
    let smape = pairs
        .clone()
        .map(|((a, _), (b, _))| (a - b).abs() / (0.5 * (a.abs() + b.abs()) + SMAPE_EPS))
        .sum::<f64>()
        / n;
    let mean_bias = pairs.clone().map(|((a, _), (b, _))| a - b).sum::<f64>() / n;
    let var_sum = bias_variance(&m, ref_m, params, ref_params);
    let entry = DirectEntry {
        name,
        smape,
        mean_bias,
        mean_bias_se: var_sum.sqrt() / n,
        mean_std: m.iter().map(|(_, v)| v.sqrt()).sum::<f64>() / n,
        mean_radiance: m.iter().map(|(a, _)| a).sum::<f64>() / n,
        elapsed_ms,
        pipeline_build_ms,
        spp: params.spp,
        calibration: None,
        lookups_per_ray: px.iter().map(|p| p.samples as f64).sum::<f64>() / (n * params.spp as f64),
        flags: engine::render::diagnostics::RayFlags::of(&px, params.spp),
        collision_cap: params.collision_cap(),
        shadow_map: None,
        paired_rms: paired.map(|p| p.0),
        paired_mean: paired.map(|p| p.1),
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
    if let Some((rms, mean)) = paired {
        println!(
            "{:<24} paired with exact shadows: RMS {rms:.5}  mean {mean:+.5}",
            ""
        );
    }
    entry.flags.warn(params);
    Ok(entry)
}

/// Variance of n x `mean_bias` from the per-pixel (mean, variance) of an entry and of the
/// reference: the sum of both images' variances of the mean, or, when the entry reuses samples
/// between pixels (`restir --restir-passes`), its part bounded as fully correlated pixels,
/// (sum of standard errors)^2 (Cauchy-Schwarz).
fn bias_variance(
    m: &[(f64, f64)],
    ref_m: &[(f64, f64)],
    params: &shared::params::RenderParams,
    ref_params: &shared::params::RenderParams,
) -> f64 {
    let reference: f64 = ref_m.iter().map(|(_, v)| v / ref_params.spp as f64).sum();
    // Spatial reuse passes make neighbouring pixels' estimates correlated.
    let restir = Integrator::from_u32(params.integrator).unit().settings == OwnSettings::Restir;
    let correlated = restir && params.restir.passes > 0;
    let own = if correlated {
        let sd: f64 = m.iter().map(|(_, v)| (v / params.spp as f64).sqrt()).sum();
        sd * sd
    } else {
        m.iter().map(|(_, v)| v / params.spp as f64).sum()
    };
    own + reference
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smape_at_budget_scales_as_noise_with_the_time_missed() {
        // Twice the budget: the noise of half the time is sqrt(2) larger.
        let s = smape_at_budget(0.1, 2000.0, 1000.0);
        assert!((s - 0.1 * 2f64.sqrt()).abs() < 1e-12, "{s}");
        assert_eq!(smape_at_budget(0.1, 1000.0, 1000.0), 0.1);
        assert_eq!(smape_at_budget(0.1, 0.0, 1000.0), 0.1);
    }

    #[test]
    fn equal_time_spp_fits_the_budget_and_flags_clamps() {
        assert_eq!(equal_time_spp(1000.0, 10.0), (100, false));
        assert_eq!(equal_time_spp(1000.0, 3.0), (333, false));
        // One sample costs more than the budget: 1 spp, over budget, flagged.
        assert_eq!(equal_time_spp(5.0, 20.0), (1, true));
        assert_eq!(equal_time_spp(1e12, 1e-3), (MAX_EQUAL_TIME_SPP, true));
        assert_eq!(equal_time_spp(10.0, 0.0), (1, true));
        assert_eq!(equal_time_spp(f64::INFINITY, 1.0), (1, true));
        assert_eq!(calibration_spp(64), 8);
        assert_eq!(calibration_spp(3), 1);
    }

    /// Independent pixels add variances; pixels correlated by reuse are bounded as fully
    /// correlated ((sum of standard errors)^2), the reference always adds variances.
    #[test]
    fn reuse_bounds_the_bias_variance_as_correlated() {
        let m = [(0.0, 4.0), (0.0, 9.0)];
        let reference = [(0.0, 8.0), (0.0, 8.0)];
        let p = shared::params::RenderParams {
            spp: 1,
            integrator: shared::params::Integrator::Restir as u32,
            ..Default::default()
        };
        let r = shared::params::RenderParams { spp: 2, ..p };
        assert_eq!(bias_variance(&m, &reference, &p, &r), 13.0 + 8.0);
        let reused = shared::params::RenderParams {
            restir: shared::params::RestirParams {
                passes: 1,
                ..p.restir
            },
            ..p
        };
        assert_eq!(bias_variance(&m, &reference, &reused, &r), 25.0 + 8.0);
    }
}
