//! OpenVDB (`.vdb`) reader for scalar float and double grids with the standard 5-4-3 tree,
//! file format 222 and newer (OpenVDB 3 onwards): no, ZIP or Blosc compression, active-mask
//! compression, half-float storage, active tiles at every level, any linear transform.
//!
//! The whole file is read into memory and parsed with a bounds-checked cursor; every buffer this
//! module allocates is bounded by the file's size or by a node's fixed value count.

use super::blosc;
use super::bytes::ByteReader;
use super::topology::{bit, child_origin, ones, Leaf, Survey, TopologySink};
use super::{GridEntry, LinearMap, Voxels};
use anyhow::{bail, ensure, Context, Result};
use std::io::Read;

/// `OPENVDB_MAGIC`, the first eight bytes of every `.vdb` file.
const MAGIC: u64 = 0x5644_4220;
/// Oldest supported format: per-node compression metadata (`NODE_MASK_COMPRESSION`).
const MIN_VERSION: u32 = 222;
/// Grid compression flag: zlib.
const COMPRESS_ZIP: u32 = 0x1;
/// Grid compression flag: only active values are stored.
const COMPRESS_ACTIVE_MASK: u32 = 0x2;
/// Grid compression flag: Blosc.
const COMPRESS_BLOSC: u32 = 0x4;
/// Suffix OpenVDB appends to a grid's type name when its floats are stored as halves.
const HALF_SUFFIX: &str = "_HalfFloat";
/// Separator OpenVDB puts between a grid's name and a counter that makes it unique.
const NAME_SEPARATOR: char = '\u{1e}';
/// Per-node metadata codes that store one or two inactive values (`io::Compression.h`).
const ONE_INACTIVE: [u8; 3] = [2, 4, 5];
/// Per-node metadata codes that store a selection mask.
const SELECTION_MASK: [u8; 3] = [3, 4, 5];
/// Per-node metadata code: every value is stored, active or not.
const ALL_VALUES: u8 = 6;

/// One grid's entry in the file's descriptor table.
struct Descriptor {
    entry: GridEntry,
    tree_type: String,
    half: bool,
    instance_parent: String,
    grid_pos: u64,
}

/// How a grid's values are stored.
#[derive(Clone, Copy)]
struct Storage {
    compression: u32,
    /// Bytes of one value in the tree (4 for float, 8 for double).
    value_size: usize,
    half: bool,
}

/// Loads grid `grid` (or the default) of the `.vdb` file `r` reads, refusing dense grids of
/// more than `cap` voxels; `sparse`: keep it sparse where it can be (see
/// [`super::LoadOptions::sparse`]).
pub fn load(
    mut r: ByteReader,
    grid: Option<&str>,
    cap: u64,
    options: &super::LoadOptions,
) -> Result<super::Loaded> {
    read_header(&mut r)?;
    let descriptors = read_descriptors(&mut r)?;
    let entries: Vec<GridEntry> = descriptors
        .iter()
        .map(|d| match grid_class(&mut r, d.grid_pos).as_deref() {
            Some("level set") => d.entry.clone().level_set(),
            _ => d.entry.clone(),
        })
        .collect();
    let (index, label) = super::select_grid(&entries, grid)?;
    let chosen = &descriptors[index];
    let mut loaded =
        read_grid(&mut r, chosen, cap, options).with_context(|| format!("grid '{label}'"))?;
    loaded.grid = label;
    Ok(loaded)
}

/// Checks the magic number and format version and skips the file-level metadata.
fn read_header(r: &mut ByteReader) -> Result<()> {
    let magic = r
        .u64()
        .context("not an OpenVDB file: too short for a header")?;
    ensure!(
        magic == MAGIC,
        "not an OpenVDB file (its first bytes are not the .vdb magic number)"
    );
    let version = r.u32()?;
    ensure!(
        version >= MIN_VERSION,
        "OpenVDB file format {version} is older than {MIN_VERSION} (OpenVDB 3); re-save it with a current OpenVDB"
    );
    let _library_version = (r.u32()?, r.u32()?);
    ensure!(
        r.u8()? == 1,
        "the file has no grid offset table (a streamed .vdb); re-save it to a regular file"
    );
    let _uuid = r.bytes(36)?;
    skip_metadata(r).context("reading the file metadata")
}

/// The "class" metadata of the grid at `grid_pos` ("level set", "fog volume", ...), if it can
/// be read; reading the grid itself reports a damaged header.
fn grid_class(r: &mut ByteReader, grid_pos: u64) -> Option<String> {
    r.seek(grid_pos).ok()?;
    let _compression = r.u32().ok()?;
    let count = r.u32().ok()?;
    for _ in 0..count {
        let name = r.string().ok()?;
        let type_name = r.string().ok()?;
        let size = r.u32().ok()?;
        let bytes = r.bytes(size as usize).ok()?;
        if name == "class" && type_name == "string" {
            return Some(String::from_utf8_lossy(bytes).into_owned());
        }
    }
    None
}

