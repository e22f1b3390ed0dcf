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
}

/// Transmittance estimators of `host render`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum EstimatorArg {
    /// Jackknife K = cos(S) exp(-X̄) (Eq. 4) on Alg. 1's two estimates.
    Jackknife,
    /// Naive exp(-X̄) on the same two estimates (biased up by Jensen's inequality).
    Naive,
}

/// High-resolution lookups.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LookupArg {
    /// The voxel containing the sample point.
    Nearest,
    /// Stochastic texture filtering: jitter by up to half a voxel, then nearest (Sec. 4.3).
    Stochastic,
}

/// Super-voxel importance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ImportanceArg {
    /// RMS of (mu - mu_min) with the mu_min control variate (Eq. 5; the paper's method).
    Variance,
    /// Mean extinction without a control variate (Kettunen et al. 2021; Fig. 9 ablation).
    Mean,
}

/// Jitter of the N samples of one estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum JitterArg {
    /// An independent offset per stratum (the paper's choice, Sec. 4.1).
    Stratified,
    /// One offset shared by all strata.
    Uniform,
}

/// Flags of `host render`.
#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// Embedded volume (cloud, explosion, constant) or a .vdb / .nvdb file.
    #[arg(long, default_value = "cloud")]
    pub volume: String,
    /// Grid to read from a file (default: "density", else the first float grid).
    #[arg(long)]
    pub grid: Option<String>,
    /// Voxels per axis of an embedded volume.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(8..=1024))]
    pub resolution: u32,
    /// Extinction per unit of stored density (default: the embedded volume's own, 1 for files).
    #[arg(long, allow_negative_numbers = true)]
    pub density_scale: Option<f32>,
    /// Voxels per super-voxel (brick) along each axis.
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(2..=256))]
    pub brick_size: u32,
    /// How the high-resolution volume is read.
    #[arg(long, value_enum, default_value_t = LookupArg::Stochastic)]
    pub lookup: LookupArg,
    /// Transmittance estimator.
    #[arg(long, value_enum, default_value_t = EstimatorArg::Jackknife)]
    pub estimator: EstimatorArg,
    /// Samples per optical depth estimate (N; two estimates per ray).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub n: u32,
    /// Super-voxel importance for sampling.
    #[arg(long, value_enum, default_value_t = ImportanceArg::Variance)]
    pub importance: ImportanceArg,
    /// Jitter of the samples within their strata.
    #[arg(long, value_enum, default_value_t = JitterArg::Stratified)]
    pub jitter: JitterArg,
    /// Image width in pixels.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: u32,
    /// Primary rays (transmittance estimates) per pixel.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    pub spp: u32,
    /// Seed; the same seed gives the same image on every backend.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Where kernels run: auto (GPU if a Vulkan driver exists, else CPU), gpu, or cpu.
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    pub backend: BackendChoice,
    /// Output EXR (linear transmittance); a PNG preview is written next to it.
    #[arg(long, short, default_value = "out/render.exr")]
    pub out: PathBuf,
    /// Also write a JSON summary here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Camera position x,y,z in world units (default: framing the volume from the front).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub camera: Option<[f32; 3]>,
    /// Point the camera looks at, x,y,z (default: the volume's center).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub look_at: Option<[f32; 3]>,
    /// Vertical field of view in degrees.
    #[arg(long, default_value_t = 40.0, allow_negative_numbers = true)]
    pub fov: f32,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Flags of `host probe`.
#[derive(Args, Debug, Clone)]
pub struct ProbeArgs {
    /// Where kernels run.
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    pub backend: BackendChoice,
    /// Number of (X0, X1) pairs.
    #[arg(long, default_value_t = 1 << 20, value_parser = clap::value_parser!(u32).range(1..=1 << 26))]
    pub count: u32,
    /// True optical depth tau of the simulated estimates.
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    pub tau: f32,
    /// Standard deviation sigma of each simulated optical depth estimate.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub sigma: f32,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
}

/// Parses "x,y,z" into three finite floats.
fn parse_vec3(s: &str) -> Result<[f32; 3], String> {
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
