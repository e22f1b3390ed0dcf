//! The foundation kernels give byte-identical outputs on the GPU (lavapipe in CI) and the CPU.
//!
//! Exact comparison, no epsilon: every output buffer over >= 2^20 inputs, random bit patterns and
//! hand-picked edge cases (zeros, subnormals, huge values, infinities, NaN, X0 = X1).

use engine::Backend;
use integration_tests::{assert_bytes_equal, gpu};
use shared::kernels::probe::{self, DepthPair};
use shared::rng::{pcg_hash, Pcg32};

const RANDOM_COUNT: u32 = 1 << 20;

/// Edge-case floats: signed zeros, subnormals, normals at the extremes, infinities and NaN.
fn edge_floats() -> Vec<f32> {
    let mut v = vec![
        0.0,
        -0.0,
        f32::from_bits(1),
        f32::from_bits(0x007f_ffff),
        f32::MIN_POSITIVE,
        1e-30,
        1e-7,
        0.5,
        1.0,
        core::f32::consts::FRAC_PI_2,
        core::f32::consts::PI,
        10.0,
        88.7,
        88.8,
        103.9,
        104.0,
        1e4,
        6433.0,
        1e10,
        3e38,
        f32::MAX,
        f32::INFINITY,
        f32::NAN,
        f32::from_bits(0x7fa0_0001), // signalling NaN with a payload
    ];
    let neg: Vec<f32> = v.iter().map(|x| -x).collect();
    v.extend(neg);
    v
}

/// Random f32 bit patterns (every class: normals, subnormals, inf, NaN) and realistic depths.
fn random_floats(n: u32, seed: u64) -> Vec<f32> {
    let mut rng = Pcg32::new(seed, 1);
    (0..n)
        .map(|i| {
            let (bits, next) = rng.next_u32();
            rng = next;
            if i % 2 == 0 {
                f32::from_bits(bits)
            } else {
                // Optical depths as the estimators produce them: [0, 64) with 24 random bits.
                shared::rng::unit_f32(bits) * 64.0
            }
        })
        .collect()
}

fn depth_pairs() -> Vec<DepthPair> {
    let edges = edge_floats();
    let mut pairs: Vec<DepthPair> = Vec::new();
    for &a in &edges {
        for &b in &edges {
            pairs.push(DepthPair { x0: a, x1: b });
        }
        pairs.push(DepthPair { x0: a, x1: a });
    }
    let r = random_floats(2 * RANDOM_COUNT, 7);
    pairs.extend(
        r.as_chunks::<2>()
            .0
            .iter()
            .map(|&[x0, x1]| DepthPair { x0, x1 }),
    );
    // X0 = X1 on random depths.
    pairs.extend(r.iter().step_by(97).map(|&x| DepthPair { x0: x, x1: x }));
    pairs
}

#[test]
fn transmittance_pairs_are_bit_identical() {
    let gpu = Backend::Gpu(gpu());
    let pairs = depth_pairs();
    assert!(pairs.len() >= 1 << 20);
    let g = gpu.transmittance_pairs(&pairs).unwrap();
    let c = Backend::Cpu.transmittance_pairs(&pairs).unwrap();
    assert_bytes_equal("transmittance_pair_cs", &pairs, &g, &c);
    // The CPU backend is the same function as calling shared directly.
    assert_eq!(c[12345], probe::transmittance_pair(pairs[12345]));
}

#[test]
fn math_functions_are_bit_identical() {
    let gpu = Backend::Gpu(gpu());
    let mut xs = edge_floats();
    xs.extend(random_floats(RANDOM_COUNT, 11));
    // Dense sweeps over the ranges the estimators use.
    xs.extend((0..1 << 18).map(|i| -104.0 + 208.0 * i as f32 / (1 << 18) as f32));
    xs.extend((0..1 << 18).map(|i| -TRIG as f32 + 2.0 * TRIG as f32 * i as f32 / (1 << 18) as f32));
    let g = gpu.math_values(&xs).unwrap();
    let c = Backend::Cpu.math_values(&xs).unwrap();
    assert_bytes_equal("math_values_cs", &xs, &g, &c);
}
const TRIG: f64 = shared::math::TRIG_ACCURATE_RANGE as f64;

#[test]
fn rng_streams_are_bit_identical() {
    let gpu = Backend::Gpu(gpu());
    for seed in [0u32, 1, pcg_hash(42), u32::MAX] {
        let g = gpu.rng_draws(RANDOM_COUNT, seed).unwrap();
        let c = Backend::Cpu.rng_draws(RANDOM_COUNT, seed).unwrap();
        let ids: Vec<u32> = (0..RANDOM_COUNT).collect();
        assert_bytes_equal(&format!("rng_draws_cs seed {seed}"), &ids, &g, &c);
    }
}

#[test]
fn launches_larger_than_one_dispatch_are_split_correctly() {
    // 65535 workgroups x 64 = 4,194,240 ids per dispatch; go past it so the host must split.
    let gpu = Backend::Gpu(gpu());
    let n = 65_535 * 64 + 1000;
    let pairs: Vec<DepthPair> = (0..n)
        .map(|i| DepthPair {
            x0: i as f32 * 1e-5,
            x1: (n - i) as f32 * 1e-5,
        })
        .collect();
    let g = gpu.transmittance_pairs(&pairs).unwrap();
    let c = Backend::Cpu.transmittance_pairs(&pairs).unwrap();
    assert_bytes_equal("transmittance_pair_cs (split)", &pairs, &g, &c);
}

