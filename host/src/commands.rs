//! The subcommands: each parses nothing, validates its flags, runs, and reports.

use crate::backend::{Backend, BackendChoice};
use crate::job::{Job, WorkKind};
use crate::output::{write_exr, write_json, write_png, OutputPlan};
use crate::render::{make_camera, occupied_world_bounds, world_to_index, CameraSpec};
use crate::volume::{Volume, VolumeData};
use anyhow::{bail, Context, Result};
use shared::kernels::probe::{self, DepthPair};
use shared::params::RenderParams;
use shared::params::{Integrator, TransmittanceHat};
use shared::sampling::lights::PointLight;
use shared::volume::grid::Lookup;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Defaults of the scene and `host eval` options (the CLI shows them as its defaults).
pub mod defaults {
    /// `--volume`.
    pub const VOLUME: &str = "cloud";
    /// `--resolution`.
    pub const RESOLUTION: u32 = 256;
    /// `--brick-size`.
    pub const BRICK_SIZE: u32 = crate::bricks::DEFAULT_BRICK_SIZE;
    /// `--fov` in degrees.
    pub const FOV: f32 = 40.0;
    /// `--albedo`.
    pub const ALBEDO: f32 = 0.8;
    /// `--exposure`.
    pub const EXPOSURE: f32 = 1.0;
    /// `--rr-depth` of `path`.
    pub const RR_DEPTH: u32 = 5;
    /// `--max-depth` of `path`.
    pub const MAX_DEPTH: u32 = 64;
    /// `--n`.
    pub const N: u32 = 10;
    /// `--f-delta`.
    pub const F_DELTA: f32 = 0.6;
    /// `host eval --width` and `--height`.
    pub const EVAL_SIZE: u32 = 128;
    /// `host eval --spp`.
    pub const EVAL_SPP: u32 = 1024;
    /// `host eval --bias-scale`.
    pub const BIAS_SCALE: f32 = 0.05;
    /// `host eval --std-scale`.
    pub const STD_SCALE: f32 = 0.5;
    /// `host eval --out-dir`.
    pub const EVAL_OUT_DIR: &str = "out/eval";
}

/// The volume and the camera, shared by `host render`, `host eval` and `host bench`.
#[derive(Debug, Clone)]
pub struct SceneOptions {
    /// Embedded volume name or a .vdb / .nvdb file.
    pub volume: String,
    /// Grid to read from a file.
    pub grid: Option<String>,
    /// Set negative densities of a file to 0 instead of refusing it.
    pub clamp_negative: bool,
    /// Voxels per axis of an embedded volume (None: [`defaults::RESOLUTION`]); refused with a
    /// file, which has its own grid.
    pub resolution: Option<u32>,
    /// Extinction per unit of stored density (None: the volume's own).
    pub density_scale: Option<f32>,
    /// Voxels per brick along each axis.
    pub brick_size: u32,
    /// How the super-voxel statistics are stored.
    pub supervoxel_format: jackknife::SupervoxelFormat,
    /// Fixed or adaptive super-voxels.
    pub supervoxels: SupervoxelOptions,
    /// Camera position (None: framing the volume).
    pub camera: Option<[f32; 3]>,
    /// Point the camera looks at (None: the volume's center).
    pub look_at: Option<[f32; 3]>,
    /// Vertical field of view in degrees.
    pub fov: f32,
    /// The volume's up axis (rotated to the renderer's +y).
    pub up: crate::render::UpAxis,
}

impl SceneOptions {
    /// Voxels per axis of an embedded volume: `--resolution` or its default.
    pub fn embedded_resolution(&self) -> u32 {
        self.resolution.unwrap_or(defaults::RESOLUTION)
    }
}

impl Default for SceneOptions {
    fn default() -> Self {
        SceneOptions {
            volume: defaults::VOLUME.into(),
            grid: None,
            clamp_negative: false,
            resolution: None,
            density_scale: None,
            brick_size: defaults::BRICK_SIZE,
            supervoxel_format: jackknife::SupervoxelFormat::F32,
            supervoxels: SupervoxelOptions::default(),
            camera: None,
            look_at: None,
            fov: defaults::FOV,
            up: crate::render::UpAxis::Y,
        }
    }
}

/// `--supervoxels`, `--cell-size`, `--split-ratio` and `--split-occupancy` as given.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SupervoxelOptions {
    /// `--supervoxels adaptive`.
    pub adaptive: bool,
    /// Voxels per cell axis of a subdivided brick (default [`jackknife::DEFAULT_CELL_SIZE`]).
    pub cell_size: Option<u32>,
    /// Split ratio (default [`jackknife::DEFAULT_SPLIT_RATIO`]).
    pub split_ratio: Option<f32>,
    /// Split occupancy (default [`jackknife::DEFAULT_SPLIT_OCCUPANCY`]).
    pub split_occupancy: Option<f32>,
}

impl SupervoxelOptions {
    /// The builder's mode; refuses `--cell-size`, `--split-ratio` and `--split-occupancy`
    /// without `adaptive`, which
    /// would be ignored.
    pub fn mode(&self) -> Result<jackknife::Supervoxels> {
        if !self.adaptive {
            if self.cell_size.is_some() {
                bail!("--cell-size only applies to --supervoxels adaptive; add it or drop --cell-size");
            }
            if self.split_ratio.is_some() {
                bail!(
                    "--split-ratio only applies to --supervoxels adaptive; add it or drop --split-ratio"
                );
            }
            if self.split_occupancy.is_some() {
                bail!(
                    "--split-occupancy only applies to --supervoxels adaptive; add it or drop \
                     --split-occupancy"
                );
            }
            return Ok(jackknife::Supervoxels::Fixed);
        }
        Ok(jackknife::Supervoxels::Adaptive {
            cell: self.cell_size.unwrap_or(jackknife::DEFAULT_CELL_SIZE),
            ratio: self.split_ratio.unwrap_or(jackknife::DEFAULT_SPLIT_RATIO),
            occupancy: self
                .split_occupancy
                .unwrap_or(jackknife::DEFAULT_SPLIT_OCCUPANCY),
        })
    }

    /// "fixed" or "adaptive".
    pub fn name(&self) -> &'static str {
        if self.adaptive {
            "adaptive"
        } else {
            "fixed"
        }
    }
}

