//! Packing a loaded volume for the kernels: the `jackknife` crate's grid builder (f16 voxels and
//! the super-voxel statistics), with its errors named in the volume file's coordinates.

use crate::volume::VolumeData;
use anyhow::{anyhow, Result};
use jackknife::{BuildError, GridBuilder, SupervoxelFormat, Supervoxels};
use shared::volume::grid::Lookup;

pub use jackknife::{Grid as PackedVolume, Underflow, DEFAULT_BRICK_SIZE, MAX_OPTICAL_DEPTH};

/// Builds the kernels' grid of `vol` (see [`jackknife::GridBuilder`]): extinction = density x
/// `density_scale`, rays' t in world units (the optical depth check uses the grid's world chord).
pub fn pack(
    vol: &dyn VolumeData,
    density_scale: f32,
    brick_size: u32,
    lookup: Lookup,
) -> Result<PackedVolume> {
    pack_paged(
        vol,
        density_scale,
        brick_size,
        SupervoxelFormat::F32,
        Supervoxels::Fixed,
        lookup,
        shared::volume::pages::GPU_PAGE_LOG2,
    )
}

/// [`pack`] with the pool laid out in pages of 2^`page_log2` words (what the backend binds:
/// [`crate::backend::Backend::page_log2`]); the voxels read are the same for every page size.
pub fn pack_paged(
    vol: &dyn VolumeData,
    density_scale: f32,
    brick_size: u32,
    format: SupervoxelFormat,
    supervoxels: Supervoxels,
    lookup: Lookup,
    page_log2: u32,
) -> Result<PackedVolume> {
    GridBuilder::from_boxes(vol.dims(), |lo, hi, out| vol.fill(lo, hi, out))
        .page_log2(page_log2)
        .density_scale(density_scale)
        .brick_size(brick_size)
        .supervoxel_format(format)
        .supervoxels(supervoxels)
        .lookup(lookup)
        .max_chord(world_chord(vol))
        .build()
        .map_err(|e| explain(vol, e))
}

/// log2 of the words per page for a device whose storage buffers (and allocations) hold at
/// most `max_buffer_bytes`: the largest page that fits one, from
/// [`shared::volume::pages::GPU_PAGE_LOG2`] (128 MiB, what every Vulkan device binds; a device
/// reporting less is refused later, naming the buffer) to [`jackknife::MAX_PAGE_LOG2`] (1 GiB:
/// eight such pages hold the largest pool a u32 voxel index reaches).
pub fn page_log2_for(max_buffer_bytes: u64) -> u32 {
    (max_buffer_bytes / 4).max(1).ilog2().clamp(
        shared::volume::pages::GPU_PAGE_LOG2,
        jackknife::MAX_PAGE_LOG2,
    )
}

/// Why the kernels cannot bind `packed`'s voxel pool (more pages than they have bindings), or
/// `None` if they can: the one refusal of the GPU backend's page limit.
pub fn too_many_pages(packed: &PackedVolume) -> Option<String> {
    let d = packed.desc.dims;
    packed.paged_desc().is_none().then(|| {
        format!(
            "the {}x{}x{} volume's voxel pool ({:.0} MiB) needs more than the {} pages of {} MiB \
             the kernels bind",
            d[0],
            d[1],
            d[2],
            std::mem::size_of_val(packed.voxels.as_slice()) as f64 / f64::from(1 << 20),
            shared::volume::pages::MAX_PAGES,
            (4u64 << packed.page_log2) >> 20
        )
    })
}

/// Longest chord through the grid in world units, bounded by the sum of its axes' world lengths.
fn world_chord(vol: &dyn VolumeData) -> f64 {
    let m = vol.index_to_world().0;
    let dims = vol.dims();
    (0..3)
        .map(|a| {
            let col = (0..3).map(|r| (m[r][a] as f64).powi(2)).sum::<f64>().sqrt();
            col * dims[a] as f64
        })
        .sum()
}

