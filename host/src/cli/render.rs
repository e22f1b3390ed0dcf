//! Flags of `host render` and the scene flags it shares with `host eval` and `host bench`.

use super::parsers::{
    f32_in, f32_open, parse_albedo, parse_density_scale, parse_f_delta, parse_msm_filter,
    parse_positive, parse_split_ratio, parse_sun, parse_vec3, BackendArg, LookupArg, MsmStorageArg,
    SamplerArg, ShadowsArg, SupervoxelFormatArg, SupervoxelsArg, THatArg, UpArg,
};
use clap::Args;
use engine::defaults;
use engine::render_job::{Estimation, Exposure, Image, Lighting, PathDepth, RenderOptions};
use engine::scene::SceneOptions;
use std::path::PathBuf;

/// The volume and the camera, shared by `host render` and `host eval`.
#[derive(Args, Debug, Clone)]
pub struct SceneArgs {
    /// Embedded volume (cloud, explosion, constant) or a .vdb / .nvdb file.
    #[arg(long, default_value = defaults::VOLUME, value_parser = super::parsers::Utf8Text)]
    pub volume: String,
    /// Grid to read from a file (default: "density", else the first float grid).
    #[arg(long)]
    pub grid: Option<String>,
    /// Set negative densities of a volume file to 0 (with a warning) instead of refusing it.
    #[arg(long)]
    pub clamp_negative: bool,
    /// Voxels per axis of an embedded volume, 8 to 1024 [default: 256] (a volume file has its own
    /// grid: refused with one).
    #[arg(long, allow_hyphen_values = true, value_parser = clap::value_parser!(u32).range(8..=1024))]
    pub resolution: Option<u32>,
    /// Extinction per unit of stored density, 0 to 3.4e38 (default: the embedded volume's own, 1
    /// for files); optical depths through the volume above 1e35 are refused.
    #[arg(long, allow_hyphen_values = true, value_parser = parse_density_scale)]
    pub density_scale: Option<f32>,
    /// Voxels per super-voxel (brick) along each axis, 2 to 256.
    #[arg(long, allow_hyphen_values = true, default_value_t = defaults::BRICK_SIZE, value_parser = clap::value_parser!(u32).range(2..=256))]
    pub brick_size: u32,
    /// How the super-voxel statistics are stored: f32, or bc4 (the paper's block-compressed
    /// grids: 4 bits per brick and statistic, conservative rounding; more variance and, on thin
    /// wisps, more jackknife bias).
    #[arg(long, value_enum, default_value_t = SupervoxelFormatArg::F32)]
    pub supervoxel_format: SupervoxelFormatArg,
    /// Super-voxels: fixed (one per brick, the paper) or adaptive (a brick whose importance is
    /// concentrated in part of it is split into cells of --cell-size voxels with their own
    /// statistics, so samples go where the extinction is; beyond the paper, Sec. 7).
    #[arg(long, value_enum, default_value_t = SupervoxelsArg::Fixed)]
    pub supervoxels: SupervoxelsArg,
    /// Adaptive super-voxels: voxels per cell axis, dividing --brick-size into 2 or more cells
    /// (default 4).
    #[arg(long, allow_hyphen_values = true, value_parser = clap::value_parser!(u32).range(1..=128))]
    pub cell_size: Option<u32>,
    /// Adaptive super-voxels: split a sparse brick when its cells' importance mass (P x voxels
    /// summed) is at most this fraction of the brick's, in (0, 1] (default 0.7).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_split_ratio)]
    pub split_ratio: Option<f32>,
    /// Adaptive super-voxels: a brick is sparse, and may be split, when its occupancy
    /// (mean - mu_min) / P is below this, in (0, 1] (default 0.2; thin wisps filling a fraction
    /// f of a brick have sqrt(f), smooth media 0.6 and more; 1 considers every brick).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_split_ratio)]
    pub split_occupancy: Option<f32>,
    #[command(flatten)]
    pub view: ViewArgs,
}

