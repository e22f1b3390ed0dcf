//! Extinction volumes, dense (`dense`) or sparse (`sparse`), and their file loaders: a scalar
//! grid of an OpenVDB (`.vdb`) or NanoVDB (`.nvdb`) file, its leaves and tiles kept sparse or
//! made dense over its active voxels' bounding box.
//!
//! Index conventions: OpenVDB and NanoVDB put voxel centers at integer index coordinates (voxel
//! `c` covers `[c - 0.5, c + 0.5]`), while [`DenseVolume`] voxel `i` covers `[i, i + 1)`. Dense
//! voxel `i` is file voxel `bbox_min + i`, so a dense index point `p` is the file index point
//! `p + bbox_min - 0.5`, and `index_to_world` is the file's map composed with that shift.
//!
//! Inactive voxels and tiles read as the grid's background value (0 for fog volumes), whatever
//! value the file stores for them. Every error names the file and says what to do about it.

mod blosc;
mod bytes;
pub mod dense;
mod nanovdb;
mod openvdb;
pub mod sparse;
mod topology;
pub mod volume;

use anyhow::{anyhow, bail, ensure, Context, Result};
pub use dense::{Affine, DenseVolume};
pub use sparse::SparseVolume;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
pub use volume::{Volume, VolumeData};

/// The grid loaded when none is named.
pub const DEFAULT_GRID: &str = "density";

/// Peak bytes per dense voxel from loading to rendering: the f32 dense grid (4) plus, while it
/// is packed, the pool of packed f16 voxels (at most 2, for a volume with every brick occupied).
pub const PEAK_BYTES_PER_VOXEL: u64 = 6;

/// Largest dense grid a loader builds (2^31 voxels, 8 GiB of f32).
pub const MAX_DENSE_VOXELS: u64 = 1 << 31;

/// Loads grid `grid` (default: "density", else the file's first float grid) of a `.vdb` or
/// `.nvdb` file as a dense volume over its active voxels.
pub fn load_volume(path: &Path, grid: Option<&str>) -> Result<DenseVolume> {
    load_volume_capped(path, grid, MAX_DENSE_VOXELS)
}

/// [`load_volume`] refusing dense grids of more than `max_voxels` (at most [`MAX_DENSE_VOXELS`]).
pub fn load_volume_capped(path: &Path, grid: Option<&str>, max_voxels: u64) -> Result<DenseVolume> {
    let options = LoadOptions {
        grid,
        max_voxels,
        sparse: false,
        ..LoadOptions::default()
    };
    match load_volume_with(path, &options)?.volume {
        Volume::Dense(v) => Ok(v),
        Volume::Sparse(_) => unreachable!("a dense load never builds a sparse volume"),
    }
}

/// What a file's tree topology tells before any voxel value is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Topology {
    /// Voxels per axis of the active voxels' bounding box (the grid that will be built).
    pub dims: [u64; 3],
    /// Voxels of the active tiles whose value is positive, each of which is stored (0 where
    /// the tree is not surveyed first: a NanoVDB grid loaded dense): a lower bound of the voxels
    /// a renderer holds, known before any leaf value is read.
    pub tile_voxels: u64,
}

/// A check of a file's [`Topology`], called once it is known and before any voxel value is
/// read or any grid is allocated; its error stops the load (e.g. a GPU that cannot hold the
/// brick table of that bounding box).
#[derive(Clone, Copy)]
pub struct TopologyCheck<'a>(
    pub &'a (dyn Fn(&Topology) -> Result<()> + Sync + std::panic::RefUnwindSafe),
);

impl std::fmt::Debug for TopologyCheck<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("TopologyCheck")
    }
}

impl TopologyCheck<'_> {
    /// Runs the check on the bounding box `lo..=hi` (index coordinates), if there is one, with
    /// `tile_voxels` (see [`Topology::tile_voxels`]).
    fn run(
        check: Option<Self>,
        bounds: Option<([i64; 3], [i64; 3])>,
        tile_voxels: u64,
    ) -> Result<()> {
        let (Some(check), Some((lo, hi))) = (check, bounds) else {
            return Ok(());
        };
        if (0..3).any(|a| lo[a] > hi[a]) {
            return Ok(());
        }
        // A box no load takes is refused as such first: the check's advice (a larger brick size)
        // could not help it.
        let dims = sparse_dims(lo, hi)?.map(u64::from);
        (check.0)(&Topology { dims, tile_voxels })
    }
}

