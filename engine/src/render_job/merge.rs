//! `host merge` as a library call: the shard files of a render added up into its pixels.

use super::shard::{plan_merge, read, read_header, render_fnv1a, ShardHeader, ShardSummary};
use crate::render::totals::PixelTotals;
use anyhow::{ensure, Context, Result};
use rayon::prelude::*;
use shared::kernels::render::PixelOut;
use shared::params::RenderParams;
use std::path::{Path, PathBuf};

/// A merged render's pixels, its extra passes' pixels (by name, those its layers need), and
/// its shards.
pub struct Merged {
    pub pixels: Vec<PixelOut>,
    pub extra: Vec<(&'static str, Vec<PixelOut>)>,
    /// The shards' render times added.
    pub elapsed_ms: f64,
    pub shards: Vec<ShardSummary>,
}

/// The headers of the shards `args.merge` (each checked: see [`read_header`]).
fn headers(args: &super::options::RenderOptions) -> Result<(Vec<&Path>, Vec<ShardHeader>)> {
    let paths: Vec<&Path> = args.merge.iter().map(PathBuf::as_path).collect();
    let headers = paths
        .iter()
        .map(|p| read_header(p))
        .collect::<Result<Vec<_>>>()?;
    Ok((paths, headers))
}

/// Checks that the shards `args.merge` are of one render (see [`plan_merge`]: the same input
/// files among them) and that the input files this merge reads are those they were rendered
/// from: the volume file and light probe of `args` (the scene of the shard with the first
/// samples), each by length and FNV-1a hash. Reads every input file once: run it before the
/// merge loads them (`host merge` does), so that a changed or missing file is refused by name
/// instead of loaded.
pub fn check_inputs(args: &super::options::RenderOptions) -> Result<()> {
    let (paths, headers) = headers(args)?;
    let order = plan_merge(&paths, &headers, super::shard::RENDER)?;
    let first = *order.first().context("give the shard files to merge")?;
    let (path, header) = (paths[first], &headers[first]);
    let current = super::shard::input_paths(&args.scene.volume, args.lighting.env.as_ref(), None);
    super::shard::check_inputs(path, header, &current)
}

/// Reads the shards `args.merge` and adds their totals in sample order (exact: any order gives
/// the same), into the pixels of the render `args` and `params` describe. The shards' input
/// files are checked by [`check_inputs`], which the caller runs before loading them.
pub fn merge(
    args: &super::options::RenderOptions,
    params: &RenderParams,
    lights: &crate::lighting::SceneLights,
) -> Result<Merged> {
    let (paths, headers) = headers(args)?;
    let order = plan_merge(&paths, &headers, super::shard::RENDER)?;
    let (Some(h), Some(&first)) = (headers.first(), paths.first()) else {
        anyhow::bail!("give the shard files to merge");
    };
    ensure!(
        (h.width, h.height, h.spp) == (params.width, params.height, params.spp),
        "{}: the shards are {}x{} at {} spp, but the merge asks for {}x{} at {} spp; leave \
         --width, --height and --spp to the shards",
        first.display(),
        h.width,
        h.height,
        h.spp,
        params.width,
        params.height,
        params.spp
    );
    let here = render_fnv1a(params, lights);
    ensure!(
        h.render_fnv1a == here,
        "{}: the shards' parameters and lights (hash {}) are not those this merge rebuilds from \
         their scene (hash {here}): their input files changed, or another host version rendered \
         them",
        first.display(),
        h.render_fnv1a
    );
    // The extra passes the merge's layers need, by their images' index in the shards.
    let mut wanted = Vec::new();
    for (name, _) in super::options::extra_passes(args, params) {
        let at = h.images.iter().position(|n| n == name).ok_or_else(|| {
            anyhow::anyhow!(
                "--layers {name}: the shards hold no totals of that layer's pass; render them \
                 with --layers {name}, or merge without it"
            )
        })?;
        wanted.push((name, at));
    }
    // read_header checked the image size and count against each shard's length.
    let pixels = h.width as usize * h.height as usize;
    let mut sums = vec![vec![PixelTotals::default(); pixels]; h.images.len()];
    let mut shards = Vec::new();
    for i in order {
        let (header, images) = read(paths[i])?;
        ensure!(
            header == headers[i]
                && images.len() == sums.len()
                && images.iter().all(|image| image.len() == pixels),
            "{}: the file changed while it was merged; merge again",
            paths[i].display()
        );
        for (total, image) in sums.iter_mut().zip(&images) {
            total.par_iter_mut().zip(image).for_each(|(t, s)| t.add(s));
        }
        shards.push(ShardSummary {
            file: paths[i].display().to_string(),
            samples: header.samples,
            backend: header.backend,
            device: header.device,
            elapsed_ms: header.elapsed_ms,
        });
    }
    let extra = wanted
        .into_iter()
        .map(|(name, k)| Ok((name, crate::render::finish_totals(&sums[k], h.spp)?)))
        .collect::<Result<Vec<_>>>()?;
    let image = sums.first().context("the shards hold no image")?;
    Ok(Merged {
        pixels: crate::render::finish_totals(image, h.spp)?,
        extra,
        elapsed_ms: shards.iter().map(|s| s.elapsed_ms).sum(),
        shards,
    })
}
