//! Flags of `host report`.

use super::parsers::{parse_density_scale, parse_positive, BackendArg, LookupArg};
use anyhow::Result;
use clap::Args;
use engine::scene::SceneOptions;
use lab::report::ReportOptions;
use std::path::PathBuf;

/// Flags of `host report`.
#[derive(Args, Debug, Clone)]
pub struct ReportArgs {
    /// Directory for index.html and one subdirectory of images per evaluation.
    #[arg(long, short, default_value = "out/report")]
    pub out: PathBuf,
    /// A scene file (as `host render --scene`): its keys that are flags of this command apply
    /// (`volume` as --volumes; not `out`, the image of a render), the flags given override them.
    #[arg(long = "scene", id = "scene_file", value_name = "FILE")]
    pub scene_file: Option<PathBuf>,
    /// Comma-separated volumes to evaluate now (embedded names or files; default: cloud unless
    /// --from-eval is given).
    #[arg(long, value_parser = super::parsers::Utf8Text)]
    pub volumes: Option<String>,
    /// Comma-separated estimators for the new evaluations, or "all".
    #[arg(long, default_value = "all")]
    pub estimators: String,
    /// Also evaluate these single-scattering integrators (comma-separated or "all") per volume.
    #[arg(long)]
    pub integrators: Option<String>,
    /// Reuse an existing `host eval` output: a directory holding eval.json, or the JSON file
    /// (repeatable; transmittance, --integrators, or --integrators direct,path evaluations: one
    /// tab per integrator with an equal-time column, std^2 x ms).
    #[arg(long = "from-eval", value_name = "DIR")]
    pub from_eval: Vec<PathBuf>,
    /// Voxels per axis of the embedded volumes, 8 to 1024 [default: 256].
    #[arg(long, allow_hyphen_values = true, value_parser = clap::value_parser!(u32).range(8..=1024))]
    pub resolution: Option<u32>,
    /// Grid to read from the volume files (default: "density", else the first float grid).
    #[arg(long)]
    pub grid: Option<String>,
    /// Extinction per unit of stored density of every volume, 0 to 3.4e38 (default: the
    /// embedded volume's own, 1 for files).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_density_scale)]
    pub density_scale: Option<f32>,
    /// Camera (default: framing each volume) and up axis of every volume.
    #[command(flatten)]
    pub view: super::render::ViewArgs,
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
    #[arg(long, value_enum, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
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

impl ReportArgs {
    /// The library's report options: the lists of `--volumes`, `--estimators` and
    /// `--integrators` parsed.
    pub fn options(&self) -> Result<ReportOptions> {
        Ok(ReportOptions {
            out: self.out.clone(),
            volumes: self
                .volumes
                .as_ref()
                .map(|list| list.split(',').map(|v| v.trim().to_string()).collect()),
            estimators: lab::eval_direct::parse_entries(&self.estimators)?,
            integrators: match &self.integrators {
                Some(list) => lab::evaluate::parse_integrators(list)?,
                None => Vec::new(),
            },
            from_eval: self.from_eval.clone(),
            scene: self.view.applied(SceneOptions {
                resolution: self.resolution,
                grid: self.grid.clone(),
                density_scale: self.density_scale,
                ..SceneOptions::default()
            }),
            lookup: self.lookup.into(),
            n: self.n,
            width: self.width,
            height: self.height,
            spp: self.spp,
            integrator_spp: self.integrator_spp,
            seed: self.seed,
            backend: self.backend.into(),
            bias_scale: self.bias_scale,
            std_scale: self.std_scale,
            quiet: self.quiet,
        })
    }
}
