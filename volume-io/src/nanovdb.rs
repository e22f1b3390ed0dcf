//! NanoVDB (`.nvdb`) reader for float grids, on the `nanovdb-rs` crate: uncompressed or ZIP
//! files, major version 32. The tree's node offsets are validated before any voxel is read.

use super::{select_grid, DenseBuilder, GridEntry, LinearMap, Loaded};
use anyhow::{ensure, Context, Result};
use nanovdb_rs::{GridClass, GridType, NvdbFile, ValidatedFloatTreeCache};
use std::path::Path;

/// `"NanoVDB0"` as a little-endian u64: the first field of every segment header and grid.
const GRID_MAGIC: u64 = 0x3042_4456_6f6e_614e;
/// The NanoVDB major version whose memory layout `nanovdb-rs` reads.
const MAJOR_VERSION: u32 = 32;

/// Bytes of a segment header: magic u64, version u32, grid count u16, codec u16.
const SEGMENT_HEADER_BYTES: u64 = 16;
/// Fixed bytes of a grid's file metadata, before its name.
const META_FIXED_BYTES: u64 = 176;
/// zlib's largest expansion: a deflate stream never decompresses to more than ~1032x its size.
const ZLIB_MAX_RATIO: u64 = 1032;

/// Loads grid `grid` (or the default) of the `.nvdb` file at `path`, refusing dense grids of
/// more than `cap` voxels.
pub fn load(path: &Path, grid: Option<&str>, cap: u64) -> Result<Loaded> {
    preflight(&super::read_file(path)?)?;
    let file = NvdbFile::open(path).map_err(explain)?;
    let entries: Vec<GridEntry> = file.grids().iter().map(entry).collect();
    let chosen = &file.grids()[select_grid(&entries, grid)?];
    load_grid(chosen, cap).with_context(|| format!("grid '{}'", chosen.name()))
}

/// Walks the file's segments and grid metadata as `nanovdb-rs` will, refusing what would make it
/// index past the end of the file or decompress more than the file can hold: the crate trusts
/// these sizes.
fn preflight(bytes: &[u8]) -> Result<()> {
    let len = bytes.len() as u64;
    let field = |at: u64, n: u64, what: &str| -> Result<&[u8]> {
        let end = at.checked_add(n).filter(|&e| e <= len);
        let end = end.with_context(|| {
            format!(
                "the file is truncated: {what} at byte {at} needs {n} bytes, the file has {len}"
            )
        })?;
        Ok(&bytes[at as usize..end as usize])
    };
    let u64_at = |b: &[u8], i: usize| u64::from_le_bytes(b[i..i + 8].try_into().expect("8 bytes"));
    ensure!(len > 0, "the file is empty");
    let mut cursor = 0u64;
    while cursor < len {
        let head = field(cursor, SEGMENT_HEADER_BYTES, "a segment header")?;
        ensure!(
            u64_at(head, 0) == GRID_MAGIC,
            "not a NanoVDB file: bad magic number at byte {cursor} (expected \"NanoVDB0\")"
        );
        let grid_count = u16::from_le_bytes([head[12], head[13]]);
        let codec = u16::from_le_bytes([head[14], head[15]]);
        ensure!(
            grid_count > 0,
            "a segment at byte {cursor} lists no grids: the file is corrupt"
        );
        cursor += SEGMENT_HEADER_BYTES;
        let mut grid_sizes = Vec::with_capacity(usize::from(grid_count));
        for _ in 0..grid_count {
            let meta = field(cursor, META_FIXED_BYTES, "grid metadata")?;
            grid_sizes.push(u64_at(meta, 0));
            let name_size = u64::from(u32::from_le_bytes(meta[136..140].try_into().expect("4")));
            cursor += META_FIXED_BYTES;
            field(cursor, name_size, "a grid name")?;
            cursor += name_size;
        }
        for grid_size in grid_sizes {
            match codec {
                0 => {
                    field(cursor, grid_size, "a grid")?;
                    cursor += grid_size;
                }
                1 => {
                    let compressed = u64_at(field(cursor, 8, "a compressed grid's size")?, 0);
                    cursor += 8;
                    field(cursor, compressed, "a compressed grid")?;
                    ensure!(
                        grid_size / ZLIB_MAX_RATIO <= compressed,
                        "a grid claims {grid_size} bytes from {compressed} compressed bytes, more \
                         than zlib can produce: the file is corrupt"
                    );
                    cursor += compressed;
                }
                // The crate reports unsupported codecs itself, with our advice.
                _ => return Ok(()),
            }
        }
    }
    Ok(())
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

/// A grid's listing: name, value type, and whether it is a plain float fog volume; level sets
/// and quantized float grids get reasons of their own.
fn entry(g: &nanovdb_rs::Grid) -> GridEntry {
    let value_type = g.value_type();
    let supported = value_type == GridType::Float;
    let mut e = GridEntry::new(g.name().to_owned(), format!("{value_type:?}"), supported);
    if matches!(
        value_type,
        GridType::Fp4 | GridType::Fp8 | GridType::Fp16 | GridType::FpN
    ) {
        e.why = Some(format!(
            "grid '{}' holds {value_type:?} values (NanoVDB's quantized floats), which this \
             reader does not decode; re-convert the .vdb without quantization (nanovdb_convert \
             without --fp4/--fp8/--fp16/--fpN) or load the .vdb itself",
            e.name
        ));
    } else if g.metadata.grid_class == GridClass::LevelSet {
        e = e.level_set();
    }
    e
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
    Ok(Loaded {
        voxels: super::Voxels::Dense(dense),
        map,
        grid: g.name().to_owned(),
    })
}