/// What `host render` renders and where it writes it.
#[derive(Debug, Clone)]
pub struct RenderOptions {
    pub scene: SceneOptions,
    pub lookup: Lookup,
    pub estimator: &'static crate::estimators::EstimatorSpec,
    pub n: u32,
    pub f_delta: f32,
    pub ratio_roulette: bool,
    /// Single scattering with this integrator instead of primary-ray transmittance.
    pub integrator: Option<Integrator>,
    pub lights: Vec<PointLight>,
    /// `--lights random:N[,seed]`: point lights scattered in and around the volume (`direct`,
    /// `path`), added to `lights`.
    pub random_lights: Option<crate::lighting::random::RandomLights>,
    /// Albedo per channel (the single-scattering integrators need equal channels).
    pub albedo: [f32; 3],
    /// Environment light of `direct` (None: the sky unless --sun or --light are given).
    pub env: Option<crate::lighting::EnvSource>,
    pub env_scale: f32,
    /// Degrees about +y.
    pub env_rotate: f32,
    pub sun: Option<crate::lighting::SunSpec>,
    /// `direct`, `path`: shadow rays toward the sun or its moment shadow map.
    pub shadows: crate::shadow_map::ShadowOptions,
    /// `restir`: candidates, target, its N and floor.
    pub restir: crate::restir::RestirOptions,
    /// `path`: vertices before Russian roulette.
    pub rr_depth: u32,
    /// `path`: most vertices of a path.
    pub max_depth: u32,
    pub hg_g: f32,
    pub t_hat: TransmittanceHat,
    pub exposure: f32,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u32,
    pub backend: BackendChoice,
    /// Output EXR; the PNG preview goes next to it.
    pub out: PathBuf,
    pub json: Option<PathBuf>,
    /// No progress bar or info lines.
    pub quiet: bool,
    /// Ids (field names) of the options the user gave explicitly.
    pub given: Vec<String>,
}

/// What `host eval` measures and where it writes it.
#[derive(Debug, Clone)]
pub struct EvalOptions {
    pub scene: SceneOptions,
    pub lookup: Lookup,
    /// Comma-separated estimators or "all".
    pub estimators: String,
    /// Comma-separated integrators or "all" (evaluates integrators instead of estimators).
    pub integrators: Option<String>,
    pub t_hat: TransmittanceHat,
    pub lights: Vec<PointLight>,
    /// `--lights random:N[,seed]` (`--integrators direct|path|restir`).
    pub random_lights: Option<crate::lighting::random::RandomLights>,
    /// `--integrators restir`: candidates, target, its N and floor.
    pub restir: crate::restir::RestirOptions,
    /// `--integrators direct|path|restir`: every entry gets the first entry's render time.
    pub equal_time: bool,
    pub albedo: f32,
    /// `--integrators direct`: the environment light (None: the sky unless --sun or --light).
    pub env: Option<crate::lighting::EnvSource>,
    pub env_scale: f32,
    pub env_rotate: f32,
    pub sun: Option<crate::lighting::SunSpec>,
    /// `--integrators path`: vertices before roulette, most vertices.
    pub rr_depth: u32,
    pub max_depth: u32,
    /// Henyey-Greenstein asymmetry g of the integrators' phase function, in (-1, 1) (None: 0,
    /// isotropic; refused without `integrators`).
    pub hg_g: Option<f32>,
    pub exposure: f32,
    pub n: u32,
    pub f_delta: f32,
    pub ratio_roulette: bool,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Estimates per pixel of a stochastic reference (None: 4 x spp, 16 x spp for integrators).
    pub reference_spp: Option<u32>,
    pub seed: u32,
    pub backend: BackendChoice,
    pub out_dir: PathBuf,
    /// JSON report path (None: <out_dir>/eval.json).
    pub json: Option<PathBuf>,
    pub bias_scale: f32,
    pub std_scale: f32,
    /// No progress bars or info lines.
    pub quiet: bool,
}

impl Default for EvalOptions {
    fn default() -> Self {
        EvalOptions {
            scene: SceneOptions::default(),
            lookup: Lookup::Nearest,
            estimators: "all".into(),
            integrators: None,
            t_hat: TransmittanceHat::Jackknife,
            lights: Vec::new(),
            random_lights: None,
            restir: Default::default(),
            equal_time: false,
            albedo: defaults::ALBEDO,
            env: None,
            env_scale: 1.0,
            env_rotate: 0.0,
            sun: None,
            rr_depth: defaults::RR_DEPTH,
            max_depth: defaults::MAX_DEPTH,
            hg_g: None,
            exposure: defaults::EXPOSURE,
            n: defaults::N,
            f_delta: defaults::F_DELTA,
            ratio_roulette: false,
            width: defaults::EVAL_SIZE,
            height: defaults::EVAL_SIZE,
            spp: defaults::EVAL_SPP,
            reference_spp: None,
            seed: 0,
            backend: BackendChoice::Auto,
            out_dir: PathBuf::from(defaults::EVAL_OUT_DIR),
            json: None,
            bias_scale: defaults::BIAS_SCALE,
            std_scale: defaults::STD_SCALE,
            quiet: false,
        }
    }
}

/// What `host probe` simulates.
#[derive(Debug, Clone)]
pub struct ProbeOptions {
    pub backend: BackendChoice,
    /// Number of (X0, X1) pairs.
    pub count: u32,
    /// True optical depth.
    pub tau: f32,
    /// Standard deviation of each estimate.
    pub sigma: f32,
    pub seed: u32,
}

/// Lower-case name of a lookup mode (JSON summaries).
pub fn lookup_name(lookup: Lookup) -> String {
    format!("{lookup:?}").to_lowercase()
}

/// Whether `--volume` names a file (it exists, or ends in .vdb / .nvdb) rather than an embedded
/// volume.
pub fn is_volume_file(spec: &str) -> bool {
    let path = Path::new(spec);
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    path.exists() || ext.eq_ignore_ascii_case("vdb") || ext.eq_ignore_ascii_case("nvdb")
}

/// Checks `--volume` before any work: a volume file that exists as a regular file, or an
/// embedded volume's name.
pub fn check_volume_spec(spec: &str) -> Result<()> {
    if is_volume_file(spec) {
        let path = Path::new(spec);
        anyhow::ensure!(
            path.is_file(),
            "{spec}: {}",
            if path.exists() {
                "not a regular file (a directory, FIFO or device); give a .vdb or .nvdb file"
            } else {
                "no such file"
            }
        );
        return Ok(());
    }
    anyhow::ensure!(
        crate::procedural::NAMES.contains(&spec),
        "{spec:?} is neither a file nor an embedded volume; embedded volumes: {}",
        crate::procedural::NAMES.join(", ")
    );
    Ok(())
}