/// The camera and the volume's up axis, shared by the scene flags and `host report`.
#[derive(Args, Debug, Clone)]
pub struct ViewArgs {
    /// Camera position x,y,z in world units (default: framing the volume from the front).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub camera: Option<[f32; 3]>,
    /// Point the camera looks at, x,y,z (default: the volume's center).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub look_at: Option<[f32; 3]>,
    /// The volume's up axis: y (default), z (Blender, Houdini caches) or x; the volume is rotated
    /// so that it points up in the renderer's y-up world (camera, sky, --camera, --look-at,
    /// --light and --sun are in that world).
    #[arg(long, value_enum, default_value_t = UpArg::Y)]
    pub up: UpArg,
    /// Vertical field of view in degrees, in (0, 180).
    #[arg(long, default_value_t = defaults::FOV, allow_hyphen_values = true, value_parser = f32_open(0.0, 180.0))]
    pub fov: f32,
}

impl ViewArgs {
    /// `scene` with this camera and up axis.
    pub fn applied(&self, scene: SceneOptions) -> SceneOptions {
        SceneOptions {
            camera: self.camera,
            look_at: self.look_at,
            fov: self.fov,
            up: self.up.into(),
            ..scene
        }
    }
}

impl SceneArgs {
    /// The library's scene options.
    pub fn options(&self) -> SceneOptions {
        self.view.applied(SceneOptions {
            volume: self.volume.clone(),
            grid: self.grid.clone(),
            clamp_negative: self.clamp_negative,
            resolution: self.resolution,
            density_scale: self.density_scale,
            brick_size: self.brick_size,
            supervoxel_format: self.supervoxel_format.into(),
            supervoxels: engine::scene::SupervoxelOptions {
                adaptive: self.supervoxels == SupervoxelsArg::Adaptive,
                cell_size: self.cell_size,
                split_ratio: self.split_ratio,
                split_occupancy: self.split_occupancy,
            },
            ..SceneOptions::default()
        })
    }
}