/// A build error in the CLI's terms: flags by name, voxels in the file's index coordinates.
fn explain(vol: &dyn VolumeData, e: BuildError) -> anyhow::Error {
    let at = |v: [u32; 3]| vol.describe_voxel(v[0], v[1], v[2]);
    match e {
        BuildError::Scale(s) => anyhow!("--density-scale must be finite and >= 0 (got {s})"),
        BuildError::BrickSize(b) => anyhow!("--brick-size must be in 2..=256 (got {b})"),
        BuildError::CellSize { cell, brick } => anyhow!(
            "--cell-size {cell} must divide --brick-size {brick} into 2 or more cells per axis \
             (e.g. --cell-size {})",
            (brick / 4).max(1)
        ),
        BuildError::SplitRatio(r) => anyhow!("--split-ratio must be in (0, 1] (got {r})"),
        BuildError::SplitOccupancy(o) => {
            anyhow!("--split-occupancy must be in (0, 1] (got {o})")
        }
        BuildError::Table(d) => anyhow!(
            "the super-voxel table of the {}x{}x{} volume (its bricks, with adaptive \
             super-voxels also their cells) exceeds 2^32 - 1 records; use a larger --brick-size \
             (with adaptive super-voxels: --supervoxels fixed or a larger --cell-size)",
            d[0],
            d[1],
            d[2]
        ),
        BuildError::OpticalDepth {
            voxel,
            density,
            scale,
            depth,
        } => anyhow!(
            "{}: {} has density {density}, which times --density-scale {scale} gives optical \
             depths up to {depth:.1e} through the volume, beyond the {MAX_OPTICAL_DEPTH:e} that \
             f32 arithmetic can sum; lower --density-scale",
            vol.name(),
            at(voxel)
        ),
        BuildError::Extinction {
            voxel,
            density,
            scale,
        } => anyhow!(
            "{}: {} has density {density}, which times --density-scale {scale} exceeds the f32 \
             range of extinctions (3.4e38); lower --density-scale (or rescale the file's \
             densities)",
            vol.name(),
            at(voxel)
        ),
        BuildError::Density { voxel, density } => anyhow!(
            "{}: {} has density {density}; densities must be finite and >= 0",
            vol.name(),
            at(voxel)
        ),
        other => anyhow!("{}: {other}", vol.name()),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn pages_are_the_largest_power_of_two_a_buffer_holds() {
        use super::page_log2_for;
        // lavapipe and the Vulkan minimum (128 MiB): 2^25 words, as before.
        assert_eq!(page_log2_for(1 << 27), 25);
        assert_eq!(page_log2_for((1 << 28) - 1), 25);
        assert_eq!(page_log2_for(1 << 29), 27);
        // NVIDIA's 4 GiB - 1: 1 GiB pages (2 GiB would fit, but 8 of them pass the u32 index).
        assert_eq!(page_log2_for(u64::from(u32::MAX)), 28);
        assert_eq!(page_log2_for(u64::MAX), 28);
        // Smaller than any device may report: the minimum page (refused later, naming it).
        assert_eq!(page_log2_for(64), 25);
        assert_eq!(page_log2_for(0), 25);
    }

    use super::*;
    use crate::volume::{Affine, DenseVolume};
    use half::f16;

    fn volume(values: Vec<f32>) -> DenseVolume {
        let n = values.len() as u32;
        DenseVolume::new(
            "test",
            [n, 1, 1],
            values,
            Affine::scale_translate([1.0; 3], [0.0; 3]),
        )
        .unwrap()
    }

    #[test]
    fn densities_in_f16_range_keep_their_bits_at_any_scale() {
        let vol = volume(vec![0.0, 0.25, 1.0, 3.5, 60000.0]);
        for scale in [1e-30f32, 0.5, 1.0, 1e5, 1e29] {
            let p = pack(&vol, scale, 4, Lookup::Nearest).unwrap();
            assert_eq!(p.desc.density_scale, scale);
            let want = [0.0f32, 0.25, 1.0, 3.5, 60000.0].map(|v| f16::from_f32(v).to_bits());
            let got: Vec<u16> = (0..5).map(|i| p.stored_f16(i, 0, 0)).collect();
            assert_eq!(got, want, "scale {scale}");
            assert_eq!(p.underflow.count, 0);
        }
    }

    #[test]
    fn densities_beyond_f16_are_prescaled_by_a_power_of_two() {
        // Before: density 1e6 was refused ("exceeds the f16 range") whatever --density-scale.
        let vol = volume(vec![1e6, 3.0e9, 0.5]);
        let p = pack(&vol, 2.0, 4, Lookup::Nearest).unwrap();
        // The stored scale carries 2^-k with k < 0.
        assert!(p.desc.density_scale > 2.0, "{}", p.desc.density_scale);
        let view = p.view();
        for (i, v) in [1e6f32, 3.0e9, 0.5].iter().enumerate() {
            let mu = view.voxel(i as u32, 0, 0);
            // f16 keeps 11 significant bits: relative error below 2^-11.
            assert!(((mu / (2.0 * v)) - 1.0).abs() < 4.9e-4, "{v}: {mu}");
        }
    }

    #[test]
    fn extinction_beyond_f32_is_refused_naming_the_voxel() {
        let vol = volume(vec![0.5, 10.0]);
        let e = pack(&vol, 1e38, 4, Lookup::Nearest)
            .unwrap_err()
            .to_string();
        assert!(e.contains("(1, 0, 0)") && e.contains("f32"), "{e}");
        // Optical depths beyond f32 sums are refused too (NaN images before).
        let e = pack(&vol, 3e34, 4, Lookup::Nearest)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("(1, 0, 0)") && e.contains("optical depth"),
            "{e}"
        );
        assert!(pack(&vol, 1e30, 4, Lookup::Nearest).is_ok());
    }

    #[test]
    fn densities_lost_to_underflow_are_counted() {
        // 1e-9 is 2^43 below 1e4: beyond the f16 voxels' range even after the prescale.
        let vol = volume(vec![1e4, 1e-9, 0.5, 0.0]);
        let p = pack(&vol, 1.0, 4, Lookup::Nearest).unwrap();
        assert_eq!((p.underflow.count, p.underflow.nonzero), (1, 3));
        // Tiny values alone are prescaled up and survive.
        let p = pack(&volume(vec![1e-9, 3e-9]), 1.0, 4, Lookup::Nearest).unwrap();
        assert_eq!(p.underflow.count, 0);
        assert!(p.view().voxel(0, 0, 0) > 0.0);
        // An extinction below f32's smallest value is lost too.
        let p = pack(&volume(vec![0.25, 1.0]), 1e-45, 4, Lookup::Nearest).unwrap();
        assert_eq!((p.underflow.count, p.underflow.nonzero), (1, 2));
    }
}
