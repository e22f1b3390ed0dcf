//! Deterministic procedural volumes generated in code: the embedded defaults and test shapes.
//!
//! Every voxel is a pure function of its index: integer hashing plus f32 `+ - * /`, `sqrt`,
//! `min`/`max` and float-to-int casts only, all exact or exactly rounded in IEEE 754 (no libm), so
//! a volume is bit-identical on every machine and for every rayon thread count. Generation runs in
//! parallel over z-slices; conservative whole-tile bounds skip the empty (and constant) regions.
//!
//! Every volume spans `[-1, 1]^3` in world units (voxel size `2 / n`) and holds values in `[0, 1]`;
//! the renderer multiplies them by a density scale, see [`default_density_scale`].

use crate::volume::{Affine, DenseVolume, SparseVolume, Volume};
use rayon::prelude::*;

/// Names accepted by [`by_name`] (besides the alias "disney" for "constant").
pub const NAMES: &[&str] = &["cloud", "explosion", "constant"];

/// The default grid size of the embedded volumes along each axis.
pub const DEFAULT_N: u32 = 256;

/// The embedded volume called `name` (case-insensitive; "disney" = "constant") at `n`^3 voxels,
/// generated sparse, 8^3 cell by cell (the same voxels as [`cloud`], [`explosion`] and
/// [`constant_interior`] give densely).
pub fn by_name(name: &str, n: u32) -> Option<Volume> {
    let v = match canonical_name(name)? {
        "cloud" => generate_sparse("cloud", n, cloud_density, cloud_uniform),
        "explosion" => generate_sparse("explosion", n, explosion_density, explosion_uniform),
        _ => generate_sparse("constant", n, constant_density, constant_uniform),
    };
    Some(Volume::Sparse(v))
}

/// Maps a user-facing volume name or alias to its entry in [`NAMES`].
fn canonical_name(name: &str) -> Option<&'static str> {
    match name.to_ascii_lowercase().as_str() {
        "cloud" => Some("cloud"),
        "explosion" => Some("explosion"),
        "constant" | "disney" => Some("constant"),
        _ => None,
    }
}

/// Density scale that gives a central optical depth (along the x axis through the centre) of
/// about 7 for "cloud" and "constant" and about 3 for "explosion"; 1.0 for unknown names.
pub fn default_density_scale(name: &str) -> f32 {
    match canonical_name(name) {
        Some("cloud") => CLOUD_SCALE,
        Some("explosion") => EXPLOSION_SCALE,
        Some(_) => CONSTANT_SCALE,
        None => 1.0,
    }
}

/// The cloud's unscaled central optical depth is 1.12 (n = 64 to 256): 7.3 when scaled.
/// Over all x-rows that hit it, the scaled depth averages 4.1 (at most 9.5).
const CLOUD_SCALE: f32 = 6.5;
/// The explosion's unscaled central optical depth is 0.041 at n = 256 (0.047 at n = 64): 3.1
/// when scaled. Over all x-rows that hit it, the scaled depth averages 3.7 (at most 24).
const EXPLOSION_SCALE: f32 = 75.0;
/// The constant cloud's unscaled central optical depth is 1.60 (n = 64 to 256): 7.2 when scaled.
/// Over all x-rows that hit it, the scaled depth averages 4.4 (at most 7.9).
const CONSTANT_SCALE: f32 = 4.5;

/// A cumulus-like cloud: fBm-shaped density inside a soft, bumpy union of ellipsoids.
pub fn cloud(n: u32) -> DenseVolume {
    generate("cloud", n, cloud_density, cloud_uniform)
}

/// A sparse, explosion-like volume: a broken turbulent shell plus thin high-frequency wisps.
pub fn explosion(n: u32) -> DenseVolume {
    generate("explosion", n, explosion_density, explosion_uniform)
}

/// A Disney-cloud-like volume: density exactly 1 inside a big blobby shape, noisy near its surface.
pub fn constant_interior(n: u32) -> DenseVolume {
    generate("constant", n, constant_density, constant_uniform)
}

