//! `host eval` as a library call: the options, their checks, and the runs of the transmittance
//! estimators, the single-scattering integrators and the lit integrators against a reference.

use crate::eval_direct::ShadowEntry;
use anyhow::{bail, Result};
use engine::backend::job::{costliest, work_of, Job, WorkKind};
use engine::backend::{Backend, BackendChoice};
use engine::defaults;
use engine::estimators::EstimatorSpec;
use engine::output::OutputPlan;
use engine::render_job::{
    direct_lights, lights_or_default, Estimation, Exposure, Image, Lighting, PathDepth,
    RenderOptions,
};
use engine::scene::camera::occupied_world_bounds;
use engine::scene::{prepare_scene, Scene, SceneOptions};
use engine::volume::VolumeData;
use shared::params::RenderParams;
use shared::params::{Integrator, TransmittanceHat};
use shared::volume::grid::Lookup;
use std::path::{Path, PathBuf};

/// What `host eval` measures and where it writes it.
#[derive(Debug, Clone)]
pub struct EvalOptions {
    pub scene: SceneOptions,
    pub lookup: Lookup,
    /// The transmittance estimators (or, with `direct`, `path` or `restir`, the shadow-ray
    /// estimators and moment shadow maps) to evaluate.
    pub estimators: Vec<ShadowEntry>,
    /// Integrators to evaluate instead of transmittance estimators (empty: the estimators on
    /// camera rays): single-scattering integrators, or `direct`, `path` and `restir`.
    pub integrators: Vec<Integrator>,
    pub t_hat: TransmittanceHat,
    /// The lights, the albedo (one value: the single-scattering integrators need equal
    /// channels) and the phase function (g only with `integrators`).
    pub lighting: Lighting,
    /// `--integrators restir`: candidates, target, its N and floor.
    pub restir: engine::integrators::restir::RestirOptions,
    /// `--integrators direct|path|restir`: every entry gets the first entry's render time.
    pub equal_time: bool,
    /// `--integrators path`: vertices before roulette, most vertices.
    pub path: PathDepth,
    pub exposure: f32,
    pub n: u32,
    pub f_delta: f32,
    pub ratio_roulette: bool,
    /// The image (its sampler independent: eval reports standard errors from per-pixel
    /// sample variances).
    pub image: Image,
    /// Estimates per pixel of a stochastic reference (None: 4 x spp, 16 x spp for integrators).
    pub reference_spp: Option<u32>,
    pub backend: BackendChoice,
    pub out_dir: PathBuf,
    /// JSON report path (None: <out_dir>/eval.json).
    pub json: Option<PathBuf>,
    pub bias_scale: f32,
    pub std_scale: f32,
    /// No progress bars or info lines.
    pub quiet: bool,
    /// Where the reference comes from: rendered, written as a shard, or added up from shards.
    pub reference_source: crate::reference::ReferenceSource,
}

impl Default for EvalOptions {
    fn default() -> Self {
        EvalOptions {
            scene: SceneOptions::default(),
            lookup: Lookup::Nearest,
            estimators: every_estimator(),
            integrators: Vec::new(),
            t_hat: TransmittanceHat::Jackknife,
            lighting: Lighting::default(),
            restir: Default::default(),
            path: PathDepth::default(),
            equal_time: false,
            exposure: defaults::EXPOSURE,
            n: defaults::N,
            f_delta: defaults::F_DELTA,
            ratio_roulette: false,
            image: Image {
                width: crate::defaults::EVAL_SIZE,
                height: crate::defaults::EVAL_SIZE,
                spp: crate::defaults::EVAL_SPP,
                seed: 0,
                sampler: shared::params::Sampler::Independent,
            },
            reference_spp: None,
            backend: BackendChoice::Auto,
            out_dir: PathBuf::from(crate::defaults::EVAL_OUT_DIR),
            json: None,
            bias_scale: crate::defaults::BIAS_SCALE,
            std_scale: crate::defaults::STD_SCALE,
            quiet: false,
            reference_source: Default::default(),
        }
    }
}

/// Every estimator but regular tracking (the deterministic reference), as shadow-ray entries:
/// `--estimators all`.
pub fn every_estimator() -> Vec<ShadowEntry> {
    crate::eval::every_estimator()
        .into_iter()
        .map(ShadowEntry::Rays)
        .collect()
}

