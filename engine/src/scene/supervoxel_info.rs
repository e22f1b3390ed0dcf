//! What a packed volume's super-voxel grid was built with and what it costs: for the JSON of
//! `host render`, `host eval` and `host bench`.

use crate::scene::bricks::PackedVolume;
use shared::params::RenderParams;

/// The super-voxel grid of a render or an evaluation: brick size, format, fixed or adaptive, its memory.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SupervoxelInfo {
    pub brick_size: u32,
    /// "f32" or "bc4".
    pub format: String,
    /// "fixed" or "adaptive".
    pub mode: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cell_size: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split_ratio: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split_occupancy: Option<f32>,
    pub subdivided_bricks: usize,
    /// Bytes of the table as held (f32 records of the bricks and the cells).
    pub table_bytes: u64,
    /// Bytes a BC4 table would take (format "bc4" only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bc4_table_bytes: Option<u64>,
    /// Super-voxel and brick reads of one traversal per camera ray ([`crate::scene::traversal`]).
    pub reads_per_ray: crate::scene::traversal::ReadsPerRay,
}

impl SupervoxelInfo {
    /// What `packed` was built with (`mode` as [`jackknife::Supervoxels`], `format`), and its
    /// reads per camera ray of `params`.
    pub fn of(
        packed: &PackedVolume,
        mode: jackknife::Supervoxels,
        format: jackknife::SupervoxelFormat,
        params: &RenderParams,
    ) -> Self {
        let (cell_size, split_ratio, split_occupancy) = match mode {
            jackknife::Supervoxels::Adaptive {
                cell,
                ratio,
                occupancy,
            } => (Some(cell), Some(ratio), Some(occupancy)),
            jackknife::Supervoxels::Fixed => (None, None, None),
        };
        SupervoxelInfo {
            brick_size: packed.desc.brick_size,
            format: format.name().into(),
            mode: mode.name().into(),
            cell_size,
            split_ratio,
            split_occupancy,
            subdivided_bricks: packed.subdivided_bricks(),
            table_bytes: packed.table_bytes(),
            bc4_table_bytes: (format == jackknife::SupervoxelFormat::Bc4)
                .then(|| packed.bc4_table_bytes()),
            reads_per_ray: crate::scene::traversal::reads_per_ray(packed, params),
        }
    }
}