/// A homogeneous ball of `density`: voxels whose centre lies within `n/2 - 1` voxels of the centre.
pub fn sphere(n: u32, density: f32) -> DenseVolume {
    let r = (n as f32 / 2.0 - 1.0).max(0.0);
    let r2 = r * r * (2.0 / n as f32) * (2.0 / n as f32);
    let inside = move |[x, y, z]: [f32; 3]| x * x + y * y + z * z <= r2;
    generate(
        "sphere",
        n,
        move |p| if inside(p) { density } else { 0.0 },
        |_, _| None,
    )
}

/// A box with every voxel equal to `density`.
pub fn constant_box(n: u32, density: f32) -> DenseVolume {
    generate("box", n, move |_| density, |_, _| None)
}

/// Tile edge (voxels, in x and y) for the whole-tile shortcut in [`generate`].
const TILE: usize = 8;

/// Voxel centres of an `n`^3 grid spanning `[-1, 1]^3` along one axis, and the affine map.
fn centres(n: u32) -> (Vec<f32>, Affine) {
    let s = 2.0 / n as f32;
    let coord = (0..n).map(|i| (i as f32 + 0.5) * s - 1.0).collect();
    (coord, Affine::scale_translate([s; 3], [-1.0; 3]))
}

/// [`generate`] as a sparse volume, 8^3 cell by cell in parallel: a cell whose voxel centres
/// lie within a ball where `uniform` knows the value is stored as that constant (nothing if 0),
/// every other cell voxel by voxel. The same voxels as [`generate`], never a dense array.
fn generate_sparse(
    name: &str,
    n: u32,
    density: impl Fn([f32; 3]) -> f32 + Sync,
    uniform: impl Fn([f32; 3], f32) -> Option<f32> + Sync,
) -> SparseVolume {
    assert!(n >= 1, "procedural volume {name}: n must be >= 1");
    let (coord, affine) = centres(n);
    let range = |c: u32| (c as usize * 8)..((c as usize + 1) * 8).min(n as usize);
    let constant = |c: [u32; 3]| {
        let r = c.map(range);
        let centre = r.clone().map(|r| 0.5 * (coord[r.start] + coord[r.end - 1]));
        let half = r.map(|r| 0.5 * (coord[r.end - 1] - coord[r.start]));
        uniform(
            centre,
            (half[0] * half[0] + half[1] * half[1] + half[2] * half[2]).sqrt(),
        )
    };
    let values = |c: [u32; 3], out: &mut [f32]| {
        let [rx, ry, rz] = c.map(range);
        for x in rx {
            for y in ry.clone() {
                for z in rz.clone() {
                    let at = SparseVolume::cell_index(x % 8, y % 8, z % 8);
                    out[at] = density([coord[x], coord[y], coord[z]]);
                }
            }
        }
    };
    SparseVolume::generate(
        format!("{name} (procedural {n}^3)"),
        [n; 3],
        affine,
        constant,
        values,
    )
}

/// Fills an `n`^3 grid spanning `[-1, 1]^3` with `density(voxel centre)`, in parallel by z-slice.
///
/// Each slice goes in `TILE` x `TILE` tiles; `uniform(centre, radius)` may return the value that
/// every point within `radius` of `centre` certainly has, which then fills the tile without
/// per-voxel evaluation. It must be conservative, so the result equals evaluating every voxel.
fn generate(
    name: &str,
    n: u32,
    density: impl Fn([f32; 3]) -> f32 + Sync,
    uniform: impl Fn([f32; 3], f32) -> Option<f32> + Sync,
) -> DenseVolume {
    assert!(n >= 1, "procedural volume {name}: n must be >= 1");
    let (coord, affine) = centres(n);
    let nu = n as usize;
    let mut values = vec![0.0f32; nu * nu * nu];
    values
        .par_chunks_mut(nu * nu)
        .enumerate()
        .for_each(|(k, slice)| {
            for y0 in (0..nu).step_by(TILE) {
                for x0 in (0..nu).step_by(TILE) {
                    let (x1, y1) = ((x0 + TILE).min(nu), (y0 + TILE).min(nu));
                    let (cx, cy) = (
                        0.5 * (coord[x0] + coord[x1 - 1]),
                        0.5 * (coord[y0] + coord[y1 - 1]),
                    );
                    let (hx, hy) = (
                        0.5 * (coord[x1 - 1] - coord[x0]),
                        0.5 * (coord[y1 - 1] - coord[y0]),
                    );
                    let fill = uniform([cx, cy, coord[k]], (hx * hx + hy * hy).sqrt());
                    for j in y0..y1 {
                        for i in x0..x1 {
                            slice[i + nu * j] =
                                fill.unwrap_or_else(|| density([coord[i], coord[j], coord[k]]));
                        }
                    }
                }
            }
        });
    DenseVolume::new(format!("{name} (procedural {n}^3)"), [n; 3], values, affine)
        .expect("procedural densities are finite and non-negative")
}