/// Skips a metadata map: a count, then (name, type name, byte size, bytes) per entry.
fn skip_metadata(r: &mut ByteReader) -> Result<()> {
    let count = r.u32()?;
    for _ in 0..count {
        let _name = r.string()?;
        let _type_name = r.string()?;
        let size = r.u32()?;
        r.skip(size.into())?;
    }
    Ok(())
}

/// Reads the grid descriptor table that follows the header.
fn read_descriptors(r: &mut ByteReader) -> Result<Vec<Descriptor>> {
    let count = r.u32().context("reading the grid count")?;
    let mut out = Vec::new();
    for i in 0..count {
        let d = read_descriptor(r)
            .with_context(|| format!("reading grid descriptor {i} of {count}"))?;
        out.push(d);
    }
    Ok(out)
}

/// Reads one grid descriptor and moves past the grid it describes.
fn read_descriptor(r: &mut ByteReader) -> Result<Descriptor> {
    let unique_name = r.string()?;
    let full_type = r.string()?;
    let instance_parent = r.string()?;
    let grid_pos = r.u64()?;
    let _block_pos = r.u64()?;
    let end_pos = r.u64()?;
    r.seek(end_pos)?;
    let name = unique_name
        .split(NAME_SEPARATOR)
        .next()
        .unwrap_or_default()
        .to_owned();
    let (tree_type, half) = match full_type.strip_suffix(HALF_SUFFIX) {
        Some(t) => (t.to_owned(), true),
        None => (full_type, false),
    };
    let value_type = value_type_name(&tree_type);
    let supported = matches!(tree_type.as_str(), "Tree_float_5_4_3" | "Tree_double_5_4_3");
    Ok(Descriptor {
        entry: GridEntry::new(name, value_type, supported),
        tree_type,
        half,
        instance_parent,
        grid_pos,
    })
}

/// The value type in a tree type name: "Tree_vec3s_5_4_3" gives "vec3s".
fn value_type_name(tree_type: &str) -> String {
    let inner = tree_type.strip_prefix("Tree_").unwrap_or(tree_type);
    inner.strip_suffix("_5_4_3").unwrap_or(inner).to_owned()
}

/// Reads the chosen grid: compression, metadata, transform, topology, then leaf values.
fn read_grid(
    r: &mut ByteReader,
    d: &Descriptor,
    cap: u64,
    options: &super::LoadOptions,
) -> Result<super::Loaded> {
    ensure!(
        d.instance_parent.is_empty(),
        "it is an instance of grid '{parent}' (it shares that grid's tree, which this reader \
         does not follow); load that grid instead with --grid {parent}",
        parent = d.instance_parent
    );
    r.seek(d.grid_pos)?;
    let compression = r.u32()?;
    ensure!(
        compression <= 0x7,
        "unknown compression flags {compression:#x}: the file is corrupt"
    );
    skip_metadata(r).context("reading the grid metadata")?;
    let map = read_transform(r).context("reading the grid transform")?;
    let value_size = if d.tree_type == "Tree_double_5_4_3" {
        8
    } else {
        4
    };
    let storage = Storage {
        compression,
        value_size,
        half: d.half,
    };
    // Pass one finds the bounding box and the leaves, pass two fills the active tiles.
    let topology = r.pos();
    let mut survey = Survey::default();
    let background = read_topology(r, storage, &mut survey).context("reading the tree topology")?;
    super::TopologyCheck::run(
        options.check_topology,
        survey.bounds.bounds,
        survey.tile_voxels,
    )?;
    let mut voxels = if options.sparse && survey.fits_cells(background) {
        survey.allocate_cells(storage.half)?
    } else {
        Voxels::Dense(survey.bounds.allocate(background, cap)?)
    };
    let buffers = r.pos();
    r.seek(topology as u64)?;
    read_topology(r, storage, &mut voxels)?;
    ensure!(
        r.pos() == buffers,
        "the tree topology read differently twice"
    );
    read_leaf_buffers(r, storage, &survey.leaves, background, &mut voxels)
        .context("reading the leaf values")?;
    Ok(super::Loaded {
        voxels,
        map,
        grid: d.entry.name.clone(),
    })
}