/// Checks an `--integrators` list of `host eval` before any work: direct, path and restir
/// together or alone, or single-scattering integrators.
pub fn check_integrator_list(list: &str) -> Result<()> {
    let names: Vec<&str> = list.split(',').map(str::trim).collect();
    let lit = names
        .iter()
        .filter(|n| matches!(**n, "direct" | "path" | "restir"))
        .count();
    if lit == 0 {
        crate::integrators::parse_integrator_list(list)?;
    } else {
        anyhow::ensure!(
            lit == names.len(),
            "--integrators {list}: direct, path and restir are evaluated together or alone (their \
             entries are shadow-ray estimators under the same lights); evaluate the \
             single-scattering integrators in a separate run"
        );
    }
    Ok(())
}

/// An embedded volume by name or a volume file by path, with its default density scale and, for
/// a file, the name of the grid read; `check` sees the bounding box before any voxel is read
/// or generated.
pub fn load_volume(
    scene: &SceneOptions,
    check: Option<crate::io::TopologyCheck>,
) -> Result<(Volume, f32, Option<String>)> {
    let spec = scene.volume.as_str();
    let path = Path::new(spec);
    if is_volume_file(spec) {
        if let Some(n) = scene.resolution {
            bail!(
                "--resolution {n}: {} is a volume file, whose grid has its own voxel counts; \
                 --resolution sets the size of an embedded volume (drop it)",
                path.display()
            );
        }
        let options = crate::io::LoadOptions {
            grid: scene.grid.as_deref(),
            clamp_negative: scene.clamp_negative,
            check_topology: check,
            ..Default::default()
        };
        let loaded = crate::io::load_volume_with(path, &options)?;
        if loaded.clamped_negative > 0 {
            tracing::warn!(
                "--clamp-negative set {} negative densities of {} to 0",
                loaded.clamped_negative,
                path.display()
            );
        }
        return Ok((loaded.volume, 1.0, Some(loaded.grid)));
    }
    let resolution = scene.embedded_resolution();
    if let (Some(grid), true) = (&scene.grid, crate::procedural::NAMES.contains(&spec)) {
        bail!(
            "--grid {grid:?}: the embedded volume {spec:?} is one density field without grids; \
             --grid picks a grid of a .vdb or .nvdb file (drop it, or give --volume a file)"
        );
    }
    if let Some(check) = check {
        let n = u64::from(resolution);
        (check.0)(&crate::io::Topology {
            dims: [n; 3],
            tile_voxels: 0,
        })?;
    }
    match crate::procedural::by_name(spec, resolution) {
        Some(v) => Ok((v, crate::procedural::default_density_scale(spec), None)),
        None => bail!(
            "--volume {spec:?} is neither a file nor an embedded volume; embedded volumes: {}",
            crate::procedural::NAMES.join(", ")
        ),
    }
}

/// The lights of `--light`, or two default lights inside the volume's occupied bounds.
fn scene_lights(args: &RenderOptions, vol: &dyn VolumeData) -> Result<Vec<PointLight>> {
    anyhow::ensure!(
        args.hg_g.is_finite() && args.hg_g > -1.0 && args.hg_g < 1.0,
        "--hg-g must be in (-1, 1) (got {})",
        args.hg_g
    );
    let [r, g, b] = args.albedo;
    anyhow::ensure!(
        r == g && g == b,
        "--albedo {r},{g},{b}: the single-scattering integrators are scalar; give one value, or use \
         --integrator direct for an RGB albedo"
    );
    lights_or_default(&args.lights, r, args.exposure, vol)
}

