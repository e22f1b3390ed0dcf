//! Flags of `host eval`.

use super::parsers::{
    f32_in, f32_open, parse_f_delta, parse_positive, BackendArg, LookupArg, THatArg,
};
use super::render::SceneArgs;
use anyhow::Result;
use clap::Args;
use engine::defaults;
use engine::render_job::{Image, Lighting, PathDepth};
use lab::defaults as eval_defaults;
use lab::evaluate::EvalOptions;
use std::path::PathBuf;

/// Flags of `host eval`.
#[derive(Args, Debug, Clone)]
pub struct EvalArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// A scene file (as `host render --scene`): its keys that are flags of this command apply
    /// (the volume, camera, image size, ...), the other `host render` keys are ignored with a
    /// note; the flags given here override it.
    #[arg(long = "scene", id = "scene_file", value_name = "FILE")]
    pub scene_file: Option<PathBuf>,
    /// Lookups: nearest (reference = regular tracking, exact), stochastic or trilinear (reference
    /// = ratio tracking at --reference-spp, unbiased but noisy).
    #[arg(long, value_enum, default_value_t = LookupArg::Nearest)]
    pub lookup: LookupArg,
    /// Comma-separated estimators, or "all" (every one but the reference).
    #[arg(long, default_value = "all")]
    pub estimators: String,
    /// Evaluate integrators instead of transmittance estimators: `direct`, `path` and `restir`
    /// (one entry direct/<estimator> per --estimators entry, reference: ratio-tracking shadow rays
    /// at --reference-spp; restir shares direct's), or single-scattering integrators, comma-separated or "all" (see `host
    /// render --integrator`). Reference: mis-jackknife
    /// with ratio-tracking T(t0) at --reference-spp (default 16 x --spp; with the default --spp
    /// of 1024 that is slow, about 25 min at 128^2 on 2 CPU cores: try --spp 16).
    #[arg(long)]
    pub integrators: Option<String>,
    /// Estimate of T(t0) in Eq. 9 for the evaluated integrators.
    #[arg(long, value_enum, default_value_t = THatArg::Jackknife)]
    pub t_hat: THatArg,
    /// A point light "x,y,z,intensity" (repeatable; default: two lights inside the volume).
    #[arg(long = "light", value_parser = engine::integrators::parse_light, allow_hyphen_values = true)]
    pub lights: Vec<shared::sampling::lights::PointLight>,
    /// `--integrators direct|path`: `random:N[,seed]` adds N point lights scattered in and around the
    /// volume, of random colour and intensities over three orders of magnitude (seed default 1;
    /// selected by power).
    #[arg(long = "lights", value_parser = engine::lighting::random::parse_random_lights)]
    pub random_lights: Option<engine::lighting::random::RandomLights>,
    #[command(flatten)]
    pub restir: super::restir::RestirArgs,
    /// `--integrators direct|path|restir`: give every entry the render time of the first one
    /// (each entry's spp from a timing run at --spp / 8, recorded in the JSON as `spp` and
    /// `calibration`).
    #[arg(long)]
    pub equal_time: bool,
    /// Single-scattering albedo, in [0, 1].
    #[arg(long, default_value_t = defaults::ALBEDO, allow_hyphen_values = true, value_parser = f32_in(0.0, 1.0))]
    pub albedo: f32,
    /// `--integrators direct`: environment light (`sky`, `none` or a .exr / .hdr probe) [default:
    /// sky, unless --sun or --light is given].
    #[arg(long, value_parser = super::parsers::EnvParser)]
    pub env: Option<engine::lighting::EnvSource>,
    /// `--integrators direct`: multiplier of the environment map, finite and >= 0.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = f32_in(0.0, 3.0e38))]
    pub env_scale: f32,
    /// `--integrators direct`: rotation of the environment map about +y in degrees.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = f32_in(-360.0, 360.0))]
    pub env_rotate: f32,
    /// `--integrators direct`: sun "x,y,z[,intensity[,angular_radius_deg]]" (see host render).
    #[arg(long, value_parser = super::parsers::parse_sun, allow_hyphen_values = true)]
    pub sun: Option<engine::lighting::SunSpec>,
    /// `--integrators path`: vertices before Russian roulette, 0 to 1024.
    #[arg(long, default_value_t = defaults::RR_DEPTH, allow_hyphen_values = true, value_parser = clap::value_parser!(u32).range(0..=1024))]
    pub rr_depth: u32,
    /// `--integrators path`: most vertices of a path, 1 to 1024.
    #[arg(long, default_value_t = defaults::MAX_DEPTH, allow_hyphen_values = true, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub max_depth: u32,
    /// `--integrators`: Henyey-Greenstein asymmetry g of the phase function, in (-1, 1)
    /// [default: 0, isotropic].
    #[arg(long, allow_hyphen_values = true, value_parser = f32_open(-1.0, 1.0))]
    pub hg_g: Option<f32>,
    /// Multiplier before the PNG previews' tone mapping, a finite number > 0.
    #[arg(long, default_value_t = defaults::EXPOSURE, allow_hyphen_values = true, value_parser = parse_positive)]
    pub exposure: f32,
    /// Samples per optical depth estimate (N), 1 to 4096.
    #[arg(long, allow_hyphen_values = true, default_value_t = defaults::N, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub n: u32,
    /// CDF step F_delta of jackknife-adaptive, in (0, 10] (the paper's Fig. 8d: 0.6).
    #[arg(long, default_value_t = defaults::F_DELTA, allow_hyphen_values = true, value_parser = parse_f_delta)]
    pub f_delta: f32,
    /// Ratio tracking with pbrt-v4's Russian roulette (off: as in the paper).
    #[arg(long)]
    pub ratio_roulette: bool,
    /// Image width, 1 to 16384.
    #[arg(long, allow_hyphen_values = true, default_value_t = eval_defaults::EVAL_SIZE, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: u32,
    /// Image height, 1 to 16384.
    #[arg(long, allow_hyphen_values = true, default_value_t = eval_defaults::EVAL_SIZE, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: u32,
    /// Estimates per pixel (all along the pixel center's ray), 2 to 2^20.
    #[arg(long, allow_hyphen_values = true, default_value_t = eval_defaults::EVAL_SPP, value_parser = clap::value_parser!(u32).range(2..=1 << 20))]
    pub spp: u32,
    /// Estimates per pixel of the reference when it is stochastic, 1 to 2^24 (default 4 x --spp;
    /// 16 x --spp with --integrators).
    #[arg(long, allow_hyphen_values = true, value_parser = clap::value_parser!(u32).range(1..=1 << 24))]
    pub reference_spp: Option<u32>,
    /// Seed, 0 to 2^32 - 1.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    pub seed: u32,
    /// Where kernels run.
    #[arg(long, value_enum, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// Directory for the bias/std/mean EXRs and false-colour PNGs.
    #[arg(long, default_value = eval_defaults::EVAL_OUT_DIR)]
    pub out_dir: PathBuf,
    /// JSON report path (default: <out-dir>/eval.json).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// |bias| mapped to full colour in the bias PNGs, a finite number > 0.
    #[arg(long, default_value_t = eval_defaults::BIAS_SCALE, allow_hyphen_values = true, value_parser = parse_positive)]
    pub bias_scale: f32,
    /// std mapped to full colour in the std PNGs, a finite number > 0.
    #[arg(long, default_value_t = eval_defaults::STD_SCALE, allow_hyphen_values = true, value_parser = parse_positive)]
    pub std_scale: f32,
    /// No progress bars.
    #[arg(long, short)]
    pub quiet: bool,
    /// Render only the reference (samples --reference-samples of it, or all) and write its
    /// exact per-pixel sums to FILE, a shard; evaluate nothing (docs/guide/scale-out.md).
    #[arg(long, value_name = "FILE", conflicts_with = "reference_from")]
    pub reference_shard: Option<PathBuf>,
    /// The samples A..B of the reference that --reference-shard renders: A and B multiples of
    /// 256, B at most --reference-spp.
    #[arg(long, value_name = "A..B", allow_hyphen_values = true, value_parser = super::parsers::parse_samples, requires = "reference_shard")]
    pub reference_samples: Option<(u32, u32)>,
    /// Take the reference from these shards (--reference-shard of the same evaluation, covering
    /// its samples once each) instead of rendering it.
    #[arg(long, value_name = "SHARD", num_args = 1..)]
    pub reference_from: Vec<PathBuf>,
}