/// How a volume file is loaded.
#[derive(Clone, Copy, Debug)]
pub struct LoadOptions<'a> {
    /// The grid to read (default: "density", else the file's first float grid).
    pub grid: Option<&'a str>,
    /// Largest dense grid to build, in voxels (at most [`MAX_DENSE_VOXELS`]). A sparse load
    /// has no cap on its bounding box's voxel count: only on each axis ([`MAX_SPARSE_AXIS`])
    /// and on the memory of its cell table and leaves.
    pub max_voxels: u64,
    /// Set negative densities to 0 instead of refusing the file.
    pub clamp_negative: bool,
    /// Keep a grid sparse (its leaves and tiles only) instead of filling a dense array over
    /// its bounding box. The two read the same, voxel for voxel; a grid with a nonzero
    /// background, nodes off the 8-voxel lattice (corrupt .vdb files) or, in a .nvdb, active
    /// voxels outside its stored index bounding box (never written by NanoVDB's tools) loads
    /// dense.
    pub sparse: bool,
    /// Called with the topology before the voxel values are read (see [`TopologyCheck`]).
    pub check_topology: Option<TopologyCheck<'a>>,
}

impl Default for LoadOptions<'_> {
    fn default() -> Self {
        LoadOptions {
            grid: None,
            max_voxels: MAX_DENSE_VOXELS,
            clamp_negative: false,
            sparse: true,
            check_topology: None,
        }
    }
}

/// A loaded volume and what loading changed.
#[derive(Clone, Debug)]
pub struct LoadedVolume {
    pub volume: Volume,
    /// How many negative densities [`LoadOptions::clamp_negative`] set to 0.
    pub clamped_negative: u64,
    /// The name of the grid that was read (the one rendered).
    pub grid: String,
}

/// Loads a `.vdb` or `.nvdb` file as [`LoadOptions`] say. Every error names the file.
pub fn load_volume_with(path: &Path, options: &LoadOptions) -> Result<LoadedVolume> {
    let format = Format::of(path)?;
    let cap = options.max_voxels.min(MAX_DENSE_VOXELS);
    let grid = options.grid;
    let loaded = guarded(|| match format {
        Format::OpenVdb => openvdb::load(stream_file(path)?, grid, cap, options),
        Format::NanoVdb => nanovdb::load(path, grid, cap, options),
    })
    .with_context(|| format!("cannot load {} file {}", format.name(), path.display()))?;
    loaded.into_volume(path, options.clamp_negative)
}

/// The volume file formats, by extension.
#[derive(Clone, Copy)]
enum Format {
    OpenVdb,
    NanoVdb,
}

impl Format {
    /// The format named by `path`'s extension.
    fn of(path: &Path) -> Result<Self> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("vdb") => Ok(Format::OpenVdb),
            Some("nvdb") => Ok(Format::NanoVdb),
            _ => bail!(
                "cannot load {}: unknown volume file extension; expected .vdb (OpenVDB) or .nvdb (NanoVDB)",
                path.display()
            ),
        }
    }

    /// The format's name, for messages.
    fn name(self) -> &'static str {
        match self {
            Format::OpenVdb => "OpenVDB",
            Format::NanoVdb => "NanoVDB",
        }
    }
}

/// A reader over a regular file (directories, FIFOs and devices, e.g. a symlink to `/dev/zero`,
/// are refused unread) that streams it through a window: its size when opened is its length, and
/// only the window and each read are held.
fn stream_file(path: &Path) -> Result<bytes::ByteReader<'static>> {
    let (file, len) = open_file(path)?;
    Ok(bytes::ByteReader::stream(file, len))
}

/// Opens a regular file and its size when opened; directories, FIFOs and devices are refused
/// unopened, with an error naming the file.
fn open_file(path: &Path) -> Result<(std::fs::File, u64)> {
    let what = || format!("cannot read {}: check the path", path.display());
    // Checked before opening: opening a FIFO blocks until something writes to it.
    let kind = std::fs::metadata(path).with_context(what)?.file_type();
    if !kind.is_file() {
        bail!(
            "cannot read {}: not a regular file (a {}); pass a .vdb or .nvdb file",
            path.display(),
            if kind.is_dir() {
                "directory"
            } else {
                "FIFO, socket or device"
            }
        );
    }
    let file = std::fs::File::open(path).with_context(what)?;
    let meta = file.metadata().with_context(what)?;
    ensure!(
        meta.is_file(),
        "cannot read {}: not a regular file",
        path.display()
    );
    Ok((file, meta.len()))
}

/// Runs a parser, turning a panic (a bug or a third-party reader's bad-input assertion) into an
/// error instead of unwinding through the caller.
fn guarded<T>(parse: impl FnOnce() -> Result<T>) -> Result<T> {
    catch_unwind(AssertUnwindSafe(parse)).unwrap_or_else(|payload| {
        let msg = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into());
        Err(anyhow!(
            "the reader panicked ({msg}): the file is probably corrupt"
        ))
    })
}