/// Validates light flags; `--light` values or two default lights inside the occupied bounds.
fn lights_or_default(
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
    let (lo, hi) = crate::render::occupied_world_bounds(vol);
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
    pub supervoxel_reads_per_ray: crate::traversal::ReadsPerRay,
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
    pub flags: crate::diagnostics::RayFlags,
    /// The grid read from a volume file (absent for embedded volumes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grid: Option<String>,
    /// The volume's up axis (`--up`), the world bounds of its occupied voxels in the renderer's
    /// y-up world, and the camera (position, unit forward, vertical field of view).
    pub up: crate::render::UpAxis,
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
    pub shadows: Option<crate::shadow_map::ShadowSummary>,
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
    pub restir: Option<crate::restir::RestirSettings>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rr_depth: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_depth: Option<u32>,
    pub hg_g: f32,
    pub t_hat: String,
    /// The PNG shows x / (1 + x) of x = exposure * radiance, sRGB-encoded; the EXR is linear.
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

/// Options that only an integrator render reads (ids in `RenderOptions::given`, flag spelling).
const INTEGRATOR_ONLY: &[(&str, &str)] = &[
    ("lights", "--light"),
    ("albedo", "--albedo"),
    ("hg_g", "--hg-g"),
    ("t_hat", "--t-hat"),
    ("exposure", "--exposure"),
    ("env", "--env"),
    ("env_scale", "--env-scale"),
    ("env_rotate", "--env-rotate"),
    ("sun", "--sun"),
];

/// Options only `--integrator direct` reads.
const DIRECT_ONLY: &[(&str, &str)] = &[
    ("random_lights", "--lights"),
    ("env", "--env"),
    ("env_scale", "--env-scale"),
    ("env_rotate", "--env-rotate"),
    ("sun", "--sun"),
    ("shadows", "--shadows"),
    ("msm_res", "--msm-res"),
    ("msm_storage", "--msm-storage"),
    ("msm_filter", "--msm-filter"),
];

/// Options that only a moment shadow map reads (`--shadows msm4|msm6`).
const MSM_ONLY: &[(&str, &str)] = &[
    ("msm_res", "--msm-res"),
    ("msm_storage", "--msm-storage"),
    ("msm_filter", "--msm-filter"),
];

/// Options only `--integrator path` reads.
const PATH_ONLY: &[(&str, &str)] = &[("rr_depth", "--rr-depth"), ("max_depth", "--max-depth")];

/// Options only `--integrator restir` reads.
const RESTIR_ONLY: &[(&str, &str)] = &[
    ("restir_candidates", "--restir-candidates"),
    ("restir_target", "--restir-target"),
    ("restir_n", "--restir-n"),
    ("restir_floor", "--restir-floor"),
    ("restir_passes", "--restir-passes"),
    ("restir_neighbours", "--restir-neighbours"),
    ("restir_radius", "--restir-radius"),
    ("restir_mis", "--restir-mis"),
    ("restir_m_cap", "--restir-m-cap"),
];

/// Options `--integrator direct` does not read.
const NOT_DIRECT: &[(&str, &str)] = &[("t_hat", "--t-hat")];

/// Flags that no integrator reads: shadow rays always use the jackknife (shared/src/integrator.rs).
const TRANSMITTANCE_ONLY: &[(&str, &str)] =
    &[("estimator", "--estimator"), ("f_delta", "--f-delta")];

/// Refuses flag combinations whose flags would be ignored, so no output is mislabelled.
pub fn check_render_flags(args: &RenderOptions) -> Result<()> {
    let given = |id: &str| args.given.iter().any(|g| g == id);
    let lit = args.integrator.is_some_and(Integrator::is_lit);
    if args.integrator != Some(Integrator::Path) {
        if let Some((_, flag)) = PATH_ONLY.iter().find(|(id, _)| given(id)) {
            bail!("{flag} only applies to --integrator path; add it or drop {flag}");
        }
    }
    if args.integrator == Some(Integrator::Restir) {
        args.restir.check()?;
        args.restir.check_image(args.width, args.height)?;
    } else if let Some((_, flag)) = RESTIR_ONLY.iter().find(|(id, _)| given(id)) {
        bail!("{flag} only applies to --integrator restir; add it or drop {flag}");
    }
    if lit {
        if let Some((_, flag)) = NOT_DIRECT.iter().find(|(id, _)| given(id)) {
            bail!(
                "{flag} has no effect with --integrator direct or path (it changes the \
                 equiangular strategy of the single-scattering integrators); drop {flag}"
            );
        }
    } else if let Some((_, flag)) = DIRECT_ONLY.iter().find(|(id, _)| given(id)) {
        bail!(
            "{flag} only applies to --integrator direct, path or restir (the single-scattering \
             integrators are lit by point lights, --light); add --integrator direct or drop {flag}"
        );
    } else if args.integrator.is_some() {
        if let Some((_, flag)) = TRANSMITTANCE_ONLY.iter().find(|(id, _)| given(id)) {
            bail!(
                "{flag} has no effect with --integrator: every integrator's shadow rays use the \
                 jackknife transmittance (with --n samples per estimate); drop {flag}, or drop \
                 --integrator to render transmittance with it"
            );
        }
    } else if let Some((_, flag)) = INTEGRATOR_ONLY.iter().find(|(id, _)| given(id)) {
        bail!(
            "{flag} only applies to single-scattering renders: add --integrator NAME (e.g. \
             --integrator mis-jackknife) or drop {flag}"
        );
    }
    if args.shadows.kind == crate::shadow_map::ShadowKind::Rays {
        if let Some((_, flag)) = MSM_ONLY.iter().find(|(id, _)| given(id)) {
            bail!("{flag} only applies to --shadows msm4 or msm6; add one or drop {flag}");
        }
    }
    args.shadows.check()?;
    let uses_ratio = match args.integrator {
        Some(i) if i.is_lit() => {
            args.estimator.estimator == shared::params::Estimator::RatioTracking
        }
        Some(_) => args.t_hat == TransmittanceHat::Ratio,
        None => args.estimator.estimator == shared::params::Estimator::RatioTracking,
    };
    if given("ratio_roulette") && !uses_ratio {
        bail!(
            "--ratio-roulette has no effect here: it changes ratio tracking, used by --estimator \
             ratio and, with --integrator, by --t-hat ratio (Miller et al.'s MIS always runs \
             without roulette); drop it or use one of those"
        );
    }
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
    if let Some(crate::lighting::EnvSource::File(env)) = &args.env {
        crate::lighting::env::check_path(env)?;
        plan.input("--env", env);
    }
    if let Some(json) = &args.json {
        plan.file("--json", json);
    }
    plan.check()?;
    Ok(png)
}

/// The integrator settings for the JSON summary.
fn integrator_settings(
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
        albedo: args.albedo.into(),
        env: None,
        sun: None,
        shadows: None,
        light_pmf: None,
        collision_cap: None,
        rr_depth: None,
        max_depth: None,
        hg_g: args.hg_g,
        t_hat: format!("{:?}", args.t_hat).to_lowercase(),
        exposure: args.exposure,
    }
}

/// The lights of a `direct` render: `--env` (default: the sky unless only --sun or --light are
/// given), `--sun`, `--light` (no default point lights).
fn direct_lights(
    args: &RenderOptions,
    vol: &dyn VolumeData,
) -> Result<crate::lighting::SceneLights> {
    use crate::lighting::{EnvSource, LightingOptions};
    anyhow::ensure!(
        args.hg_g.is_finite() && args.hg_g > -1.0 && args.hg_g < 1.0,
        "--hg-g must be in (-1, 1) (got {})",
        args.hg_g
    );
    let (lo, hi) = crate::render::occupied_world_bounds(vol);
    let mut points = args.lights.clone();
    if let Some(spec) = args.random_lights {
        points.extend(crate::lighting::random::random_lights(spec, lo, hi)?);
    }
    let env = match &args.env {
        Some(e) => e.clone(),
        None if args.sun.is_some() || !points.is_empty() => EnvSource::None,
        None => EnvSource::Sky,
    };
    let center = [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]));
    let radius = 0.5 * (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
    crate::lighting::build(
        &LightingOptions {
            env,
            env_scale: args.env_scale,
            env_rotate_deg: args.env_rotate,
            sun: args.sun,
            points,
            albedo: args.albedo,
        },
        center,
        radius,
    )
}

