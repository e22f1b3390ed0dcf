//! Packing a dense volume for the kernels: f16 voxels and the super-voxel (brick) statistics.

use crate::volume::DenseVolume;
use anyhow::{bail, Result};
use half::f16;
use shared::grid::{Brick, GridDesc, Lookup};

/// Default brick size B (voxels per axis), as in the paper.
pub const DEFAULT_BRICK_SIZE: u32 = 16;

/// A volume ready for the kernels: what [`shared::grid::VolumeView`] borrows.
#[derive(Clone, Debug)]
pub struct PackedVolume {
    pub desc: GridDesc,
    /// f16 voxel bits, two per word, x fastest (padded to whole words).
    pub voxels: Vec<u32>,
    pub bricks: Vec<Brick>,
    /// Nonzero densities that became 0 when scaled and stored as f16.
    pub underflow: Underflow,
}

impl PackedVolume {
    /// Borrow as the kernels' view.
    pub fn view(&self) -> shared::grid::VolumeView<'_> {
        shared::grid::VolumeView {
            desc: &self.desc,
            voxels: &self.voxels,
            bricks: &self.bricks,
        }
    }
}

/// Smallest f32 >= v (v rounded up from f64).
fn round_up(v: f64) -> f32 {
    let f = v as f32;
    if (f as f64) < v {
        f.next_up()
    } else {
        f
    }
}

/// Scales by `density_scale`, quantizes to f16 and computes per-brick min, max, mean and P (Eq. 5).
///
/// The scale is applied before the f16 conversion, so the range checks (above 65504: an error;
/// nonzero values rounding to 0: counted in [`PackedVolume::underflow`]) apply to the extinction
/// the kernels read, and `desc.density_scale` is 1.
/// Statistics come from exactly the values the kernels read (`scale * f16`), over each brick
/// widened by one voxel on every side ([-1, B+1) per axis, clamped to the grid). The widening makes
/// them conservative for stochastically filtered lookups (jitter <= 0.5 voxel) and for nearest
/// lookups whose position rounds into a neighbouring voxel at a brick boundary. mu_min is exact;
/// mean, max and P are rounded up; P is at least 0.01 mu_min so non-empty bricks get samples.
pub fn pack(
    vol: &DenseVolume,
    density_scale: f32,
    brick_size: u32,
    lookup: Lookup,
) -> Result<PackedVolume> {
    if !(density_scale.is_finite() && density_scale >= 0.0) {
        bail!("--density-scale must be finite and >= 0 (got {density_scale})");
    }
    if !(2..=256).contains(&brick_size) {
        bail!("--brick-size must be in 2..=256 (got {brick_size})");
    }
    let dims = vol.dims;
    let (mut halves, underflow) = to_f16(vol, density_scale)?;
    if !halves.len().is_multiple_of(2) {
        halves.push(0);
    }
    let voxels: Vec<u32> = halves
        .as_chunks::<2>()
        .0
        .iter()
        .map(|&[lo, hi]| lo as u32 | (hi as u32) << 16)
        .collect();
    let brick_dims = [0, 1, 2].map(|a| dims[a].div_ceil(brick_size));
    let desc = GridDesc {
        dims: [dims[0], dims[1], dims[2], 0],
        brick_dims: [brick_dims[0], brick_dims[1], brick_dims[2], 0],
        brick_size,
        lookup: lookup as u32,
        // The voxels already hold density x scale (scaled before the f16 conversion).
        density_scale: 1.0,
        _pad: 0,
    };
    let view = shared::grid::VolumeView {
        desc: &desc,
        voxels: &voxels,
        bricks: &[],
    };
    let count = brick_dims.iter().map(|&d| d as usize).product::<usize>();
    use rayon::prelude::*;
    let bricks: Vec<Brick> = (0..count)
        .into_par_iter()
        .map(|i| {
            let b = unflatten(i, brick_dims);
            brick_stats(&view, [b.0, b.1, b.2], brick_size)
        })
        .collect();
    Ok(PackedVolume {
        desc,
        voxels,
        bricks,
        underflow,
    })
}

/// Nonzero densities that became 0 in f16 once scaled: how many, and the first one.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Underflow {
    /// Voxels with density > 0 whose scaled value rounds to 0 in f16.
    pub count: u64,
    /// Voxels with density > 0.
    pub nonzero: u64,
    /// The first such voxel, described for messages (file coordinates for files), and its density.
    pub first: Option<(String, f32)>,
}

/// Extinction `density * scale` of every voxel as f16 bits; refuses values above the f16 range
/// (naming the voxel) and counts nonzero values that underflow to 0.
fn to_f16(vol: &DenseVolume, scale: f32) -> Result<(Vec<u16>, Underflow)> {
    let mut halves = Vec::with_capacity(vol.values.len() + 1);
    let mut underflow = Underflow::default();
    for (i, &v) in vol.values.iter().enumerate() {
        let mu = v * scale;
        let h = f16::from_f32(mu);
        if h.is_infinite() || !mu.is_finite() {
            let (x, y, z) = unflatten(i, vol.dims);
            bail!(
                "{}: {} has density {v}, which times --density-scale {scale} is {mu}, above the \
                 f16 range of the volume (65504); lower --density-scale (or rescale the file's \
                 densities)",
                vol.name,
                vol.describe_voxel(x, y, z)
            );
        }
        // A scale of 0 empties the volume on purpose: nothing to report.
        if v > 0.0 && scale > 0.0 {
            underflow.nonzero += 1;
            if h.to_f32() == 0.0 {
                underflow.count += 1;
                if underflow.first.is_none() {
                    let (x, y, z) = unflatten(i, vol.dims);
                    underflow.first = Some((vol.describe_voxel(x, y, z), v));
                }
            }
        }
        halves.push(h.to_bits());
    }
    Ok((halves, underflow))
}

/// (x, y, z) of flat index i in a grid of `dims`, x fastest.
fn unflatten(i: usize, dims: [u32; 3]) -> (u32, u32, u32) {
    let (dx, dy) = (dims[0] as usize, dims[1] as usize);
    (
        (i % dx) as u32,
        (i / dx % dy) as u32,
        (i / (dx * dy)) as u32,
    )
}

/// Statistics of brick b over its widened, clamped window.
fn brick_stats(view: &shared::grid::VolumeView, b: [u32; 3], size: u32) -> Brick {
    let d = view.desc.dims;
    let lo = [0, 1, 2].map(|a| (b[a] * size).saturating_sub(1));
    let hi = [0, 1, 2].map(|a| ((b[a] + 1) * size + 1).min(d[a]));
    let (mut mn, mut mx) = (f32::INFINITY, 0.0f32);
    let (mut sum, mut sum2, mut n) = (0.0f64, 0.0f64, 0u64);
    for z in lo[2]..hi[2] {
        for y in lo[1]..hi[1] {
            for x in lo[0]..hi[0] {
                let mu = view.voxel(x, y, z);
                mn = mn.min(mu);
                mx = mx.max(mu);
                sum += mu as f64;
                sum2 += mu as f64 * mu as f64;
                n += 1;
            }
        }
    }
    let mean = sum / n as f64;
    let m2 = sum2 / n as f64;
    let min = mn as f64;
    // Eq. 5: RMS of (mu - mu_min) = sqrt(E[mu^2] - 2 mu_min E[mu] + mu_min^2).
    let p = (m2 + min * (min - 2.0 * mean))
        .max(0.0)
        .sqrt()
        .max(0.01 * min);
    Brick {
        mu_min: mn,
        mu_max: mx,
        mean: round_up(mean),
        p: round_up(p),
    }
}