/// Flags of `host render`.
#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// How the high-resolution volume is read.
    #[arg(long, value_enum, default_value_t = LookupArg::Stochastic)]
    pub lookup: LookupArg,
    /// Transmittance estimator: jackknife, naive, naive-m1, jackknife-adaptive, jackknife-mean,
    /// jackknife-uniform, biased-rm, biased-rm2, unbiased-rm, unbiased-rm2, track-length, ratio,
    /// telescoping, telescoping-cycles, regular (docs/reference/estimators.md).
    #[arg(long, default_value = "jackknife", value_parser = engine::estimators::parse)]
    pub estimator: &'static engine::estimators::EstimatorSpec,
    /// Samples per optical depth estimate (N; two estimates per ray), 1 to 4096.
    #[arg(long, allow_hyphen_values = true, default_value_t = defaults::N, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub n: u32,
    /// CDF step F_delta of jackknife-adaptive, in (0, 10] (the paper's Fig. 8d: 0.6; the author's
    /// UI default is 0.3). Expected samples per estimate: F / F_delta.
    #[arg(long, default_value_t = defaults::F_DELTA, allow_hyphen_values = true, value_parser = parse_f_delta)]
    pub f_delta: f32,
    /// Ratio tracking with pbrt-v4's Russian roulette (q = 0.75 below T = 0.05) for `--estimator
    /// ratio` and `--t-hat ratio`; off by default, as in the paper and the author's code.
    #[arg(long)]
    pub ratio_roulette: bool,
    /// Render radiance with this integrator instead of primary-ray transmittance: `direct`
    /// (RGB direct illumination from --env, --sun and --light, shadow rays by --estimator),
    /// `path` (RGB multiple scattering, the same lights and shadow rays), `restir` (`direct` with
    /// the point lights resampled from --restir-candidates draws by power), or one of the
    /// single-scattering integrators lit by point lights (docs/guide/integrators.md)
    #[arg(long, value_parser = super::parsers::IntegratorParser)]
    pub integrator: Option<shared::params::Integrator>,
    /// A point light "x,y,z,intensity" in world units (repeat for more; default: two lights
    /// inside the volume; with `direct`, `path`, `restir`: none, and a --light replaces the
    /// default sky unless --env is given).
    #[arg(long = "light", value_parser = engine::integrators::parse_light, allow_hyphen_values = true)]
    pub lights: Vec<shared::sampling::lights::PointLight>,
    /// `direct`, `path`, `restir`: `random:N[,seed]` adds N point lights scattered in and around
    /// the volume, of random colour and intensities over three orders of magnitude (seed default
    /// 1; selected by power). Like --light, it replaces the default sky unless --env is given.
    #[arg(long = "lights", value_parser = engine::lighting::random::parse_random_lights)]
    pub random_lights: Option<engine::lighting::random::RandomLights>,
    #[command(flatten)]
    pub restir: super::restir::RestirArgs,
    /// Single-scattering albedo: one value or r,g,b (RGB: `direct`, `path`, `restir`), each in
    /// [0, 1].
    #[arg(long, default_value = "0.8", allow_hyphen_values = true, value_parser = parse_albedo)]
    pub albedo: [f32; 3],
    /// Environment light of `direct`, `path`, `restir`: `sky` (the embedded Preetham daylight sky
    /// with its sun), `none`, `constant:R,G,B` (one linear radiance in every direction, as a
    /// world colour; `constant:V` for grey), or an equirectangular .exr / .hdr light probe
    /// [default: sky, unless --sun, --light or --lights is given].
    #[arg(long, value_parser = super::parsers::EnvParser)]
    pub env: Option<engine::lighting::EnvSource>,
    /// Multiplier of the environment map's radiance, finite and >= 0.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = f32_in(0.0, 3.0e38))]
    pub env_scale: f32,
    /// Rotation of the environment map about +y, in degrees (-360 to 360).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = f32_in(-360.0, 360.0))]
    pub env_rotate: f32,
    /// Sun of `direct`, `path`, `restir`: "x,y,z[,intensity[,angular_radius_deg]]", the direction
    /// toward it, its irradiance perpendicular to it (default: 4x the sky's horizontal irradiance
    /// with --env sky, else 1) and its angular radius (default 0.2666; 0: a delta light). Its
    /// colour is a slightly warm white: linear Rec. 709 (1, 0.93, 0.85) scaled to luminance 1,
    /// times the intensity.
    #[arg(long, value_parser = parse_sun, allow_hyphen_values = true)]
    pub sun: Option<engine::lighting::SunSpec>,
    /// `direct`, `path`: transmittance of light samples toward the sun: shadow rays through
    /// --estimator, or the sun's moment shadow map with four or six moments (Peters et al. 2017;
    /// deterministic, biased, no voxel lookups per shadow ray; needs a sun).
    #[arg(long, value_enum, default_value_t = ShadowsArg::Rays)]
    pub shadows: ShadowsArg,
    /// Texels per side of the moment shadow map, 8 to 2048.
    #[arg(long, allow_hyphen_values = true, default_value_t = engine::render::shadow_map::DEFAULT_RESOLUTION, value_parser = clap::value_parser!(u32).range(8..=2048))]
    pub msm_res: u32,
    /// Storage of the moment shadow map [default: u16 for msm4, f32 for msm6].
    #[arg(long, value_enum)]
    pub msm_storage: Option<MsmStorageArg>,
    /// Prefilter of the moment shadow map (soft shadows): none, box:R or gauss:R, R the radius
    /// in texels (1 to 64).
    #[arg(long, default_value = "none", value_parser = parse_msm_filter)]
    pub msm_filter: (shared::shadows::map::MsmFilter, u32),
    /// `path`: vertices before Russian roulette starts (survival = the throughput's largest
    /// channel, at least 0.05), 0 to 1024.
    #[arg(long, default_value_t = defaults::RR_DEPTH, allow_hyphen_values = true, value_parser = clap::value_parser!(u32).range(0..=1024))]
    pub rr_depth: u32,
    /// `path`: most vertices (scattering events) of a path, 1 to 1024.
    #[arg(long, default_value_t = defaults::MAX_DEPTH, allow_hyphen_values = true, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub max_depth: u32,
    /// Henyey-Greenstein anisotropy g in (-1, 1) (0: isotropic).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = f32_open(-1.0, 1.0))]
    pub hg_g: f32,
    /// Estimate of T(t0) for the equiangular strategy of Eq. 9: jackknife or ratio (unbiased).
    #[arg(long, value_enum, default_value_t = THatArg::Jackknife)]
    pub t_hat: THatArg,
    /// Multiplier of the PNG preview's automatic exposure (radiance renders: the image's
    /// log-average luminance to middle grey, then a filmic curve; the EXR stays linear), a finite
    /// number > 0. With --fixed-exposure, the preview's gain itself.
    #[arg(long, default_value_t = defaults::EXPOSURE, allow_hyphen_values = true, value_parser = parse_positive)]
    pub exposure: f32,
    /// The preview's gain is --exposure alone, without automatic exposure (the same gain for
    /// every render, e.g. the frames of an animation).
    #[arg(long)]
    pub fixed_exposure: bool,
    /// Image width in pixels, 1 to 16384.
    #[arg(long, allow_hyphen_values = true, default_value_t = defaults::SIZE, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: u32,
    /// Image height in pixels, 1 to 16384.
    #[arg(long, allow_hyphen_values = true, default_value_t = defaults::SIZE, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: u32,
    /// Primary rays (transmittance estimates) per pixel, 1 to 2^20.
    #[arg(long, allow_hyphen_values = true, default_value_t = defaults::SPP, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    pub spp: u32,
    /// Seed, 0 to 2^32 - 1; the same seed gives the same image on every backend.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    pub seed: u32,
    /// Where each sample's uniforms come from: sobol (the pixel jitter and every path vertex's
    /// free flight, light, phase and roulette numbers from Owen-scrambled Sobol patterns,
    /// stratified within the pixel: less noise per sample) or independent (every number from a
    /// hash generator). Default: sobol, or independent when `--layers stderr` is asked for (a
    /// pixel's standard error needs independent samples; stderr with sobol is refused).
    #[arg(long, value_enum)]
    pub sampler: Option<SamplerArg>,
    /// Where kernels run: auto (a hardware Vulkan GPU if there is one, else the CPU; on a
    /// software device such as lavapipe, the one that finishes sooner for this job), gpu, or cpu.
    #[arg(long, value_enum, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// Output EXR (linear transmittance or radiance; must end in .exr); a PNG preview is written
    /// next to it (same name, .png).
    #[arg(long, short, default_value = "out/render.exr")]
    pub out: PathBuf,
    /// Also write a JSON summary here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
    /// Extra parts of the EXR beside the image's part (`transmittance`, or `radiance` with
    /// --integrator), one layer each, comma-separated: stderr (the standard error of
    /// the pixel's mean, of the luminance for RGB; needs --spp 2 or more), samples (per pixel),
    /// lookups (mean high-resolution lookups per sample), camera-transmittance (of the camera rays by
    /// --estimator, 1 - alpha; with --integrator a second render of the same rays), albedo
    /// (--integrator only: --albedo times 1 - camera-transmittance, RGB; with the image, a
    /// denoiser's colour and albedo inputs), depth (the mean distance from the camera of the
    /// camera rays' first collision in the medium, 0 where none collides; a pass of delta
    /// tracking along the same rays); all linear, one channel `Y` each but albedo.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub layers: Vec<super::parsers::LayerArg>,
    /// A scene to render: a TOML file whose keys are these flags without the dashes, or the
    /// JSON summary of an earlier render (its `scene`); the flags given here override it.
    /// `host render FILE` is the same (docs/guide/rendering.md, Scene files).
    #[arg(long = "scene", id = "scene_file", value_name = "FILE")]
    pub scene_file: Option<PathBuf>,
    /// Write the resolved scene of this command line (a --scene file's settings, then the flags
    /// given) to FILE as TOML, and exit without rendering.
    #[arg(long, value_name = "FILE")]
    pub write_scene: Option<PathBuf>,
    /// Render only samples A..B (A included, B not) of the --spp, into the --shard file: a
    /// shard of a render split over machines. A and B are multiples of 256 (B may be --spp);
    /// `host merge` adds the shards into the bytes one render gives (docs/guide/scale-out.md).
    #[arg(long, value_name = "A..B", allow_hyphen_values = true, value_parser = super::parsers::parse_samples, requires = "shard")]
    pub samples: Option<(u32, u32)>,
    /// Write the exact per-pixel sums of the samples rendered (all, or --samples) to FILE
    /// instead of the images: a shard for `host merge`.
    #[arg(long, value_name = "FILE")]
    pub shard: Option<PathBuf>,
    /// Ids of the flags given on the command line (filled by [`parse`], not a flag).
    #[arg(skip)]
    pub given: Vec<String>,
    /// The resolved scene (filled by [`parse`], not a flag).
    #[arg(skip)]
    pub record: engine::render_job::scene_record::SceneRecord,
    /// Long names of the flags typed on the command line itself, without those a --scene file
    /// gave (filled by [`parse`], not a flag): a scene's run keys (`json`) never block a shard.
    #[arg(skip)]
    pub typed: Vec<String>,
}

