//! NanoVDB (`.nvdb`) reader for float grids, on the `nanovdb-rs` crate: uncompressed or ZIP
//! files, major version 32. The tree's node offsets are validated before any voxel is read.
//!
//! A sparse load walks the validated tree's nodes ([`walk`]: root tiles, the 32^3 upper and
//! 16^3 lower internal nodes, the 8^3 leaves) into the sparse cells, never visiting the
//! bounding box voxel by voxel; the dense load asks the crate's accessor for every voxel of the
//! index bounding box. The two read the same voxels (tested on every fixture).

use super::bytes::ByteReader;
use super::topology::{bit, child_origin, ones, Survey, TopologySink};
use super::{select_grid, sparse, DenseBuilder, GridEntry, LinearMap, Loaded, Voxels};
use anyhow::{ensure, Context, Result};
use nanovdb_rs::{GridClass, GridType, NvdbFile, ValidatedFloatTreeCache, GRID_DATA_SIZE};
use std::collections::HashSet;
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
/// more than `cap` voxels; `options`: whether to keep it sparse where it can be and the check of
/// its bounding box before any value is read (see [`super::LoadOptions`]).
pub fn load(
    path: &Path,
    grid: Option<&str>,
    cap: u64,
    options: &super::LoadOptions,
) -> Result<Loaded> {
    preflight(&mut super::stream_file(path)?)?;
    let file = NvdbFile::open(path).map_err(explain)?;
    let entries: Vec<GridEntry> = file.grids().iter().map(entry).collect();
    let (index, label) = select_grid(&entries, grid)?;
    let chosen = &file.grids()[index];
    let mut loaded = load_grid(chosen, cap, options).with_context(|| format!("grid '{label}'"))?;
    loaded.grid = label;
    Ok(loaded)
}

