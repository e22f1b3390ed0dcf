//! Command-line interface: `host render` (the default), `host probe`.

use crate::backend::BackendChoice;
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

/// Jackknife transmittance (Peters 2025) on a Vulkan GPU or the CPU, from one Rust source.
///
/// Without a subcommand, `host` renders (same flags as `host render`).
#[derive(Parser, Debug)]
#[command(version, about, args_conflicts_with_subcommands = true)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    #[command(flatten)]
    pub render: RenderArgs,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a primary-ray transmittance image (like the paper's Fig. 8): EXR + PNG + JSON.
    Render(RenderArgs),
    /// Evaluate Eq. 4 on simulated normal optical-depth pairs and compare with exp(-tau).
    Probe(ProbeArgs),
    /// Measure bias, std, RMSE, samples/ray and time of estimators against a reference.
    Eval(EvalArgs),
    /// Reproduce the paper's statistical experiments (Table 1, Fig. 2-7, App. A).
    Study(crate::study::StudyArgs),
    /// Time every estimator on the same rays (CPU and/or GPU), with work-normalized variance and
    /// an optional sweep over volume resolution and image size.
    Bench(crate::bench::BenchArgs),
    /// Write a static HTML viewer comparing estimators (side by side, slider, insets, numbers)
    /// from new `host eval` runs or existing eval output directories.
    Report(ReportArgs),
}

/// High-resolution lookups.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LookupArg {
    /// The voxel containing the sample point.
    Nearest,
    /// Stochastic texture filtering: jitter by up to half a voxel, then nearest (Sec. 4.3).
    Stochastic,
}

/// Estimate of T(t0) in Eq. 9.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum THatArg {
    /// Jackknife transmittance (tiny bias).
    Jackknife,
    /// Ratio tracking (unbiased).
    Ratio,
}

/// Integrator names of `--integrator`.
pub const INTEGRATORS: &[(&str, shared::integrators::Integrator)] = {
    use shared::integrators::Integrator as I;
    &[
        ("free-flight", I::FreeFlight),
        ("equiangular", I::Equiangular),
        ("mis-jackknife", I::MisJackknife),
        ("mis-naive", I::MisNaive),
        ("combined-jackknife", I::CombinedJackknife),
        ("combined-naive", I::CombinedNaive),
        ("miller", I::Miller),
        ("mis-power", I::MisPowerJackknife),
    ]
};

/// Parses an integrator name.
pub fn parse_integrator(s: &str) -> Result<shared::integrators::Integrator, String> {
    INTEGRATORS
        .iter()
        .find(|(n, _)| *n == s)
        .map(|(_, i)| *i)
        .ok_or_else(|| {
            let names: Vec<&str> = INTEGRATORS.iter().map(|(n, _)| *n).collect();
            format!(
                "unknown integrator {s:?}; choose one of: {}",
                names.join(", ")
            )
        })
}

/// Name of an integrator.
pub fn integrator_name(i: shared::integrators::Integrator) -> &'static str {
    INTEGRATORS
        .iter()
        .find(|(_, x)| *x == i)
        .map(|(n, _)| *n)
        .unwrap_or("transmittance")
}

/// Parses "x,y,z,intensity" into a point light.
pub fn parse_light(s: &str) -> Result<shared::sampling::lights::PointLight, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|p| {
            p.trim()
                .parse::<f32>()
                .map_err(|_| format!("{p:?} is not a number in {s:?}"))
        })
        .collect::<Result<_, _>>()?;
    if v.len() != 4 || v.iter().any(|x| !x.is_finite()) || v[3] < 0.0 {
        return Err(format!(
            "expected x,y,z,intensity (finite, intensity >= 0), got {s:?}"
        ));
    }
    Ok(shared::sampling::lights::PointLight {
        position: shared::geometry::V3::new(v[0], v[1], v[2]),
        intensity: v[3],
    })
}

