//! The JSON summary of one render (docs/reference/json.md).

use super::options::RenderOptions;
use crate::backend::gpu::BuildTime;
use crate::backend::Backend;
use crate::lighting::SceneLights;
use crate::render::diagnostics::RayFlags;
use crate::render::shadow_map::ShadowSummary;
use crate::scene::supervoxel_info::SupervoxelInfo;
use crate::scene::{lookup_name, Scene};
use crate::volume::VolumeData;
use anyhow::Result;
use shared::integrators::unit::OwnSettings;
use shared::params::{Integrator, RenderParams};
use shared::sampling::lights::PointLight;
use std::path::Path;

/// JSON summary of one render (field names are part of the CLI's interface; docs/reference/json.md).
#[derive(serde::Serialize)]
pub struct RenderSummary {
    pub backend: String,
    pub device: String,
    pub volume: String,
    /// Voxel counts of the grid (the file's active bounding box) along x, y, z.
    pub dims: [u32; 3],
    /// The transmittance estimator, or for an integrator render the integrator's name.
    pub estimator: String,
    pub lookup: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u32,
    /// Where each sample's uniforms came from: "independent" or "sobol" (stratified within a
    /// pixel: per-pixel sample variances then overstate the error of the mean).
    pub sampler: String,
    pub n: u32,
    pub density_scale: f32,
    pub brick_size: u32,
    /// How the super-voxel statistics are stored ("f32" or "bc4"; `brick_table_bytes` is the
    /// table as held, decoded to f32; `bc4_brick_table_bytes` what a BC4 table would take).
    pub supervoxel_format: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bc4_brick_table_bytes: Option<u64>,
    /// "fixed" (one super-voxel per brick) or "adaptive" (subdivided bricks).
    pub supervoxels: String,
    /// Adaptive: voxels per cell axis and the split ratio the grid was built with.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub supervoxel_cell_size: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split_ratio: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split_occupancy: Option<f32>,
    /// Bricks split into cells, and the cell records they add to the table (each split brick
    /// adds a cell box record too, counted in `brick_table_bytes`, not here).
    pub subdivided_bricks: usize,
    pub supervoxel_cells: usize,
    /// Most cell iterations one traversal of the super-voxels may take (0: none subdivided).
    pub cell_traversal_steps: u32,
    /// Super-voxel (and, for comparison, brick) reads of one traversal per pixel-centre
    /// camera ray that meets the grid; the estimators' lookups are counted apart.
    pub supervoxel_reads_per_ray: crate::scene::traversal::ReadsPerRay,
    /// Render time, without the GPU pipeline builds it waited for.
    pub elapsed_ms: f64,
    /// Wall time of the GPU pipeline builds during the render (each kernel variant compiles on
    /// first use: seconds to minutes on lavapipe, less with the driver's disk cache), and how
    /// many were built.
    pub pipeline_build_ms: f64,
    pub pipeline_builds: u64,
    pub mean_samples_per_ray: f64,
    /// Mean transmittance (transmittance renders only).
    #[serde(rename = "mean_T", skip_serializing_if = "Option::is_none")]
    pub mean_t: Option<f64>,
    pub exr: String,
    pub png: String,
    /// CDF step of jackknife-adaptive.
    pub f_delta: f32,
    /// Whether ratio tracking used Russian roulette (`--ratio-roulette`).
    pub ratio_roulette: bool,
    /// Rays traced, rays a loop bound changed, rays outside the jackknife's regime.
    #[serde(flatten)]
    pub flags: crate::render::diagnostics::RayFlags,
    /// The grid read from a volume file (absent for embedded volumes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grid: Option<String>,
    /// The volume's up axis (`--up`), the world bounds of its occupied voxels in the renderer's
    /// y-up world, and the camera (position, unit forward, vertical field of view).
    pub up: crate::scene::camera::UpAxis,
    pub world_bounds: [[f64; 3]; 2],
    pub camera: CameraSummary,
    /// Mean radiance (integrator renders only).
    #[serde(rename = "mean_L", skip_serializing_if = "Option::is_none")]
    pub mean_l: Option<f64>,
    /// Everything an integrator render depends on beyond the fields above.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub integrator: Option<IntegratorSettings>,
    /// Nonzero densities that became 0 as scaled f16 values (see the warning).
    pub underflowed_voxels: u64,
    /// Bricks of the grid, those holding a nonzero voxel, and the bytes of the voxel pool (the
    /// f16 voxels of the occupied bricks only) and of the brick table.
    pub bricks: usize,
    pub occupied_bricks: usize,
    pub pool_bytes: u64,
    pub brick_table_bytes: u64,
    /// Pages of the voxel pool (a GPU binds up to 8) and their size: 128 MiB, what every
    /// device binds, or up to 1 GiB on a GPU with larger storage buffers.
    pub pool_pages: usize,
    pub pool_page_bytes: u64,
    /// Most iterations of one traversal of the bricks and of one traversal of the voxels (the
    /// bound from the occupied bricks with empty-space skipping, or the stepping bound if
    /// smaller; a traversal that would exceed it is counted in `capped_rays`), and the loop
    /// iterations one ray of this render may take (a GPU invocation runs at most 60000).
    pub brick_traversal_steps: u32,
    pub voxel_traversal_steps: u32,
    pub loop_iterations_per_ray: u64,
    /// How the loaded voxels were held before packing: "dense" (the bounding box as f32) or
    /// "sparse" (a file's leaves and tiles only), and their bytes.
    pub volume_storage: String,
    pub volume_bytes: u64,
    /// Wall time to load (or generate) and pack the volume.
    pub prepare_ms: f64,
    /// The host version and the command line, to reproduce the image.
    pub host_version: String,
    pub command_line: Vec<String>,
    /// The resolved scene by flag name (`host render --scene THIS.json` renders it again).
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub scene: super::scene_record::SceneRecord,
    /// The shard files a merged render was added up from (`host merge`), in sample order.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shards: Option<Vec<super::shard::ShardSummary>>,
    /// The passes its `--layers` rendered beside the image (`camera-transmittance`, `depth`),
    /// with their rays that a loop bound changed.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub layer_passes: Vec<LayerPass>,
    /// How the PNG preview shows the linear image (radiance renders).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub preview: Option<PreviewSummary>,
}