/// Reads a grid transform: the map's type name, then its parameters.
fn read_transform(r: &mut ByteReader) -> Result<LinearMap> {
    let kind = r.string()?;
    let map = match kind.as_str() {
        "UniformScaleMap" | "ScaleMap" => LinearMap::scale_translate(read_scale(r)?, [0.0; 3]),
        "UniformScaleTranslateMap" | "ScaleTranslateMap" => {
            let translation = r.vec3d()?;
            LinearMap::scale_translate(read_scale(r)?, translation)
        }
        "TranslationMap" => LinearMap::scale_translate([1.0; 3], r.vec3d()?),
        "AffineMap" | "UnitaryMap" => read_affine(r)?,
        other => bail!(
            "transform '{other}' is not linear; resample the grid to a linear transform first"
        ),
    };
    ensure!(
        map.is_finite(),
        "the transform has non-finite entries: the file is corrupt"
    );
    Ok(map)
}

/// Reads a scale map's scale, skipping the four derived vectors stored after it.
fn read_scale(r: &mut ByteReader) -> Result<[f64; 3]> {
    let scale = r.vec3d()?;
    r.skip(4 * 24)?;
    Ok(scale)
}

/// Reads OpenVDB's row-vector 4x4 matrix (`world = [x y z 1] * M`) as a linear map.
fn read_affine(r: &mut ByteReader) -> Result<LinearMap> {
    let mut m = [[0.0f64; 4]; 4];
    for row in &mut m {
        for v in row.iter_mut() {
            *v = r.f64()?;
        }
    }
    let mut map = LinearMap {
        m: [[0.0; 3]; 3],
        t: [m[3][0], m[3][1], m[3][2]],
    };
    for (out_axis, row) in map.m.iter_mut().enumerate() {
        for (in_axis, v) in row.iter_mut().enumerate() {
            *v = m[in_axis][out_axis];
        }
    }
    Ok(map)
}

/// Reads a tree topology (`Tree::readTopology`) into `sink`; returns the background value.
fn read_topology(
    r: &mut ByteReader,
    storage: Storage,
    sink: &mut impl TopologySink,
) -> Result<f32> {
    let buffer_count = r.u32()?;
    ensure!(
        buffer_count == 1,
        "tree with {buffer_count} buffers per leaf (expected 1): the file is corrupt"
    );
    let background = read_value(r, storage.value_size)?;
    let tiles = r.u32()?;
    let children = r.u32()?;
    for _ in 0..tiles {
        let origin = r.coord()?;
        let value = read_value(r, storage.value_size)?;
        if r.u8()? != 0 {
            sink.tile(origin, 12, value);
        }
    }
    let mut walk = Walk {
        r,
        storage,
        background,
        sink,
        values: Vec::new(),
    };
    for _ in 0..children {
        let origin = walk.r.coord()?;
        walk.internal(origin, 5)?;
    }
    Ok(background)
}

/// State for walking the internal nodes of a topology.
struct Walk<'w, 'a, S> {
    r: &'w mut ByteReader<'a>,
    storage: Storage,
    background: f32,
    sink: &'w mut S,
    /// Scratch space for a node's tile values.
    values: Vec<f32>,
}

impl<S: TopologySink> Walk<'_, '_, S> {
    /// Reads an internal node (`log2` 5: upper, 4: lower) at `origin` and its children.
    fn internal(&mut self, origin: [i32; 3], log2: u32) -> Result<()> {
        let words = (1usize << (3 * log2)) / 64;
        let child_mask = read_mask(self.r, words)?;
        let value_mask = read_mask(self.r, words)?;
        read_values(
            self.r,
            self.storage,
            &value_mask,
            self.background,
            &mut self.values,
        )?;
        let child_log2 = if log2 == 5 { 7 } else { 3 };
        for n in ones(&value_mask).filter(|&n| !bit(&child_mask, n)) {
            self.sink.tile(
                child_origin(origin, n, log2, child_log2),
                child_log2,
                self.values[n],
            );
        }
        for n in ones(&child_mask) {
            let child = child_origin(origin, n, log2, child_log2);
            if log2 == 5 {
                self.internal(child, 4)?;
            } else {
                let mask = read_mask(self.r, 8)?;
                self.sink.leaf(child, mask.try_into().expect("8 words"));
            }
        }
        Ok(())
    }
}

/// Reads each leaf's value buffer (in topology order) and writes its active voxels.
fn read_leaf_buffers(
    r: &mut ByteReader,
    s: Storage,
    leaves: &[Leaf],
    background: f32,
    voxels: &mut Voxels,
) -> Result<()> {
    let mut values = Vec::new();
    for (i, leaf) in leaves.iter().enumerate() {
        let mask = read_mask(r, 8).with_context(|| format!("leaf {i} of {}", leaves.len()))?;
        ensure!(
            mask == leaf.mask,
            "leaf {i} at {:?}: buffer mask differs from the topology",
            leaf.origin
        );
        read_values(r, s, &leaf.mask, background, &mut values)
            .with_context(|| format!("leaf {i} of {} at {:?}", leaves.len(), leaf.origin))?;
        voxels.set_leaf(leaf.origin, &leaf.mask, &values);
    }
    Ok(())
}