/// A grid listed in a file, for choosing one and for messages.
#[derive(Clone, Debug)]
struct GridEntry {
    name: String,
    /// The value type as the format names it ("float", "vec3s", "Int32", ...).
    value_type: String,
    /// Whether the loader can read this grid's values.
    supported: bool,
    /// Why an unsupported grid is refused, with advice (default: not scalar floats).
    why: Option<String>,
}

impl GridEntry {
    /// A grid listing; `supported` grids have no refusal reason.
    fn new(name: String, value_type: String, supported: bool) -> Self {
        GridEntry {
            name,
            value_type,
            supported,
            why: None,
        }
    }

    /// Marks the grid unsupported because it is a level set (signed distances, not densities).
    fn level_set(mut self) -> Self {
        self.supported = false;
        self.value_type = format!("{} level set", self.value_type);
        self.why = Some(format!(
            "grid '{}' is a level set (signed distances to a surface, negative inside), not a \
             density; convert it to a fog volume first (OpenVDB tools::sdfToFogVolume, Houdini \
             'Convert VDB' to Fog VDB) or pick a fog-volume grid with --grid",
            self.name
        ));
        self
    }
}

/// Picks the grid to load: `requested`, else "density", else the first supported grid. Returns
/// its index and label: the name, or `name[k]` (OpenVDB's own notation, k from 0) when several
/// grids share the name; a shared name without `[k]` is refused, never resolved silently.
fn select_grid(grids: &[GridEntry], requested: Option<&str>) -> Result<(usize, String)> {
    ensure!(!grids.is_empty(), "the file contains no grids");
    let name = requested.unwrap_or(DEFAULT_GRID);
    let named: Vec<usize> = (0..grids.len())
        .filter(|&i| grids[i].name == name)
        .collect();
    if named.len() > 1 {
        let labels: Vec<String> = (0..named.len()).map(|k| format!("{name}[{k}]")).collect();
        bail!(
            "{} grids are named '{name}' ({}); pick one with --grid {} (available grids: {})",
            named.len(),
            labels.join(", "),
            labels.join(" or --grid "),
            list(grids)
        );
    }
    let (found, label) = match (named.first(), requested.and_then(indexed)) {
        (Some(&i), _) => (Some(i), name.to_owned()),
        (None, Some((base, k))) => {
            let same: Vec<usize> = (0..grids.len())
                .filter(|&i| grids[i].name == base)
                .collect();
            (same.get(k).copied(), name.to_owned())
        }
        (None, None) => (None, name.to_owned()),
    };
    let (index, label) = match (found, requested) {
        (Some(i), _) => (i, label),
        (None, Some(_)) => bail!("no grid named '{name}'; available grids: {}", list(grids)),
        (None, None) => {
            let i = grids.iter().position(|g| g.supported).with_context(|| {
                format!(
                    "no '{DEFAULT_GRID}' grid and no float grid to fall back on; available grids: {}",
                    list(grids)
                )
            })?;
            (i, grids[i].name.clone())
        }
    };
    let g = &grids[index];
    if let (false, Some(why)) = (g.supported, &g.why) {
        bail!("{why} (available grids: {})", list(grids));
    }
    ensure!(
        g.supported,
        "grid '{}' holds {} values, not scalar floats; pick a float grid (available grids: {})",
        g.name,
        g.value_type,
        list(grids)
    );
    Ok((index, label))
}

/// `name[k]` split into the name and k, if `s` has that form.
fn indexed(s: &str) -> Option<(&str, usize)> {
    let (base, rest) = s.strip_suffix(']')?.rsplit_once('[')?;
    Some((base, rest.parse().ok()?))
}

