//! Moment shadow maps (Peters et al. 2017), four power moments: the reconstruction's properties
//! from the paper (exact for two-atom distributions, bounds on both sides, monotone in depth),
//! the quantization transform's round trip, and a homogeneous slab against exp(-tau).

use shared::rng::{pcg_hash, unit_f32};
use shared::shadows::msm::{
    add_atom, add_atom6, bias, bias6, dequantize_transform, from_unorm16, quantize_transform,
    shadow_bounds, shadow_bounds2, shadow_bounds6, shadow_estimate, to_unorm16, Moments4, Moments6,
    ALPHA6_F32, ALPHA_F32, ALPHA_U16, TARGET6, TARGET_F32, TARGET_U16,
};

/// Moments of the atoms (depth, weight).
fn moments(atoms: &[(f32, f32)]) -> Moments4 {
    atoms.iter().fold([0.0; 5], |b, &(z, w)| add_atom(b, z, w))
}

/// Z(z < zf) of the atoms, exactly.
fn below(atoms: &[(f32, f32)], zf: f32) -> f32 {
    atoms.iter().filter(|(z, _)| *z < zf).map(|(_, w)| w).sum()
}

/// Uniform in [lo, hi) from a hashed counter.
fn uniform(k: u32, lo: f32, hi: f32) -> f32 {
    lo + (hi - lo) * unit_f32(pcg_hash(k))
}

/// A distribution of two atoms is reproduced exactly (up to the f32 bias and rounding): 2000
/// random pairs in [-1, 1] with weights summing to 1, fragment depths between and around them
/// at least 0.2 from both atoms (closer, the reconstruction is ill-conditioned in f32: the upper
/// bound's atom at z_f picks up weight of order alpha / (z_f - z_atom)^2); tolerance 2e-3.
#[test]
fn two_atoms_are_reconstructed_exactly() {
    let mut worst = 0.0f32;
    for k in 0..2000u32 {
        let a = uniform(6 * k, -1.0, 0.9);
        let c = uniform(6 * k + 1, a + 0.1, 1.0);
        let w = uniform(6 * k + 2, 0.05, 0.95);
        let atoms = [(a, w), (c, 1.0 - w)];
        let b = bias(moments(&atoms), ALPHA_F32, TARGET_F32);
        for zf in [a - 0.2, 0.5 * (a + c), c + 0.2] {
            if !(-1.0..=1.0).contains(&zf) || (zf - a).abs() < 0.2 || (zf - c).abs() < 0.2 {
                continue;
            }
            let (lo, hi) = shadow_bounds(b, zf);
            let exact = below(&atoms, zf);
            worst = worst.max((lo - exact).abs()).max((hi - exact).abs());
        }
    }
    assert!(worst < 2e-3, "two atoms: worst error {worst}");
}

/// The two-moment bounds (the fallback for numerically singular moments) bound the truth too:
/// 500 random distributions, 41 depths, within 1e-4.
#[test]
fn two_moment_bounds_hold() {
    for k in 0..500u32 {
        let atoms: Vec<(f32, f32)> = (0..5)
            .map(|i| (uniform(77 * k + i, -1.0, 1.0), 0.2))
            .collect();
        let b = moments(&atoms);
        for j in 0..=40 {
            let zf = -1.0 + j as f32 * 0.05;
            let (lo, hi) = shadow_bounds2(b, zf);
            let exact = below(&atoms, zf);
            assert!(
                lo <= exact + 1e-4 && exact <= hi + 1e-4,
                "{k}, {zf}: {lo} {exact} {hi}"
            );
        }
    }
}

/// For 500 random distributions of 3 to 12 atoms in [-1, 1] (plus the far-plane atom at 1 for
/// the light that passes), lower <= Z(z < zf) <= upper at 41 fragment depths, within 1e-4 (the
/// f32 bias and rounding).
#[test]
fn bounds_hold_on_both_sides() {
    for k in 0..500u32 {
        let n = 3 + pcg_hash(k) % 10;
        let mut atoms: Vec<(f32, f32)> = (0..n)
            .map(|i| {
                (
                    uniform(1000 * k + 2 * i, -1.0, 1.0),
                    uniform(1000 * k + 2 * i + 1, 0.0, 1.0),
                )
            })
            .collect();
        let total: f32 = atoms.iter().map(|a| a.1).sum::<f32>() * 1.25;
        for a in &mut atoms {
            a.1 /= total;
        }
        atoms.push((1.0, 0.2));
        let b = bias(moments(&atoms), ALPHA_F32, TARGET_F32);
        for j in 0..=40 {
            let zf = -1.0 + j as f32 * 0.05;
            let (lo, hi) = shadow_bounds(b, zf);
            let exact = below(&atoms, zf);
            assert!(
                lo <= exact + 1e-4 && exact <= hi + 1e-4,
                "distribution {k}, zf {zf}: {lo} <= {exact} <= {hi} fails"
            );
        }
    }
}

