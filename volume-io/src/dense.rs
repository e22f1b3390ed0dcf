//! A dense extinction volume on the host, before it is packed for the kernels.

use anyhow::{bail, Result};

/// An affine map from voxel index space to world space: `world = m * [x, y, z, 1]` (row-major 3x4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Affine(pub [[f32; 4]; 3]);

impl Affine {
    /// Uniform voxel size `scale`, voxel (0,0,0)'s corner at `translation`.
    pub fn scale_translate(scale: [f32; 3], translation: [f32; 3]) -> Self {
        Affine([
            [scale[0], 0.0, 0.0, translation[0]],
            [0.0, scale[1], 0.0, translation[1]],
            [0.0, 0.0, scale[2], translation[2]],
        ])
    }

    /// The identity: one voxel is one world unit.
    pub fn identity() -> Self {
        Self::scale_translate([1.0; 3], [0.0; 3])
    }
}

/// A dense grid of extinction values (before the density scale), x fastest, then y, then z.
///
/// Voxel (i, j, k) covers index-space [i, i+1) x [j, j+1) x [k, k+1); `index_to_world` places it.
#[derive(Clone, Debug)]
pub struct DenseVolume {
    /// Where it came from, for messages: a file path or an embedded volume's name.
    pub name: String,
    /// Voxel counts along x, y, z (each >= 1).
    pub dims: [u32; 3],
    /// `dims[0] * dims[1] * dims[2]` values, finite and >= 0.
    pub values: Vec<f32>,
    /// Voxel index space to world space.
    pub index_to_world: Affine,
    /// For a volume read from a file: the file index of dense voxel (0, 0, 0), so messages can
    /// name voxels in the file's own coordinates.
    pub file_origin: Option<[i32; 3]>,
}

impl DenseVolume {
    /// Checks the invariants: non-zero dims, matching length, finite non-negative values.
    /// Errors name the volume and the first bad voxel.
    pub fn new(
        name: impl Into<String>,
        dims: [u32; 3],
        values: Vec<f32>,
        index_to_world: Affine,
    ) -> Result<Self> {
        let name = name.into();
        if dims.contains(&0) {
            bail!("{name}: volume has zero size {dims:?}");
        }
        let n = dims.iter().map(|&d| d as u64).product::<u64>();
        if n != values.len() as u64 {
            bail!(
                "{name}: {} values for a {}x{}x{} grid ({n} voxels)",
                values.len(),
                dims[0],
                dims[1],
                dims[2]
            );
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite() || *v < 0.0) {
            let (x, y, z) = (
                i as u64 % dims[0] as u64,
                i as u64 / dims[0] as u64 % dims[1] as u64,
                i as u64 / (dims[0] as u64 * dims[1] as u64),
            );
            bail!(
                "{name}: voxel ({x}, {y}, {z}) has density {}; densities must be finite and >= 0",
                values[i]
            );
        }
        Ok(DenseVolume {
            name,
            dims,
            values,
            index_to_world,
            file_origin: None,
        })
    }

    /// The same volume, its dense voxel (0, 0, 0) being file voxel `origin`.
    pub fn with_file_origin(mut self, origin: [i32; 3]) -> Self {
        self.file_origin = Some(origin);
        self
    }

    /// Value of voxel (x, y, z).
    pub fn at(&self, x: u32, y: u32, z: u32) -> f32 {
        self.values[(x as usize)
            + self.dims[0] as usize * (y as usize + self.dims[1] as usize * z as usize)]
    }
}