impl RenderArgs {
    /// The shard this command line writes (`--shard`, with `--samples` or all samples).
    pub fn shard_output(&self) -> Option<engine::render_job::ShardOutput> {
        self.shard
            .as_ref()
            .map(|path| engine::render_job::ShardOutput {
                path: path.clone(),
                samples: self.samples.unwrap_or((0, self.spp)),
            })
    }

    /// The sampler the flags give: `--sampler`, else [`engine::render_job::layers::default_sampler`].
    pub fn sampler(&self) -> shared::params::Sampler {
        match self.sampler {
            Some(s) => s.into(),
            None => {
                let layers: Vec<_> = self.layers.iter().map(|&l| l.into()).collect();
                engine::render_job::layers::default_sampler(&layers)
            }
        }
    }

    /// The library's render options.
    pub fn options(&self) -> RenderOptions {
        RenderOptions {
            scene: self.scene.options(),
            image: Image {
                width: self.width,
                height: self.height,
                spp: self.spp,
                seed: self.seed,
                sampler: self.sampler(),
            },
            estimation: Estimation {
                lookup: self.lookup.into(),
                estimator: self.estimator,
                n: self.n,
                f_delta: self.f_delta,
                ratio_roulette: self.ratio_roulette,
                t_hat: self.t_hat.into(),
            },
            integrator: self.integrator,
            lighting: Lighting {
                lights: self.lights.clone(),
                random_lights: self.random_lights,
                albedo: self.albedo,
                env: self.env.clone(),
                env_scale: self.env_scale,
                env_rotate: self.env_rotate,
                sun: self.sun,
                hg_g: self.hg_g,
            },
            restir: self.restir.options(),
            shadows: engine::render::shadow_map::ShadowOptions {
                kind: self.shadows.into(),
                storage: self.msm_storage.map(Into::into),
                resolution: self.msm_res,
                filter: self.msm_filter.0,
                radius: self.msm_filter.1,
            },
            path: PathDepth {
                rr_depth: self.rr_depth,
                max_depth: self.max_depth,
            },
            exposure: Exposure {
                gain: self.exposure,
                fixed: self.fixed_exposure,
            },
            backend: self.backend.into(),
            out: self.out.clone(),
            json: self.json.clone(),
            quiet: self.quiet,
            scene_record: self.record.clone(),
            scene_file: self.scene_file.clone(),
            merge: Vec::new(),
            layers: self.layers.iter().map(|&l| l.into()).collect(),
        }
    }
}