/// Walks the file's segments and grid metadata as `nanovdb-rs` will, refusing what would make it
/// index past the end of the file or decompress more than the file can hold: the crate trusts
/// these sizes. Reads only the headers and metadata through `r` (a streamed file); the grids
/// themselves are only bounds-checked, so the file is never held in memory twice (`nanovdb-rs`
/// maps it).
fn preflight(r: &mut ByteReader) -> Result<()> {
    let len = r.remaining() as u64;
    // Whether [at, at + n) lies within the file, with the error naming `what`.
    let within = |at: u64, n: u64, what: &str| -> Result<()> {
        let end = at.checked_add(n).filter(|&e| e <= len);
        end.map(|_| ()).with_context(|| {
            format!(
                "the file is truncated: {what} at byte {at} needs {n} bytes, the file has {len}"
            )
        })
    };
    // The `n` bytes at `at` (headers and metadata only: `n` is a small constant).
    let mut field = |at: u64, n: u64, what: &str| -> Result<Vec<u8>> {
        within(at, n, what)?;
        r.seek(at)?;
        Ok(r.bytes(n as usize)?.to_vec())
    };
    let u64_at = |b: &[u8], i: usize| u64::from_le_bytes(b[i..i + 8].try_into().expect("8 bytes"));
    ensure!(len > 0, "the file is empty");
    let mut cursor = 0u64;
    while cursor < len {
        let head = field(cursor, SEGMENT_HEADER_BYTES, "a segment header")?;
        ensure!(
            u64_at(&head, 0) == GRID_MAGIC,
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
            grid_sizes.push(u64_at(&meta, 0));
            let name_size = u64::from(u32::from_le_bytes(meta[136..140].try_into().expect("4")));
            cursor += META_FIXED_BYTES;
            within(cursor, name_size, "a grid name")?;
            cursor += name_size;
        }
        for grid_size in grid_sizes {
            match codec {
                0 => {
                    within(cursor, grid_size, "a grid")?;
                    cursor += grid_size;
                }
                1 => {
                    let compressed = u64_at(&field(cursor, 8, "a compressed grid's size")?, 0);
                    cursor += 8;
                    within(cursor, compressed, "a compressed grid")?;
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

/// Reads one float grid: sparse (see [`load_sparse`]) or into a dense grid over its index
/// bounding box.
fn load_grid(g: &nanovdb_rs::Grid, cap: u64, options: &super::LoadOptions) -> Result<Loaded> {
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
    let (lo, hi) = g.index_bbox();
    if options.sparse {
        if let Some(voxels) = load_sparse(bytes, (lo, hi), options)? {
            return Ok(Loaded {
                voxels,
                map,
                grid: g.name().to_owned(),
            });
        }
    }
    let mut accessor = g.float_read_accessor().context("not a float grid")?;
    let mut bounds = DenseBuilder::default();
    if (0..3).all(|a| lo[a] <= hi[a]) {
        bounds.include(lo.map(i64::from), hi.map(i64::from));
    }
    super::TopologyCheck::run(options.check_topology, bounds.bounds, 0)?;
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

/// The grid's active tiles and leaves as sparse cells, if it can be kept sparse: background 0
/// and the active voxels' bounds equal to the index bounding box `bbox` (what NanoVDB's
/// builders write; the dense load reads exactly that box). `None`: load it dense (which also
/// gives the error of an empty box). The topology check of `options` runs once the tree is
/// surveyed, before any leaf value is read.
fn load_sparse(
    bytes: &[u8],
    bbox: ([i32; 3], [i32; 3]),
    options: &super::LoadOptions,
) -> Result<Option<Voxels>> {
    let (lo, hi) = (bbox.0.map(i64::from), bbox.1.map(i64::from));
    if (0..3).any(|a| lo[a] > hi[a]) {
        return Ok(None);
    }
    let tree = Tree::new(bytes, (lo, hi))?;
    let mut survey = Survey::default();
    // Whether every active leaf value is an f16 exactly (a grid converted from a half-float
    // OpenVDB file): its leaves are then held as f16, half the bytes of f32 and the same values,
    // and the sparse store never widens while it is filled. Decided in the survey's walk.
    let mut halves = true;
    tree.walk(&mut |node| match node {
        Node::Tile {
            origin,
            log2,
            value,
        } => survey.tile(origin, log2, value),
        Node::Leaf {
            origin,
            mask,
            values,
        } => {
            survey.leaf(origin, mask);
            halves = halves && active_values_are_halves(&mask, values);
        }
    })?;
    if !survey.fits_cells(tree.background) || survey.bounds.bounds != Some((lo, hi)) {
        return Ok(None);
    }
    super::TopologyCheck::run(
        options.check_topology,
        survey.bounds.bounds,
        survey.tile_voxels,
    )?;
    let mut voxels = survey.allocate_cells(halves)?;
    let mut values = vec![0.0f32; 512];
    tree.walk(&mut |node| match node {
        Node::Tile {
            origin,
            log2,
            value,
        } => voxels.tile(origin, log2, value),
        Node::Leaf {
            origin,
            mask,
            values: raw,
        } => {
            for (v, b) in values.iter_mut().zip(raw.as_chunks::<4>().0) {
                *v = f32::from_le_bytes(*b);
            }
            voxels.set_leaf(origin, &mask, &values);
        }
    })?;
    Ok(Some(voxels))
}

/// Whether every active value of a leaf (`mask`, its 512 raw f32 `values`) is an f16 exactly.
fn active_values_are_halves(mask: &[u64; 8], values: &[u8]) -> bool {
    let raw = values.as_chunks::<4>().0;
    ones(mask).all(|n| sparse::exact_half(f32::from_le_bytes(raw[n])).is_some())
}

/// Bytes of a root node's header before its tile table (`RootData<float>`, 32-byte aligned).
const ROOT_HEADER_BYTES: usize = 64;
/// Bytes of one root tile: key u64, child offset i64, state u32, value f32, padding.
const ROOT_TILE_BYTES: usize = 32;
/// Offset of a leaf's active-voxel mask (after its bbox and flags).
const LEAF_MASK_AT: usize = 16;
/// Offset of a leaf's 512 f32 values (after the mask and its min/max/average/std).
const LEAF_VALUES_AT: usize = 96;
/// Root keys put each axis's coordinate bits above 12 in 21-bit fields (z lowest, x highest)
/// of which the coordinate fills 20; a key with other bits set is reached by no coordinate.
const ROOT_KEY_BITS: u64 = 0xF_FFFF | 0xF_FFFF << 21 | 0xF_FFFF << 42;

/// A node met by [`Tree::walk`].
enum Node<'a> {
    /// An active tile of `2^log2` voxels per axis at `origin` with value `value`.
    Tile {
        origin: [i32; 3],
        log2: u32,
        value: f32,
    },
    /// A leaf at `origin`: its active-voxel mask and its 512 values (f32, little-endian, bit
    /// `x << 6 | y << 3 | z`).
    Leaf {
        origin: [i32; 3],
        mask: [u64; 8],
        values: &'a [u8],
    },
}

/// A float grid's tree, for walking its nodes within a box.
struct Tree<'a> {
    bytes: &'a [u8],
    /// The inclusive index box walked: nodes entirely outside it are skipped (the dense load
    /// never reads them either), so a corrupt tree whose nodes share children cannot make the
    /// walk visit more nodes than the box holds.
    clip: ([i64; 3], [i64; 3]),
    /// Byte offset of the root node in `bytes`.
    root: usize,
    background: f32,
}

impl<'a> Tree<'a> {
    /// The tree of validated grid bytes (see [`ValidatedFloatTreeCache`]), walked in `clip`.
    fn new(bytes: &'a [u8], clip: ([i64; 3], [i64; 3])) -> Result<Self> {
        let mut tree = Tree {
            bytes,
            clip,
            root: 0,
            background: 0.0,
        };
        // TreeData follows GridData: node offsets leaf, lower, upper, root, relative to it.
        let root = tree.u64(GRID_DATA_SIZE + 24)?;
        tree.root = usize::try_from(root)
            .ok()
            .and_then(|r| r.checked_add(GRID_DATA_SIZE))
            .context("the root node offset is out of range: the file is corrupt")?;
        tree.background = f32::from_bits(tree.u32(tree.root + 28)?);
        Ok(tree)
    }

    /// `n` bytes at `at`, or an error if the grid is shorter.
    fn slice(&self, at: usize, n: usize) -> Result<&'a [u8]> {
        at.checked_add(n)
            .and_then(|end| self.bytes.get(at..end))
            .with_context(|| {
                format!("a node at byte {at} runs past the end of the grid: the file is corrupt")
            })
    }

    fn u32(&self, at: usize) -> Result<u32> {
        Ok(u32::from_le_bytes(self.slice(at, 4)?.try_into()?))
    }

    fn u64(&self, at: usize) -> Result<u64> {
        Ok(u64::from_le_bytes(self.slice(at, 8)?.try_into()?))
    }

    /// Whether the node of `2^log2` voxels per axis at `origin` overlaps the walked box.
    fn overlaps(&self, origin: [i32; 3], log2: u32) -> bool {
        let (lo, hi) = self.clip;
        (0..3).all(|a| {
            let o = i64::from(origin[a]);
            o <= hi[a] && o + (1i64 << log2) > lo[a]
        })
    }

    /// The node `offset` bytes (signed) from the node at `from`.
    fn child(&self, from: usize, offset: u64) -> Result<usize> {
        (from as i64)
            .checked_add(offset as i64)
            .and_then(|c| usize::try_from(c).ok())
            .context("a child offset points outside the grid: the file is corrupt")
    }

    /// Calls `visit` for every active tile and every leaf, each at the place the tree's
    /// coordinates give it (as the accessor finds them; a node's own bbox fields are not read).
    /// A root key listed twice is walked once, as the accessor only ever finds the first.
    fn walk(&self, visit: &mut impl FnMut(Node<'a>)) -> Result<()> {
        let count = self.u32(self.root + 24)? as usize;
        let mut seen = HashSet::new();
        for i in 0..count {
            let tile = self.root + ROOT_HEADER_BYTES + i * ROOT_TILE_BYTES;
            let key = self.u64(tile)?;
            if key & !ROOT_KEY_BITS != 0 || !seen.insert(key) {
                continue;
            }
            let field = |shift: u32| (((key >> shift) & 0xF_FFFF) << 12) as u32 as i32;
            let origin = [field(42), field(21), field(0)];
            if !self.overlaps(origin, 12) {
                continue;
            }
            let child = self.u64(tile + 8)?;
            if child == 0 {
                if self.u32(tile + 16)? != 0 {
                    let value = f32::from_bits(self.u32(tile + 20)?);
                    visit(Node::Tile {
                        origin,
                        log2: 12,
                        value,
                    });
                }
            } else {
                self.internal(self.child(self.root, child)?, origin, 5, visit)?;
            }
        }
        Ok(())
    }

    /// An internal node of `2^log2` children per axis (5: upper, 4: lower) at `origin`.
    fn internal(
        &self,
        node: usize,
        origin: [i32; 3],
        log2: u32,
        visit: &mut impl FnMut(Node<'a>),
    ) -> Result<()> {
        let slots = 1usize << (3 * log2);
        let mask_bytes = slots / 8;
        let masks = |at: usize| -> Result<Vec<u64>> {
            Ok(self
                .slice(at, mask_bytes)?
                .as_chunks::<8>()
                .0
                .iter()
                .map(|&w| u64::from_le_bytes(w))
                .collect())
        };
        // InternalData: bbox (24), flags (8), value mask, child mask, 4 statistics, 32-aligned.
        let value_mask = masks(node + 32)?;
        let child_mask = masks(node + 32 + mask_bytes)?;
        let table = node + (32 + 2 * mask_bytes + 16).next_multiple_of(32);
        let child_log2 = if log2 == 5 { 7 } else { 3 };
        for n in ones(&value_mask).filter(|&n| !bit(&child_mask, n)) {
            let tile = child_origin(origin, n, log2, child_log2);
            if self.overlaps(tile, child_log2) {
                visit(Node::Tile {
                    origin: tile,
                    log2: child_log2,
                    value: f32::from_bits(self.u32(table + 8 * n)?),
                });
            }
        }
        for n in ones(&child_mask) {
            let at = origin;
            let origin = child_origin(at, n, log2, child_log2);
            if !self.overlaps(origin, child_log2) {
                continue;
            }
            let child = self.child(node, self.u64(table + 8 * n)?)?;
            if log2 == 5 {
                self.internal(child, origin, 4, visit)?;
            } else {
                let mask = self.slice(child + LEAF_MASK_AT, 64)?.as_chunks::<8>().0;
                visit(Node::Leaf {
                    origin,
                    mask: std::array::from_fn(|w| u64::from_le_bytes(mask[w])),
                    values: self.slice(child + LEAF_VALUES_AT, 512 * 4)?,
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;
    use std::io::{Cursor, Read, Seek, SeekFrom};
    use std::rc::Rc;

    /// A reader over bytes in memory that counts the bytes read.
    struct Counting {
        inner: Cursor<Vec<u8>>,
        read: Rc<Cell<u64>>,
    }

    impl Read for Counting {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let n = self.inner.read(buf)?;
            self.read.set(self.read.get() + n as u64);
            Ok(n)
        }
    }

    impl Seek for Counting {
        fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
            self.inner.seek(pos)
        }
    }

    /// A one-segment, one-grid, uncompressed file whose grid is `grid` zero bytes.
    fn file_with_grid(grid: u64) -> Vec<u8> {
        let mut file = Vec::new();
        file.extend(GRID_MAGIC.to_le_bytes());
        file.extend(0u32.to_le_bytes()); // version (the crate checks it)
        file.extend(1u16.to_le_bytes()); // grid count
        file.extend(0u16.to_le_bytes()); // codec: none
        let mut meta = vec![0u8; META_FIXED_BYTES as usize];
        meta[0..8].copy_from_slice(&grid.to_le_bytes());
        meta[136..140].copy_from_slice(&4u32.to_le_bytes());
        file.extend(meta);
        file.extend(b"test");
        file.resize(file.len() + grid as usize, 0);
        file
    }

    /// The preflight reads the headers, not the grids (`nanovdb-rs` maps the file; reading it
    /// whole as well held it in memory twice): a file with a 64 MiB grid is checked reading at
    /// most one 1 MiB window, and the same file one byte short is refused naming the grid.
    #[test]
    fn preflight_reads_the_headers_not_the_grids() {
        let file = file_with_grid(64 << 20);
        let read = Rc::new(Cell::new(0u64));
        let len = file.len() as u64;
        let src = Counting {
            inner: Cursor::new(file.clone()),
            read: read.clone(),
        };
        preflight(&mut ByteReader::from_source(src, len)).unwrap();
        assert!(read.get() <= 1 << 20, "read {} bytes", read.get());

        let short = file[..file.len() - 1].to_vec();
        let n = short.len() as u64;
        let err = preflight(&mut ByteReader::from_source(Cursor::new(short), n)).unwrap_err();
        assert!(
            err.to_string().contains("a grid at byte"),
            "unexpected error: {err:#}"
        );
    }
}