/// The settings of a `direct` render for the JSON summary.
fn direct_settings(
    args: &RenderOptions,
    lights: &crate::lighting::SceneLights,
    collision_cap: u32,
    shadows: crate::shadow_map::ShadowSummary,
) -> IntegratorSettings {
    let l = &lights.lighting;
    let env = match &args.env {
        Some(crate::lighting::EnvSource::File(p)) => p.display().to_string(),
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
    IntegratorSettings {
        name: crate::integrators::integrator_name(args.integrator.unwrap_or(Integrator::Direct))
            .into(),
        shadow_rays: args.estimator.name.into(),
        lights: args
            .lights
            .iter()
            .map(|l| [l.position.x, l.position.y, l.position.z, l.intensity])
            .collect(),
        random_lights: args.random_lights.map(|r| r.to_string()),
        point_lights: Some(lights.points.len()),
        albedo: args.albedo.into(),
        env: Some(env),
        sun,
        shadows: Some(shadows),
        light_pmf: Some([l.p_sun, l.p_env, l.p_points]),
        collision_cap: Some(collision_cap),
        restir: (args.integrator == Some(Integrator::Restir)).then(|| args.restir.settings()),
        rr_depth: (args.integrator == Some(Integrator::Path)).then_some(args.rr_depth),
        max_depth: (args.integrator == Some(Integrator::Path)).then_some(args.max_depth),
        hg_g: args.hg_g,
        t_hat: "none".into(),
        exposure: args.exposure,
    }
}

/// `host render`: checks flags and outputs, loads, packs, renders, writes EXR + PNG (+ JSON),
/// prints a summary.
pub fn run_render(args: &RenderOptions) -> Result<RenderSummary> {
    check_render_flags(args)?;
    crate::render::check_image_memory(args.width, args.height, 1)?;
    let png = plan_render_outputs(args)?;
    // The backend first: a forced GPU that is missing fails before any loading, and the pool
    // is laid out in the pages the device binds.
    let backend = Backend::open(args.backend)?;
    let t_load = Instant::now();
    let check = backend.topology_check(args.backend, args.scene.brick_size);
    let scene = prepare_scene(
        &args.scene,
        args.lookup,
        args.width,
        args.height,
        backend.page_log2(),
        Some(crate::io::TopologyCheck(&check)),
    )?;
    let (vol, packed, density_scale) = (&scene.volume, &scene.packed, scene.density_scale);
    let load_ms = t_load.elapsed().as_secs_f64() * 1e3;
    let job = Job::render(args.integrator, args.width, args.height, args.spp);
    let backend = backend.fit(args.backend, packed, &job)?;
    let volume_label = match &scene.grid {
        Some(grid) => format!("{} (grid '{grid}')", vol.name()),
        None => vol.name().to_owned(),
    };
    if !args.quiet {
        tracing::info!(
            "volume {volume_label} {}x{}x{} (density scale {density_scale}, {} bricks of {}^3, {} occupied: {:.1} MiB of voxels), prepared in {load_ms:.0} ms",
            vol.dims()[0],
            vol.dims()[1],
            vol.dims()[2],
            packed.grid_bricks().len(),
            args.scene.brick_size,
            packed.occupied_bricks(),
            std::mem::size_of_val(packed.voxels.as_slice()) as f64 / (1 << 20) as f64
        );
        tracing::info!("backend: {} ({})", backend.kind(), backend.device());
    }
    let mut params = RenderParams {
        camera: scene.camera,
        world_to_index: scene.world_to_index,
        width: args.width,
        height: args.height,
        spp: args.spp,
        seed: args.seed,
        n: args.n,
        f_delta: args.f_delta,
        pixel_jitter: 1,
        roulette: args.ratio_roulette as u32,
        ..Default::default()
    };
    args.estimator.apply(&mut params);
    let direct = args.integrator.is_some_and(Integrator::is_lit);
    let scene_lights = if direct {
        let mut l = direct_lights(args, vol)?;
        if args.integrator == Some(Integrator::Restir) {
            l.resample_points();
        }
        l
    } else {
        crate::lighting::SceneLights::points_only(&scene_lights(args, vol)?)
    };
    let lights = scene_lights.points.clone();
    if let Some(integrator) = args.integrator {
        params.integrator = integrator as u32;
        params.light_count = lights.len() as u32;
        params.albedo = args.albedo[0];
        params.hg_g = args.hg_g;
        params.t_hat = args.t_hat as u32;
        params.rr_depth = args.rr_depth;
        params.max_depth = args.max_depth;
        args.restir.apply(&mut params);
    }
    if direct {
        // A safeguard: lower the tracking loops' collision cap if one invocation would not fit.
        params = crate::render::fit_collision_cap(&params, &packed.desc);
    }
    let per_ray = crate::render::loop_iterations_per_ray(&params, &packed.desc);
    let backend = match backend {
        Backend::Gpu(_)
            if args.backend == BackendChoice::Auto && per_ray > crate::render::LOOP_BUDGET =>
        {
            tracing::warn!(
                "one ray may need {per_ray} loop iterations through this {}x{}x{} grid, more than \
                 a GPU invocation may run; falling back to the CPU backend",
                vol.dims()[0],
                vol.dims()[1],
                vol.dims()[2]
            );
            Backend::Cpu
        }
        b => b,
    };
    let resident = crate::render::Resident::new(&backend, packed)?;
    let mut scene_lights = scene_lights;
    let shadows = if direct {
        let s = crate::shadow_map::build_into(
            &resident,
            &params,
            &mut scene_lights,
            occupied_world_bounds(vol),
            &args.shadows,
        )?;
        if let (Some(m), false) = (&s.map, args.quiet) {
            tracing::info!(
                "moment shadow map of the sun ({}, {}x{} texels, {:?}, {} bytes) built in {:.1} ms",
                crate::shadow_map::name(s.shadows),
                m.resolution,
                m.resolution,
                m.storage,
                m.bytes,
                m.build_ms
            );
        }
        Some(s)
    } else {
        None
    };
    let (pixels, elapsed_ms, built) = backend.timed(|| {
        crate::render::render_resident_lit(&resident, &params, &scene_lights, !args.quiet)
    })?;

    let flags = crate::diagnostics::RayFlags::of(&pixels, args.spp);
    flags.warn(&params);
    crate::diagnostics::check_finite(&pixels, args.width)?;
    let t: Vec<f32> = pixels.iter().map(|p| p.t_mean).collect();
    let rays = pixels.len() as f64 * args.spp as f64;
    let samples: f64 = pixels.iter().map(|p| p.samples as f64).sum();
    let mean = t.iter().map(|&v| v as f64).sum::<f64>() / t.len() as f64;
    if direct {
        let rgb: Vec<[f32; 3]> = pixels
            .iter()
            .map(|p| [p.rgb_mean.r, p.rgb_mean.g, p.rgb_mean.b])
            .collect();
        crate::output::write_exr_rgb(&args.out, args.width, args.height, &rgb)?;
        crate::output::write_png_rgb_exposed(&png, args.width, args.height, &rgb, args.exposure)?;
    } else {
        write_exr(&args.out, args.width, args.height, &t)?;
    }
    let preview: Vec<f32> = if args.integrator.is_some() {
        // Radiance: exposure, then Reinhard x / (1 + x) so highlights do not clip.
        t.iter()
            .map(|&v| {
                let x = v * args.exposure;
                x / (1.0 + x)
            })
            .collect()
    } else {
        t.clone()
    };
    if !direct {
        write_png(&png, args.width, args.height, &preview)?;
    }
    let radiance = args.integrator.is_some();
    let sv = crate::eval::SupervoxelInfo::of(
        packed,
        args.scene.supervoxels.mode()?,
        args.scene.supervoxel_format,
        &params,
    );
    let summary = RenderSummary {
        backend: backend.kind().into(),
        device: backend.device(),
        volume: vol.name().to_owned(),
        dims: vol.dims(),
        estimator: match args.integrator {
            Some(i) => crate::integrators::integrator_name(i).into(),
            None => args.estimator.name.into(),
        },
        lookup: lookup_name(args.lookup),
        width: args.width,
        height: args.height,
        spp: args.spp,
        seed: args.seed,
        n: args.n,
        density_scale,
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
        elapsed_ms,
        pipeline_build_ms: built.ms(),
        pipeline_builds: built.count,
        mean_samples_per_ray: samples / rays,
        mean_t: (!radiance).then_some(mean),
        exr: args.out.display().to_string(),
        png: png.display().to_string(),
        f_delta: args.f_delta,
        ratio_roulette: args.ratio_roulette,
        flags,
        grid: scene.grid.clone(),
        up: scene.up,
        world_bounds: scene.world_bounds,
        camera: CameraSummary {
            position: [
                scene.camera.origin.x,
                scene.camera.origin.y,
                scene.camera.origin.z,
            ],
            forward: [
                scene.camera.forward.x,
                scene.camera.forward.y,
                scene.camera.forward.z,
            ],
            fov_deg: args.scene.fov,
        },
        mean_l: radiance.then_some(mean),
        integrator: match args.integrator {
            Some(i) if i.is_lit() => Some(direct_settings(
                args,
                &scene_lights,
                crate::render::collision_cap(&params),
                shadows.clone().expect("built for direct and path"),
            )),
            Some(i) => Some(integrator_settings(args, i, &lights)),
            None => None,
        },
        underflowed_voxels: packed.underflow.count,
        bricks: packed.grid_bricks().len(),
        occupied_bricks: packed.occupied_bricks(),
        pool_bytes: std::mem::size_of_val(packed.voxels.as_slice()) as u64,
        brick_table_bytes: std::mem::size_of_val(packed.bricks.as_slice()) as u64,
        pool_pages: packed.pages().count(),
        pool_page_bytes: 4u64 << packed.page_log2,
        brick_traversal_steps: packed.desc.brick_budget(),
        voxel_traversal_steps: packed.desc.voxel_budget(),
        loop_iterations_per_ray: per_ray,
        volume_storage: vol.storage().into(),
        volume_bytes: vol.stored_bytes(),
        prepare_ms: load_ms,
        host_version: env!("CARGO_PKG_VERSION").into(),
        command_line: std::env::args().collect(),
    };
    if let Some(path) = &args.json {
        write_json(path, &summary)?;
    }
    let compiled = match built.count {
        0 => String::new(),
        n => format!(
            " (+ {:.1} s compiling {n} GPU pipeline{} on first use)",
            built.wall.as_secs_f64(),
            if n == 1 { "" } else { "s" }
        ),
    };
    println!(
        "{} {}x{} spp {} on {}: {:.1} ms{compiled}, {:.2} samples/ray, mean {} {:.5} -> {} (volume {volume_label})",
        summary.estimator,
        args.width,
        args.height,
        args.spp,
        summary.backend,
        elapsed_ms,
        summary.mean_samples_per_ray,
        if radiance { "L" } else { "T" },
        mean,
        args.out.display()
    );
    Ok(summary)
}

/// Two normal optical depth estimates N(tau, sigma^2) for one id (Box-Muller on PCG32 draws).
fn normal_pair(id: u32, seed: u32, tau: f32, sigma: f32) -> DepthPair {
    let rng = probe::pcg32_for(id, seed);
    let (u1, rng) = rng.next_f32();
    let (u2, _) = rng.next_f32();
    let radius = (-2.0 * shared::math::ln(1.0 - u1)).sqrt();
    let (s, c) = shared::math::sin_cos(std::f32::consts::TAU * u2);
    DepthPair {
        x0: tau + sigma * radius * c,
        x1: tau + sigma * radius * s,
    }
}

/// `host probe`: Eq. 4 and exp(-X̄) on simulated normal pairs, next to exp(-tau).
pub fn run_probe(args: &ProbeOptions) -> Result<()> {
    anyhow::ensure!(
        args.tau.is_finite() && args.sigma.is_finite() && args.sigma >= 0.0,
        "--tau must be finite and --sigma finite and >= 0 (got --tau {} --sigma {})",
        args.tau,
        args.sigma
    );
    let backend = Backend::open(args.backend)?;
    println!("backend: {} ({})", backend.kind(), backend.device());
    let pairs: Vec<DepthPair> = crate::cpu::generate(args.count, |i| {
        normal_pair(i, args.seed, args.tau, args.sigma)
    });
    let start = Instant::now();
    let out = backend
        .transmittance_pairs(&pairs)
        .context("evaluating Eq. 4")?;
    let elapsed = start.elapsed();
    let n = out.len() as f64;
    let stats = |f: &dyn Fn(usize) -> f32| {
        let mean = (0..out.len()).map(|i| f(i) as f64).sum::<f64>() / n;
        let var = (0..out.len())
            .map(|i| (f(i) as f64 - mean).powi(2))
            .sum::<f64>()
            / (n - 1.0).max(1.0);
        (mean, (var / n).sqrt())
    };
    let (jackknife, se_j) = stats(&|i| out[i].jackknife);
    let (naive, se_n) = stats(&|i| out[i].naive);
    let exact = (-(args.tau as f64)).exp();
    println!(
        "{} pairs X0, X1 ~ N(tau = {}, sigma = {}), seed {}: kernel time {:.1} ms",
        args.count,
        args.tau,
        args.sigma,
        args.seed,
        elapsed.as_secs_f64() * 1e3
    );
    println!("  exact exp(-tau)        {exact:.6}");
    println!(
        "  jackknife K (Eq. 4)    {jackknife:.6} ± {se_j:.6}  bias {:+.6}",
        jackknife - exact
    );
    println!(
        "  naive exp(-X̄)         {naive:.6} ± {se_n:.6}  bias {:+.6}",
        naive - exact
    );
    Ok(())
}

/// A loaded and packed volume with the camera framing it.
pub struct Scene {
    pub volume: Volume,
    pub packed: crate::bricks::PackedVolume,
    pub density_scale: f32,
    pub camera: shared::camera::Camera,
    pub world_to_index: shared::geometry::Affine3x4,
    /// The grid read from a volume file (None for embedded volumes).
    pub grid: Option<String>,
    /// World bounds of the occupied voxels (after `--up`), [lo, hi].
    pub world_bounds: [[f64; 3]; 2],
    pub up: crate::render::UpAxis,
}

/// Loads the volume of `--volume` (`check`: see [`load_volume`]), packs it (its pool in pages
/// of 2^`page_log2` words: see [`Backend::page_log2`]) and sets up the camera for a `w` x `h`
/// image.
pub fn prepare_scene(
    args: &SceneOptions,
    lookup: Lookup,
    w: u32,
    h: u32,
    page_log2: u32,
    check: Option<crate::io::TopologyCheck>,
) -> Result<Scene> {
    anyhow::ensure!(
        args.fov.is_finite() && args.fov > 0.0 && args.fov < 180.0,
        "--fov must be in (0, 180) degrees (got {})",
        args.fov
    );
    // A spinner while loading and packing (seconds for production-size files); drawn only when
    // stderr is a terminal.
    let bar =
        indicatif::ProgressBar::new_spinner().with_message(format!("loading {}", args.volume));
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    let prepared = (|| -> Result<_> {
        let (mut volume, default_scale, grid) = load_volume(args, check)?;
        let turned = args.up.apply(volume.index_to_world());
        volume.set_index_to_world(turned);
        let density_scale = args.density_scale.unwrap_or(default_scale);
        bar.set_message(format!(
            "packing {} ({} voxels held {})",
            args.volume,
            volume.dims().iter().map(|&d| u64::from(d)).product::<u64>(),
            volume.storage()
        ));
        let packed = crate::bricks::pack_paged(
            &volume,
            density_scale,
            args.brick_size,
            args.supervoxel_format,
            args.supervoxels.mode()?,
            lookup,
            page_log2,
        )?;
        Ok((volume, grid, density_scale, packed))
    })();
    // Cleared on errors too, so the spinner never stays above an error message.
    bar.finish_and_clear();
    let (volume, grid, density_scale, packed) = prepared?;
    report_underflow(&volume, &packed.underflow, density_scale)?;
    let spec = CameraSpec {
        position: args.camera,
        look_at: args.look_at,
        fov_deg: args.fov,
    };
    let bounds = occupied_world_bounds(&volume);
    let camera = make_camera(&spec, bounds, w, h)?;
    let world_to_index = world_to_index(volume.index_to_world())?;
    Ok(Scene {
        volume,
        packed,
        density_scale,
        camera,
        world_to_index,
        grid,
        world_bounds: [bounds.0, bounds.1],
        up: args.up,
    })
}

/// Warns (with a count) about nonzero densities that became 0 as scaled f16 values; refuses a
/// volume all of whose nonzero densities did, which would render as empty.
fn report_underflow(vol: &dyn VolumeData, u: &crate::bricks::Underflow, scale: f32) -> Result<()> {
    let Some(([x, y, z], density)) = u.first else {
        return Ok(());
    };
    let (name, voxel) = (vol.name(), vol.describe_voxel(x, y, z));
    let what = format!(
        "{name}: {} of {} nonzero densities (first: {voxel}, density {density}) become 0: \
         times --density-scale {scale:e} they are below f32's smallest value, or more than 2^40 \
         below the largest density (the range of the f16 voxels)",
        u.count, u.nonzero
    );
    anyhow::ensure!(
        u.count < u.nonzero,
        "{what}: the volume would render as empty; raise --density-scale"
    );
    tracing::warn!("{what}; raise --density-scale if they matter");
    Ok(())
}

/// `host eval`: the reference and each estimator on pixel-center rays; JSON + images.
pub fn run_eval(args: &EvalOptions) -> Result<()> {
    crate::render::check_image_memory(args.width, args.height, 2)?;
    if let Some(list) = args.integrators.as_deref() {
        let names: Vec<&str> = list.split(',').map(str::trim).collect();
        let lit: Vec<Integrator> = names
            .iter()
            .filter_map(|n| match *n {
                "direct" => Some(Integrator::Direct),
                "path" => Some(Integrator::Path),
                "restir" => Some(Integrator::Restir),
                _ => None,
            })
            .collect();
        if !lit.is_empty() {
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
            return run_eval_direct(args, &unique);
        }
    }
    anyhow::ensure!(
        !args.equal_time,
        "--equal-time applies to --integrators direct, path or restir; add one or drop it"
    );
    anyhow::ensure!(
        args.random_lights.is_none(),
        "--lights random:N applies to --integrators direct, path or restir (the \
         single-scattering integrators take at most {} lights, by --light); drop --lights",
        shared::sampling::lights::MAX_LIGHTS
    );
    anyhow::ensure!(
        args.restir == crate::restir::RestirOptions::default(),
        "the --restir-* flags apply to --integrators restir; add it or drop them"
    );
    let given_direct = args.env.is_some() || args.sun.is_some();
    if let (Some(g), None) = (args.hg_g, &args.integrators) {
        bail!(
            "--hg-g {g}: the phase function is the integrators'; transmittance evaluations have \
             none (add --integrators or drop --hg-g)"
        );
    }
    anyhow::ensure!(
        !given_direct,
        "--env and --sun only apply to --integrators direct; add it or drop them"
    );
    let estimators = crate::eval::parse_list(&args.estimators)?;
    let integrators = args
        .integrators
        .as_deref()
        .map(crate::integrators::parse_integrator_list)
        .transpose()?;
    let images = match &integrators {
        Some(list) => crate::eval::integrator_files(&args.out_dir, list.iter().map(|(n, _)| *n)),
        None => crate::eval::estimator_files(&args.out_dir, estimators.iter().map(|e| e.name)),
    };
    let json = plan_eval_outputs(args, &images)?;
    let lookup = args.lookup;
    let backend = Backend::open(args.backend)?;
    let page_log2 = backend.page_log2();
    let check = backend.topology_check(args.backend, args.scene.brick_size);
    let check = Some(crate::io::TopologyCheck(&check));
    let scene = prepare_scene(
        &args.scene,
        lookup,
        args.width,
        args.height,
        page_log2,
        check,
    )?;
    let (vol, packed) = (&scene.volume, &scene.packed);
    let job = match &integrators {
        // Each integrator: every estimator at --spp and a jackknife reference at 16 x --spp.
        Some(list) => eval_job(
            list.iter().map(|(_, i)| *i),
            args,
            estimators.len(),
            args.reference_spp.unwrap_or(16 * args.spp),
        ),
        None => eval_job(
            [Integrator::Transmittance],
            args,
            estimators.len(),
            args.reference_spp.unwrap_or(4 * args.spp),
        ),
    };
    let backend = backend.fit(args.backend, packed, &job)?;
    if !args.quiet {
        tracing::info!("backend: {} ({})", backend.kind(), backend.device());
    }
    let params = RenderParams {
        camera: scene.camera,
        world_to_index: scene.world_to_index,
        width: args.width,
        height: args.height,
        spp: args.spp,
        seed: args.seed,
        n: args.n,
        f_delta: args.f_delta,
        pixel_jitter: 0,
        roulette: args.ratio_roulette as u32,
        ..Default::default()
    };
    if let Some(integrators) = &integrators {
        return run_eval_integrators(args, integrators, &json, vol, packed, &backend, params);
    }
    let (reference, reference_spp) = match lookup {
        // Deterministic and exact for nearest lookups: one estimate per pixel suffices.
        Lookup::Nearest => (
            crate::estimators::by_name("regular").expect("registered"),
            1,
        ),
        // Regular tracking integrates the nearest-neighbour grid only: ratio tracking is
        // unbiased for any lookup.
        Lookup::Stochastic | Lookup::Trilinear => (
            crate::estimators::by_name("ratio").expect("registered"),
            args.reference_spp.unwrap_or(4 * args.spp),
        ),
    };
    let setup = crate::eval::EvalSetup {
        backend: &backend,
        volume: packed,
        volume_name: vol.name().to_owned(),
        params,
        reference,
        reference_spp,
        out_dir: &args.out_dir,
        bias_scale: args.bias_scale,
        std_scale: args.std_scale,
        progress: !args.quiet,
        supervoxels: Some(crate::eval::SupervoxelInfo::of(
            packed,
            args.scene.supervoxels.mode()?,
            args.scene.supervoxel_format,
            &params,
        )),
    };
    let report = crate::eval::evaluate(&setup, &estimators)?;
    crate::eval::write_report(&json, &report)?;
    println!("wrote {}", json.display());
    Ok(())
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
    if let Some(crate::lighting::EnvSource::File(env)) = &args.env {
        crate::lighting::env::check_path(env)?;
        plan.input("--env", env);
    }
    for image in images {
        plan.file("an image of --out-dir", image);
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
    packed: &crate::bricks::PackedVolume,
    backend: &Backend,
    mut params: RenderParams,
) -> Result<()> {
    let lights = lights_or_default(&args.lights, args.albedo, args.exposure, vol)?;
    params.light_count = lights.len() as u32;
    params.albedo = args.albedo;
    params.hg_g = args.hg_g.unwrap_or(0.0);
    params.pixel_jitter = 1;
    params.t_hat = args.t_hat as u32;
    let setup = crate::eval::EvalSetup {
        backend,
        volume: packed,
        volume_name: vol.name().to_owned(),
        params,
        reference: crate::estimators::by_name("jackknife").expect("registered"),
        reference_spp: args.reference_spp.unwrap_or(16 * args.spp),
        out_dir: &args.out_dir,
        bias_scale: args.bias_scale,
        std_scale: args.std_scale,
        progress: !args.quiet,
        supervoxels: Some(crate::eval::SupervoxelInfo::of(
            packed,
            args.scene.supervoxels.mode()?,
            args.scene.supervoxel_format,
            &params,
        )),
    };
    let report = crate::eval::evaluate_integrators(&setup, &lights, integrators, args.exposure)?;
    crate::output::write_json(json, &report)?;
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
    let kinds: Vec<WorkKind> = integrators
        .into_iter()
        .map(|i| WorkKind::of(Some(i)))
        .collect();
    let pixels = u64::from(args.width) * u64::from(args.height);
    let spp = u64::from(args.spp) * renders as u64 + u64::from(reference_spp);
    Job {
        kind: WorkKind::costliest(&kinds),
        samples: pixels * spp * kinds.len() as u64,
    }
}

/// `host eval --integrators direct`: each shadow-ray estimator of `--estimators` in the `direct`
/// integrator against ratio-tracking shadow rays at `--reference-spp` (default 16 x `--spp`).
fn run_eval_direct(args: &EvalOptions, integrators: &[Integrator]) -> Result<()> {
    let labels: Vec<&str> = integrators
        .iter()
        .map(|&i| crate::integrators::integrator_name(i))
        .collect();
    let entries = crate::eval_direct::parse_entries(&args.estimators)?;
    let names: Vec<String> = entries.iter().map(|e| e.name()).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let images = crate::eval_direct::direct_files(&args.out_dir, &labels, &names);
    let json = plan_eval_outputs(args, &images)?;
    let backend = Backend::open(args.backend)?;
    let page_log2 = backend.page_log2();
    let check = backend.topology_check(args.backend, args.scene.brick_size);
    let check = Some(crate::io::TopologyCheck(&check));
    let scene = prepare_scene(
        &args.scene,
        args.lookup,
        args.width,
        args.height,
        page_log2,
        check,
    )?;
    let (vol, packed) = (&scene.volume, &scene.packed);
    let reference_spp = args.reference_spp.unwrap_or(16 * args.spp);
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
        lookup: args.lookup,
        estimator: crate::estimators::by_name("jackknife").expect("registered"),
        n: args.n,
        f_delta: args.f_delta,
        ratio_roulette: args.ratio_roulette,
        integrator: Some(integrators[0]),
        lights: args.lights.clone(),
        random_lights: args.random_lights,
        albedo: [args.albedo; 3],
        env: args.env.clone(),
        env_scale: args.env_scale,
        env_rotate: args.env_rotate,
        sun: args.sun,
        shadows: Default::default(),
        restir: args.restir,
        rr_depth: args.rr_depth,
        max_depth: args.max_depth,
        hg_g: args.hg_g.unwrap_or(0.0),
        t_hat: TransmittanceHat::Jackknife,
        exposure: args.exposure,
        width: args.width,
        height: args.height,
        spp: args.spp,
        seed: args.seed,
        backend: args.backend,
        out: PathBuf::from("unused.exr"),
        json: None,
        quiet: args.quiet,
        given: Vec::new(),
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
        camera: scene.camera,
        world_to_index: scene.world_to_index,
        width: args.width,
        height: args.height,
        spp: args.spp,
        seed: args.seed,
        n: args.n,
        f_delta: args.f_delta,
        pixel_jitter: 1,
        rr_depth: args.rr_depth,
        max_depth: args.max_depth,
        hg_g: args.hg_g.unwrap_or(0.0),
        ..Default::default()
    };
    if integrators.contains(&Integrator::Restir) {
        args.restir.check()?;
        args.restir.check_image(args.width, args.height)?;
    } else {
        anyhow::ensure!(
            args.restir == crate::restir::RestirOptions::default(),
            "the --restir-* flags apply to --integrators restir; add it or drop them"
        );
    }
    let mut params = params;
    args.restir.apply(&mut params);
    let setup = crate::eval::EvalSetup {
        backend: &backend,
        volume: packed,
        volume_name: vol.name().to_owned(),
        params,
        reference: crate::estimators::by_name("ratio").expect("registered"),
        reference_spp: args.reference_spp.unwrap_or(16 * args.spp),
        out_dir: &args.out_dir,
        bias_scale: args.bias_scale,
        std_scale: args.std_scale,
        progress: !args.quiet,
        supervoxels: Some(crate::eval::SupervoxelInfo::of(
            packed,
            args.scene.supervoxels.mode()?,
            args.scene.supervoxel_format,
            &params,
        )),
    };
    let report = crate::eval_direct::evaluate_direct(
        &setup,
        integrators,
        &lights,
        &entries,
        occupied_world_bounds(vol),
        args.exposure,
        args.equal_time,
    )?;
    crate::output::write_json(&json, &report)?;
    println!("wrote {}", json.display());
    Ok(())
}
