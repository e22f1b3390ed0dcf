//! What `host render` renders and where it writes it, and the checks of those options before
//! any work.

use super::settings::{Estimation, Exposure, Image, Lighting, PathDepth};
use crate::backend::BackendChoice;
use crate::output::OutputPlan;
use crate::scene::SceneOptions;
use anyhow::Result;
use shared::integrators::unit::OwnSettings;
use shared::params::{Integrator, RenderParams};
use std::path::{Path, PathBuf};

/// What `host render` renders and where it writes it: the scene, the groups of
/// [`super::settings`], the integrator's own settings and the outputs.
#[derive(Debug, Clone, Default)]
pub struct RenderOptions {
    pub scene: SceneOptions,
    pub image: Image,
    pub estimation: Estimation,
    /// Radiance with this integrator instead of primary-ray transmittance.
    pub integrator: Option<Integrator>,
    pub lighting: Lighting,
    /// `direct`, `path`: shadow rays toward the sun or its moment shadow map.
    pub shadows: crate::render::shadow_map::ShadowOptions,
    /// `restir`: candidates, target, its N and floor.
    pub restir: crate::integrators::restir::RestirOptions,
    /// `path`: vertices before Russian roulette, most vertices.
    pub path: PathDepth,
    pub exposure: Exposure,
    pub backend: BackendChoice,
    /// Output EXR; the PNG preview goes next to it.
    pub out: PathBuf,
    pub json: Option<PathBuf>,
    /// No progress bar or info lines.
    pub quiet: bool,
    /// The scene as the command line resolved it (recorded in the JSON summary as `scene`;
    /// empty: not recorded).
    pub scene_record: super::scene_record::SceneRecord,
    /// Extra EXR layers beside the image (`--layers`).
    pub layers: Vec<super::layers::Layer>,
    /// The scene file this render was read from (an input: never written).
    pub scene_file: Option<PathBuf>,
    /// `host merge`: shard files whose totals give the pixels instead of rendering them.
    pub merge: Vec<PathBuf>,
}

/// `host render --samples A..B --shard FILE`: one sample range of a render, written as exact
/// totals.
#[derive(Debug, Clone)]
pub struct ShardOutput {
    pub path: PathBuf,
    /// Samples [start, end) of the render's --spp.
    pub samples: (u32, u32),
}

impl ShardOutput {
    /// Refuses a range outside 0..spp, empty, or not cut at sample blocks (shards cut
    /// elsewhere could not add up to one render's bytes).
    pub fn check(&self, spp: u32) -> Result<()> {
        let (a, b) = self.samples;
        let block = shared::kernels::render::SAMPLE_BLOCK;
        anyhow::ensure!(
            a < b && b <= spp,
            "--samples {a}..{b}: give a non-empty range within the render's --spp {spp} (A < B <= \
             {spp})"
        );
        anyhow::ensure!(
            a % block == 0 && (b % block == 0 || b == spp),
            "--samples {a}..{b}: a shard starts and ends at a multiple of {block} samples (or \
             ends at --spp {spp}), so that shards add up to the bytes of one render; e.g. \
             --samples {}..{}",
            a / block * block,
            (b.div_ceil(block) * block).min(spp)
        );
        Ok(())
    }
}

impl RenderOptions {
    /// The settings of the integrator's own ([`OwnSettings::None`] without one).
    pub fn own_settings(&self) -> OwnSettings {
        self.integrator
            .map_or(OwnSettings::None, |i| i.unit().settings)
    }
}

/// Checks the options a render reads before any work: `restir`'s settings against the image,
/// the shadow-map options, and that `--out` is an .exr file. (Whether each flag applies to the
/// integrator is the command line's check: `host::cli::applicable`.)
pub fn check_render_flags(args: &RenderOptions) -> Result<()> {
    if args.own_settings() == OwnSettings::Restir {
        args.restir.check()?;
        args.restir
            .check_image(args.image.width, args.image.height)?;
    }
    args.shadows.check()?;
    super::layers::check(
        &args.layers,
        args.image.spp,
        args.integrator.is_some(),
        args.image.sampler,
    )?;
    let is_exr = args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    anyhow::ensure!(
        is_exr,
        "--out {}: the image is written as a linear OpenEXR file, so --out must end in .exr (the \
         PNG preview is written next to it with the extension .png)",
        args.out.display()
    );
    Ok(())
}

/// Checks every output of `host render` up front: the EXR, its PNG preview and the JSON must
/// be distinct, must not replace the input volume, and must be writable. Returns the PNG path.
pub fn plan_render_outputs(args: &RenderOptions) -> Result<std::path::PathBuf> {
    let png = args.out.with_extension("png");
    let mut plan = OutputPlan::new();
    plan.input("--volume", Path::new(&args.scene.volume))
        .file("--out", &args.out)
        .file("the PNG preview of --out", &png);
    if let Some(crate::lighting::EnvSource::File(env)) = &args.lighting.env {
        crate::lighting::env::check_path(env)?;
        plan.input("--env", env);
    }
    if let Some(scene) = &args.scene_file {
        plan.input("--scene", scene);
    }
    if let Some(json) = &args.json {
        plan.file("--json", json);
    }
    for shard in &args.merge {
        plan.input("a shard", shard);
    }
    plan.check()?;
    Ok(png)
}

/// Checks the output of `host render --shard FILE` up front: not an input, writable.
pub fn plan_shard_output(args: &RenderOptions, shard: &Path) -> Result<()> {
    let mut plan = OutputPlan::new();
    plan.input("--volume", Path::new(&args.scene.volume))
        .file("--shard", shard);
    if let Some(crate::lighting::EnvSource::File(env)) = &args.lighting.env {
        crate::lighting::env::check_path(env)?;
        plan.input("--env", env);
    }
    if let Some(scene) = &args.scene_file {
        plan.input("--scene", scene);
    }
    plan.check()
}

/// The parameters of the camera rays' transmittance render of an integrator render with
/// `--layers camera-transmittance` or `albedo` (None: no such render).
pub fn camera_params(args: &RenderOptions, params: &RenderParams) -> Option<RenderParams> {
    if args.integrator.is_none() || !args.layers.iter().any(|l| l.needs_camera()) {
        return None;
    }
    let mut p = *params;
    p.integrator = Integrator::Transmittance as u32;
    p.light_count = 0;
    Some(p)
}

/// The passes a render's layers need beyond the image, by name: the camera rays' transmittance
/// (`camera-transmittance`, `albedo` of an integrator render) and the first collision
/// (`depth`).
pub fn extra_passes(
    args: &RenderOptions,
    params: &RenderParams,
) -> Vec<(&'static str, RenderParams)> {
    use super::layers::Layer;
    let camera = camera_params(args, params).map(|p| (Layer::CameraTransmittance.name(), p));
    let depth = depth_params(args, params).map(|p| (Layer::Depth.name(), p));
    camera.into_iter().chain(depth).collect()
}

/// The parameters of the first-collision pass of a render with `--layers depth` (None: no such
/// pass): the same camera rays, delta tracking to their first collision.
pub fn depth_params(args: &RenderOptions, params: &RenderParams) -> Option<RenderParams> {
    if !args.layers.contains(&super::layers::Layer::Depth) {
        return None;
    }
    let mut p = *params;
    p.integrator = Integrator::Transmittance as u32;
    p.light_count = 0;
    p.estimator = shared::params::Estimator::FirstCollision as u32;
    Some(p)
}