/// The lower bound never decreases with depth (100 random distributions, 401 depths).
#[test]
fn lower_bound_is_monotone_in_depth() {
    for k in 0..100u32 {
        let atoms: Vec<(f32, f32)> = (0..6)
            .map(|i| (uniform(50 * k + 2 * i, -1.0, 1.0), 1.0 / 6.0))
            .collect();
        let b = bias(moments(&atoms), ALPHA_F32, TARGET_F32);
        let mut last = 0.0f32;
        for j in 0..=400 {
            let zf = -1.0 + j as f32 * 0.005;
            let (lo, _) = shadow_bounds(b, zf);
            assert!(lo >= last - 1e-5, "distribution {k}: {lo} < {last} at {zf}");
            last = lo;
        }
    }
}

/// Theta_4^* and its inverse round-trip in f32 within 1e-6; through 16-bit storage the moments
/// come back within 4e-5 (two or three quantization steps of 1.5e-5 combined), and the biased
/// reconstruction still bounds the truth within 2e-3.
#[test]
fn quantization_round_trips() {
    let mut worst_f32 = 0.0f32;
    let mut worst_u16 = 0.0f32;
    for k in 0..2000u32 {
        let atoms: Vec<(f32, f32)> = (0..4)
            .map(|i| (uniform(10 * k + i, -1.0, 1.0), 0.25))
            .collect();
        let b = moments(&atoms);
        let u = quantize_transform(b);
        let back = dequantize_transform(u);
        let stored = u.map(|x| from_unorm16(to_unorm16(x)));
        let back16 = dequantize_transform(stored);
        for j in 1..5 {
            worst_f32 = worst_f32.max((back[j] - b[j]).abs());
            worst_u16 = worst_u16.max((back16[j] - b[j]).abs());
        }
        assert!(u.iter().all(|x| (-1e-6..=1.0 + 1e-6).contains(x)), "{u:?}");
        let biased = bias(back16, ALPHA_U16, TARGET_U16);
        for zf in [-0.5f32, 0.0, 0.5] {
            let (lo, hi) = shadow_bounds(biased, zf);
            let exact = below(&atoms, zf);
            assert!(lo <= exact + 2e-3 && exact <= hi + 2e-3, "{k}, {zf}");
        }
    }
    assert!(worst_f32 < 1e-6, "f32 round trip {worst_f32}");
    assert!(worst_u16 < 4e-5, "16-bit round trip {worst_u16}");
}

/// A homogeneous slab filling [-1, 1] with optical depth tau along the light: 256 absorption
/// atoms, the rest at the far plane; T_msm = 1 - the midpoint of the bounds (beta = 1/2, the
/// paper's worst-case choice) vs the truth. Prints the worst error per tau (four moments of a
/// continuous distribution leave wide bounds) and checks that the truth lies within the bounds
/// and the midpoint within half their width.
#[test]
fn homogeneous_slab_error_is_reported() {
    for tau in [0.5f32, 2.0, 8.0] {
        let n = 256;
        let mut atoms = Vec::new();
        let mut t_prev = 1.0f32;
        for i in 0..n {
            let z_hi = -1.0 + 2.0 * (i + 1) as f32 / n as f32;
            let t = (-tau * (z_hi + 1.0) * 0.5).exp();
            atoms.push((z_hi - 1.0 / n as f32, t_prev - t));
            t_prev = t;
        }
        atoms.push((1.0, t_prev));
        let b = bias(moments(&atoms), ALPHA_F32, TARGET_F32);
        let b6 = bias6(moments6(&atoms), ALPHA6_F32, TARGET6);
        let mut worst = 0.0f32;
        let mut worst6 = 0.0f32;
        for j in 1..40 {
            let zf = -1.0 + j as f32 * 0.05;
            let (lo, hi) = shadow_bounds(b, zf);
            let exact = below(&atoms, zf);
            assert!(
                lo <= exact + 1e-4 && exact <= hi + 1e-4,
                "tau {tau}, zf {zf}"
            );
            let mid = shadow_estimate(b, zf, 0.5);
            let err = (mid - exact).abs();
            assert!(err <= 0.5 * (hi - lo) + 1e-4, "tau {tau}, zf {zf}");
            worst = worst.max(err);
            let (lo6, hi6) = shadow_bounds6(b6, zf);
            assert!(
                lo6 <= exact + 1e-3 && exact <= hi6 + 1e-3,
                "tau {tau}, zf {zf}, six"
            );
            worst6 = worst6.max((0.5 * (lo6 + hi6) - exact).abs());
        }
        println!(
            "homogeneous slab, tau {tau}: worst |T_msm - T| = {worst:.4} (4 moments), {worst6:.4} (6)"
        );
    }
}