// ---------------------------------------------------------------------------------------------
// Shapes
// ---------------------------------------------------------------------------------------------

/// An ellipsoid blob: centre and inverse radii in world units.
struct Blob {
    c: [f32; 3],
    inv_r: [f32; 3],
}

/// The blob centred at `c` with radii `r`.
const fn blob(c: [f32; 3], r: [f32; 3]) -> Blob {
    Blob {
        c,
        inv_r: [1.0 / r[0], 1.0 / r[1], 1.0 / r[2]],
    }
}

/// The cumulus: a wide flat base (y is up) with towers on top.
const CLOUD_BLOBS: &[Blob] = &[
    blob([0.0, -0.378, 0.0], [0.874, 0.314, 0.694]),
    blob([-0.358, -0.042, 0.09], [0.448, 0.448, 0.448]),
    blob([0.202, 0.07, -0.09], [0.515, 0.515, 0.515]),
    blob([0.022, 0.45, 0.045], [0.358, 0.336, 0.358]),
    blob([0.538, -0.132, 0.224], [0.336, 0.336, 0.336]),
    blob([-0.582, -0.222, -0.246], [0.336, 0.291, 0.336]),
];

/// The Disney-like cloud: a big blobby mass filling much of the box.
const CONSTANT_BLOBS: &[Blob] = &[
    blob([0.0, -0.28, 0.0], [0.94, 0.5, 0.78]),
    blob([-0.333, 0.17, 0.111], [0.555, 0.555, 0.555]),
    blob([0.333, 0.226, -0.111], [0.555, 0.61, 0.555]),
    blob([0.056, 0.56, 0.0], [0.388, 0.333, 0.388]),
];

/// Smooth-union blending width of the blob fields.
const BLEND: f32 = 0.2;

