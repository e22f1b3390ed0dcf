//! Where an evaluation's reference comes from: rendered here, or rendered elsewhere in shards
//! (`host eval --reference-shard FILE --reference-samples A..B` on any machines) and added up
//! (`host eval --reference-from SHARD...`), byte for byte the reference one machine renders.

use anyhow::{ensure, Result};
use engine::lighting::SceneLights;
use engine::render::Resident;
use engine::render_job::shard::{self, ShardHeader};
use engine::totals::PixelTotals;
use rayon::prelude::*;
use shared::kernels::render::PixelOut;
use shared::params::RenderParams;
use std::path::{Path, PathBuf};

/// Where an evaluation's reference comes from.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum ReferenceSource {
    /// Rendered by the evaluation.
    #[default]
    Render,
    /// Render samples `samples` of the reference only (None: all), write them as a shard to
    /// `path`, and evaluate nothing.
    WriteShard {
        path: PathBuf,
        samples: Option<(u32, u32)>,
    },
    /// Added up from these shards of the reference instead of rendered.
    Shards(Vec<PathBuf>),
}

/// The error that ends an evaluation after its reference shard is written (`run_eval` turns
/// it into success).
#[derive(Debug)]
pub struct ShardWritten;

impl std::fmt::Display for ShardWritten {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "the reference shard was written")
    }
}

impl std::error::Error for ShardWritten {}

/// The pixels of the reference `label` of `params` under `lights`: `render` renders them all;
/// from shards, their totals added; for [`ReferenceSource::WriteShard`], the shard is written
/// and the error [`ShardWritten`] returned.
pub fn reference_pixels(
    source: &ReferenceSource,
    label: &str,
    resident: &Resident,
    params: &RenderParams,
    lights: &SceneLights,
    progress: bool,
    render: impl FnOnce() -> Result<Vec<PixelOut>>,
) -> Result<Vec<PixelOut>> {
    match source {
        ReferenceSource::Render => render(),
        ReferenceSource::WriteShard { path, samples } => {
            write_shard(path, *samples, label, resident, params, lights, progress)?;
            Err(ShardWritten.into())
        }
        ReferenceSource::Shards(paths) => from_shards(paths, label, params, lights),
    }
}

/// Renders samples `samples` of the reference and writes their totals to `path`.
fn write_shard(
    path: &Path,
    samples: Option<(u32, u32)>,
    label: &str,
    resident: &Resident,
    params: &RenderParams,
    lights: &SceneLights,
    progress: bool,
) -> Result<()> {
    let block = shared::kernels::render::SAMPLE_BLOCK;
    let spp = params.spp;
    let (a, b) = samples.unwrap_or((0, spp));
    ensure!(
        a < b && b <= spp,
        "--reference-samples {a}..{b}: give a non-empty range within the reference's {spp} \
         samples per pixel (--reference-spp)"
    );
    ensure!(
        a % block == 0 && (b % block == 0 || b == spp),
        "--reference-samples {a}..{b}: a shard starts and ends at a multiple of {block} samples \
         (or ends at the reference's {spp}), so that shards add up to the bytes of one reference"
    );
    let t = std::time::Instant::now();
    let totals = engine::render::render_totals(resident, params, lights, a..b, progress)?;
    let header = ShardHeader {
        kind: shard::EVAL_REFERENCE.into(),
        scene: Default::default(),
        width: params.width,
        height: params.height,
        spp,
        samples: [a, b],
        sample_block: block,
        images: vec![label.to_owned()],
        render_fnv1a: shard::render_fnv1a(params, lights),
        payload_bytes: 0,
        payload_fnv1a: String::new(),
        backend: String::new(),
        device: String::new(),
        elapsed_ms: t.elapsed().as_secs_f64() * 1e3,
        host_version: env!("CARGO_PKG_VERSION").into(),
        command_line: std::env::args().collect(),
    };
    shard::write(path, &header, &[totals])?;
    println!(
        "reference shard: {label}, samples {a}..{b} of {spp} ({}x{}) -> {} (evaluate with \
         --reference-from and every shard)",
        params.width,
        params.height,
        path.display()
    );
    Ok(())
}

/// The reference added up from `paths`, which must be shards of exactly this reference.
fn from_shards(
    paths: &[PathBuf],
    label: &str,
    params: &RenderParams,
    lights: &SceneLights,
) -> Result<Vec<PixelOut>> {
    let paths: Vec<&Path> = paths.iter().map(PathBuf::as_path).collect();
    let headers = paths
        .iter()
        .map(|p| shard::read_header(p))
        .collect::<Result<Vec<_>>>()?;
    let order = shard::plan_merge(&paths, &headers, shard::EVAL_REFERENCE)?;
    let want = shard::render_fnv1a(params, lights);
    let h = &headers[0];
    ensure!(
        h.images == [label] && h.render_fnv1a == want && h.spp == params.spp,
        "{}: a shard of the reference `{}` ({} spp, hash {}), but this evaluation's reference is \
         `{label}` ({} spp, hash {want}): render the shards with the same flags as this \
         evaluation (volume, camera, image, lookups, --reference-spp, seed, lights)",
        paths[0].display(),
        h.images.join(","),
        h.spp,
        h.render_fnv1a,
        params.spp
    );
    let mut sum = vec![PixelTotals::default(); params.width as usize * params.height as usize];
    for i in order {
        let (header, images) = shard::read(paths[i])?;
        ensure!(
            header == headers[i] && images.len() == 1 && images[0].len() == sum.len(),
            "{}: the file changed while it was read",
            paths[i].display()
        );
        sum.par_iter_mut()
            .zip(&images[0])
            .for_each(|(t, s)| t.add(s));
    }
    tracing::info!(
        "reference `{label}` added up from {} shard{}",
        paths.len(),
        if paths.len() == 1 { "" } else { "s" }
    );
    engine::render::finish_totals(&sum, params.spp)
}