/// "name (type), ..." for messages; a name several grids share is written `name[k]`.
fn list(grids: &[GridEntry]) -> String {
    grids
        .iter()
        .enumerate()
        .map(|(i, g)| {
            let same = grids.iter().filter(|h| h.name == g.name).count();
            let k = grids[..i].iter().filter(|h| h.name == g.name).count();
            match same {
                1 => format!("{} ({})", g.name, g.value_type),
                _ => format!("{}[{k}] ({})", g.name, g.value_type),
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// A file's index-to-world map, `world = m * index + t`, with voxel centers at integer indices.
#[derive(Clone, Copy, Debug, PartialEq)]
struct LinearMap {
    /// Row `r` gives world axis `r` from the three index axes.
    m: [[f64; 3]; 3],
    t: [f64; 3],
}

impl LinearMap {
    /// A diagonal map: `world = scale * index + translation`.
    fn scale_translate(scale: [f64; 3], translation: [f64; 3]) -> Self {
        let mut m = [[0.0; 3]; 3];
        for (a, row) in m.iter_mut().enumerate() {
            row[a] = scale[a];
        }
        LinearMap { m, t: translation }
    }

    /// Whether every entry is finite.
    fn is_finite(&self) -> bool {
        self.m
            .iter()
            .flatten()
            .chain(&self.t)
            .all(|v| v.is_finite())
    }

    /// Refuses maps that cannot be inverted in f32: non-finite, singular or nearly so.
    fn check_invertible(&self) -> Result<()> {
        let f32_ok = self
            .m
            .iter()
            .flatten()
            .chain(&self.t)
            .all(|&v| (v as f32).is_finite());
        ensure!(
            f32_ok,
            "its entries are not finite in f32: the file is corrupt"
        );
        let m = &self.m;
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        let column_norms: f64 = (0..3)
            .map(|c| (0..3).map(|r| m[r][c] * m[r][c]).sum::<f64>().sqrt())
            .product();
        ensure!(
            column_norms > 0.0 && (det / column_norms).abs() > 1e-6 && det.abs() > 1e-30,
            "the transform is singular (a voxel size of 0, or collapsed axes; determinant {det:e}); \
             fix the grid's transform"
        );
        Ok(())
    }

    /// The dense grid's affine map, whose voxel (0,0,0) is file voxel `min` (see the module doc).
    fn dense_affine(&self, min: [i32; 3]) -> Affine {
        let shift: [f64; 3] = std::array::from_fn(|a| f64::from(min[a]) - 0.5);
        Affine(std::array::from_fn(|r| {
            let row = self.m[r];
            let t = self.t[r] + (0..3).map(|c| row[c] * shift[c]).sum::<f64>();
            [row[0] as f32, row[1] as f32, row[2] as f32, t as f32]
        }))
    }
}

/// What a format reader returns: the voxels and the file's map.
struct Loaded {
    voxels: Voxels,
    map: LinearMap,
    /// The name of the grid read.
    grid: String,
}

/// The voxels a reader filled: a dense grid over the active bounding box, or the cells of the
/// leaves and tiles (see [`sparse`]).
enum Voxels {
    Dense(Dense),
    Sparse {
        cells: sparse::Cells,
        /// File index of local voxel (0, 0, 0).
        min: [i32; 3],
        dims: [u32; 3],
    },
}

impl Loaded {
    /// The validated [`Volume`], named after the file; negative densities set to 0 if
    /// `clamp_negative`, else refused like NaN and infinities, naming the voxel's file index
    /// (the first one in x-fastest order, whatever the storage).
    fn into_volume(self, path: &Path, clamp_negative: bool) -> Result<LoadedVolume> {
        let name = path.display().to_string();
        self.map
            .check_invertible()
            .with_context(|| format!("cannot load {name}: the grid transform is unusable"))?;
        let mut clamped_negative = 0;
        let clamp = |v: f32| if v < 0.0 { 0.0 } else { v };
        let (volume, bad) = match self.voxels {
            Voxels::Dense(mut dense) => {
                if clamp_negative {
                    for v in dense.values.iter_mut().filter(|v| **v < 0.0) {
                        *v = 0.0;
                        clamped_negative += 1;
                    }
                }
                let values = &dense.values;
                if let Some(i) = values.iter().position(|v| !v.is_finite() || *v < 0.0) {
                    return Err(bad_density(&name, dense.file_index(i), values[i]));
                }
                let Dense {
                    min, dims, values, ..
                } = dense;
                let volume = DenseVolume::new(&name, dims, values, self.map.dense_affine(min))?
                    .with_file_origin(min);
                (Volume::Dense(volume), None)
            }
            Voxels::Sparse { cells, min, dims } => {
                let mut volume = SparseVolume {
                    name: name.clone(),
                    dims,
                    index_to_world: self.map.dense_affine(min),
                    file_origin: Some(min),
                    cells,
                };
                if clamp_negative {
                    clamped_negative = volume.map_values(clamp);
                }
                let bad = volume.first_bad().map(|(v, value)| {
                    let ijk: [i64; 3] =
                        std::array::from_fn(|a| i64::from(min[a]) + i64::from(v[a]));
                    (ijk, value)
                });
                (Volume::Sparse(volume), bad)
            }
        };
        if let Some((ijk, value)) = bad {
            return Err(bad_density(&name, ijk, value));
        }
        Ok(LoadedVolume {
            volume,
            clamped_negative,
            grid: self.grid,
        })
    }
}

/// The refusal of file voxel `ijk`'s density `value` (NaN, infinite or negative), with advice.
fn bad_density(name: &str, ijk: [i64; 3], value: f32) -> anyhow::Error {
    let advice = if value < 0.0 {
        "densities must be >= 0: fix the grid, or pass --clamp-negative to set negative values to 0"
    } else {
        "densities must be finite: fix the grid (replace NaN/inf in the tool that wrote it)"
    };
    anyhow!(
        "cannot load {name}: voxel ({}, {}, {}) (file index coordinates) has density {value}; \
         {advice}",
        ijk[0],
        ijk[1],
        ijk[2]
    )
}

/// The bounding box of active voxels, grown tile by tile and leaf by leaf.
#[derive(Default)]
struct DenseBuilder {
    bounds: Option<([i64; 3], [i64; 3])>,
}

impl DenseBuilder {
    /// Includes the inclusive index box `min..=max`.
    fn include(&mut self, min: [i64; 3], max: [i64; 3]) {
        self.bounds = Some(match self.bounds {
            None => (min, max),
            Some((lo, hi)) => (
                std::array::from_fn(|a| lo[a].min(min[a])),
                std::array::from_fn(|a| hi[a].max(max[a])),
            ),
        });
    }

    /// Includes an active tile of `2^log2` voxels per axis at `origin`.
    fn include_tile(&mut self, origin: [i32; 3], log2: u32) {
        let min = origin.map(i64::from);
        self.include(min, min.map(|v| v + (1i64 << log2) - 1));
    }

    /// Includes the active voxels of an 8^3 leaf (bit `x << 6 | y << 3 | z` of `mask`).
    fn include_leaf(&mut self, origin: [i32; 3], mask: &[u64; 8]) {
        let mut lo = [i64::MAX; 3];
        let mut hi = [i64::MIN; 3];
        for (w, &word) in mask.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                let n = w * 64 + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let local = [n >> 6, (n >> 3) & 7, n & 7];
                for a in 0..3 {
                    let v = i64::from(origin[a]) + local[a] as i64;
                    lo[a] = lo[a].min(v);
                    hi[a] = hi[a].max(v);
                }
            }
        }
        if lo[0] <= hi[0] {
            self.include(lo, hi);
        }
    }

    /// Allocates the dense grid over the bounds, filled with `background`; refuses empty grids
    /// and grids above `cap` voxels before allocating.
    fn allocate(&self, background: f32, cap: u64) -> Result<Dense> {
        let (lo, hi) = self
            .bounds
            .context("the grid has no active voxels (it is empty); pick another grid")?;
        let dims = dense_dims(lo, hi, cap)?;
        let count: usize = dims.iter().map(|&d| d as usize).product();
        check_memory(dims, available_memory())?;
        let mut values = Vec::new();
        values.try_reserve_exact(count).map_err(|_| {
            anyhow!(
                "cannot allocate {:.1} GiB for its dense grid; crop or resample the volume",
                count as f64 * 4.0 / (1u64 << 30) as f64
            )
        })?;
        values.resize(count, background);
        let min = lo.map(|v| v as i32);
        Ok(Dense { min, dims, values })
    }
}

/// Refuses a dense grid of `dims` whose peak memory ([`PEAK_BYTES_PER_VOXEL`] per voxel) exceeds
/// `available` bytes (when known), so it fails with advice instead of aborting later.
fn check_memory(dims: [u32; 3], available: Option<u64>) -> Result<()> {
    let count: u64 = dims.iter().map(|&d| u64::from(d)).product();
    let bytes = count.saturating_mul(PEAK_BYTES_PER_VOXEL);
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    if let Some(available) = available {
        ensure!(
            bytes <= available,
            "its dense {}x{}x{} grid needs {:.1} GiB at its peak ({PEAK_BYTES_PER_VOXEL} bytes \
             per voxel of the active bounding box: f32 values, then the f16 pool), more than \
             the {:.1} GiB of memory available; crop the volume to the region of interest or \
             resample it coarser",
            dims[0],
            dims[1],
            dims[2],
            gib(bytes),
            gib(available)
        );
    }
    Ok(())
}

/// Refuses loading `what` when its peak of `bytes` exceeds `available` bytes (when known).
fn check_bytes(bytes: u64, what: &str, available: Option<u64>) -> Result<()> {
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    if let Some(available) = available {
        ensure!(
            bytes <= available,
            "{what} need {:.1} GiB at their peak (values, then the f16 pool), more than the \
             {:.1} GiB of memory available (the least of free memory, `ulimit -v` and the \
             cgroup's limit); crop the volume to the region of interest or resample it coarser",
            gib(bytes),
            gib(available)
        );
    }
    Ok(())
}

/// The memory this process may still allocate, if known (Linux): the smallest of what the OS
/// says is available (MemAvailable), what the address-space limit leaves (`ulimit -v`, RLIMIT_AS,
/// less the current VmSize) and what the memory cgroup leaves (v2 memory.max less
/// memory.current, v1 memory.limit_in_bytes less memory.usage_in_bytes, each plus the inactive
/// file cache it counts). An allocation past either limit aborts the process instead of
/// failing, so loads check against all three.
pub fn available_memory() -> Option<u64> {
    let read = |p: &str| std::fs::read_to_string(p).ok();
    [
        read("/proc/meminfo").and_then(|t| mem_available(&t)),
        read("/proc/self/limits")
            .zip(read("/proc/self/status"))
            .and_then(|(l, s)| address_space_left(&l, &s)),
        cgroup_memory_left(),
    ]
    .into_iter()
    .flatten()
    .min()
}

/// MemAvailable of /proc/meminfo, in bytes.
fn mem_available(meminfo: &str) -> Option<u64> {
    kib_field(meminfo, "MemAvailable:")
}

/// A `Name:  N kB` field of /proc files, in bytes.
fn kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The soft address-space limit of /proc/self/limits less the VmSize of /proc/self/status
/// (None when unlimited).
fn address_space_left(limits: &str, status: &str) -> Option<u64> {
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    let soft: u64 = line
        .trim_start_matches("Max address space")
        .split_whitespace()
        .next()?
        .parse()
        .ok()?;
    let used = kib_field(status, "VmSize:").unwrap_or(0);
    Some(soft.saturating_sub(used))
}

/// What this process's memory cgroup leaves (None without a limit or a readable cgroup).
fn cgroup_memory_left() -> Option<u64> {
    let cgroups = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let read = |p: String| std::fs::read_to_string(p).ok();
    for line in cgroups.lines() {
        let mut parts = line.splitn(3, ':');
        let (_, controllers, path) = (parts.next()?, parts.next()?, parts.next()?);
        // v2: "0::/path"; v1: "N:memory:/path". The path may be outside this mount namespace,
        // so the mount's root is tried too.
        let (dir, max, current, inactive) = if controllers.is_empty() {
            (
                "/sys/fs/cgroup",
                "memory.max",
                "memory.current",
                "inactive_file",
            )
        } else if controllers.split(',').any(|c| c == "memory") {
            (
                "/sys/fs/cgroup/memory",
                "memory.limit_in_bytes",
                "memory.usage_in_bytes",
                "total_inactive_file",
            )
        } else {
            continue;
        };
        for base in [format!("{dir}{path}"), dir.to_owned()] {
            if let (Some(m), Some(c)) = (
                read(format!("{base}/{max}")),
                read(format!("{base}/{current}")),
            ) {
                // Usage counts the page cache; its inactive part is reclaimed before an
                // allocation fails (the working set of docker and the kubelet).
                let cache = read(format!("{base}/memory.stat"))
                    .and_then(|t| stat_field(&t, inactive))
                    .unwrap_or(0);
                if let Some(left) = cgroup_left(&m, &c) {
                    return Some(left.saturating_add(cache.min(c.trim().parse().unwrap_or(0))));
                }
            }
        }
    }
    None
}

/// A `name value` line of a cgroup's memory.stat.
fn stat_field(stat: &str, name: &str) -> Option<u64> {
    stat.lines()
        .find_map(|l| l.strip_prefix(name)?.strip_prefix(' ')?.trim().parse().ok())
}

/// A cgroup's limit less its usage (None for "max" or a limit too large to be one: cgroup v1
/// writes about 2^63 for none).
fn cgroup_left(max: &str, current: &str) -> Option<u64> {
    let limit: u64 = max.trim().parse().ok()?;
    if limit >= 1 << 60 {
        return None;
    }
    let used: u64 = current.trim().parse().ok()?;
    Some(limit.saturating_sub(used))
}

/// Longest axis of a sparse grid's bounding box, in voxels: index coordinates are i32, and the
/// renderer's u32 voxel coordinates keep room for a brick past the end.
pub const MAX_SPARSE_AXIS: u64 = 1 << 31;

/// Voxel counts of the inclusive box `lo..=hi` of a sparse grid: no cap on their product (the
/// memory its cell table and leaves need is checked instead), each at most [`MAX_SPARSE_AXIS`].
fn sparse_dims(lo: [i64; 3], hi: [i64; 3]) -> Result<[u32; 3]> {
    let d: [u64; 3] = std::array::from_fn(|a| (hi[a] - lo[a] + 1).max(0) as u64);
    ensure!(
        d.iter().all(|&v| v > 0),
        "the grid's bounding box {lo:?}..={hi:?} is empty"
    );
    ensure!(
        d.iter().all(|&v| v <= MAX_SPARSE_AXIS),
        "its active voxels span {}x{}x{} voxels (index box {lo:?}..={hi:?}), more than 2^31 \
         along an axis; crop the volume to the region of interest",
        d[0],
        d[1],
        d[2]
    );
    Ok(d.map(|v| v as u32))
}

/// Voxel counts of the inclusive box `lo..=hi`, if its dense grid has at most `cap` voxels
/// (and, as [`sparse_dims`], each at most [`MAX_SPARSE_AXIS`]).
fn dense_dims(lo: [i64; 3], hi: [i64; 3], cap: u64) -> Result<[u32; 3]> {
    let d = sparse_dims(lo, hi)?.map(u64::from);
    let total = d.iter().map(|&v| u128::from(v)).product::<u128>();
    ensure!(
        total <= u128::from(cap),
        "its active voxels span {}x{}x{} = {total} voxels (index box {lo:?}..={hi:?}), more than the \
         {cap} a dense grid may hold; crop the volume to the region of interest or resample it coarser",
        d[0],
        d[1],
        d[2]
    );
    Ok(d.map(|v| v as u32))
}

/// The dense grid being filled: voxel `min + (x, y, z)` is `values[x + dims.x * (y + dims.y * z)]`.
struct Dense {
    min: [i32; 3],
    dims: [u32; 3],
    values: Vec<f32>,
}

impl Dense {
    /// The index of file voxel `ijk` in `values`, if it lies in the grid.
    fn index(&self, ijk: [i64; 3]) -> Option<usize> {
        let mut index = 0usize;
        for a in (0..3).rev() {
            let local = ijk[a] - i64::from(self.min[a]);
            if local < 0 || local >= i64::from(self.dims[a]) {
                return None;
            }
            index = index * self.dims[a] as usize + local as usize;
        }
        Some(index)
    }

    /// The file index of `values[i]`.
    fn file_index(&self, i: usize) -> [i64; 3] {
        let d = self.dims.map(|v| v as usize);
        let local = [i % d[0], i / d[0] % d[1], i / (d[0] * d[1])];
        std::array::from_fn(|a| i64::from(self.min[a]) + local[a] as i64)
    }

    /// Sets file voxel `ijk` (ignored outside the grid).
    fn set(&mut self, ijk: [i32; 3], value: f32) {
        if let Some(i) = self.index(ijk.map(i64::from)) {
            self.values[i] = value;
        }
    }

    /// Sets every voxel of an active tile of `2^log2` voxels per axis at `origin`.
    fn fill_tile(&mut self, origin: [i32; 3], log2: u32, value: f32) {
        let lo: [i64; 3] =
            std::array::from_fn(|a| i64::from(origin[a]).max(i64::from(self.min[a])));
        let hi: [i64; 3] = std::array::from_fn(|a| {
            (i64::from(origin[a]) + (1i64 << log2))
                .min(i64::from(self.min[a]) + i64::from(self.dims[a]))
        });
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                let (Some(start), Some(end)) =
                    (self.index([lo[0], y, z]), self.index([hi[0] - 1, y, z]))
                else {
                    continue;
                };
                self.values[start..=end].fill(value);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The memory limits parse from the kernel's text formats: MemAvailable, the address-space
    /// limit less VmSize (None when unlimited), a cgroup's limit less usage (None for "max" or
    /// v1's 2^63 - 4096).
    #[test]
    fn memory_limits_parse() {
        assert_eq!(
            mem_available("MemTotal: 100 kB\nMemAvailable:    2048 kB\n"),
            Some(2 << 20)
        );
        let limits = "Max stack size            8388608              unlimited            bytes\n\
                      Max address space         8192000000           unlimited            bytes\n";
        let status = "Name:\thost\nVmSize:\t  1000 kB\n";
        assert_eq!(
            address_space_left(limits, status),
            Some(8_192_000_000 - 1_024_000)
        );
        let unlimited =
            "Max address space         unlimited            unlimited            bytes\n";
        assert_eq!(address_space_left(unlimited, status), None);
        assert_eq!(
            cgroup_left("3000000000\n", "1000000000\n"),
            Some(2_000_000_000)
        );
        assert_eq!(cgroup_left("max\n", "1000\n"), None);
        assert_eq!(cgroup_left("9223372036854771712\n", "1000\n"), None);
        assert_eq!(cgroup_left("100\n", "1000\n"), Some(0));
        let stat = "cache 5\ntotal_inactive_file 4096\ninactive_file 7\n";
        assert_eq!(stat_field(stat, "total_inactive_file"), Some(4096));
        assert_eq!(stat_field(stat, "inactive_file"), Some(7));
        assert!(available_memory().is_some_and(|b| b > 0));
    }

    fn entry(name: &str, value_type: &str, supported: bool) -> GridEntry {
        GridEntry::new(name.into(), value_type.into(), supported)
    }

    #[test]
    fn selection_prefers_density_then_first_float() {
        let grids = [
            entry("vel", "vec3s", false),
            entry("heat", "float", true),
            entry("density", "float", true),
        ];
        assert_eq!(select_grid(&grids, None).unwrap(), (2, "density".into()));
        assert_eq!(select_grid(&grids[..2], None).unwrap(), (1, "heat".into()));
        assert_eq!(select_grid(&grids, Some("heat")).unwrap().0, 1);
        let err = select_grid(&grids, Some("smoke")).unwrap_err().to_string();
        assert!(
            err.contains("no grid named 'smoke'") && err.contains("vel (vec3s), heat (float)"),
            "{err}"
        );
        let err = select_grid(&grids, Some("vel")).unwrap_err().to_string();
        assert!(err.contains("vec3s"), "{err}");
        let err = select_grid(&grids[..1], None).unwrap_err().to_string();
        assert!(err.contains("no float grid"), "{err}");
    }

    /// Two grids named alike are refused unless picked as `name[k]` (issue 43, item 10).
    #[test]
    fn shared_grid_names_are_refused_unless_indexed() {
        let grids = [
            entry("density", "float", true),
            entry("heat", "float", true),
            entry("density", "float", true),
        ];
        for requested in [None, Some("density")] {
            let err = select_grid(&grids, requested).unwrap_err().to_string();
            assert!(
                err.contains("2 grids are named 'density'")
                    && err.contains("--grid density[0] or --grid density[1]")
                    && err.contains("density[1] (float)"),
                "{err}"
            );
        }
        assert_eq!(
            select_grid(&grids, Some("density[1]")).unwrap(),
            (2, "density[1]".into())
        );
        assert_eq!(select_grid(&grids, Some("density[0]")).unwrap().0, 0);
        let err = select_grid(&grids, Some("density[2]"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("no grid named 'density[2]'"), "{err}");
        assert_eq!(
            select_grid(&grids, Some("heat")).unwrap(),
            (1, "heat".into())
        );
    }

    #[test]
    fn dense_affine_shifts_by_half_a_voxel() {
        let map = LinearMap::scale_translate([2.0, 1.0, 0.5], [10.0, 0.0, 0.0]);
        let a = map.dense_affine([3, -1, 0]);
        // Dense point 0 is file index 2.5 on x: world 10 + 2 * 2.5 = 15.
        assert_eq!(a.0[0], [2.0, 0.0, 0.0, 15.0]);
        assert_eq!(a.0[1], [0.0, 1.0, 0.0, -1.5]);
        assert_eq!(a.0[2], [0.0, 0.0, 0.5, -0.25]);
    }

    #[test]
    fn oversized_boxes_are_refused_before_allocating() {
        let err = dense_dims([0; 3], [2000; 3], MAX_DENSE_VOXELS)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("2001x2001x2001") && err.contains("crop"),
            "{err}"
        );
        let err = dense_dims([i32::MIN.into(); 3], [i32::MAX.into(); 3], MAX_DENSE_VOXELS)
            .unwrap_err()
            .to_string();
        assert!(err.contains("4294967296x"), "{err}");
        assert_eq!(dense_dims([-1, 0, 5], [1, 0, 6], 6).unwrap(), [3, 1, 2]);
        assert!(dense_dims([-1, 0, 5], [1, 0, 6], 5).is_err());
    }

    #[test]
    fn memory_check_counts_the_peak_not_just_the_f32_grid() {
        // 2^20 voxels: 4 MiB of f32 fit in 5 MiB, the 6 MiB peak does not.
        let dims = [128, 128, 64];
        let err = check_memory(dims, Some(5 << 20)).unwrap_err().to_string();
        assert!(
            err.contains("6 bytes per voxel") && err.contains("crop"),
            "{err}"
        );
        assert!(check_memory(dims, Some(6 << 20)).is_ok());
        assert!(check_memory(dims, None).is_ok());
    }

    #[test]
    fn tiles_are_clipped_to_the_grid() {
        let mut b = DenseBuilder::default();
        b.include([0, 0, 0], [9, 1, 1]);
        let mut dense = b.allocate(0.0, 1000).unwrap();
        dense.fill_tile([8, 0, 0], 3, 2.0);
        assert_eq!(
            dense.values.iter().filter(|&&v| v == 2.0).count(),
            2 * 2 * 2
        );
        assert_eq!(dense.values[8], 2.0);
        assert_eq!(dense.values[7], 0.0);
    }

    #[test]
    fn panics_become_errors() {
        let err = guarded::<()>(|| panic!("boom")).unwrap_err().to_string();
        assert!(err.contains("boom") && err.contains("corrupt"), "{err}");
    }
}
