//! Flags of `host bench`.

use super::parsers::{BenchBackendArg, LookupArg};
use super::render::SceneArgs;
use clap::Args;
use lab::bench::BenchOptions;
use std::path::PathBuf;

/// Flags of `host bench`.
#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// A scene file (as `host render --scene`): its keys that are flags of this command apply
    /// (the volume, camera, image size, ...), the other `host render` keys are ignored with a
    /// note; the flags given here override it.
    #[arg(long = "scene", id = "scene_file", value_name = "FILE")]
    pub scene_file: Option<PathBuf>,
    /// How the high-resolution volume is read.
    #[arg(long, value_enum, default_value_t = LookupArg::Stochastic)]
    pub lookup: LookupArg,
    /// Comma-separated estimators, or "all".
    #[arg(
        long,
        default_value = "jackknife,naive-m1,biased-rm,unbiased-rm,telescoping,track-length,ratio"
    )]
    pub estimators: String,
    /// Backends to time.
    #[arg(long, value_enum, default_value_t = BenchBackendArg::Both)]
    pub backend: BenchBackendArg,
    /// Image width, 1 to 16384.
    #[arg(long, allow_hyphen_values = true, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: u32,
    /// Image height, 1 to 16384.
    #[arg(long, allow_hyphen_values = true, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: u32,
    /// Estimates per pixel per frame, 2 to 4096.
    #[arg(long, allow_hyphen_values = true, default_value_t = 8, value_parser = clap::value_parser!(u32).range(2..=4096))]
    pub spp: u32,
    /// Samples per optical depth estimate (N), 1 to 4096.
    #[arg(long, allow_hyphen_values = true, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub n: u32,
    /// Seed, 0 to 2^32 - 1 (every frame of an estimator renders the same rays and samples).
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    pub seed: u32,
    /// Timed frames per estimator, 1 to 1000.
    #[arg(long, allow_hyphen_values = true, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub reps: u32,
    /// Untimed frames per estimator first, 0 to 100 (pipeline compilation, caches).
    #[arg(long, allow_hyphen_values = true, default_value_t = 1, value_parser = clap::value_parser!(u32).range(0..=100))]
    pub warmup: u32,
    /// Also sweep the embedded volume's resolution and the image size.
    #[arg(long)]
    pub sweep: bool,
    /// Volume resolutions of the sweep, each 8 to 1024.
    #[arg(long, default_value = "64,128,256,512")]
    pub sweep_resolutions: String,
    /// Image sizes (square) of the sweep, each 1 to 16384.
    #[arg(long, default_value = "64,128,256,512")]
    pub sweep_sizes: String,
    /// Estimators of the sweep.
    #[arg(long, default_value = "jackknife,track-length,ratio,unbiased-rm")]
    pub sweep_estimators: String,
    /// Volume files (.vdb, .nvdb) timed one by one, e.g. a sparse series of growing bounding
    /// boxes: load + pack time, peak resident memory, pool size and ns/ray per backend and
    /// sweep estimator (JSON `sweep_files`); comma-separated.
    #[arg(long, value_delimiter = ',')]
    pub sweep_files: Vec<PathBuf>,
    /// Plot of the sweep (.png or .svg).
    #[arg(long, default_value = "out/bench_sweep.png")]
    pub plot: PathBuf,
    /// Write every number as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// No progress lines.
    #[arg(long, short)]
    pub quiet: bool,
}

impl BenchArgs {
    /// The library's bench options: the comma-separated lists parsed.
    pub fn options(&self) -> anyhow::Result<BenchOptions> {
        use lab::bench::{parse_estimators, parse_numbers};
        Ok(BenchOptions {
            scene: self.scene.options(),
            lookup: self.lookup.into(),
            estimators: parse_estimators(&self.estimators, "--estimators")?,
            backend: self.backend.into(),
            width: self.width,
            height: self.height,
            spp: self.spp,
            n: self.n,
            seed: self.seed,
            reps: self.reps,
            warmup: self.warmup,
            sweep: self.sweep,
            sweep_resolutions: parse_numbers(
                &self.sweep_resolutions,
                "--sweep-resolutions",
                8..=1024,
            )?,
            sweep_sizes: parse_numbers(&self.sweep_sizes, "--sweep-sizes", 1..=16384)?,
            sweep_estimators: parse_estimators(&self.sweep_estimators, "--sweep-estimators")?,
            sweep_files: self.sweep_files.clone(),
            plot: self.plot.clone(),
            json: self.json.clone(),
            quiet: self.quiet,
        })
    }
}