/// Moments of the atoms, six.
fn moments6(atoms: &[(f32, f32)]) -> Moments6 {
    atoms.iter().fold([0.0; 7], |b, &(z, w)| add_atom6(b, z, w))
}

/// Six moments reproduce three atoms (2000 random triples in [-1, 1], fragment depths at least
/// 0.2 from every atom, tolerance 2e-3).
#[test]
fn six_moments_reconstruct_three_atoms() {
    let mut worst = 0.0f32;
    let mut checked = 0;
    for k in 0..2000u32 {
        let mut zs = [
            uniform(9 * k, -1.0, 1.0),
            uniform(9 * k + 1, -1.0, 1.0),
            uniform(9 * k + 2, -1.0, 1.0),
        ];
        zs.sort_by(f32::total_cmp);
        if zs[1] - zs[0] < 0.4 || zs[2] - zs[1] < 0.4 {
            continue;
        }
        let w0 = uniform(9 * k + 3, 0.1, 0.5);
        let w1 = uniform(9 * k + 4, 0.1, 0.4);
        let atoms = [(zs[0], w0), (zs[1], w1), (zs[2], 1.0 - w0 - w1)];
        let b = bias6(moments6(&atoms), ALPHA6_F32, TARGET6);
        for zf in [
            zs[0] - 0.2,
            0.5 * (zs[0] + zs[1]),
            0.5 * (zs[1] + zs[2]),
            zs[2] + 0.2,
        ] {
            if !(-1.0..=1.0).contains(&zf) || zs.iter().any(|z| (z - zf).abs() < 0.2) {
                continue;
            }
            let (lo, hi) = shadow_bounds6(b, zf);
            let exact = below(&atoms, zf);
            worst = worst.max((lo - exact).abs()).max((hi - exact).abs());
            checked += 1;
        }
    }
    assert!(checked > 500, "only {checked} cases");
    assert!(
        worst < 2e-3,
        "three atoms, six moments: worst error {worst}"
    );
}

/// Six-moment bounds hold on both sides (within 1e-3) for 500 random distributions of 4 to 12
/// atoms (plus the far-plane atom) at 41 depths, and are tighter than the four-moment ones: the
/// summed width over all cases is smaller.
#[test]
fn six_moment_bounds_hold_and_are_tighter() {
    let (mut width4, mut width6) = (0.0f64, 0.0f64);
    for k in 0..500u32 {
        let n = 4 + pcg_hash(k + 7) % 9;
        let mut atoms: Vec<(f32, f32)> = (0..n)
            .map(|i| {
                (
                    uniform(3000 * k + 2 * i, -1.0, 1.0),
                    uniform(3000 * k + 2 * i + 1, 0.0, 1.0),
                )
            })
            .collect();
        let total: f32 = atoms.iter().map(|a| a.1).sum::<f32>() * 1.25;
        for a in &mut atoms {
            a.1 /= total;
        }
        atoms.push((1.0, 0.2));
        let b6 = bias6(moments6(&atoms), ALPHA6_F32, TARGET6);
        let b4 = bias(moments(&atoms), ALPHA_F32, TARGET_F32);
        for j in 0..=40 {
            let zf = -1.0 + j as f32 * 0.05;
            let (lo, hi) = shadow_bounds6(b6, zf);
            let exact = below(&atoms, zf);
            assert!(
                lo <= exact + 1e-3 && exact <= hi + 1e-3,
                "distribution {k}, zf {zf}: {lo} <= {exact} <= {hi} fails (six moments)"
            );
            let (lo4, hi4) = shadow_bounds(b4, zf);
            width4 += (hi4 - lo4) as f64;
            width6 += (hi - lo) as f64;
        }
    }
    assert!(
        width6 < width4,
        "six-moment bounds {width6} not tighter than four {width4}"
    );
}

