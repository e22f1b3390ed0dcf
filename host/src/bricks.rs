//! Packing a dense volume for the kernels: f16 voxels and the super-voxel (brick) statistics.

use crate::volume::DenseVolume;
use anyhow::{bail, Result};
use half::f16;
use shared::volume::grid::{Brick, GridDesc, Lookup};

/// Default brick size B (voxels per axis), as in the paper.
pub const DEFAULT_BRICK_SIZE: u32 = 16;

/// A volume ready for the kernels: what [`shared::volume::grid::VolumeView`] borrows.
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
    pub fn view(&self) -> shared::volume::grid::VolumeView<'_> {
        shared::volume::grid::VolumeView {
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

/// Quantizes to f16 (exactly rescaled by a power of two where the densities need it) and computes
/// per-brick min, max, mean and P (Eq. 5).
///
/// The kernels read `desc.density_scale * f16`. The f16 voxels hold density x 2^k and
/// `desc.density_scale` is `density_scale` x 2^-k ([`f16_exponent`]): multiplying by a power of
/// two changes no mantissa bit, so any density scale from 0 to f32's range renders, and volumes
/// whose densities fit f16 as they are (k = 0) keep exactly the bits they always had. The checks
/// apply to the extinction the kernels read, density x scale: beyond f32's range it is an error
/// naming the voxel in file coordinates; nonzero values that round to 0 are counted in
/// [`PackedVolume::underflow`] (a warning, or an error if every one does).
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
    check_optical_depth_range(vol, density_scale)?;
    let k = f16_exponent(vol);
    let stored_scale = (density_scale as f64 * pow2(-k)) as f32;
    let (mut halves, underflow) = to_f16(vol, k, density_scale, stored_scale)?;
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
        density_scale: stored_scale,
        _pad: 0,
    };
    let view = shared::volume::grid::VolumeView {
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

/// Largest optical depth the estimators may meet: sums of up to ~1000 such terms (two estimates,
/// squares of half of it in the MIS weights' complex exponentials) stay within f32.
pub const MAX_OPTICAL_DEPTH: f64 = 1e35;

/// Refuses a density scale whose largest extinction times the longest chord through the grid
/// (in world units) exceeds [`MAX_OPTICAL_DEPTH`]: beyond it f32 sums of optical depths overflow
/// and images would be NaN. Names the densest voxel.
fn check_optical_depth_range(vol: &DenseVolume, scale: f32) -> Result<()> {
    let Some((i, &max)) = vol
        .values
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
    else {
        return Ok(());
    };
    let m = vol.index_to_world.0;
    // Longest chord: the grid diagonal, bounded by the sum of the axes' world lengths.
    let chord: f64 = (0..3)
        .map(|a| {
            let col = (0..3).map(|r| (m[r][a] as f64).powi(2)).sum::<f64>().sqrt();
            col * vol.dims[a] as f64
        })
        .sum();
    let depth = max as f64 * scale as f64 * chord;
    if depth > MAX_OPTICAL_DEPTH {
        let (x, y, z) = unflatten(i, vol.dims);
        bail!(
            "{}: {} has density {max}, which times --density-scale {scale} gives optical depths up \
             to {depth:.1e} through the volume, beyond the {MAX_OPTICAL_DEPTH:e} that f32 \
             arithmetic can sum; lower --density-scale",
            vol.name,
            vol.describe_voxel(x, y, z)
        );
    }
    Ok(())
}

/// 2^k exactly, for |k| < 1000.
fn pow2(k: i32) -> f64 {
    2f64.powi(k)
}

/// The exponent k of the f16 voxels' power-of-two prescale: 0 when every density fits f16 as it
/// is (no value above 65504, none nonzero that rounds to 0); otherwise the largest k for which
/// the largest density x 2^k stays within 65504 (fewest values lost to underflow).
pub fn f16_exponent(vol: &DenseVolume) -> i32 {
    let max = vol.values.iter().fold(0.0f32, |m, &v| m.max(v));
    if !(max > 0.0) {
        return 0;
    }
    let fits = |v: f32| f16::from_f32(v).is_finite();
    let keeps = |v: f32| !(v > 0.0) || f16::from_f32(v).to_f32() != 0.0;
    if fits(max) && vol.values.iter().all(|&v| keeps(v)) {
        return 0;
    }
    let mut k = (f16::MAX.to_f32() as f64 / max as f64).log2().floor() as i32;
    while !fits((max as f64 * pow2(k)) as f32) {
        k -= 1;
    }
    k
}

/// Nonzero densities that became 0 once scaled and stored: how many, and the first one.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Underflow {
    /// Voxels with density > 0 whose extinction (scale x stored f16) is 0.
    pub count: u64,
    /// Voxels with density > 0.
    pub nonzero: u64,
    /// The first such voxel, described for messages (file coordinates for files), and its density.
    pub first: Option<(String, f32)>,
}

/// Every voxel's density x 2^k as f16 bits; refuses extinctions (density x `scale`) beyond f32's
/// range, naming the voxel, and counts nonzero densities whose extinction
/// (`stored_scale` x f16) is 0.
fn to_f16(
    vol: &DenseVolume,
    k: i32,
    scale: f32,
    stored_scale: f32,
) -> Result<(Vec<u16>, Underflow)> {
    let mut halves = Vec::with_capacity(vol.values.len() + 1);
    let mut underflow = Underflow::default();
    let prescale = pow2(k);
    for (i, &v) in vol.values.iter().enumerate() {
        let h = f16::from_f32((v as f64 * prescale) as f32);
        let mu = stored_scale * h.to_f32();
        if !mu.is_finite() || !stored_scale.is_finite() {
            let (x, y, z) = unflatten(i, vol.dims);
            bail!(
                "{}: {} has density {v}, which times --density-scale {scale} exceeds the f32 \
                 range of extinctions (3.4e38); lower --density-scale (or rescale the file's \
                 densities)",
                vol.name,
                vol.describe_voxel(x, y, z)
            );
        }
        // A scale of 0 empties the volume on purpose: nothing to report.
        if v > 0.0 && scale > 0.0 {
            underflow.nonzero += 1;
            if mu == 0.0 {
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
fn brick_stats(view: &shared::volume::grid::VolumeView, b: [u32; 3], size: u32) -> Brick {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::Affine;

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
            assert_eq!(f16_exponent(&vol), 0);
            assert_eq!(p.desc.density_scale, scale);
            let want = [0.0f32, 0.25, 1.0, 3.5, 60000.0].map(|v| f16::from_f32(v).to_bits());
            let got: Vec<u16> = (0..5)
                .map(|i| (p.voxels[i / 2] >> (16 * (i % 2))) as u16)
                .collect();
            assert_eq!(got, want, "scale {scale}");
            assert_eq!(p.underflow.count, 0);
        }
    }

    #[test]
    fn densities_beyond_f16_are_prescaled_by_a_power_of_two() {
        // Before: density 1e6 was refused ("exceeds the f16 range") whatever --density-scale.
        let vol = volume(vec![1e6, 3.0e9, 0.5]);
        let k = f16_exponent(&vol);
        assert!(k < 0, "{k}");
        let p = pack(&vol, 2.0, 4, Lookup::Nearest).unwrap();
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