/// Reads a node's values (`io::readCompressedValues`) into `out`, one per bit of `mask`;
/// inactive positions get `background` (the dense grid never uses them).
fn read_values(
    r: &mut ByteReader,
    s: Storage,
    mask: &[u64],
    background: f32,
    out: &mut Vec<f32>,
) -> Result<()> {
    let count = mask.len() * 64;
    let meta = r.u8()?;
    ensure!(
        meta <= ALL_VALUES,
        "node compression code {meta} (expected 0-6): the file is corrupt"
    );
    if ONE_INACTIVE.contains(&meta) {
        r.skip(s.value_size as u64)?;
    }
    if meta == 5 {
        r.skip(s.value_size as u64)?;
    }
    if SELECTION_MASK.contains(&meta) {
        r.skip(count as u64 / 8)?;
    }
    let active_only = s.compression & COMPRESS_ACTIVE_MASK != 0 && meta != ALL_VALUES;
    let active: usize = mask.iter().map(|w| w.count_ones() as usize).sum();
    let stored = if active_only { active } else { count };
    let elem = if s.half { 2 } else { s.value_size };
    let raw = if s.half && stored == 0 {
        Vec::new()
    } else {
        read_data(r, s.compression, stored * elem)?
    };
    out.clear();
    out.resize(count, background);
    let decoded = raw.chunks_exact(elem).map(decode);
    if active_only {
        for (n, v) in ones(mask).zip(decoded) {
            out[n] = v;
        }
    } else {
        for (slot, v) in out.iter_mut().zip(decoded) {
            *slot = v;
        }
    }
    Ok(())
}

/// One stored value as f32: a half, a float or a double.
fn decode(b: &[u8]) -> f32 {
    match b.len() {
        2 => half::f16::from_le_bytes([b[0], b[1]]).to_f32(),
        4 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        _ => f64::from_le_bytes(std::array::from_fn(|i| b[i])) as f32,
    }
}

/// Reads `expected` bytes of (possibly ZIP- or Blosc-compressed) data (`io::readData`).
fn read_data(r: &mut ByteReader, compression: u32, expected: usize) -> Result<Vec<u8>> {
    if compression & (COMPRESS_BLOSC | COMPRESS_ZIP) == 0 {
        return Ok(r.bytes(expected)?.to_vec());
    }
    let size = r.i64()?;
    if size <= 0 {
        ensure!(
            size.unsigned_abs() == expected as u64,
            "uncompressed block of {} bytes where {expected} were expected: the file is corrupt",
            size.unsigned_abs()
        );
        return Ok(r.bytes(expected)?.to_vec());
    }
    let packed = r.bytes(usize::try_from(size).unwrap_or(usize::MAX))?;
    if compression & COMPRESS_BLOSC != 0 {
        blosc::decompress(packed, expected).context("corrupt Blosc block: the file is damaged")
    } else {
        let mut out = vec![0u8; expected];
        flate2::read::ZlibDecoder::new(packed)
            .read_exact(&mut out)
            .context("corrupt ZIP block: the file is damaged")?;
        Ok(out)
    }
}

/// Reads a float or double value (never stored as half).
fn read_value(r: &mut ByteReader, size: usize) -> Result<f32> {
    Ok(if size == 8 {
        r.f64()? as f32
    } else {
        f32::from_le_bytes(r.array()?)
    })
}

/// Reads a bit mask of `words` u64 words.
fn read_mask(r: &mut ByteReader, words: usize) -> Result<Vec<u64>> {
    let bytes = r.bytes(words * 8)?;
    Ok(bytes
        .as_chunks::<8>()
        .0
        .iter()
        .map(|&c| u64::from_le_bytes(c))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn affine_matrix_is_transposed_from_row_vector_form() {
        let mut bytes = Vec::new();
        let m = [
            1.0, 2.0, 0.0, 0.0, 3.0, 4.0, 0.0, 0.0, 0.0, 0.0, 5.0, 0.0, 7.0, 8.0, 9.0, 1.0,
        ];
        for v in m {
            bytes.extend_from_slice(&f64::to_le_bytes(v));
        }
        let map = read_affine(&mut ByteReader::new(&bytes)).unwrap();
        assert_eq!(map.m, [[1.0, 3.0, 0.0], [2.0, 4.0, 0.0], [0.0, 0.0, 5.0]]);
        assert_eq!(map.t, [7.0, 8.0, 9.0]);
    }
}