/// The volume and the camera, shared by `host render` and `host eval`.
#[derive(Args, Debug, Clone)]
pub struct SceneArgs {
    /// Embedded volume (cloud, explosion, constant) or a .vdb / .nvdb file.
    #[arg(long, default_value = "cloud")]
    pub volume: String,
    /// Grid to read from a file (default: "density", else the first float grid).
    #[arg(long)]
    pub grid: Option<String>,
    /// Set negative densities of a volume file to 0 (with a warning) instead of refusing it.
    #[arg(long)]
    pub clamp_negative: bool,
    /// Voxels per axis of an embedded volume, 8 to 1024.
    #[arg(long, allow_hyphen_values = true, default_value_t = 256, value_parser = clap::value_parser!(u32).range(8..=1024))]
    pub resolution: u32,
    /// Extinction per unit of stored density, 0 to 3.4e38 (default: the embedded volume's own, 1
    /// for files); optical depths through the volume above 1e35 are refused.
    #[arg(long, allow_hyphen_values = true, value_parser = parse_density_scale)]
    pub density_scale: Option<f32>,
    /// Voxels per super-voxel (brick) along each axis, 2 to 256.
    #[arg(long, allow_hyphen_values = true, default_value_t = 16, value_parser = clap::value_parser!(u32).range(2..=256))]
    pub brick_size: u32,
    /// Camera position x,y,z in world units (default: framing the volume from the front).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub camera: Option<[f32; 3]>,
    /// Point the camera looks at, x,y,z (default: the volume's center).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub look_at: Option<[f32; 3]>,
    /// Vertical field of view in degrees, in (0, 180).
    #[arg(long, default_value_t = 40.0, allow_hyphen_values = true, value_parser = f32_open(0.0, 180.0))]
    pub fov: f32,
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
    /// regular (see README).
    #[arg(long, default_value = "jackknife", value_parser = crate::estimators::parse)]
    pub estimator: &'static crate::estimators::EstimatorSpec,
    /// Samples per optical depth estimate (N; two estimates per ray), 1 to 4096.
    #[arg(long, allow_hyphen_values = true, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub n: u32,
    /// CDF step F_delta of jackknife-adaptive, in (0, 10] (the paper's Fig. 8d: 0.6; the author's
    /// UI default is 0.3). Expected samples per estimate: F / F_delta.
    #[arg(long, default_value_t = 0.6, allow_hyphen_values = true, value_parser = parse_f_delta)]
    pub f_delta: f32,
    /// Ratio tracking with pbrt-v4's Russian roulette (q = 0.75 below T = 0.05) for `--estimator
    /// ratio` and `--t-hat ratio`; off by default, as in the paper and the author's code.
    #[arg(long)]
    pub ratio_roulette: bool,
    /// Render single scattering from point lights with this integrator instead of primary-ray
    /// transmittance: free-flight, equiangular, mis-jackknife, mis-naive, combined-jackknife,
    /// combined-naive, miller, mis-power (see README).
    #[arg(long, value_parser = parse_integrator)]
    pub integrator: Option<shared::integrators::Integrator>,
    /// A point light "x,y,z,intensity" in world units (repeat for more; default: two lights
    /// inside the volume).
    #[arg(long = "light", value_parser = parse_light, allow_hyphen_values = true)]
    pub lights: Vec<shared::sampling::lights::PointLight>,
    /// Single-scattering albedo, in [0, 1].
    #[arg(long, default_value_t = 0.8, allow_hyphen_values = true, value_parser = f32_in(0.0, 1.0))]
    pub albedo: f32,
    /// Henyey-Greenstein anisotropy g in (-1, 1) (0: isotropic).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = f32_open(-1.0, 1.0))]
    pub hg_g: f32,
    /// Estimate of T(t0) for the equiangular strategy of Eq. 9: jackknife or ratio (unbiased).
    #[arg(long, value_enum, default_value_t = THatArg::Jackknife)]
    pub t_hat: THatArg,
    /// Multiplier applied before the PNG preview's tone mapping (the EXR stays linear), a finite
    /// number > 0.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = parse_positive)]
    pub exposure: f32,
    /// Image width in pixels, 1 to 16384.
    #[arg(long, allow_hyphen_values = true, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: u32,
    /// Image height in pixels, 1 to 16384.
    #[arg(long, allow_hyphen_values = true, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: u32,
    /// Primary rays (transmittance estimates) per pixel, 1 to 2^20.
    #[arg(long, allow_hyphen_values = true, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    pub spp: u32,
    /// Seed, 0 to 2^32 - 1; the same seed gives the same image on every backend.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    pub seed: u32,
    /// Where kernels run: auto (GPU if a Vulkan driver exists, else CPU), gpu, or cpu.
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    pub backend: BackendChoice,
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
    /// Ids of the flags given on the command line (filled by [`parse`], not a flag).
    #[arg(skip)]
    pub given: Vec<String>,
}