impl EvalArgs {
    /// The library's eval options: the lists of `--estimators` and `--integrators` parsed.
    pub fn options(&self) -> Result<EvalOptions> {
        if let (Some(g), None) = (self.hg_g, &self.integrators) {
            anyhow::bail!(
                "--hg-g {g}: the phase function is the integrators'; transmittance evaluations \
                 have none (add --integrators or drop --hg-g)"
            );
        }
        Ok(EvalOptions {
            scene: self.scene.options(),
            lookup: self.lookup.into(),
            estimators: lab::eval_direct::parse_entries(&self.estimators)?,
            integrators: match &self.integrators {
                Some(list) => lab::evaluate::parse_integrators(list)?,
                None => Vec::new(),
            },
            t_hat: self.t_hat.into(),
            lighting: Lighting {
                lights: self.lights.clone(),
                random_lights: self.random_lights,
                albedo: [self.albedo; 3],
                env: self.env.clone(),
                env_scale: self.env_scale,
                env_rotate: self.env_rotate,
                sun: self.sun,
                hg_g: self.hg_g.unwrap_or(0.0),
            },
            restir: self.restir.options(),
            equal_time: self.equal_time,
            path: PathDepth {
                rr_depth: self.rr_depth,
                max_depth: self.max_depth,
            },
            exposure: self.exposure,
            n: self.n,
            f_delta: self.f_delta,
            ratio_roulette: self.ratio_roulette,
            image: Image {
                width: self.width,
                height: self.height,
                spp: self.spp,
                seed: self.seed,
                ..EvalOptions::default().image
            },
            reference_spp: self.reference_spp,
            backend: self.backend.into(),
            out_dir: self.out_dir.clone(),
            json: self.json.clone(),
            bias_scale: self.bias_scale,
            std_scale: self.std_scale,
            quiet: self.quiet,
            reference_source: self.reference_source(),
        })
    }

    /// Where the reference comes from (`--reference-shard`, `--reference-from`), with the input
    /// files whose identity its shards record and are checked against.
    fn reference_source(&self) -> lab::reference::ReferenceSource {
        use lab::reference::{ReferenceSource, ShardSet};
        let inputs = engine::render_job::shard::input_paths(
            &self.scene.volume,
            self.env.as_ref(),
            self.scene_file.as_deref(),
        );
        if let Some(path) = &self.reference_shard {
            return ReferenceSource::WriteShard {
                path: path.clone(),
                samples: self.reference_samples,
                inputs,
            };
        }
        if !self.reference_from.is_empty() {
            return ReferenceSource::Shards(ShardSet {
                paths: self.reference_from.clone(),
                inputs,
            });
        }
        ReferenceSource::Render
    }
}