/// The view transform of a radiance render's PNG preview ([`super::preview`]).
#[derive(serde::Serialize)]
pub struct PreviewSummary {
    /// `filmic` (the curve after the gain, then sRGB).
    pub transform: &'static str,
    /// `--exposure`.
    pub exposure: f32,
    /// The automatic exposure the gain includes (None with `--fixed-exposure`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto_exposure: Option<f32>,
    /// The gain applied to radiance: exposure times auto_exposure.
    pub gain: f32,
}

impl PreviewSummary {
    /// The summary of `tone`, the preview of a render with `args` (None for transmittance).
    pub fn of(args: &RenderOptions, tone: super::preview::Preview) -> Option<Self> {
        tone.gain().map(|gain| PreviewSummary {
            transform: super::preview::TRANSFORM,
            exposure: args.exposure.gain,
            auto_exposure: (!args.exposure.fixed).then(|| gain / args.exposure.gain),
            gain,
        })
    }
}

/// One extra pass of a render's layers in its JSON summary.
#[derive(serde::Serialize)]
pub struct LayerPass {
    pub name: String,
    pub capped_rays: u64,
}

/// The camera of a render, as resolved.
#[derive(serde::Serialize)]
pub struct CameraSummary {
    pub position: [f32; 3],
    pub forward: [f32; 3],
    pub fov_deg: f32,
}

/// The settings of an integrator render, as resolved (default lights included).
#[derive(serde::Serialize)]
pub struct IntegratorSettings {
    pub name: String,
    /// The transmittance estimator of the shadow rays (the jackknife for the single-scattering
    /// integrators; `--estimator` for `direct`).
    pub shadow_rays: String,
    /// Every `--light` (or default) light as [x, y, z, intensity] in world units (the `--light`
    /// syntax); the lights of `--lights random:N` are in `random_lights`.
    pub lights: Vec<[f32; 4]>,
    /// `direct`, `path`: the `--lights random:N,seed` scatter (reproducible from it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub random_lights: Option<String>,
    /// `direct`, `path`: all point lights (`--light` and random), drawn by power.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub point_lights: Option<usize>,
    /// One number, or [r, g, b] for an RGB albedo.
    pub albedo: Albedo,
    /// `direct`: the environment light (`sky`, a file, or `none`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub env: Option<String>,
    /// `direct`: the sun as [x, y, z] (unit, toward it), irradiance, angular radius in degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sun: Option<SunSettings>,
    /// `direct`, `path`: shadow rays toward the sun (`rays`) or its moment shadow map.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shadows: Option<crate::render::shadow_map::ShadowSummary>,
    /// `direct`: probability of sampling the sun, the map and the point lights.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub light_pmf: Option<[f32; 3]>,
    /// `direct`, `path`: the collision cap of every tracking loop (10000 unless one invocation
    /// would exceed a GPU invocation's loop budget).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub collision_cap: Option<u32>,
    /// `path`: vertices before Russian roulette, and the most vertices of a path.
    /// `restir`: candidates, target, its N and floor.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub restir: Option<crate::integrators::restir::RestirSettings>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rr_depth: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_depth: Option<u32>,
    pub hg_g: f32,
    pub t_hat: String,
    /// `--exposure` (the preview's view transform: the summary's `preview`).
    pub exposure: f32,
}

