//! The embedded procedural volumes: determinism, value ranges, sparsity and placement.

use engine::scene::procedural::{
    self, by_name, cloud, constant_box, constant_interior, explosion, sphere, NAMES,
};
use engine::volume::{Affine, DenseVolume};

/// Brick edge length in voxels, as in the renderer's brick grid.
const BRICK: u32 = 16;

/// Per-brick (min, max) over a grid of `BRICK`^3 bricks (edge bricks may be partial).
fn brick_min_max(v: &DenseVolume) -> Vec<(f32, f32)> {
    let nb = v.dims.map(|d| d.div_ceil(BRICK));
    let mut out = Vec::new();
    for bz in 0..nb[2] {
        for by in 0..nb[1] {
            for bx in 0..nb[0] {
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                for z in bz * BRICK..((bz + 1) * BRICK).min(v.dims[2]) {
                    for y in by * BRICK..((by + 1) * BRICK).min(v.dims[1]) {
                        for x in bx * BRICK..((bx + 1) * BRICK).min(v.dims[0]) {
                            let a = v.at(x, y, z);
                            lo = lo.min(a);
                            hi = hi.max(a);
                        }
                    }
                }
                out.push((lo, hi));
            }
        }
    }
    out
}

/// Fractions of bricks that are empty (max == 0) and constant non-zero (min == max > 0).
fn brick_fractions(v: &DenseVolume) -> (f64, f64) {
    let b = brick_min_max(v);
    let empty = b.iter().filter(|(_, hi)| *hi == 0.0).count();
    let constant = b.iter().filter(|(lo, hi)| lo == hi && *hi > 0.0).count();
    (
        empty as f64 / b.len() as f64,
        constant as f64 / b.len() as f64,
    )
}

/// Unscaled optical depth along the x axis through the centre (mean of the 4 central rows).
fn central_depth(v: &DenseVolume) -> f64 {
    let n = v.dims[0];
    let s = v.index_to_world.0[0][0] as f64;
    let mut sum = 0.0;
    for (y, z) in [
        (n / 2 - 1, n / 2 - 1),
        (n / 2, n / 2 - 1),
        (n / 2 - 1, n / 2),
        (n / 2, n / 2),
    ] {
        sum += (0..n).map(|x| v.at(x, y, z) as f64).sum::<f64>();
    }
    sum / 4.0 * s
}