/// Parses an `--integrators` list of `host eval` (comma-separated names or "all"): `direct`,
/// `path` and `restir` together or alone (each once), or single-scattering integrators.
pub fn parse_integrators(list: &str) -> Result<Vec<Integrator>> {
    let names: Vec<&str> = list.split(',').map(str::trim).collect();
    let lit: Vec<Integrator> = names
        .iter()
        .filter_map(|n| engine::integrators::parse_integrator(n).ok())
        .filter(|i| i.is_lit())
        .collect();
    if lit.is_empty() {
        return Ok(engine::integrators::parse_integrator_list(list)?
            .into_iter()
            .map(|(_, i)| i)
            .collect());
    }
    anyhow::ensure!(
        lit.len() == names.len(),
        "--integrators {list}: direct, path and restir are evaluated together or alone (their \
         entries are shadow-ray estimators under the same lights); evaluate the \
         single-scattering integrators in a separate run"
    );
    let mut unique: Vec<Integrator> = Vec::new();
    for i in lit {
        if !unique.contains(&i) {
            unique.push(i);
        }
    }
    Ok(unique)
}

/// The estimators of a transmittance or single-scattering evaluation: `entries` without moment
/// shadow maps, which only `direct`, `path` and `restir` read.
pub fn rays_only(entries: &[ShadowEntry]) -> Result<Vec<&'static EstimatorSpec>> {
    entries
        .iter()
        .map(|e| match e {
            ShadowEntry::Rays(spec) => Ok(*spec),
            ShadowEntry::Map { .. } => bail!(
                "--estimators {}: a moment shadow map replaces the sun's shadow rays of \
                 --integrators direct, path or restir; add one of those or drop it",
                e.name()
            ),
        })
        .collect()
}

/// Names of integrators, comma-separated (error messages).
fn names(integrators: &[Integrator]) -> String {
    let names: Vec<&str> = integrators
        .iter()
        .map(|&i| engine::integrators::integrator_name(i))
        .collect();
    names.join(",")
}

/// Opens the backend of `--backend` and loads and packs the volume in the pages it binds,
/// refusing grids it cannot hold before any voxel is read.
fn open_scene(args: &EvalOptions) -> Result<(Backend, Scene)> {
    let backend = Backend::open(args.backend)?;
    let check = backend.topology_check(args.backend, args.scene.brick_size);
    let scene = prepare_scene(
        &args.scene,
        args.lookup,
        args.image.width,
        args.image.height,
        backend.page_log2(),
        Some(engine::io::TopologyCheck(&check)),
    )?;
    Ok((backend, scene))
}

/// The setup of an evaluation against `reference` at `reference_spp`, with the report's
/// scales, output directory and super-voxel grid from `args`.
fn eval_setup<'a>(
    args: &'a EvalOptions,
    backend: &'a Backend,
    vol: &dyn VolumeData,
    packed: &'a engine::scene::bricks::PackedVolume,
    params: RenderParams,
    reference: &'a EstimatorSpec,
    reference_spp: u32,
) -> Result<crate::eval::EvalSetup<'a>> {
    Ok(crate::eval::EvalSetup {
        backend,
        volume: packed,
        volume_name: vol.name().to_owned(),
        params,
        reference,
        reference_spp,
        out_dir: &args.out_dir,
        bias_scale: args.bias_scale,
        std_scale: args.std_scale,
        progress: !args.quiet,
        reference_source: &args.reference_source,
        supervoxels: Some(engine::scene::supervoxel_info::SupervoxelInfo::of(
            packed,
            args.scene.supervoxels.mode()?,
            args.scene.supervoxel_format,
            &params,
        )),
    })
}