/// Parses the command line like `Cli::parse`, recording which render flags the user gave.
pub fn parse() -> Result<Cli, clap::Error> {
    use clap::{CommandFactory, FromArgMatches};
    let matches = Cli::command().try_get_matches()?;
    let mut cli = Cli::from_arg_matches(&matches)?;
    let (render, sub) = match &mut cli.command {
        Some(Command::Render(args)) => (args, matches.subcommand_matches("render")),
        None => (&mut cli.render, Some(&matches)),
        Some(_) => return Ok(cli),
    };
    if let Some(m) = sub {
        render.given = m
            .ids()
            .filter(|id| {
                m.value_source(id.as_str()) == Some(clap::parser::ValueSource::CommandLine)
            })
            .map(|id| id.as_str().to_owned())
            .collect();
    }
    Ok(cli)
}

/// Flags of `host eval`.
#[derive(Args, Debug, Clone)]
pub struct EvalArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Lookups: nearest (reference = regular tracking, exact) or stochastic (reference = ratio
    /// tracking at --reference-spp, unbiased but noisy).
    #[arg(long, value_enum, default_value_t = LookupArg::Nearest)]
    pub lookup: LookupArg,
    /// Comma-separated estimators, or "all" (every one but the reference).
    #[arg(long, default_value = "all")]
    pub estimators: String,
    /// Evaluate single-scattering integrators instead of transmittance estimators:
    /// comma-separated names or "all" (see `host render --integrator`). Reference: mis-jackknife
    /// with ratio-tracking T(t0) at --reference-spp (default 16 x --spp; with the default --spp
    /// of 1024 that is slow, about 25 min at 128^2 on 2 CPU cores: try --spp 16).
    #[arg(long)]
    pub integrators: Option<String>,
    /// Estimate of T(t0) in Eq. 9 for the evaluated integrators.
    #[arg(long, value_enum, default_value_t = THatArg::Jackknife)]
    pub t_hat: THatArg,
    /// A point light "x,y,z,intensity" (repeatable; default: two lights inside the volume).
    #[arg(long = "light", value_parser = parse_light, allow_hyphen_values = true)]
    pub lights: Vec<shared::sampling::lights::PointLight>,
    /// Single-scattering albedo, in [0, 1].
    #[arg(long, default_value_t = 0.8, allow_hyphen_values = true, value_parser = f32_in(0.0, 1.0))]
    pub albedo: f32,
    /// Multiplier before the PNG previews' tone mapping, a finite number > 0.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = parse_positive)]
    pub exposure: f32,
    /// Samples per optical depth estimate (N), 1 to 4096.
    #[arg(long, allow_hyphen_values = true, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub n: u32,
    /// CDF step F_delta of jackknife-adaptive, in (0, 10] (the paper's Fig. 8d: 0.6).
    #[arg(long, default_value_t = 0.6, allow_hyphen_values = true, value_parser = parse_f_delta)]
    pub f_delta: f32,
    /// Ratio tracking with pbrt-v4's Russian roulette (off: as in the paper).
    #[arg(long)]
    pub ratio_roulette: bool,
    /// Image width, 1 to 16384.
    #[arg(long, allow_hyphen_values = true, default_value_t = 128, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: u32,
    /// Image height, 1 to 16384.
    #[arg(long, allow_hyphen_values = true, default_value_t = 128, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: u32,
    /// Estimates per pixel (all along the pixel center's ray), 2 to 2^20.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(2..=1 << 20))]
    pub spp: u32,
    /// Estimates per pixel of the reference when it is stochastic, 1 to 2^24 (default 4 x --spp;
    /// 16 x --spp with --integrators).
    #[arg(long, allow_hyphen_values = true, value_parser = clap::value_parser!(u32).range(1..=1 << 24))]
    pub reference_spp: Option<u32>,
    /// Seed, 0 to 2^32 - 1.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    pub seed: u32,
    /// Where kernels run.
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    pub backend: BackendChoice,
    /// Directory for the bias/std/mean EXRs and false-colour PNGs.
    #[arg(long, default_value = "out/eval")]
    pub out_dir: PathBuf,
    /// JSON report path (default: <out-dir>/eval.json).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// |bias| mapped to full colour in the bias PNGs, a finite number > 0.
    #[arg(long, default_value_t = 0.05, allow_hyphen_values = true, value_parser = parse_positive)]
    pub bias_scale: f32,
    /// std mapped to full colour in the std PNGs, a finite number > 0.
    #[arg(long, default_value_t = 0.5, allow_hyphen_values = true, value_parser = parse_positive)]
    pub std_scale: f32,
    /// No progress bars.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Flags of `host report`.
#[derive(Args, Debug, Clone)]
pub struct ReportArgs {
    /// Directory for index.html and one subdirectory of images per evaluation.
    #[arg(long, short, default_value = "out/report")]
    pub out: PathBuf,
    /// Comma-separated volumes to evaluate now (embedded names or files; default: cloud unless
    /// --from-eval is given).
    #[arg(long)]
    pub volumes: Option<String>,
    /// Comma-separated estimators for the new evaluations, or "all".
    #[arg(long, default_value = "all")]
    pub estimators: String,
    /// Also evaluate these single-scattering integrators (comma-separated or "all") per volume.
    #[arg(long)]
    pub integrators: Option<String>,
    /// Reuse an existing `host eval` output: a directory holding eval.json, or the JSON file
    /// (repeatable; transmittance or --integrators evaluations).
    #[arg(long = "from-eval", value_name = "DIR")]
    pub from_eval: Vec<PathBuf>,
    /// Voxels per axis of an embedded volume, 8 to 1024.
    #[arg(long, allow_hyphen_values = true, default_value_t = 256, value_parser = clap::value_parser!(u32).range(8..=1024))]
    pub resolution: u32,
    /// Lookups of the new evaluations (see `host eval --lookup`).
    #[arg(long, value_enum, default_value_t = LookupArg::Nearest)]
    pub lookup: LookupArg,
    /// Samples per optical depth estimate (N), 1 to 4096.
    #[arg(long, allow_hyphen_values = true, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub n: u32,
    /// Image width, 1 to 16384.
    #[arg(long, allow_hyphen_values = true, default_value_t = 128, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: u32,
    /// Image height, 1 to 16384.
    #[arg(long, allow_hyphen_values = true, default_value_t = 128, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: u32,
    /// Estimates per pixel of the transmittance evaluations, 2 to 2^20.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(2..=1 << 20))]
    pub spp: u32,
    /// Samples per pixel of the integrator evaluations, 2 to 2^20 (reference: 16 x this).
    #[arg(long, allow_hyphen_values = true, default_value_t = 16, value_parser = clap::value_parser!(u32).range(2..=1 << 20))]
    pub integrator_spp: u32,
    /// Seed, 0 to 2^32 - 1.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    pub seed: u32,
    /// Where kernels run.
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    pub backend: BackendChoice,
    /// |bias| mapped to full colour in the bias images, a finite number > 0.
    #[arg(long, default_value_t = 0.05, allow_hyphen_values = true, value_parser = parse_positive)]
    pub bias_scale: f32,
    /// std mapped to full colour in the std images, a finite number > 0.
    #[arg(long, default_value_t = 0.5, allow_hyphen_values = true, value_parser = parse_positive)]
    pub std_scale: f32,
    /// No progress bars.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Flags of `host probe`.
#[derive(Args, Debug, Clone)]
pub struct ProbeArgs {
    /// Where kernels run.
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    pub backend: BackendChoice,
    /// Number of (X0, X1) pairs, 1 to 2^26.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1 << 20, value_parser = clap::value_parser!(u32).range(1..=1 << 26))]
    pub count: u32,
    /// True optical depth tau of the simulated estimates, 0 to 20.
    #[arg(long, default_value_t = 2.0, allow_hyphen_values = true, value_parser = f32_in(0.0, 20.0))]
    pub tau: f32,
    /// Standard deviation sigma of each simulated optical depth estimate, 0 to 10.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = f32_in(0.0, 10.0))]
    pub sigma: f32,
    /// Seed, 0 to 2^32 - 1.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    pub seed: u32,
}

/// Parses `--f-delta`: a CDF step in (0, 10]. Steps far above a ray's F take no sample on most
/// rays (T = exp(-tau_c) there), so larger values are refused rather than rendered as empty.
pub fn parse_f_delta(s: &str) -> Result<f32, String> {
    let v: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if !(v > 0.0 && v <= 10.0) {
        return Err(format!("must be in (0, 10] (got {s}); the paper uses 0.6"));
    }
    Ok(v)
}

/// A value parser of finite numbers in `[lo, hi]`, for a flag's documented range.
pub fn f32_in(lo: f32, hi: f32) -> impl Fn(&str) -> Result<f32, String> + Clone + Send + Sync {
    move |s: &str| match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && (lo..=hi).contains(&v) => Ok(v),
        Ok(v) => Err(format!("must be a finite number in [{lo}, {hi}] (got {v})")),
        Err(e) => Err(format!("not a number: {e}")),
    }
}

/// A value parser of finite numbers in the open interval `(lo, hi)`.
pub fn f32_open(lo: f32, hi: f32) -> impl Fn(&str) -> Result<f32, String> + Clone + Send + Sync {
    move |s: &str| match s.trim().parse::<f32>() {
        Ok(v) if v > lo && v < hi => Ok(v),
        Ok(v) => Err(format!("must be in ({lo}, {hi}) (got {v})")),
        Err(e) => Err(format!("not a number: {e}")),
    }
}

/// Parses `--density-scale`: a finite number >= 0 that f32 holds (a nonzero value that rounds
/// to 0 is refused rather than rendered as an empty volume). Optical depths beyond f32's sums
/// are refused later, against the volume's densities and size.
pub fn parse_density_scale(s: &str) -> Result<f32, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    let f = v as f32;
    if !(f.is_finite() && f >= 0.0) {
        return Err(format!(
            "must be a finite number >= 0 and at most 3.4e38 (got {s})"
        ));
    }
    if v > 0.0 && f == 0.0 {
        return Err(format!(
            "{s} rounds to 0 in f32 (the smallest is 1.4e-45); use 0 for an empty volume"
        ));
    }
    Ok(f)
}

/// A finite number > 0.
pub fn parse_positive(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(v) => Err(format!("must be a finite number > 0 (got {v})")),
        Err(e) => Err(format!("not a number: {e}")),
    }
}

/// Parses "x,y,z" into three finite floats.
pub fn parse_vec3(s: &str) -> Result<[f32; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!(
            "expected x,y,z (three comma-separated numbers), got {s:?}"
        ));
    }
    let mut v = [0.0f32; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        *slot = p
            .parse()
            .map_err(|_| format!("{p:?} is not a number in {s:?}"))?;
        if !slot.is_finite() {
            return Err(format!("{p:?} is not finite in {s:?}"));
        }
    }
    Ok(v)
}
