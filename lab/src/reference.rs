//! Where an evaluation's reference comes from: rendered here, or rendered elsewhere in shards
//! (`host eval --reference-shard FILE --reference-samples A..B` on any machines) and added up
//! (`host eval --reference-from SHARD...`), byte for byte the reference one machine renders.

use anyhow::{ensure, Context, Result};
use engine::lighting::SceneLights;
use engine::render::totals::PixelTotals;
use engine::render::Resident;
use engine::render_job::shard::{self, InputPaths, ShardHeader};
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
    /// `path` with the identity of the evaluation's input files `inputs`
    /// ([`shard::input_paths`]), and evaluate nothing.
    WriteShard {
        path: PathBuf,
        samples: Option<(u32, u32)>,
        inputs: InputPaths,
    },
    /// Added up from these shards of the reference instead of rendered.
    Shards(ShardSet),
}

/// The shards an evaluation's reference is added up from, and the evaluation's input files
/// ([`shard::input_paths`]), which must be those the shards were rendered from. Reads as the
/// list of the shards' paths.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShardSet {
    pub paths: Vec<PathBuf>,
    pub inputs: InputPaths,
}

impl std::ops::Deref for ShardSet {
    type Target = [PathBuf];

    fn deref(&self) -> &[PathBuf] {
        &self.paths
    }
}

impl<'a> IntoIterator for &'a ShardSet {
    type Item = &'a PathBuf;
    type IntoIter = std::slice::Iter<'a, PathBuf>;

    fn into_iter(self) -> Self::IntoIter {
        self.paths.iter()
    }
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
        ReferenceSource::WriteShard {
            path,
            samples,
            inputs,
        } => {
            let shard = Reference {
                label,
                params,
                lights,
            };
            write_shard(path, *samples, inputs, &shard, resident, progress)?;
            Err(ShardWritten.into())
        }
        ReferenceSource::Shards(set) => from_shards(set, label, params, lights),
    }
}

/// What a reference is of.
struct Reference<'a> {
    label: &'a str,
    params: &'a RenderParams,
    lights: &'a SceneLights,
}

/// Renders samples `samples` of the reference and writes their totals to `path`, with the
/// identity of the input files `inputs`.
fn write_shard(
    path: &Path,
    samples: Option<(u32, u32)>,
    inputs: &InputPaths,
    reference: &Reference,
    resident: &Resident,
    progress: bool,
) -> Result<()> {
    let Reference {
        label,
        params,
        lights,
    } = *reference;
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
    // The input files' identity, read before hours of rendering.
    let inputs = shard::record_inputs(inputs)?;
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
        inputs,
        payload_bytes: 0,
        payload_fnv1a: String::new(),
        backend: resident.backend().kind().into(),
        device: resident.backend().device(),
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

/// The reference added up from the shards `set`, which must be shards of exactly this
/// reference, rendered from the evaluation's input files as they are now.
fn from_shards(
    set: &ShardSet,
    label: &str,
    params: &RenderParams,
    lights: &SceneLights,
) -> Result<Vec<PixelOut>> {
    let paths: Vec<&Path> = set.paths.iter().map(PathBuf::as_path).collect();
    let headers = paths
        .iter()
        .map(|p| shard::read_header(p))
        .collect::<Result<Vec<_>>>()?;
    let order = shard::plan_merge(&paths, &headers, shard::EVAL_REFERENCE)?;
    let first = *order.first().context("give the reference's shard files")?;
    let (path, h) = (paths[first], &headers[first]);
    // The input files first: a changed volume changes the parameters' hash too.
    shard::check_inputs(path, h, &set.inputs)?;
    let want = shard::render_fnv1a(params, lights);
    ensure!(
        h.images == [label]
            && h.render_fnv1a == want
            && (h.width, h.height, h.spp) == (params.width, params.height, params.spp),
        "{}: a shard of the reference `{}` ({}x{}, {} spp, hash {}), but this evaluation's \
         reference is `{label}` ({}x{}, {} spp, hash {want}): render the shards with the same \
         flags as this evaluation (volume, camera, image, lookups, --reference-spp, seed, lights)",
        path.display(),
        h.images.join(","),
        h.width,
        h.height,
        h.spp,
        h.render_fnv1a,
        params.width,
        params.height,
        params.spp
    );
    let mut sum = vec![PixelTotals::default(); params.width as usize * params.height as usize];
    for i in order {
        let (header, images) = shard::read(paths[i])?;
        let image = match images.as_slice() {
            [image] if header == headers[i] && image.len() == sum.len() => image,
            _ => anyhow::bail!(
                "{}: the file changed while it was read; evaluate again",
                paths[i].display()
            ),
        };
        sum.par_iter_mut().zip(image).for_each(|(t, s)| t.add(s));
    }
    tracing::info!(
        "reference `{label}` added up from {} shard{}",
        paths.len(),
        if paths.len() == 1 { "" } else { "s" }
    );
    engine::render::finish_totals(&sum, params.spp)
}
