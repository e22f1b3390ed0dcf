//! NanoVDB (`.nvdb`) reader for float grids, on the `nanovdb-rs` crate: uncompressed or ZIP
//! files, major version 32. The tree's node offsets are validated before any voxel is read.

use super::{select_grid, DenseBuilder, GridEntry, LinearMap, Loaded};
use anyhow::{ensure, Context, Result};
use nanovdb_rs::{GridType, NvdbFile, ValidatedFloatTreeCache};
use std::path::Path;

/// `"NanoVDB0"` as a little-endian u64, the first field of every grid.
const GRID_MAGIC: u64 = 0x3042_4456_6f6e_614e;
/// The NanoVDB major version whose memory layout `nanovdb-rs` reads.
const MAJOR_VERSION: u32 = 32;

/// Loads grid `grid` (or the default) of the `.nvdb` file at `path`, refusing dense grids of
/// more than `cap` voxels.
pub fn load(path: &Path, grid: Option<&str>, cap: u64) -> Result<Loaded> {
    std::fs::metadata(path)
        .with_context(|| format!("cannot read {}: check the path", path.display()))?;
    let file = NvdbFile::open(path).map_err(explain)?;
    let entries: Vec<GridEntry> = file.grids().iter().map(entry).collect();
    let chosen = &file.grids()[select_grid(&entries, grid)?];
    load_grid(chosen, cap).with_context(|| format!("grid '{}'", chosen.name()))
}

/// Adds advice to the crate's errors.
fn explain(e: nanovdb_rs::Error) -> anyhow::Error {
    let advice = match e {
        nanovdb_rs::Error::CompressionUnsupported(_) => {
            "; re-convert it without Blosc (nanovdb_convert -z for ZIP, or no flag)"
        }
        nanovdb_rs::Error::BadMagic(_) => "; is it really a .nvdb file?",
        _ => ": the file is truncated or corrupt",
    };
    anyhow::anyhow!("{e}{advice}")
}

/// A grid's listing: name, value type, and whether it is a plain float grid.
fn entry(g: &nanovdb_rs::Grid) -> GridEntry {
    let value_type = g.value_type();
    let supported = value_type == GridType::Float;
    GridEntry {
        name: g.name().to_owned(),
        value_type: format!("{value_type:?}"),
        supported,
    }
}

/// Reads one float grid into a dense grid over its index bounding box.
fn load_grid(g: &nanovdb_rs::Grid, cap: u64) -> Result<Loaded> {
    let version = g.metadata.version;
    ensure!(
        version.major() == MAJOR_VERSION,
        "NanoVDB version {version} is not supported (only {MAJOR_VERSION}.x); re-convert it with nanovdb_convert"
    );
    let bytes = g.raw_bytes();
    let header = g
        .header()
        .context("the grid header is truncated: the file is corrupt")?;
    ensure!(
        header.magic == GRID_MAGIC,
        "the grid header has a bad magic number: the file is corrupt"
    );
    ensure!(
        ValidatedFloatTreeCache::new(bytes).is_some(),
        "the tree's node offsets point outside the grid: the file is corrupt"
    );
    let map = LinearMap {
        m: header.map.mat_d,
        t: header.map.vec_d,
    };
    ensure!(
        map.is_finite(),
        "the transform has non-finite entries: the file is corrupt"
    );
    let mut accessor = g.float_read_accessor().context("not a float grid")?;
    let (lo, hi) = g.index_bbox();
    let mut bounds = DenseBuilder::default();
    if (0..3).all(|a| lo[a] <= hi[a]) {
        bounds.include(lo.map(i64::from), hi.map(i64::from));
    }
    let mut dense = bounds.allocate(accessor.background(), cap)?;
    for z in lo[2]..=hi[2] {
        for y in lo[1]..=hi[1] {
            for x in lo[0]..=hi[0] {
                if accessor.is_active([x, y, z]) {
                    dense.set([x, y, z], accessor.get_value([x, y, z]));
                }
            }
        }
    }
    Ok(Loaded { dense, map })
}