/// The value bits, for bytewise comparison.
fn bits(v: &DenseVolume) -> Vec<u32> {
    v.values.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn generation_is_deterministic_and_independent_of_thread_count() {
    let single = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for name in NAMES {
        let a = by_name(name, 64).unwrap();
        let b = by_name(name, 64).unwrap();
        let c = single.install(|| by_name(name, 64).unwrap());
        assert_eq!(
            volume_bits(&a),
            volume_bits(&b),
            "{name}: two generations differ"
        );
        assert_eq!(
            volume_bits(&a),
            volume_bits(&c),
            "{name}: the 1-thread pool differs from the default pool"
        );
    }
}

#[test]
fn values_are_finite_in_unit_range_and_not_all_zero() {
    for name in NAMES {
        let v = dense(name, 96);
        assert!(
            v.values
                .iter()
                .all(|x| x.is_finite() && (0.0..=1.0).contains(x)),
            "{name}: value out of [0, 1]"
        );
        let max = v.values.iter().copied().fold(0.0f32, f32::max);
        assert!(max > 0.5, "{name}: max value {max} is too small");
    }
}

#[test]
fn faces_of_the_box_are_empty() {
    let n = 128;
    for name in NAMES {
        let v = dense(name, n);
        let mut face = 0.0f32;
        for a in 0..n {
            for b in 0..n {
                for c in [0, n - 1] {
                    face = face
                        .max(v.at(c, a, b))
                        .max(v.at(a, c, b))
                        .max(v.at(a, b, c));
                }
            }
        }
        assert_eq!(face, 0.0, "{name}: density {face} on a face of the box");
    }
}

#[test]
fn dims_and_affine_span_minus_one_to_one() {
    for n in [1, 7, 64] {
        let v = cloud(n);
        assert_eq!(v.dims, [n; 3]);
        assert_eq!(v.values.len(), (n * n * n) as usize);
        let s = 2.0 / n as f32;
        assert_eq!(v.index_to_world, Affine::scale_translate([s; 3], [-1.0; 3]));
        let far = v.index_to_world.0[0][0] * n as f32 + v.index_to_world.0[0][3];
        assert!((far - 1.0).abs() < 1e-6, "n = {n}: far corner at {far}");
    }
}

#[test]
fn by_name_knows_the_names_and_the_disney_alias() {
    for name in NAMES {
        assert!(by_name(name, 8).is_some(), "{name}");
    }
    assert_eq!(
        volume_bits(&by_name("disney", 32).unwrap()),
        bits(&constant_interior(32))
    );
    assert_eq!(
        volume_bits(&by_name("Explosion", 32).unwrap()),
        bits(&explosion(32))
    );
    assert!(by_name("teapot", 8).is_none());
    assert_eq!(procedural::default_density_scale("teapot"), 1.0);
}

#[test]
fn cloud_has_empty_edges_and_a_substantial_detailed_interior() {
    let v = cloud(128);
    let (empty, constant) = brick_fractions(&v);
    assert!(empty > 0.3, "cloud: only {empty:.3} of bricks empty");
    assert!(
        1.0 - empty > 0.25,
        "cloud: only {:.3} of bricks non-empty",
        1.0 - empty
    );
    assert!(
        constant < 0.05,
        "cloud: {constant:.3} of bricks constant; the interior should be detailed"
    );
    let corner = v.at(0, 0, 0) + v.at(127, 127, 127) + v.at(0, 127, 0) + v.at(127, 0, 127);
    assert_eq!(corner, 0.0, "cloud: corners must be empty");
}

#[test]
fn explosion_is_sparse_with_empty_core_and_wisps() {
    let v = explosion(128);
    let (empty, _) = brick_fractions(&v);
    assert!(empty > 0.3, "explosion: only {empty:.3} of bricks empty");
    assert!(
        empty < 0.9,
        "explosion: {empty:.3} of bricks empty; nearly nothing left"
    );
    assert_eq!(
        v.at(64, 64, 64),
        0.0,
        "explosion: the centre must be hollow"
    );
    let nonzero = v.values.iter().filter(|x| **x > 0.0).count() as f64 / v.values.len() as f64;
    assert!(
        nonzero < 0.15,
        "explosion: {nonzero:.3} of voxels non-zero; should be sparse"
    );
}

#[test]
fn constant_interior_has_many_constant_bricks() {
    let v = constant_interior(128);
    let b = brick_min_max(&v);
    let ones = b.iter().filter(|(lo, hi)| *lo == 1.0 && *hi == 1.0).count() as f64 / b.len() as f64;
    let (empty, _) = brick_fractions(&v);
    assert!(
        ones > 0.06,
        "constant: only {ones:.3} of bricks are all 1.0"
    );
    assert!(empty > 0.1, "constant: only {empty:.3} of bricks empty");
    let partial = 1.0 - ones - empty;
    assert!(
        partial > 0.1,
        "constant: only {partial:.3} of bricks in the noisy boundary layer"
    );
}

#[test]
fn default_density_scales_give_the_intended_central_optical_depths() {
    for (name, lo, hi) in [
        ("cloud", 5.0, 10.0),
        ("constant", 5.0, 10.0),
        ("explosion", 2.0, 5.0),
    ] {
        for n in [64, 128] {
            let tau =
                central_depth(&dense(name, n)) * procedural::default_density_scale(name) as f64;
            assert!(
                (lo..=hi).contains(&tau),
                "{name} at n = {n}: central optical depth {tau:.2}"
            );
        }
    }
}

#[test]
fn sphere_and_box_are_homogeneous() {
    let b = constant_box(16, 0.25);
    assert!(b.values.iter().all(|x| *x == 0.25));
    let n = 32;
    let s = sphere(n, 2.0);
    assert_eq!(s.at(16, 16, 16), 2.0);
    assert_eq!(s.at(0, 0, 0), 0.0);
    assert_eq!(
        s.at(0, 16, 16),
        0.0,
        "centre 15.5 voxels away is outside radius 15"
    );
    assert_eq!(
        s.at(1, 16, 16),
        2.0,
        "centre 14.5 voxels away is inside radius 15"
    );
    assert!(s.values.iter().all(|x| *x == 0.0 || *x == 2.0));
    // Volume of the ball of radius 15 voxels.
    let count = s.values.iter().filter(|x| **x > 0.0).count() as f64;
    let expected = 4.0 / 3.0 * std::f64::consts::PI * 15.0f64.powi(3);
    assert!(
        (count / expected - 1.0).abs() < 0.03,
        "{count} voxels vs {expected:.0}"
    );
}

#[test]
fn default_size_cloud_generates() {
    let v = cloud(procedural::DEFAULT_N);
    assert_eq!(v.values.len(), 256 * 256 * 256);
    assert!(v.values.iter().any(|x| *x > 0.0));
}

/// The embedded volumes as rendered (`by_name`: generated sparse, 8^3 cell by cell, constant
/// cells from the same conservative bounds) hold exactly the voxels of the dense generators, at
/// sizes that are and are not multiples of the cell size.
#[test]
fn sparse_generation_gives_the_dense_voxels() {
    use engine::volume::{Volume, VolumeData};
    for n in [61, 64] {
        for (name, dense) in [
            ("cloud", cloud(n)),
            ("explosion", explosion(n)),
            ("constant", constant_interior(n)),
        ] {
            let sparse = by_name(name, n).unwrap();
            assert!(matches!(sparse, Volume::Sparse(_)), "{name}");
            assert_eq!(sparse.dims(), dense.dims, "{name}");
            assert_eq!(sparse.index_to_world(), &dense.index_to_world, "{name}");
            let mut all = Vec::new();
            if sparse.fill([0; 3], sparse.dims(), &mut all) {
                assert_eq!(bits_of(&all), bits(&dense), "{name} {n}");
            } else {
                panic!("{name} {n}: generated empty");
            }
            assert_eq!(sparse.occupied_box(), dense.occupied_box(), "{name} {n}");
            // Constant cells hold no values: at 64^3 the sparse volume stores less than the
            // dense one (at 256^3: 42, 33, 43 MiB instead of 64).
            let stored = match &sparse {
                Volume::Sparse(s) => s.stored_bytes(),
                Volume::Dense(_) => unreachable!(),
            };
            if n == 64 {
                assert!(
                    stored < u64::from(n).pow(3) * 4,
                    "{name} {n}: {stored} bytes"
                );
            }
        }
    }
}

/// The dense generator of an embedded volume (`by_name` gives the same voxels, sparse).
fn dense(name: &str, n: u32) -> DenseVolume {
    match name {
        "cloud" => cloud(n),
        "explosion" => explosion(n),
        _ => constant_interior(n),
    }
}

fn bits_of(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// Every voxel's bits of a volume, x fastest.
fn volume_bits(v: &engine::volume::Volume) -> Vec<u32> {
    use engine::volume::VolumeData;
    let mut all = Vec::new();
    assert!(v.fill([0; 3], v.dims(), &mut all), "empty");
    bits_of(&all)
}