/// A homogeneous 16^3 cube (extinction 1.5 in [-1, 1]^3), its world-to-index map, and the frame
/// of an 8 x 8 map of a sun straight above it (depth 3 from y = 1.5 down).
fn homogeneous_cube() -> (
    engine::scene::bricks::PackedVolume,
    shared::geometry::Affine3x4,
    shared::shadows::map::MsmDesc,
) {
    use shared::geometry::V3;
    let n = 16;
    let vol = integration_tests::volume(
        "cube",
        [n; 3],
        integration_tests::unit_cube(n),
        |_, _, _| 1.5,
    );
    let packed =
        engine::scene::bricks::pack(&vol, 1.0, 8, shared::volume::grid::Lookup::Nearest).unwrap();
    let w2i = engine::scene::camera::world_to_index(&vol.index_to_world).unwrap();
    let desc = shared::shadows::map::MsmDesc {
        origin: V3::new(-1.0, 1.5, -1.0),
        width: 8,
        axis_u: V3::new(2.0, 0.0, 0.0),
        height: 8,
        axis_v: V3::new(0.0, 0.0, 2.0),
        depth_len: 3.0,
        dir: V3::new(0.0, -1.0, 0.0),
        ones: u32::MAX,
        dequant: shared::shadows::msm::U16_DEQUANT,
    };
    (packed, w2i, desc)
}

/// The map of a homogeneous cube (extinction 1.5 in [-1, 1]^3) under a sun straight above: at
/// points of every height, the true T = exp(-1.5 (1 - y)) lies within the map's bounds, and the
/// midpoint estimate's worst error is reported (8 x 8 texels, all alike, so filtering is exact).
#[test]
fn map_of_a_homogeneous_cube_bounds_the_truth() {
    use shared::geometry::V3;
    use shared::shadows::map::{build_texel, filtered_moments, transmittance4};
    let (packed, w2i, desc) = homogeneous_cube();
    let view = packed.view();
    let mut map = Vec::new();
    for j in 0..8 {
        for i in 0..8 {
            let b = build_texel(&view, &w2i, &desc, i, j);
            assert!((b[0] - 1.0).abs() < 1e-5, "b0 {}", b[0]);
            map.extend_from_slice(&b[1..]);
        }
    }
    let mut worst = 0.0f32;
    for k in 0..=20 {
        let y = 0.95 - 0.095 * k as f32;
        let x = V3::new(0.3, y, -0.2);
        let exact = (-1.5 * (1.0 - y)).exp();
        let (u, v, z) = desc.project(x);
        let b = bias(filtered_moments(&desc, &map, u, v), ALPHA_F32, TARGET_F32);
        let (lo, hi) = shadow_bounds(b, z);
        assert!(
            1.0 - hi <= exact + 2e-3 && exact <= 1.0 - lo + 2e-3,
            "y {y}: {} <= {exact} <= {}",
            1.0 - hi,
            1.0 - lo
        );
        worst = worst.max((transmittance4(&desc, &map, x) - exact).abs());
    }
    println!(
        "moment shadow map of a homogeneous cube (tau up to 3): worst |T_msm - T| = {worst:.4}"
    );
}