/// `host eval`: the reference and each estimator on pixel-center rays; JSON + images. With
/// `--reference-shard`, only the reference's shard.
pub fn run_eval(args: &EvalOptions) -> Result<()> {
    use crate::reference::{ReferenceSource, ShardWritten};
    if args.reference_source != ReferenceSource::Render {
        let mut lit: Vec<Integrator> = args
            .integrators
            .iter()
            .copied()
            .filter(|i| i.is_lit())
            .collect();
        lit.dedup();
        anyhow::ensure!(
            lit.len() <= 1,
            "--reference-shard and --reference-from take one reference: evaluate one of --integrators {} \
             per run",
            names(&lit)
        );
    }
    match evaluate_all(args) {
        Err(e) if e.downcast_ref::<ShardWritten>().is_some() => Ok(()),
        other => other,
    }
}

/// [`run_eval`] without the reference-source checks.
fn evaluate_all(args: &EvalOptions) -> Result<()> {
    // The reference's spp is at most 16 x spp when not given.
    let most_spp = args
        .reference_spp
        .unwrap_or(args.image.spp.saturating_mul(16))
        .max(args.image.spp);
    engine::render::check_image_memory(
        args.image.width,
        args.image.height,
        2,
        engine::render::keeps_totals(most_spp),
    )?;
    let lit = args.integrators.iter().filter(|i| i.is_lit()).count();
    if lit > 0 {
        anyhow::ensure!(
            lit == args.integrators.len(),
            "--integrators {}: direct, path and restir are evaluated together or alone (their \
             entries are shadow-ray estimators under the same lights); evaluate the \
             single-scattering integrators in a separate run",
            names(&args.integrators)
        );
        let mut unique: Vec<Integrator> = Vec::new();
        for &i in &args.integrators {
            if !unique.contains(&i) {
                unique.push(i);
            }
        }
        return run_eval_direct(args, &unique);
    }
    check_single_scattering_flags(args)?;
    let estimators = rays_only(&args.estimators)?;
    let integrators: Option<Vec<(&'static str, Integrator)>> =
        (!args.integrators.is_empty()).then(|| {
            args.integrators
                .iter()
                .map(|&i| (engine::integrators::integrator_name(i), i))
                .collect()
        });
    let images = match &integrators {
        Some(list) => crate::eval::integrator_files(&args.out_dir, list.iter().map(|(n, _)| *n)),
        None => crate::eval::estimator_files(&args.out_dir, estimators.iter().map(|e| e.name)),
    };
    let json = plan_eval_outputs(args, &images)?;
    let lookup = args.lookup;
    let (backend, scene) = open_scene(args)?;
    let (vol, packed) = (&scene.volume, &scene.packed);
    let job = match &integrators {
        // Each integrator: every estimator at --spp and a jackknife reference at 16 x --spp.
        Some(list) => eval_job(
            list.iter().map(|(_, i)| *i),
            args,
            estimators.len(),
            args.reference_spp.unwrap_or(16 * args.image.spp),
        ),
        None => eval_job(
            [Integrator::Transmittance],
            args,
            estimators.len(),
            args.reference_spp.unwrap_or(4 * args.image.spp),
        ),
    };
    let backend = backend.fit(args.backend, packed, &job)?;
    if !args.quiet {
        tracing::info!("backend: {} ({})", backend.kind(), backend.device());
    }
    let params = eval_params(args, &scene);
    if let Some(integrators) = &integrators {
        return run_eval_integrators(args, integrators, &json, vol, packed, &backend, params);
    }
    let (reference, reference_spp) = match lookup {
        // Deterministic and exact for nearest lookups: one estimate per pixel suffices.
        Lookup::Nearest => (
            engine::estimators::by_name("regular").expect("registered"),
            1,
        ),
        // Regular tracking integrates the nearest-neighbour grid only: ratio tracking is
        // unbiased for any lookup.
        Lookup::Stochastic | Lookup::Trilinear => (
            engine::estimators::by_name("ratio").expect("registered"),
            args.reference_spp.unwrap_or(4 * args.image.spp),
        ),
    };
    let setup = eval_setup(
        args,
        &backend,
        vol,
        packed,
        params,
        reference,
        reference_spp,
    )?;
    let report = crate::eval::evaluate(&setup, &estimators)?;
    crate::eval::write_report(&json, &report)?;
    println!("wrote {}", json.display());
    Ok(())
}

/// `restir`'s settings checked when it is evaluated, refused when it is not.
fn check_restir_flags(args: &EvalOptions, integrators: &[Integrator]) -> Result<()> {
    let reads_restir = integrators
        .iter()
        .any(|i| i.unit().settings == shared::integrators::unit::OwnSettings::Restir);
    if reads_restir {
        args.restir.check()?;
        args.restir
            .check_image(args.image.width, args.image.height)?;
    } else {
        anyhow::ensure!(
            args.restir == engine::integrators::restir::RestirOptions::default(),
            "the --restir-* flags apply to --integrators restir; add it or drop them"
        );
    }
    Ok(())
}

/// Refuses the flags that only `--integrators direct`, `path` or `restir` read, in an
/// evaluation of transmittance estimators or single-scattering integrators.
fn check_single_scattering_flags(args: &EvalOptions) -> Result<()> {
    anyhow::ensure!(
        !args.equal_time,
        "--equal-time applies to --integrators direct, path or restir; add one or drop it"
    );
    anyhow::ensure!(
        args.lighting.random_lights.is_none(),
        "--lights random:N applies to --integrators direct, path or restir (the \
         single-scattering integrators take at most {} lights, by --light); drop --lights",
        shared::sampling::lights::MAX_LIGHTS
    );
    anyhow::ensure!(
        args.restir == engine::integrators::restir::RestirOptions::default(),
        "the --restir-* flags apply to --integrators restir; add it or drop them"
    );
    let given_direct = args.lighting.env.is_some() || args.lighting.sun.is_some();
    anyhow::ensure!(
        !given_direct,
        "--env and --sun only apply to --integrators direct; add it or drop them"
    );
    Ok(())
}

/// The kernels' parameters of a transmittance or single-scattering evaluation: the camera's
/// pixel centres (no pixel jitter: every estimate of a pixel sees the reference's ray).
fn eval_params(args: &EvalOptions, scene: &Scene) -> RenderParams {
    RenderParams {
        n: args.n,
        f_delta: args.f_delta,
        pixel_jitter: 0,
        roulette: args.ratio_roulette as u32,
        ..scene.params(
            args.image.width,
            args.image.height,
            args.image.spp,
            args.image.seed,
        )
    }
}

/// Checks every output of `host eval` before any work: `--out-dir` and each image in it, and
/// the JSON report, distinct and writable. Returns the JSON path.
fn plan_eval_outputs(
    args: &EvalOptions,
    images: &[std::path::PathBuf],
) -> Result<std::path::PathBuf> {
    let json = args
        .json
        .clone()
        .unwrap_or_else(|| args.out_dir.join("eval.json"));
    let mut plan = OutputPlan::new();
    plan.input("--volume", Path::new(&args.scene.volume))
        .dir("--out-dir", &args.out_dir);
    if let Some(engine::lighting::EnvSource::File(env)) = &args.lighting.env {
        engine::lighting::env::check_path(env)?;
        plan.input("--env", env);
    }
    for image in images {
        plan.file("an image of --out-dir", image);
    }
    match &args.reference_source {
        crate::reference::ReferenceSource::WriteShard { path, .. } => {
            plan.file("--reference-shard", path);
        }
        crate::reference::ReferenceSource::Shards(paths) => {
            for shard in paths {
                plan.input("--reference-from", shard);
            }
        }
        crate::reference::ReferenceSource::Render => {}
    }
    plan.file("--json", &json).check()?;
    Ok(json)
}

/// `host eval --integrators`: single scattering against an unbiased high-spp reference.
fn run_eval_integrators(
    args: &EvalOptions,
    integrators: &[(&'static str, Integrator)],
    json: &std::path::Path,
    vol: &dyn VolumeData,
    packed: &engine::scene::bricks::PackedVolume,
    backend: &Backend,
    mut params: RenderParams,
) -> Result<()> {
    let lights = lights_or_default(
        &args.lighting.lights,
        args.lighting.albedo[0],
        args.exposure,
        vol,
    )?;
    params.light_count = lights.len() as u32;
    params.albedo = args.lighting.albedo[0];
    params.hg_g = args.lighting.hg_g;
    params.pixel_jitter = 1;
    params.t_hat = args.t_hat as u32;
    let setup = eval_setup(
        args,
        backend,
        vol,
        packed,
        params,
        engine::estimators::by_name("jackknife").expect("registered"),
        args.reference_spp.unwrap_or(16 * args.image.spp),
    )?;
    let report = crate::eval::evaluate_integrators(&setup, &lights, integrators, args.exposure)?;
    engine::output::write_json(json, &report)?;
    println!("wrote {}", json.display());
    Ok(())
}

/// The work of an evaluation for `--backend auto`'s cost model: for each of `integrators`,
/// `renders` images at `--spp` and a reference at `reference_spp`; the costliest integrator's
/// kind stands for all.
fn eval_job(
    integrators: impl IntoIterator<Item = Integrator>,
    args: &EvalOptions,
    renders: usize,
    reference_spp: u32,
) -> Job {
    let kinds: Vec<WorkKind> = integrators.into_iter().map(|i| work_of(Some(i))).collect();
    let pixels = u64::from(args.image.width) * u64::from(args.image.height);
    let spp = u64::from(args.image.spp) * renders as u64 + u64::from(reference_spp);
    Job {
        kind: costliest(&kinds),
        samples: pixels * spp * kinds.len() as u64,
        wide: false,
    }
}

/// `host eval --integrators direct`: each shadow-ray estimator of `--estimators` in the `direct`
/// integrator against ratio-tracking shadow rays at `--reference-spp` (default 16 x `--spp`).
fn run_eval_direct(args: &EvalOptions, integrators: &[Integrator]) -> Result<()> {
    let entries = args.estimators.clone();
    let names: Vec<String> = entries.iter().map(|e| e.name()).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let images = crate::eval_direct::direct_files(&args.out_dir, integrators, &names);
    let json = plan_eval_outputs(args, &images)?;
    let (backend, scene) = open_scene(args)?;
    let (vol, packed) = (&scene.volume, &scene.packed);
    let reference_spp = args.reference_spp.unwrap_or(16 * args.image.spp);
    let job = eval_job(
        integrators.iter().copied(),
        args,
        entries.len(),
        reference_spp,
    );
    let backend = backend.fit(args.backend, packed, &job)?;
    if !args.quiet {
        tracing::info!("backend: {} ({})", backend.kind(), backend.device());
    }
    let render = RenderOptions {
        scene: args.scene.clone(),
        image: args.image,
        estimation: Estimation {
            lookup: args.lookup,
            n: args.n,
            f_delta: args.f_delta,
            ratio_roulette: args.ratio_roulette,
            ..Default::default()
        },
        integrator: Some(integrators[0]),
        lighting: args.lighting.clone(),
        restir: args.restir,
        path: args.path,
        exposure: Exposure {
            gain: args.exposure,
            fixed: false,
        },
        backend: args.backend,
        out: PathBuf::from("unused.exr"),
        quiet: args.quiet,
        ..Default::default()
    };
    let lights = direct_lights(&render, vol)?;
    if let Some(map) = entries
        .iter()
        .find(|e| matches!(e, crate::eval_direct::ShadowEntry::Map { .. }))
    {
        anyhow::ensure!(
            lights.lighting.sun.present != 0,
            "--estimators {}: a moment shadow map is the sun's; add --sun x,y,z (or --env sky, \
             whose sun it is)",
            map.name()
        );
    }
    let params = RenderParams {
        n: args.n,
        f_delta: args.f_delta,
        pixel_jitter: 1,
        rr_depth: args.path.rr_depth,
        max_depth: args.path.max_depth,
        hg_g: args.lighting.hg_g,
        ..scene.params(
            args.image.width,
            args.image.height,
            args.image.spp,
            args.image.seed,
        )
    };
    check_restir_flags(args, integrators)?;
    let mut params = params;
    args.restir.apply(&mut params);
    let setup = eval_setup(
        args,
        &backend,
        vol,
        packed,
        params,
        engine::estimators::by_name("ratio").expect("registered"),
        args.reference_spp.unwrap_or(16 * args.image.spp),
    )?;
    let report = crate::eval_direct::evaluate_direct(
        &setup,
        integrators,
        &lights,
        &entries,
        occupied_world_bounds(vol),
        args.exposure,
        args.equal_time,
    )?;
    engine::output::write_json(&json, &report)?;
    println!("wrote {}", json.display());
    Ok(())
}
