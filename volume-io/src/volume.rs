//! Volumes as the renderer sees them: dense or sparse voxels behind one interface.

pub use crate::dense::{Affine, DenseVolume};
pub use crate::sparse::SparseVolume;

/// What the renderer reads of a volume, whatever its storage.
pub trait VolumeData: Sync {
    /// Where it came from, for messages: a file path or an embedded volume's name.
    fn name(&self) -> &str;
    /// Voxel counts along x, y, z (each >= 1).
    fn dims(&self) -> [u32; 3];
    /// Voxel index space to world space.
    fn index_to_world(&self) -> &Affine;
    /// For a volume read from a file: the file index of voxel (0, 0, 0).
    fn file_origin(&self) -> Option<[i32; 3]>;
    /// Writes the densities of the voxel box [lo, hi) into `out` (x fastest); returns false,
    /// leaving `out` unspecified, when it knows every density there is 0.
    fn fill(&self, lo: [u32; 3], hi: [u32; 3], out: &mut Vec<f32>) -> bool;
    /// The voxel box [lo, hi) of the voxels with density > 0 (None if there are none).
    fn occupied_box(&self) -> Option<([u32; 3], [u32; 3])>;

    /// The density of voxel (x, y, z) (inside the grid).
    fn density(&self, x: u32, y: u32, z: u32) -> f32 {
        let mut one = Vec::with_capacity(1);
        if self.fill([x, y, z], [x + 1, y + 1, z + 1], &mut one) {
            one[0]
        } else {
            0.0
        }
    }

    /// Describes voxel (x, y, z) for messages: in file index coordinates for a file, else as is.
    fn describe_voxel(&self, x: u32, y: u32, z: u32) -> String {
        match self.file_origin() {
            Some(o) => format!(
                "voxel ({}, {}, {}) (file index coordinates)",
                i64::from(o[0]) + i64::from(x),
                i64::from(o[1]) + i64::from(y),
                i64::from(o[2]) + i64::from(z)
            ),
            None => format!("voxel ({x}, {y}, {z})"),
        }
    }
}

/// A loaded volume: dense (NanoVDB files, test shapes) or sparse (OpenVDB files, the embedded
/// volumes).
#[derive(Clone, Debug)]
pub enum Volume {
    Dense(DenseVolume),
    Sparse(SparseVolume),
}

impl Volume {
    /// Replaces the index-to-world map (e.g. to turn a z-up file y-up).
    pub fn set_index_to_world(&mut self, a: Affine) {
        match self {
            Volume::Dense(v) => v.index_to_world = a,
            Volume::Sparse(v) => v.index_to_world = a,
        }
    }

    /// The storage's name for summaries: "dense" or "sparse".
    pub fn storage(&self) -> &'static str {
        match self {
            Volume::Dense(_) => "dense",
            Volume::Sparse(_) => "sparse",
        }
    }

    /// Bytes the loaded voxels occupy (dense: 4 per voxel of the box; sparse: cells and values).
    pub fn stored_bytes(&self) -> u64 {
        match self {
            Volume::Dense(v) => v.values.len() as u64 * 4,
            Volume::Sparse(v) => v.stored_bytes(),
        }
    }

    fn data(&self) -> &dyn VolumeData {
        match self {
            Volume::Dense(v) => v,
            Volume::Sparse(v) => v,
        }
    }
}

impl From<DenseVolume> for Volume {
    fn from(v: DenseVolume) -> Self {
        Volume::Dense(v)
    }
}

impl VolumeData for Volume {
    fn name(&self) -> &str {
        self.data().name()
    }
    fn dims(&self) -> [u32; 3] {
        self.data().dims()
    }
    fn index_to_world(&self) -> &Affine {
        self.data().index_to_world()
    }
    fn file_origin(&self) -> Option<[i32; 3]> {
        self.data().file_origin()
    }
    fn fill(&self, lo: [u32; 3], hi: [u32; 3], out: &mut Vec<f32>) -> bool {
        self.data().fill(lo, hi, out)
    }
    fn occupied_box(&self) -> Option<([u32; 3], [u32; 3])> {
        self.data().occupied_box()
    }
}

impl VolumeData for DenseVolume {
    fn name(&self) -> &str {
        &self.name
    }
    fn dims(&self) -> [u32; 3] {
        self.dims
    }
    fn index_to_world(&self) -> &Affine {
        &self.index_to_world
    }
    fn file_origin(&self) -> Option<[i32; 3]> {
        self.file_origin
    }
    fn fill(&self, lo: [u32; 3], hi: [u32; 3], out: &mut Vec<f32>) -> bool {
        out.clear();
        let [dx, dy, _] = self.dims.map(|d| d as usize);
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                let row = (z as usize * dy + y as usize) * dx;
                out.extend_from_slice(&self.values[row + lo[0] as usize..row + hi[0] as usize]);
            }
        }
        true
    }
    fn occupied_box(&self) -> Option<([u32; 3], [u32; 3])> {
        let mut b = BoxGrower::default();
        let [dx, dy, _] = self.dims.map(|d| d as usize);
        for (i, &v) in self.values.iter().enumerate() {
            if v > 0.0 {
                b.include([
                    (i % dx) as u32,
                    (i / dx % dy) as u32,
                    (i / (dx * dy)) as u32,
                ]);
            }
        }
        b.get()
    }
}

impl VolumeData for SparseVolume {
    fn name(&self) -> &str {
        &self.name
    }
    fn dims(&self) -> [u32; 3] {
        self.dims
    }
    fn index_to_world(&self) -> &Affine {
        &self.index_to_world
    }
    fn file_origin(&self) -> Option<[i32; 3]> {
        self.file_origin
    }
    fn fill(&self, lo: [u32; 3], hi: [u32; 3], out: &mut Vec<f32>) -> bool {
        SparseVolume::fill(self, lo, hi, out)
    }
    fn occupied_box(&self) -> Option<([u32; 3], [u32; 3])> {
        let mut b = BoxGrower::default();
        self.for_each_stored(|v, value| {
            if value > 0.0 {
                b.include(v);
            }
        });
        b.get()
    }
}

/// The box [lo, hi) of the voxels included so far.
struct BoxGrower {
    lo: [u32; 3],
    hi: [u32; 3],
}

impl Default for BoxGrower {
    fn default() -> Self {
        BoxGrower {
            lo: [u32::MAX; 3],
            hi: [0; 3],
        }
    }
}

impl BoxGrower {
    fn include(&mut self, v: [u32; 3]) {
        self.lo = std::array::from_fn(|a| self.lo[a].min(v[a]));
        self.hi = std::array::from_fn(|a| self.hi[a].max(v[a] + 1));
    }

    fn get(&self) -> Option<([u32; 3], [u32; 3])> {
        (self.lo[0] != u32::MAX).then_some((self.lo, self.hi))
    }
}