/// An albedo in the JSON summary: a number when the channels agree.
#[derive(serde::Serialize)]
#[serde(untagged)]
pub enum Albedo {
    Grey(f32),
    Rgb([f32; 3]),
}

impl From<[f32; 3]> for Albedo {
    fn from(a: [f32; 3]) -> Self {
        if a[0] == a[1] && a[1] == a[2] {
            Albedo::Grey(a[0])
        } else {
            Albedo::Rgb(a)
        }
    }
}

/// The sun of a `direct` render as resolved.
#[derive(serde::Serialize)]
pub struct SunSettings {
    pub direction: [f32; 3],
    pub irradiance: f32,
    pub angular_radius_deg: f32,
}

/// The integrator settings for the JSON summary.
pub(super) fn integrator_settings(
    args: &RenderOptions,
    integrator: Integrator,
    lights: &[PointLight],
) -> IntegratorSettings {
    IntegratorSettings {
        name: crate::integrators::integrator_name(integrator).into(),
        shadow_rays: "jackknife".into(),
        lights: lights
            .iter()
            .map(|l| [l.position.x, l.position.y, l.position.z, l.intensity])
            .collect(),
        random_lights: None,
        point_lights: None,
        restir: None,
        albedo: args.lighting.albedo.into(),
        env: None,
        sun: None,
        shadows: None,
        light_pmf: None,
        collision_cap: None,
        rr_depth: None,
        max_depth: None,
        hg_g: args.lighting.hg_g,
        t_hat: format!("{:?}", args.estimation.t_hat).to_lowercase(),
        exposure: args.exposure.gain,
    }
}

/// The settings of a `direct` render for the JSON summary.
pub(super) fn direct_settings(
    args: &RenderOptions,
    lights: &crate::lighting::SceneLights,
    collision_cap: u32,
    shadows: crate::render::shadow_map::ShadowSummary,
) -> IntegratorSettings {
    let l = &lights.lighting;
    let env = match &args.lighting.env {
        Some(
            e @ (crate::lighting::EnvSource::File(_) | crate::lighting::EnvSource::Constant(_)),
        ) => e.spelling(),
        Some(crate::lighting::EnvSource::None) => "none".into(),
        _ if l.env.present() => "sky".into(),
        _ => "none".into(),
    };
    let sun = (l.sun.present != 0).then(|| {
        let omega = l.sun.solid_angle();
        let lum = l.sun.radiance.luminance();
        SunSettings {
            direction: [l.sun.dir.x, l.sun.dir.y, l.sun.dir.z],
            irradiance: if l.sun.is_delta() { lum } else { lum * omega },
            angular_radius_deg: (1.0 - l.sun.one_minus_cos as f64).acos().to_degrees() as f32,
        }
    });
    let own = args.own_settings();
    IntegratorSettings {
        name: crate::integrators::integrator_name(args.integrator.unwrap_or(Integrator::Direct))
            .into(),
        shadow_rays: args.estimation.estimator.name.into(),
        lights: args
            .lighting
            .lights
            .iter()
            .map(|l| [l.position.x, l.position.y, l.position.z, l.intensity])
            .collect(),
        random_lights: args.lighting.random_lights.map(|r| r.to_string()),
        point_lights: Some(lights.points.len()),
        albedo: args.lighting.albedo.into(),
        env: Some(env),
        sun,
        shadows: Some(shadows),
        light_pmf: Some([l.p_sun, l.p_env, l.p_points]),
        collision_cap: Some(collision_cap),
        restir: (own == OwnSettings::Restir).then(|| args.restir.settings()),
        rr_depth: (own == OwnSettings::PathDepth).then_some(args.path.rr_depth),
        max_depth: (own == OwnSettings::PathDepth).then_some(args.path.max_depth),
        hg_g: args.lighting.hg_g,
        t_hat: "none".into(),
        exposure: args.exposure.gain,
    }
}

/// What a finished render knows, for its summary.
pub(super) struct Rendered<'a> {
    pub args: &'a RenderOptions,
    pub scene: &'a Scene,
    pub params: &'a RenderParams,
    pub backend: &'a Backend,
    pub lights: &'a SceneLights,
    pub shadows: Option<ShadowSummary>,
    pub png: &'a Path,
    pub flags: RayFlags,
    /// Mean T, or mean L of an integrator render.
    pub mean: f64,
    pub samples_per_ray: f64,
    pub elapsed_ms: f64,
    pub built: BuildTime,
    pub load_ms: f64,
    pub per_ray: u64,
}