/// Each texel's moments equal an f64 march of the same midpoint atoms through a lumpy volume
/// (relative 1e-4), under an oblique sun.
#[test]
fn map_texels_match_an_f64_march() {
    use engine::scene::bricks::pack;
    use engine::scene::camera::world_to_index;
    use shared::geometry::V3;
    use shared::shadows::map::{build_texel, MsmDesc};
    use shared::volume::dda::{clip_to_box, GridDda};
    let vol = integration_tests::lumpy_blobs(20, 5);
    let packed = pack(&vol, 1.0, 8, shared::volume::grid::Lookup::Nearest).unwrap();
    let w2i = world_to_index(&vol.index_to_world).unwrap();
    let dir = {
        let d = V3::new(0.3, -1.0, 0.2);
        d * (1.0 / d.dot(d).sqrt())
    };
    // Axes orthogonal to dir.
    let u_axis = shared::geometry::cross(dir, V3::new(0.0, 0.0, 1.0));
    let u_axis = u_axis * (3.0 / u_axis.dot(u_axis).sqrt());
    let v_axis = shared::geometry::cross(u_axis, dir);
    let v_axis = v_axis * (3.0 / v_axis.dot(v_axis).sqrt());
    let desc = MsmDesc {
        origin: dir * -2.0 - u_axis * 0.5 - v_axis * 0.5,
        width: 12,
        axis_u: u_axis,
        height: 12,
        axis_v: v_axis,
        depth_len: 4.0,
        dir,
        ones: u32::MAX,
        dequant: shared::shadows::msm::U16_DEQUANT,
    };
    let view = packed.view();
    let d = view.desc.dims;
    let hi = V3::new(d[0] as f32, d[1] as f32, d[2] as f32);
    for j in 0..12 {
        for i in 0..12 {
            let b = build_texel(&view, &w2i, &desc, i, j);
            let ray = shared::geometry::to_index_space(&desc.texel_ray(i, j), &w2i);
            let (t0, t1) = clip_to_box(&ray, hi, 0.0, desc.depth_len);
            let mut reference = [0.0f64; 5];
            let mut t = 1.0f64;
            let mut tau = 0.0f64;
            let mut add = |z: f64, w: f64| {
                for (p, r) in reference.iter_mut().enumerate() {
                    *r += w * z.powi(p as i32);
                }
            };
            if t0 < t1 {
                let mut dda = GridDda::voxels(&view.desc, &ray, t0, t1);
                while !dda.done() {
                    let seg = dda.step();
                    tau += (seg.t1 - seg.t0) as f64
                        * view.voxel(seg.cell[0], seg.cell[1], seg.cell[2]) as f64;
                    let next = (-tau).exp();
                    let z = 2.0 * 0.5 * (seg.t0 + seg.t1) as f64 / desc.depth_len as f64 - 1.0;
                    add(z, t - next);
                    t = next;
                }
            }
            add(1.0, t);
            for p in 0..5 {
                assert!(
                    (b[p] as f64 - reference[p]).abs() <= 1e-4 * reference[p].abs().max(1e-2),
                    "texel ({i}, {j}) moment {p}: {} vs {}",
                    b[p],
                    reference[p]
                );
            }
        }
    }
}

/// The stored map of a homogeneous cube (extinction 1.5 in [-1, 1]^3, sun straight above) read
/// back through `map_transmittance` in each storage: at 21 heights the error |T_msm - T| is
/// reported, and six moments beat four, in 16 bits or 32 (the exponential absorption profile
/// is no few-atom distribution, so more moments tighten the bounds).
#[test]
fn stored_maps_of_a_homogeneous_cube_six_beat_four() {
    use shared::geometry::V3;
    use shared::shadows::map::{build_raw_texel, map_transmittance, store_texel, Shadows};
    let (packed, w2i, desc) = homogeneous_cube();
    let view = packed.view();
    let mut worst = Vec::new();
    for mode in [Shadows::Msm4U16, Shadows::Msm4, Shadows::Msm6] {
        let w = mode.words_per_texel() as usize;
        let map: Vec<u32> = (0..64)
            .flat_map(|k| {
                store_texel(mode, build_raw_texel(&view, &w2i, &desc, k), desc.ones)[..w].to_vec()
            })
            .collect();
        let mut err = 0.0f32;
        for k in 0..=20 {
            let y = 0.95 - 0.095 * k as f32;
            let exact = (-1.5 * (1.0 - y)).exp();
            let (t, fell_back) =
                map_transmittance(&desc, mode, map.as_slice(), V3::new(0.3, y, -0.2));
            assert_eq!(fell_back, 0, "{mode:?} y {y}");
            err = err.max((t - exact).abs());
        }
        println!("homogeneous cube, {mode:?}: worst |T_msm - T| = {err:.4}");
        worst.push(err);
    }
    assert!(worst[2] < worst[1] && worst[2] < worst[0], "{worst:?}");
    assert!(worst[0] < 0.1, "{worst:?}");
}

/// The 16-bit quantization with its products rounded one by one (`quantize_u16`, what maps store)
/// equals `to_unorm16` of `quantize_transform` on the CPU, on 100,000 random moment vectors of
/// random depth distributions (seed 11).
#[test]
fn quantize_u16_equals_the_transform_then_unorm16() {
    use shared::shadows::msm::quantize_u16;
    for k in 0..100_000u32 {
        let mut b: Moments4 = [1.0, 0.0, 0.0, 0.0, 0.0];
        let atoms = 1 + pcg_hash(k ^ 11) % 4;
        let mut left = 1.0f32;
        for a in 0..atoms {
            let z = 2.0 * unit_f32(pcg_hash(k * 8 + a)) - 1.0;
            let w = if a + 1 == atoms {
                left
            } else {
                left * unit_f32(pcg_hash(k * 8 + a + 4))
            };
            left -= w;
            b = add_atom(b, z, w);
        }
        let u = quantize_transform(b);
        assert_eq!(quantize_u16(b, u32::MAX), u.map(to_unorm16), "{b:?}");
    }
}
