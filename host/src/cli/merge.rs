//! `host merge`: the shards of a render added up into its images.

use super::scene_file;
use anyhow::{Context, Result};
use clap::Args;
use std::ffi::OsString;
use std::path::PathBuf;

/// Flags of `host merge`.
#[derive(Args, Debug, Clone)]
pub struct MergeArgs {
    /// The shard files of one render (`host render --samples A..B --shard FILE`), covering its
    /// --spp samples once each, in any order.
    #[arg(required = true, value_name = "SHARD")]
    pub shards: Vec<PathBuf>,
    /// Output EXR (must end in .exr; the PNG preview goes next to it) [default: the render's
    /// own --out].
    #[arg(long, short)]
    pub out: Option<PathBuf>,
    /// Also write the JSON summary here [default: the `json` key of the shards' scene (when
    /// they rendered a scene file or summary that names one); else no summary].
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// No info lines.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Reads the scene of the shard with the first samples, makes it the render's command line with
/// this command's outputs, checks the input files it reads against those the shards were
/// rendered from, and renders it from the shards' totals instead of from the volume.
pub fn run(args: &MergeArgs) -> Result<()> {
    // The scene of the shard with the first samples (its backend and outputs become the
    // merged render's defaults, whatever order the shards are given in).
    let mut headers = Vec::new();
    for path in &args.shards {
        headers.push((engine::render_job::shard::read_header(path)?, path));
    }
    let (header, first) = headers
        .iter()
        .min_by_key(|(h, _)| h.samples)
        .context("give the shard files to merge")?;
    anyhow::ensure!(
        header.kind == engine::render_job::shard::RENDER,
        "{} is a shard of an evaluation's reference: give it to `host eval --reference-from`",
        first.display()
    );
    let mut argv: Vec<OsString> = scene_file::record_tokens(&header.scene, first)?;
    if let Some(out) = &args.out {
        argv.extend(["--out".into(), out.into()]);
    }
    if let Some(json) = &args.json {
        argv.extend(["--json".into(), json.into()]);
    }
    if args.quiet {
        argv.push("--quiet".into());
    }
    let render = scene_file::parse_render(argv).map_err(|e| {
        anyhow::anyhow!(
            "{}: its scene is not a render this host version reads: {}",
            first.display(),
            e.to_string().trim_start_matches("error: ").trim()
        )
    })?;
    let mut options = render.options();
    options.merge = args.shards.clone();
    // Before the volume is loaded: a changed or missing input file is refused by name.
    engine::render_job::merge::check_inputs(&options)?;
    engine::render_job::run_render(&options)
        .with_context(|| format!("merging {} shard files", args.shards.len()))
        .map(|_| ())
}