#[test]
fn buffers_over_the_device_limit_are_refused_clearly() {
    // 4.2M RngDraws = 134 MB > lavapipe's 128 MiB maxStorageBufferRange: an error, not a crash.
    let gpu = Backend::Gpu(gpu());
    match gpu.rng_draws(65_535 * 64 + 1000, 3) {
        Ok(_) => {} // a device with a larger limit runs it; nothing to check here
        Err(e) => assert!(format!("{e:#}").contains("maxStorageBufferRange"), "{e:#}"),
    }
}

#[test]
fn equiangular_sampling_is_bit_identical() {
    let gpu = Backend::Gpu(gpu());
    let r = random_floats(12 * 200_000, 21);
    let inputs: Vec<probe::EquiangularIn> = r
        .as_chunks::<12>()
        .0
        .iter()
        .map(|c| {
            // Only the realistic-depth half of random_floats: odd indices are in [0, 64).
            let v = |i: usize| c[i | 1] / 32.0 - 1.0;
            let dir = shared::geometry::V3::new(v(2), v(3), v(4));
            let len = (dir.dot(dir)).sqrt().max(1e-3);
            probe::EquiangularIn {
                o: shared::geometry::V3::new(v(0) * 2.0, v(1) * 2.0, -2.0),
                dir: dir * (1.0 / len),
                light: shared::geometry::V3::new(v(5), v(6), v(7)),
                ta: 0.5 + v(8).abs(),
                tb: 2.0 + v(9).abs() * 2.0,
                u: (v(10) + 1.0) * 0.5,
            }
        })
        .collect();
    let g = gpu.equiangular(&inputs).unwrap();
    let c = Backend::Cpu.equiangular(&inputs).unwrap();
    assert_bytes_equal("equiangular_cs", &inputs, &g, &c);
}

/// Henyey-Greenstein sampling and evaluation over g in (-1, 1) (including the g values of
/// every test and docs/guide/integrators.md: 0.2, 0.3, 0.6, 0.85, -0.5), uniform numbers and
/// directions.
#[test]
fn phase_sampling_is_bit_identical() {
    let gpu = Backend::Gpu(gpu());
    let mut rng = Pcg32::new(77, 5);
    let gs = [0.2f32, 0.3, 0.6, 0.85, -0.5, 0.0, 0.999, -0.999, 5e-4];
    let inputs: Vec<probe::PhaseIn> = (0..100_000)
        .map(|k| {
            let mut next = || {
                let (v, r) = rng.next_f32();
                rng = r;
                v
            };
            let g = if k < gs.len() * 1000 {
                gs[k % gs.len()]
            } else {
                1.998 * next() - 0.999
            };
            let d = shared::geometry::V3::new(next() - 0.5, next() - 0.5, next() - 0.5);
            let len = d.dot(d).sqrt().max(1e-3);
            probe::PhaseIn {
                wo: d * (1.0 / len),
                g,
                u0: next(),
                u1: next(),
                cos_theta: 2.0 * next() - 1.0,
                _pad: 0.0,
            }
        })
        .collect();
    let g = gpu.phase(&inputs).unwrap();
    let c = Backend::Cpu.phase(&inputs).unwrap();
    assert_bytes_equal("phase_cs", &inputs, &g, &c);
}

/// Moment-shadow-map lookups (bilinear filtering, dequantization, bias, 4- and 6-moment
/// reconstruction) of random 2 x 2 maps built from random absorption events, at random points.
#[test]
fn shadow_map_lookups_are_bit_identical() {
    use shared::shadows::map::{store_texel, MsmDesc, Shadows};
    use shared::shadows::msm::add_atom6;
    let gpu = Backend::Gpu(gpu());
    let mut rng = Pcg32::new(91, 3);
    let mut next = || {
        let (v, r) = rng.next_f32();
        rng = r;
        v
    };
    let desc = MsmDesc {
        origin: shared::geometry::V3::new(-1.0, 2.0, -1.0),
        width: 2,
        axis_u: shared::geometry::V3::new(2.0, 0.0, 0.0),
        height: 2,
        axis_v: shared::geometry::V3::new(0.0, 0.0, 2.0),
        depth_len: 4.0,
        dir: shared::geometry::V3::new(0.0, -1.0, 0.0),
        ones: u32::MAX,
        dequant: shared::shadows::msm::U16_DEQUANT,
    };
    let modes = [Shadows::Msm4, Shadows::Msm4U16, Shadows::Msm6];
    let inputs: Vec<probe::MsmLookupIn> = (0..60_000)
        .map(|k| {
            let mode = modes[k % 3];
            let mut words = [0u32; 24];
            let n = mode.words_per_texel() as usize;
            for t in 0..4 {
                // 1 to 4 absorption events and the rest at the far plane.
                let mut b = [0.0f32; 7];
                let mut left = 1.0f32;
                for _ in 0..1 + (next() * 4.0) as usize {
                    let w = left * next();
                    b = add_atom6(b, 2.0 * next() - 1.0, w);
                    left -= w;
                }
                b = add_atom6(b, 1.0, left);
                let w = store_texel(mode, [b[1], b[2], b[3], b[4], b[5], b[6]], u32::MAX);
                words[n * t..n * t + n].copy_from_slice(&w[..n]);
            }
            probe::MsmLookupIn {
                desc,
                x: shared::geometry::V3::new(
                    2.4 * next() - 1.2,
                    4.0 * next() - 2.0,
                    2.4 * next() - 1.2,
                ),
                mode: mode as u32,
                words,
            }
        })
        .collect();
    let g = gpu.msm_lookup(&inputs).unwrap();
    let c = Backend::Cpu.msm_lookup(&inputs).unwrap();
    assert!(c.iter().any(|o| o.t > 0.05 && o.t < 0.95));
    assert_bytes_equal("msm_lookup_cs", &inputs, &g, &c);
}