/// `1 - |(p - c) / r|`: 1 at the centre, 0 on the surface, negative outside.
fn blob_field(b: &Blob, p: [f32; 3]) -> f32 {
    let d = [
        (p[0] - b.c[0]) * b.inv_r[0],
        (p[1] - b.c[1]) * b.inv_r[1],
        (p[2] - b.c[2]) * b.inv_r[2],
    ];
    1.0 - (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// Polynomial smooth maximum of `a` and `b` with blending width `k`.
fn smax(a: f32, b: f32, k: f32) -> f32 {
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.max(b) + h * h * k * 0.25
}

/// Smooth union of the blobs' fields.
fn blobs_field(blobs: &[Blob], p: [f32; 3]) -> f32 {
    blobs
        .iter()
        .fold(-1e9, |acc, b| smax(acc, blob_field(b, p), BLEND))
}

/// A Lipschitz constant of [`blobs_field`]: the largest inverse radius (smax keeps the bound).
fn blobs_lipschitz(blobs: &[Blob]) -> f32 {
    blobs.iter().flat_map(|b| b.inv_r).fold(0.0, f32::max)
}

/// Bounds of the blob field over the ball of `radius` around `c`, widened by `margin`.
fn blobs_range(blobs: &[Blob], c: [f32; 3], radius: f32, margin: f32) -> (f32, f32) {
    let (f, d) = (
        blobs_field(blobs, c),
        blobs_lipschitz(blobs) * radius + margin,
    );
    (f - d, f + d)
}

/// `x` mapped linearly from `[lo, hi]` to `[0, 1]` and clamped.
fn ramp(x: f32, lo: f32, hi: f32) -> f32 {
    ((x - lo) / (hi - lo)).clamp(0.0, 1.0)
}

/// Amplitude of the cloud's fBm displacement of the blob field.
const CLOUD_AMP: f32 = 0.3;
/// Octaves of the cloud's fBm.
const CLOUD_OCTAVES: u32 = 5;

/// Cloud density at world point `p`.
fn cloud_density(p: [f32; 3]) -> f32 {
    let f = blobs_field(CLOUD_BLOBS, p);
    if f + CLOUD_AMP * fbm_bound(CLOUD_OCTAVES) < 0.0 {
        return 0.0;
    }
    // Stop once the remaining octaves cannot change the result: certainly outside (0) or certainly
    // saturated (1: the edge ramp and the interior term both at 1; see the return expression).
    let outside = |sum: f32, rest: f32| f + CLOUD_AMP * (sum + rest) < -1e-4;
    let saturated = |sum: f32, rest: f32| {
        let low = sum - rest;
        f + CLOUD_AMP * low > 0.12 + 1e-4
            && 0.35 + 0.9 * f + (0.9 * CLOUD_AMP + 0.8) * low > 1.0 + 1e-4
    };
    let decided = |sum: f32, rest: f32| outside(sum, rest) || saturated(sum, rest);
    let (sum, rest) = fbm(p, 2.5, CLOUD_OCTAVES, 11, |_, sum, rest| decided(sum, rest));
    if outside(sum, rest) {
        return 0.0;
    }
    if saturated(sum, rest) {
        return 1.0;
    }
    let g = f + CLOUD_AMP * sum;
    ramp(g, 0.0, 0.12) * (0.35 + 0.9 * g + 0.8 * sum).clamp(0.0, 1.0)
}

/// Zero where the cloud's displaced field is certainly negative within `radius` of `c`.
fn cloud_uniform(c: [f32; 3], radius: f32) -> Option<f32> {
    let (_, hi) = blobs_range(CLOUD_BLOBS, c, radius, 1e-3);
    (hi + CLOUD_AMP * fbm_bound(CLOUD_OCTAVES) < 0.0).then_some(0.0)
}

/// Amplitude of the turbulent displacement of the explosion's shell radius (turbulence in [-1, 1]).
const EXPLOSION_AMP: f32 = 0.15;
/// Octaves of the explosion's turbulence.
const EXPLOSION_OCTAVES: u32 = 4;
/// The explosion's shell: mean radius and half thickness.
const SHELL: (f32, f32) = (0.7, 0.12);
/// The radii between which the explosion's wisps live.
const WISPS: (f32, f32) = (0.45, 0.97);

/// Radii outside which the explosion certainly vanishes (shell and wisps).
fn explosion_limits() -> (f32, f32) {
    let d = SHELL.1 + EXPLOSION_AMP;
    ((SHELL.0 - d).min(WISPS.0), (SHELL.0 + d).max(WISPS.1))
}

/// Explosion density at world point `p`.
fn explosion_density(p: [f32; 3]) -> f32 {
    let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    let (lo, hi) = explosion_limits();
    if r <= lo || r >= hi {
        return 0.0;
    }
    // Large-scale lobes break the shell into patches; the wisps live in and just around them.
    let lobe = noise(scale_offset(rotate(p), 1.7, [0.0; 3]), 31);
    let fire_mask = ramp(lobe, 0.05, 0.3);
    let wisp_env = ramp(r, WISPS.0, WISPS.0 + 0.1) * ramp(-r, -WISPS.1, -WISPS.1 + 0.12);
    let wisp_mask = wisp_env * ramp(lobe, -0.08, 0.08);
    if fire_mask == 0.0 && wisp_mask == 0.0 {
        return 0.0;
    }
    // Turbulence t; the wisps are warped by its first two octaves only, so the remaining octaves
    // can be skipped wherever the shell is certainly empty.
    let offset = |t: f32| r + EXPLOSION_AMP * t.clamp(-1.0, 1.0) - SHELL.0;
    let shell_empty =
        |t: f32, rest: f32| offset(t - rest - 1e-3) > SHELL.1 || offset(t + rest + 1e-3) < -SHELL.1;
    let mut warp = 0.0;
    let (t, rest) = fbm(p, 2.0, EXPLOSION_OCTAVES, 21, |done, t, rest| {
        if done == 2 {
            warp = t;
        }
        done >= 2 && (fire_mask == 0.0 || shell_empty(t, rest))
    });
    let fire = if fire_mask > 0.0 && !shell_empty(t, rest) {
        let shell = fire_mask * ramp(-offset(t).abs(), -SHELL.1, -0.02);
        shell * ramp(t + noise(scale_offset(p, 7.0, [0.0; 3]), 41), -0.3, 0.5)
    } else {
        0.0
    };
    if wisp_mask == 0.0 {
        return fire;
    }
    // Filaments: where two differently oriented ridged noises both peak (two thin sheets crossing).
    let q = scale_offset(p, 4.5, [0.3 * warp, -0.3 * warp, 0.2 * warp]);
    let a = 1.0 - noise(q, 51).abs();
    if a < 0.85 {
        return fire;
    }
    let b = 1.0 - noise(scale_offset(rotate(q), 1.1, [0.0; 3]), 61).abs();
    let wisp = ramp(a * b, 0.86, 0.97);
    (fire + wisp_mask * wisp * wisp).min(1.0)
}

/// Zero where the ball of `radius` around `c` lies entirely inside or outside the explosion.
fn explosion_uniform(c: [f32; 3], radius: f32) -> Option<f32> {
    let r = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    let (lo, hi) = explosion_limits();
    (r + radius < lo - 1e-3 || r - radius > hi + 1e-3).then_some(0.0)
}

/// Amplitude of the constant cloud's fBm displacement of the blob field.
const CONSTANT_AMP: f32 = 0.18;
/// Octaves of the constant cloud's surface displacement.
const CONSTANT_OCTAVES: u32 = 3;
/// Depth (in blob-field units) of the constant cloud's noisy boundary layer.
const BAND: f32 = 0.1;

/// Disney-like density at world point `p`: exactly 1 deeper than `BAND` below the bumpy surface.
fn constant_density(p: [f32; 3]) -> f32 {
    let f = blobs_field(CONSTANT_BLOBS, p);
    // Certainly outside (0) or certainly deeper than the band (1), whatever the remaining octaves.
    let outside = |sum: f32, rest: f32| f + CONSTANT_AMP * (sum + rest) < -1e-4;
    let inside = |sum: f32, rest: f32| f + CONSTANT_AMP * (sum - rest) > BAND + 1e-4;
    let bound = fbm_bound(CONSTANT_OCTAVES);
    if outside(0.0, bound) {
        return 0.0;
    }
    if inside(0.0, bound) {
        return 1.0;
    }
    let decided = |sum: f32, rest: f32| outside(sum, rest) || inside(sum, rest);
    let (sum, rest) = fbm(p, 2.0, CONSTANT_OCTAVES, 71, |_, sum, rest| {
        decided(sum, rest)
    });
    let g = f + CONSTANT_AMP * sum;
    if outside(sum, rest) || g <= 0.0 {
        return 0.0;
    }
    if inside(sum, rest) || g >= BAND {
        return 1.0;
    }
    let (detail, _) = fbm(p, 12.0, 2, 81, |_, _, _| false);
    (g / BAND * (0.7 + 0.9 * detail)).clamp(0.0, 1.0)
}

/// Zero or one where the constant cloud is certainly outside or deep inside near `c`.
fn constant_uniform(c: [f32; 3], radius: f32) -> Option<f32> {
    let (lo, hi) = blobs_range(CONSTANT_BLOBS, c, radius, 1e-3);
    let bound = CONSTANT_AMP * fbm_bound(CONSTANT_OCTAVES);
    if hi + bound < 0.0 {
        Some(0.0)
    } else if lo - bound > BAND + 1e-4 {
        Some(1.0)
    } else {
        None
    }
}

// ---------------------------------------------------------------------------------------------
// Noise
// ---------------------------------------------------------------------------------------------

/// Octave frequency multiplier (not exactly 2, to avoid aligned lattices).
const LACUNARITY: f32 = 2.03;

/// The largest possible |sum| of `octaves` fBm octaves (amplitudes 1, 1/2, 1/4, ...).
fn fbm_bound(octaves: u32) -> f32 {
    2.0 - 2.0 / (1u32 << octaves) as f32
}

/// A fixed rotation (orthonormal, det 1) that keeps octaves and noises off a shared lattice.
fn rotate(p: [f32; 3]) -> [f32; 3] {
    [
        0.8 * p[1] + 0.6 * p[2],
        -0.8 * p[0] + 0.36 * p[1] - 0.48 * p[2],
        -0.6 * p[0] - 0.48 * p[1] + 0.64 * p[2],
    ]
}

/// `p * k + o`, componentwise.
fn scale_offset(p: [f32; 3], k: f32, o: [f32; 3]) -> [f32; 3] {
    [p[0] * k + o[0], p[1] * k + o[1], p[2] * k + o[2]]
}

/// fBm of `octaves` gradient-noise octaves from `freq`; stops early once `stop(done, sum, rest)`.
///
/// `stop` sees the number of octaves summed so far, their sum, and `rest`, the bound on what the
/// remaining octaves could still add. Returns the (partial) sum and that bound (0 when complete).
fn fbm(
    p: [f32; 3],
    freq: f32,
    octaves: u32,
    seed: u32,
    mut stop: impl FnMut(u32, f32, f32) -> bool,
) -> (f32, f32) {
    let (mut sum, mut amp, mut q) = (0.0f32, 1.0f32, scale_offset(p, freq, [0.0; 3]));
    for o in 0..octaves {
        sum += amp * noise(q, seed.wrapping_add(o));
        amp *= 0.5;
        q = scale_offset(rotate(q), LACUNARITY, [17.31, -9.7, 5.3]);
        let rest = 2.0 * amp - 2.0 * amp / (1u32 << (octaves - 1 - o)) as f32;
        if o + 1 < octaves && stop(o + 1, sum, rest) {
            return (sum, rest);
        }
    }
    (sum, 0.0)
}

/// Per-axis hash multipliers for lattice coordinates.
const HASH_MUL: [u32; 3] = [0x8da6_b343, 0xd816_3841, 0xcb1a_b31f];

/// Murmur3-style 32-bit finaliser.
fn fmix(mut h: u32) -> u32 {
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^ (h >> 16)
}

/// Perlin's 12 edge gradients (4 repeated to make 16), x components.
const GX: [f32; 16] = [
    1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0, -1.0, 0.0, 0.0,
];
/// y components of the gradients.
const GY: [f32; 16] = [
    1.0, 1.0, -1.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0, -1.0, 1.0, -1.0, 1.0, 1.0, -1.0, -1.0,
];
/// z components of the gradients.
const GZ: [f32; 16] = [
    0.0, 0.0, 0.0, 0.0, 1.0, 1.0, -1.0, -1.0, 1.0, 1.0, -1.0, -1.0, 0.0, 0.0, 1.0, -1.0,
];

/// Dot product of the offset with the gradient chosen by `h` (branch-free table lookup).
fn grad(h: u32, x: f32, y: f32, z: f32) -> f32 {
    let i = (h & 15) as usize;
    GX[i] * x + GY[i] * y + GZ[i] * z
}

/// `floor(x)` as an integer, without a libm call (exact for |x| < 2^31).
fn floor_i32(x: f32) -> i32 {
    let i = x as i32;
    if (i as f32) > x {
        i - 1
    } else {
        i
    }
}

/// Perlin's quintic fade curve.
fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// Linear interpolation from `a` to `b`.
fn lerp(t: f32, a: f32, b: f32) -> f32 {
    a + t * (b - a)
}

/// Hash-based 3D gradient noise, clamped to `[-1, 1]`.
fn noise(p: [f32; 3], seed: u32) -> f32 {
    let (ix, iy, iz) = (floor_i32(p[0]), floor_i32(p[1]), floor_i32(p[2]));
    let (x, y, z) = (p[0] - ix as f32, p[1] - iy as f32, p[2] - iz as f32);
    let (u, v, w) = (fade(x), fade(y), fade(z));
    // Lattice hash of corner (ix + dx, iy + dy, iz + dz): the per-axis terms xor-ed, then mixed.
    let hx = [
        (ix as u32).wrapping_mul(HASH_MUL[0]),
        (ix as u32).wrapping_add(1).wrapping_mul(HASH_MUL[0]),
    ];
    let hy = [
        (iy as u32).wrapping_mul(HASH_MUL[1]),
        (iy as u32).wrapping_add(1).wrapping_mul(HASH_MUL[1]),
    ];
    let sz = seed.wrapping_mul(0x9e37_79b9);
    let hz = [
        sz ^ (iz as u32).wrapping_mul(HASH_MUL[2]),
        sz ^ (iz as u32).wrapping_add(1).wrapping_mul(HASH_MUL[2]),
    ];
    let g = |dx: usize, dy: usize, dz: usize| {
        let h = fmix(hx[dx] ^ hy[dy] ^ hz[dz]);
        grad(h, x - dx as f32, y - dy as f32, z - dz as f32)
    };
    let x00 = lerp(u, g(0, 0, 0), g(1, 0, 0));
    let x10 = lerp(u, g(0, 1, 0), g(1, 1, 0));
    let x01 = lerp(u, g(0, 0, 1), g(1, 0, 1));
    let x11 = lerp(u, g(0, 1, 1), g(1, 1, 1));
    lerp(w, lerp(v, x00, x10), lerp(v, x01, x11)).clamp(-1.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The whole-tile shortcut must give exactly what evaluating every voxel gives.
    #[test]
    fn tile_shortcut_matches_per_voxel_evaluation() {
        type Density = fn([f32; 3]) -> f32;
        type Uniform = fn([f32; 3], f32) -> Option<f32>;
        let cases: [(&str, Density, Uniform); 3] = [
            ("cloud", cloud_density, cloud_uniform),
            ("explosion", explosion_density, explosion_uniform),
            ("constant", constant_density, constant_uniform),
        ];
        for (name, density, uniform) in cases {
            for n in [40, 96] {
                let fast = generate(name, n, density, uniform);
                let slow = generate(name, n, density, |_, _| None);
                let same = fast
                    .values
                    .iter()
                    .zip(&slow.values)
                    .all(|(a, b)| a.to_bits() == b.to_bits());
                assert!(same, "{name} at n = {n}: the tile shortcut changed a voxel");
            }
        }
    }

    /// Early-exit fBm returns a bound that contains the full sum.
    #[test]
    fn fbm_rest_bounds_the_skipped_octaves() {
        for i in 0..2000 {
            let p = [
                i as f32 * 0.0131 - 1.0,
                i as f32 * 0.0077 - 0.5,
                i as f32 * 0.0043,
            ];
            let (full, rest) = fbm(p, 2.5, 5, 11, |_, _, _| false);
            assert_eq!(rest, 0.0);
            for stop_at in 1..5 {
                let (part, rest) = fbm(p, 2.5, 5, 11, |done, _, _| done == stop_at);
                assert!(
                    (full - part).abs() <= rest + 1e-6,
                    "{p:?}: {full} vs {part} +- {rest}"
                );
            }
        }
    }
}
