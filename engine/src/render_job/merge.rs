//! `host merge` as a library call: the shard files of a render added up into its pixels.

use super::shard::{plan_merge, read, read_header, render_fnv1a, ShardSummary};
use crate::totals::PixelTotals;
use anyhow::{ensure, Result};
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

/// Reads the shards `args.merge` and adds their totals in sample order (exact: any order gives
/// the same), into the pixels of the render `args` and `params` describe.
pub fn merge(
    args: &super::options::RenderOptions,
    params: &RenderParams,
    lights: &crate::lighting::SceneLights,
) -> Result<Merged> {
    let paths: Vec<&Path> = args.merge.iter().map(PathBuf::as_path).collect();
    let headers = paths
        .iter()
        .map(|p| read_header(p))
        .collect::<Result<Vec<_>>>()?;
    let order = plan_merge(&paths, &headers, super::shard::RENDER)?;
    let h = &headers[0];
    ensure!(
        (h.width, h.height, h.spp) == (params.width, params.height, params.spp),
        "{}: the shards are {}x{} at {} spp, but the merge asks for {}x{} at {} spp; leave \
         --width, --height and --spp to the shards",
        paths[0].display(),
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
        paths[0].display(),
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
    let pixels = h.width as usize * h.height as usize;
    let mut sums = vec![vec![PixelTotals::default(); pixels]; h.images.len()];
    let mut shards = Vec::new();
    for i in order {
        let (header, images) = read(paths[i])?;
        ensure!(
            header == headers[i],
            "{}: the file changed while it was merged",
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
    Ok(Merged {
        pixels: crate::render::finish_totals(&sums[0], h.spp)?,
        extra,
        elapsed_ms: shards.iter().map(|s| s.elapsed_ms).sum(),
        shards,
    })
}