/// The JSON summary of a finished render.
pub(super) fn summarize(r: &Rendered) -> Result<RenderSummary> {
    let (args, scene, params) = (r.args, r.scene, r.params);
    let (vol, packed) = (&scene.volume, &scene.packed);
    let radiance = args.integrator.is_some();
    let sv = SupervoxelInfo::of(
        packed,
        args.scene.supervoxels.mode()?,
        args.scene.supervoxel_format,
        params,
    );
    let integrator = match args.integrator {
        Some(i) if i.is_lit() => Some(direct_settings(
            args,
            r.lights,
            params.collision_cap(),
            r.shadows.clone().expect("built for direct and path"),
        )),
        Some(i) => Some(integrator_settings(args, i, &r.lights.points)),
        None => None,
    };
    Ok(RenderSummary {
        backend: r.backend.kind().into(),
        device: r.backend.device(),
        volume: vol.name().to_owned(),
        dims: vol.dims(),
        estimator: match args.integrator {
            Some(i) => crate::integrators::integrator_name(i).into(),
            None => args.estimation.estimator.name.into(),
        },
        lookup: lookup_name(args.estimation.lookup),
        width: args.image.width,
        height: args.image.height,
        spp: args.image.spp,
        seed: args.image.seed,
        sampler: sampler_name(args.image.sampler).into(),
        n: args.estimation.n,
        density_scale: scene.density_scale,
        brick_size: args.scene.brick_size,
        supervoxel_format: sv.format,
        bc4_brick_table_bytes: sv.bc4_table_bytes,
        supervoxels: sv.mode,
        supervoxel_cell_size: sv.cell_size,
        split_ratio: sv.split_ratio,
        split_occupancy: sv.split_occupancy,
        subdivided_bricks: sv.subdivided_bricks,
        supervoxel_cells: packed.bricks.len() - packed.grid_bricks().len() - sv.subdivided_bricks,
        cell_traversal_steps: packed.desc.cell_budget(),
        supervoxel_reads_per_ray: sv.reads_per_ray,
        elapsed_ms: r.elapsed_ms,
        pipeline_build_ms: r.built.ms(),
        pipeline_builds: r.built.count,
        mean_samples_per_ray: r.samples_per_ray,
        mean_t: (!radiance).then_some(r.mean),
        exr: args.out.display().to_string(),
        png: r.png.display().to_string(),
        f_delta: args.estimation.f_delta,
        ratio_roulette: args.estimation.ratio_roulette,
        flags: r.flags,
        grid: scene.grid.clone(),
        up: scene.up,
        world_bounds: scene.world_bounds,
        camera: CameraSummary::of(&scene.camera, args.scene.fov),
        mean_l: radiance.then_some(r.mean),
        integrator,
        underflowed_voxels: packed.underflow.count,
        bricks: packed.grid_bricks().len(),
        occupied_bricks: packed.occupied_bricks(),
        pool_bytes: std::mem::size_of_val(packed.voxels.as_slice()) as u64,
        brick_table_bytes: std::mem::size_of_val(packed.bricks.as_slice()) as u64,
        pool_pages: packed.pages().count(),
        pool_page_bytes: 4u64 << packed.page_log2,
        brick_traversal_steps: packed.desc.brick_budget(),
        voxel_traversal_steps: packed.desc.voxel_budget(),
        loop_iterations_per_ray: r.per_ray,
        volume_storage: vol.storage().into(),
        volume_bytes: vol.stored_bytes(),
        prepare_ms: r.load_ms,
        host_version: env!("CARGO_PKG_VERSION").into(),
        command_line: std::env::args().collect(),
        scene: args.scene_record.clone(),
        shards: None,
        layer_passes: Vec::new(),
        preview: None,
    })
}

impl CameraSummary {
    /// Position, unit forward and vertical field of view of `camera`.
    pub fn of(camera: &shared::camera::Camera, fov_deg: f32) -> Self {
        let (o, f) = (camera.origin, camera.forward);
        CameraSummary {
            position: [o.x, o.y, o.z],
            forward: [f.x, f.y, f.z],
            fov_deg,
        }
    }
}

/// A sampler's name as the CLI spells it.
pub fn sampler_name(s: shared::params::Sampler) -> &'static str {
    match s {
        shared::params::Sampler::Independent => "independent",
        shared::params::Sampler::Sobol => "sobol",
    }
}
