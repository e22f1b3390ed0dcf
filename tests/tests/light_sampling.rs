//! Light sampling of the light-transport layer, on the CPU: the environment map's
//! piecewise-constant 2D importance sampling (sampled pdf == evaluated pdf, normalisation,
//! chi-square of the texel histogram), Henyey-Greenstein sampling (chi-square, pdf, sign
//! convention), the sun's cone sampling, `frame_from_z` and the deterministic `atan2`.
//!
//! Every random number comes from `shared::rng::Pcg32` with the seed stated in the test, so each
//! run draws the same numbers; the chi-square tests reject at p < 1e-4.

use engine::lighting::env::EnvMap;
use shared::geometry::{cross, frame_from_z, V3};
use shared::math::atan2;
use shared::rgb::Rgb;
use shared::rng::Pcg32;
use shared::sampling::env::EnvDesc;
use shared::sampling::phase::{phase_hg, sample_hg};
use shared::sampling::sun::Sun;
use std::f64::consts::PI;

/// The p-value below which a chi-square test rejects.
const P_REJECT: f64 = 1e-4;

// ---------------------------------------------------------------------------------------------
// Statistics helpers.

/// ln Gamma(x) for x > 0 (Lanczos, g = 7, n = 9; relative error < 1e-13).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let t = x + 7.5;
    let s: f64 = C[0] + (1..9).map(|k| C[k] / (x + k as f64)).sum::<f64>();
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + s.ln()
}

/// The regularized upper incomplete gamma Q(a, x) (Numerical Recipes: series below a + 1,
/// Lentz's continued fraction above).
fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let front = (-x + a * x.ln() - ln_gamma(a)).exp();
    if x < a + 1.0 {
        let (mut sum, mut term, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * front
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            d = if d.abs() < tiny { tiny } else { d };
            c = b + an / c;
            c = if c.abs() < tiny { tiny } else { c };
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-15 {
                break;
            }
        }
        front * h
    }
}

/// Chi-square statistic, degrees of freedom and p-value of `observed` counts against bin
/// probabilities `p` (summing to 1). Bins with fewer than 5 expected counts are pooled into one;
/// a count in a bin of probability 0 is returned as p-value 0.
fn chi_square(observed: &[u64], p: &[f64]) -> (f64, usize, f64) {
    assert_eq!(observed.len(), p.len());
    let n: u64 = observed.iter().sum();
    let total_p: f64 = p.iter().sum();
    assert!(
        (total_p - 1.0).abs() < 1e-6,
        "bin probabilities sum to {total_p}"
    );
    let (mut stat, mut bins) = (0.0, 0usize);
    let (mut pooled_o, mut pooled_e) = (0u64, 0.0f64);
    for (o, p) in observed.iter().zip(p) {
        let e = p * n as f64;
        if *p <= 0.0 {
            if *o > 0 {
                return (f64::INFINITY, 0, 0.0);
            }
        } else if e < 5.0 {
            pooled_o += o;
            pooled_e += e;
        } else {
            stat += (*o as f64 - e).powi(2) / e;
            bins += 1;
        }
    }
    if pooled_e > 0.0 {
        stat += (pooled_o as f64 - pooled_e).powi(2) / pooled_e;
        bins += 1;
    }
    let dof = bins.saturating_sub(1).max(1);
    (stat, dof, gamma_q(dof as f64 / 2.0, stat / 2.0))
}

/// Uniform numbers from a seeded PCG32.
struct Uniform(Pcg32);

impl Uniform {
    /// PCG32 with state `seed` and stream 54.
    fn new(seed: u64) -> Self {
        Uniform(Pcg32::new(seed, 54))
    }

    /// The next uniform number in [0, 1).
    fn next(&mut self) -> f32 {
        let (u, rng) = self.0.next_f32();
        self.0 = rng;
        u
    }

    /// A direction uniform on the unit sphere.
    fn direction(&mut self) -> V3 {
        let z = 1.0 - 2.0 * self.next() as f64;
        let phi = 2.0 * PI * self.next() as f64;
        let r = (1.0 - z * z).max(0.0).sqrt();
        v3([r * phi.cos(), r * phi.sin(), z])
    }
}

/// f64 components to a V3.
fn v3(d: [f64; 3]) -> V3 {
    V3::new(d[0] as f32, d[1] as f32, d[2] as f32)
}

/// Length of v in f64.
fn len(v: V3) -> f64 {
    let (x, y, z) = (v.x as f64, v.y as f64, v.z as f64);
    (x * x + y * y + z * z).sqrt()
}

/// Dot product in f64.
fn dot64(a: V3, b: V3) -> f64 {
    a.x as f64 * b.x as f64 + a.y as f64 * b.y as f64 + a.z as f64 * b.z as f64
}

// ---------------------------------------------------------------------------------------------
// Environment maps.

/// One test map: its texels and the rotation about +y.
struct TestMap {
    name: &'static str,
    width: u32,
    height: u32,
    texels: Vec<[f32; 3]>,
    rotate_deg: f64,
}

impl TestMap {
    /// The map from a texel function.
    fn new(name: &'static str, w: u32, h: u32, f: impl Fn(u32, u32) -> [f32; 3]) -> Self {
        let texels = (0..h)
            .flat_map(|j| (0..w).map(move |i| (i, j)))
            .map(|(i, j)| f(i, j));
        TestMap {
            name,
            width: w,
            height: h,
            texels: texels.collect(),
            rotate_deg: 0.0,
        }
    }

    /// The same map rotated by `deg` about +y.
    fn rotated(mut self, name: &'static str, deg: f64) -> Self {
        self.name = name;
        self.rotate_deg = deg;
        self
    }

    /// The shared descriptor and data buffer, built by the host as `--env` does.
    fn prepare(&self) -> (EnvDesc, Vec<f32>) {
        let map = EnvMap {
            width: self.width,
            height: self.height,
            texels: self.texels.clone(),
        };
        map.check(self.name).unwrap();
        let (data, _) = map.clone().data(1.0).unwrap();
        assert_eq!(data.len(), EnvDesc::data_len(self.width, self.height));
        let rot = self.rotate_deg.to_radians();
        let desc = EnvDesc {
            width: self.width,
            height: self.height,
            cos_rotation: rot.cos() as f32,
            sin_rotation: rot.sin() as f32,
        };
        (desc, data)
    }

    /// The probability of drawing texel (i, j), computed here from the definition (luminance x
    /// sin(theta at the row centre), normalised), independently of the CDFs.
    fn texel_probabilities(&self) -> Vec<f64> {
        let (w, h) = (self.width as usize, self.height as usize);
        let f: Vec<f64> = (0..w * h)
            .map(|k| {
                let t = self.texels[k];
                let y = 0.2126 * t[0] as f64 + 0.7152 * t[1] as f64 + 0.0722 * t[2] as f64;
                y * (PI * ((k / w) as f64 + 0.5) / h as f64).sin()
            })
            .collect();
        let total: f64 = f.iter().sum();
        f.iter().map(|v| v / total).collect()
    }
}

/// The maps under test: constant; a gradient; zero rows and columns with one bright texel; a
/// single non-zero texel; a non-square map with odd sides; rotated maps.
fn maps() -> Vec<TestMap> {
    let gradient = |i: u32, j: u32| {
        let (x, y) = (i as f32, j as f32);
        [0.1 + 0.3 * x, 0.05 + 0.2 * y, 0.02 + 0.1 * (x + y)]
    };
    let sparse = |i: u32, j: u32| {
        if [0, 1, 5].contains(&j) || [0, 3, 4].contains(&i) {
            [0.0; 3]
        } else if (i, j) == (7, 3) {
            [500.0, 400.0, 300.0]
        } else {
            [0.2, 0.3, 0.1]
        }
    };
    let single = |i: u32, j: u32| {
        if (i, j) == (2, 1) {
            [3.0, 2.0, 1.0]
        } else {
            [0.0; 3]
        }
    };
    let lumpy = |i: u32, j: u32| {
        let h = shared::rng::pcg_hash(i + 31 * j);
        if h.is_multiple_of(5) {
            [0.0; 3]
        } else {
            let v = shared::rng::unit_f32(h);
            [4.0 * v, 2.0 * v * v, 1.0 - v]
        }
    };
    vec![
        TestMap::new("constant 8x4", 8, 4, |_, _| [1.0, 1.0, 1.0]),
        TestMap::new("gradient 16x8", 16, 8, gradient),
        TestMap::new("sparse 12x6", 12, 6, sparse),
        TestMap::new("single texel 9x5", 9, 5, single),
        TestMap::new("non-square 7x3", 7, 3, lumpy),
        TestMap::new("tall 3x10", 3, 10, lumpy),
        TestMap::new("", 16, 8, gradient).rotated("gradient 16x8 rotated 37 deg", 37.0),
        TestMap::new("", 12, 6, sparse).rotated("sparse 12x6 rotated -123 deg", -123.0),
        TestMap::new("", 7, 3, lumpy).rotated("non-square 7x3 rotated 180 deg", 180.0),
    ]
}

/// [`maps`] and the 1 x 1 maps (`--env constant:R,G,B`), whose samples are uniform over the
/// sphere rather than by texel (no texel histogram to fit).
fn maps_and_uniform() -> Vec<TestMap> {
    let mut m = maps();
    m.push(TestMap::new("uniform 1x1", 1, 1, |_, _| [0.5, 0.25, 2.0]));
    m.push(
        TestMap::new("", 1, 1, |_, _| [1.0, 1.0, 1.0]).rotated("uniform 1x1 rotated 70 deg", 70.0),
    );
    m
}

/// Distance of (u, v) to the nearest texel border, in texels.
fn border_distance(desc: &EnvDesc, u: f32, v: f32) -> f64 {
    let fu = u as f64 * desc.width as f64;
    let fv = v as f64 * desc.height as f64;
    let du = (fu - fu.round()).abs();
    let dv = (fv - fv.round()).abs();
    du.min(dv)
}

/// The texel (i, j) of world direction d.
fn texel_of(desc: &EnvDesc, d: V3) -> (u32, u32) {
    let (u, v, _) = desc.uv(d);
    let i = ((u * desc.width as f32) as u32).min(desc.width - 1);
    let j = ((v * desc.height as f32) as u32).min(desc.height - 1);
    (i, j)
}

/// For every test map, 200,000 samples (PCG32 seed 1000 + map index): each direction is a unit
/// vector (|len - 1| <= 1e-6), its pdf is positive, and the pdf and radiance `sample` returns
/// equal `pdf` and `radiance` evaluated at the direction, bit for bit, for at least 99.9% of the
/// samples. The rest lie on a texel border (within 1e-4 texels): the direction, rounded to f32,
/// falls into the neighbouring texel, whose pdf and radiance `pdf` and `radiance` then return
/// (a set of measure zero in exact arithmetic).
#[test]
fn env_sample_pdf_and_radiance_equal_their_evaluation() {
    const N: usize = 200_000;
    for (m, map) in maps_and_uniform().iter().enumerate() {
        let (desc, data) = map.prepare();
        let mut rng = Uniform::new(1000 + m as u64);
        let (mut pdf_off, mut radiance_off, mut zero) = (0usize, 0usize, 0usize);
        let mut worst_border = 0.0f64;
        let (mut inside, mut example) = (0usize, None);
        for _ in 0..N {
            let (u0, u1) = (rng.next(), rng.next());
            let s = desc.sample(&data, u0, u1);
            let l = len(s.dir);
            assert!(
                (l - 1.0).abs() <= 1e-6,
                "{}: |dir| = {l} for u = ({u0}, {u1})",
                map.name
            );
            if !(s.pdf > 0.0) {
                zero += 1;
                continue;
            }
            let pdf = desc.pdf(&data, s.dir);
            let radiance = desc.radiance(&data, s.dir);
            if pdf != s.pdf || radiance != s.radiance {
                pdf_off += (pdf != s.pdf) as usize;
                radiance_off += (radiance != s.radiance) as usize;
                let (u, v, _) = desc.uv(s.dir);
                let b = border_distance(&desc, u, v);
                worst_border = worst_border.max(b);
                if b >= 1e-4 {
                    inside += 1;
                    example.get_or_insert(format!(
                        "sampled pdf {} radiance {:?}, evaluated {pdf} {radiance:?} at (u, v) = \
                         ({u}, {v}), {b} texels from a border (u = ({u0}, {u1}))",
                        s.pdf, s.radiance
                    ));
                }
            }
        }
        assert_eq!(
            inside,
            0,
            "{}: {inside} samples off a texel border differ from their evaluation, e.g. {}",
            map.name,
            example.unwrap_or_default()
        );
        let limit = N / 1000;
        assert!(
            pdf_off <= limit && radiance_off <= limit,
            "{}: {pdf_off} pdfs and {radiance_off} radiances of {N} samples differ from their \
             evaluation (at most {limit} allowed)",
            map.name
        );
        // Only directions exactly at a pole (v = 0 or 1, probability ~2^-24) have pdf 0.
        assert!(zero <= 2, "{}: {zero} samples with pdf 0", map.name);
        println!(
            "{}: pdf differs {pdf_off}, radiance differs {radiance_off} of {N} (all within \
             {worst_border:.1e} texels of a border), pdf 0: {zero}",
            map.name
        );
    }
}

/// The solid-angle pdf integrates to 1 over the sphere: a midpoint rule in f64 over
/// 1200 x 2016 (theta, phi) cells of the integrand pdf(theta, phi) sin(theta) = p(u, v) / (2 pi^2),
/// which is piecewise constant on the texels. 1200 and 2016 are multiples of every test map's
/// height and width, so for unrotated maps each cell lies in one texel and the rule is exact up
/// to f32 rounding: tolerance 1e-5. A rotation cuts cells in phi at the texel borders (an error
/// below (w / 2016) x the largest relative jump between neighbouring columns): tolerance 1e-3
/// (observed errors are printed: about 1e-7).
#[test]
fn env_pdf_integrates_to_one() {
    const NT: usize = 1200;
    const NP: usize = 2016;
    for map in maps_and_uniform() {
        let (desc, data) = map.prepare();
        let (dt, dp) = (PI / NT as f64, 2.0 * PI / NP as f64);
        let mut sum = 0.0f64;
        for a in 0..NT {
            let theta = (a as f64 + 0.5) * dt;
            let (st, ct) = theta.sin_cos();
            let mut row = 0.0f64;
            for b in 0..NP {
                let phi = (b as f64 + 0.5) * dp;
                let d = v3([st * phi.cos(), ct, st * phi.sin()]);
                row += desc.pdf(&data, d) as f64;
            }
            sum += row * st * dt * dp;
        }
        let aligned = map.rotate_deg == 0.0
            && NT.is_multiple_of(map.height as usize)
            && NP.is_multiple_of(map.width as usize);
        let tol = if aligned { 1e-5 } else { 1e-3 };
        println!("{}: integral of pdf = {sum:.8}", map.name);
        assert!(
            (sum - 1.0).abs() <= tol,
            "{}: the pdf integrates to {sum}, not 1 (tolerance {tol})",
            map.name
        );
    }
}

/// The texel histogram of 400,000 samples per map (PCG32 seed 2000 + map index) fits the
/// probabilities luminance x sin(theta_centre) / sum computed here from the texels (chi-square,
/// bins under 5 expected counts pooled, reject at p < 1e-4); no sample falls into a texel of
/// probability 0. `texel_pdf / (w h)` equals those probabilities to 1e-6 absolute + 1e-5
/// relative (the CDFs are rounded to f32).
#[test]
fn env_texel_histogram_fits_by_chi_square() {
    const N: usize = 400_000;
    for (m, map) in maps().iter().enumerate() {
        let (desc, data) = map.prepare();
        let p = map.texel_probabilities();
        let (w, h) = (map.width, map.height);
        for j in 0..h {
            for i in 0..w {
                let k = (j * w + i) as usize;
                let q = desc.texel_pdf(&data, i, j) as f64 / (w * h) as f64;
                assert!(
                    (q - p[k]).abs() <= 1e-6 + 1e-5 * p[k],
                    "{}: texel ({i}, {j}) has texel_pdf / (w h) = {q}, expected {}",
                    map.name,
                    p[k]
                );
            }
        }
        let mut rng = Uniform::new(2000 + m as u64);
        let mut counts = vec![0u64; (w * h) as usize];
        for _ in 0..N {
            let s = desc.sample(&data, rng.next(), rng.next());
            let (i, j) = texel_of(&desc, s.dir);
            counts[(j * w + i) as usize] += 1;
        }
        let (stat, dof, pv) = chi_square(&counts, &p);
        println!("{}: chi2 = {stat:.1}, dof = {dof}, p = {pv:.3}", map.name);
        assert!(
            pv >= P_REJECT,
            "{}: texel histogram rejected (chi2 {stat}, dof {dof}, p {pv}): {counts:?}",
            map.name
        );
    }
}

/// A 1 x 1 map (`--env constant:R,G,B`) is sampled uniformly over the sphere: 400,000 samples
/// (PCG32 seed 3000) in 16 equal-area bands of cos(theta) times 16 sectors of phi (256 bins of
/// probability 1/256 each) fit by chi-square (reject at p < 1e-4); every sample has pdf
/// 1 / (4 pi) and the map's radiance, whatever its direction (and with any rotation), and the
/// radiance and pdf of any direction are the texel's and 1 / (4 pi).
#[test]
fn uniform_map_samples_are_uniform_over_the_sphere() {
    const N: usize = 400_000;
    const B: usize = 16;
    for map in [
        TestMap::new("uniform 1x1", 1, 1, |_, _| [0.5, 0.25, 2.0]),
        TestMap::new("", 1, 1, |_, _| [0.5, 0.25, 2.0]).rotated("uniform 1x1 rotated", 70.0),
    ] {
        let (desc, data) = map.prepare();
        assert!(desc.uniform(), "{}", map.name);
        let texel = Rgb::new(0.5, 0.25, 2.0);
        let pdf = (1.0 / (4.0 * PI)) as f32;
        let mut rng = Uniform::new(3000);
        let mut counts = vec![0u64; B * B];
        for _ in 0..N {
            let s = desc.sample(&data, rng.next(), rng.next());
            assert_eq!((s.pdf, s.radiance), (pdf, texel), "{}", map.name);
            assert!(
                (len(s.dir) - 1.0).abs() <= 1e-6,
                "{}: {:?}",
                map.name,
                s.dir
            );
            assert_eq!(desc.pdf(&data, s.dir), pdf, "{}", map.name);
            assert_eq!(desc.radiance(&data, s.dir), texel, "{}", map.name);
            let band = (((s.dir.y as f64 + 1.0) * 0.5 * B as f64) as usize).min(B - 1);
            let phi = (s.dir.z as f64).atan2(s.dir.x as f64).rem_euclid(2.0 * PI);
            let sector = ((phi / (2.0 * PI) * B as f64) as usize).min(B - 1);
            counts[band * B + sector] += 1;
        }
        let p = vec![1.0 / (B * B) as f64; B * B];
        let (stat, dof, pv) = chi_square(&counts, &p);
        println!("{}: chi2 = {stat:.1}, dof = {dof}, p = {pv:.3}", map.name);
        assert!(
            pv >= P_REJECT,
            "{}: directions not uniform over the sphere (chi2 {stat}, dof {dof}, p {pv})",
            map.name
        );
    }
}

/// Without a map (`width` 0) the map is black, has pdf 0 and sampling returns pdf 0.
#[test]
fn env_absent_is_black_with_zero_pdf() {
    let desc = EnvDesc::default();
    let data = [0.0f32];
    let d = V3::new(0.0, 1.0, 0.0);
    assert!(!desc.present());
    assert_eq!(desc.pdf(&data, d), 0.0);
    assert_eq!(desc.radiance(&data, d), Rgb::ZERO);
    assert_eq!(desc.sample(&data, 0.3, 0.7).pdf, 0.0);
}

// ---------------------------------------------------------------------------------------------
// Henyey-Greenstein.

/// The asymmetry parameters under test.
const GS: [f32; 4] = [-0.7, 0.0, 0.3, 0.9];

/// P(cos(wo, wi) <= c) under the density phase_hg(cos, g) of `shared` (denominator
/// 1 + g^2 + 2 g cos): 2 pi times the integral of phase_hg from -1 to c, in closed form.
fn hg_cdf(c: f64, g: f64) -> f64 {
    if g == 0.0 {
        return 0.5 * (c + 1.0);
    }
    (1.0 - g * g) / (2.0 * g) * (1.0 / (1.0 - g).abs() - 1.0 / (1.0 + g * g + 2.0 * g * c).sqrt())
}

/// Outgoing directions of the HG tests: the poles, an axis, and a generic direction.
fn hg_wos() -> Vec<V3> {
    let s = (1.0f64 / 3.0).sqrt();
    vec![
        V3::new(0.0, 0.0, 1.0),
        V3::new(0.0, 0.0, -1.0),
        V3::new(1.0, 0.0, 0.0),
        v3([s, -s, s]),
    ]
}

/// For each g and wo, 100,000 samples (PCG32 seed 3000 + 10 g-index + wo-index): the
/// histogram of cos(wo, wi) in 40 equal bins fits the HG law of `phase_hg` (closed-form CDF), and
/// the azimuth of wi about wo in 16 bins is uniform (chi-square, reject at p < 1e-4 each).
#[test]
fn hg_sampling_fits_phase_hg_by_chi_square() {
    const N: usize = 100_000;
    const BINS: usize = 40;
    const AZ: usize = 16;
    for (a, &g) in GS.iter().enumerate() {
        let p: Vec<f64> = (0..BINS)
            .map(|k| {
                let c0 = -1.0 + 2.0 * k as f64 / BINS as f64;
                let c1 = -1.0 + 2.0 * (k + 1) as f64 / BINS as f64;
                hg_cdf(c1, g as f64) - hg_cdf(c0, g as f64)
            })
            .collect();
        for (b, wo) in hg_wos().into_iter().enumerate() {
            let mut rng = Uniform::new(3000 + 10 * a as u64 + b as u64);
            let (t, bt) = frame_from_z(wo);
            let mut counts = vec![0u64; BINS];
            let mut az = vec![0u64; AZ];
            for _ in 0..N {
                let (wi, _) = sample_hg(wo, g, rng.next(), rng.next());
                let c = dot64(wo, wi).clamp(-1.0, 1.0);
                let k = (((c + 1.0) * 0.5 * BINS as f64) as usize).min(BINS - 1);
                counts[k] += 1;
                let phi = dot64(bt, wi).atan2(dot64(t, wi)).rem_euclid(2.0 * PI);
                az[((phi / (2.0 * PI) * AZ as f64) as usize).min(AZ - 1)] += 1;
            }
            let (stat, dof, pv) = chi_square(&counts, &p);
            assert!(
                pv >= P_REJECT,
                "g = {g}, wo = {wo:?}: cos histogram rejected (chi2 {stat}, dof {dof}, p {pv}): \
                 {counts:?}"
            );
            let (stat, dof, pa) = chi_square(&az, &[1.0 / AZ as f64; AZ]);
            assert!(
                pa >= P_REJECT,
                "g = {g}, wo = {wo:?}: azimuth histogram rejected (chi2 {stat}, dof {dof}, p \
                 {pa}): {az:?}"
            );
            println!("g = {g}, wo = {wo:?}: p(cos) = {pv:.3}, p(azimuth) = {pa:.3}");
        }
    }
}

/// For each g, 200,000 samples with random wo (PCG32 seed 4000 + g-index): wi is a unit vector
/// (|len - 1| <= 1e-6) and the returned pdf equals phase_hg(wo . wi, g) evaluated at the
/// returned direction to 1e-4 relative (f32 rounding of wo . wi, amplified where the
/// denominator (1 - |g|)^2 is small: observed 5.3e-5 at g = 0.9; 2e-6 for |g| <= 0.3). Not
/// covered: |g| >= 0.99, where f32 is too coarse near cos = -+1 (0.5% pdf mismatch at 0.99; at
/// g = -0.999, 6% of the samples round to wi == wo exactly).
#[test]
fn hg_pdf_equals_phase_at_the_sampled_direction() {
    const N: usize = 200_000;
    for (a, &g) in GS.iter().enumerate() {
        let mut rng = Uniform::new(4000 + a as u64);
        let mut worst = 0.0f64;
        for _ in 0..N {
            let wo = rng.direction();
            let (wi, pdf) = sample_hg(wo, g, rng.next(), rng.next());
            let l = len(wi);
            assert!((l - 1.0).abs() <= 1e-6, "g = {g}: |wi| = {l}");
            let p = phase_hg(wo.dot(wi), g);
            assert!(pdf > 0.0 && pdf.is_finite(), "g = {g}: pdf {pdf}");
            let rel = ((pdf - p) as f64 / p as f64).abs();
            worst = worst.max(rel);
        }
        println!("g = {g}: max relative |pdf - phase_hg(wo . wi)| = {worst:.2e}");
        let tol = if g.abs() <= 0.3 { 2e-6 } else { 1e-4 };
        assert!(
            worst <= tol,
            "g = {g}: returned pdf differs from phase_hg(wo . wi, g) by {worst} relative"
        );
    }
}

/// P(cos(wo, wi) <= c) of the HG law from y = 1 + c (g >= 0) or y = 1 - c (g < 0), without
/// cancellation: the denominator 1 + g^2 + 2 g c is (1 - g)^2 + 2 g y or (1 + g)^2 - 2 g y.
fn hg_cdf_near_lobe(y: f64, g: f64) -> f64 {
    let d = if g >= 0.0 {
        (1.0 - g) * (1.0 - g) + 2.0 * g * y
    } else {
        (1.0 + g) * (1.0 + g) - 2.0 * g * y
    };
    (1.0 - g * g) / (2.0 * g) * (1.0 / (1.0 - g).abs() - 1.0 / d.sqrt())
}

/// Strongly peaked lobes, g in {-0.999, -0.99, 0.99, 0.999} (the CLI accepts |g| < 1), with
/// 200,000 samples each and random wo (PCG32 seed 5500 + g-index): the probability integral
/// transform F(wo . wi), with 1 -+ cos computed accurately as |wi +- wo|^2 / 2 in f64, is
/// uniform in 40 bins (chi-square, reject at p < 1e-4). In f32, cos within 3e-8 of -+1 rounds to
/// -+1: a sampler that computes cos first put 6% of the samples at wi == wo exactly (g = -0.999).
#[test]
fn hg_sampling_resolves_strongly_peaked_lobes() {
    const N: usize = 200_000;
    const BINS: usize = 40;
    for (a, g) in [-0.999f32, -0.99, 0.99, 0.999].into_iter().enumerate() {
        let mut rng = Uniform::new(5500 + a as u64);
        let mut counts = vec![0u64; BINS];
        let mut exact = 0usize;
        for _ in 0..N {
            let wo = rng.direction();
            let (wi, _) = sample_hg(wo, g, rng.next(), rng.next());
            let s = if g >= 0.0 { 1.0 } else { -1.0 };
            let e = [
                wi.x as f64 + s * wo.x as f64,
                wi.y as f64 + s * wo.y as f64,
                wi.z as f64 + s * wo.z as f64,
            ];
            let y = 0.5 * (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
            exact += (y == 0.0) as usize;
            let p = hg_cdf_near_lobe(y, g as f64);
            counts[((p * BINS as f64) as usize).min(BINS - 1)] += 1;
        }
        let (stat, dof, pv) = chi_square(&counts, &[1.0 / BINS as f64; BINS]);
        println!("g = {g}: wi == -+wo exactly: {exact}; chi2 {stat:.1} dof {dof} p {pv:.3}");
        assert!(
            pv >= P_REJECT,
            "g = {g}: F(wo . wi) not uniform (chi2 {stat}, dof {dof}, p {pv}; {exact} samples \
             at wi == -+wo exactly): {counts:?}"
        );
    }
}

/// The sign convention (pbrt-v4): wo points away from the scattering point toward the viewer,
/// phase_hg(wo . wi, g) has the denominator 1 + g^2 + 2 g cos, so g > 0 (forward scattering)
/// sends light on along -wo: wi is drawn near -wo and E[wo . wi] = -g. Checked on the density
/// itself (phase_hg(-1, g) > phase_hg(1, g) for g > 0) and on 400,000 samples per g (PCG32 seed
/// 5000 + g-index): the sample mean of wo . wi is within 5 standard errors of -g.
#[test]
fn hg_mean_cosine_is_minus_g_in_pbrt_convention() {
    const N: usize = 400_000;
    for (a, &g) in GS.iter().enumerate() {
        if g > 0.0 {
            assert!(phase_hg(-1.0, g) > phase_hg(1.0, g), "g = {g}");
        }
        // The density's own mean cosine, by quadrature: the two functions must agree.
        let m: f64 = (0..100_000)
            .map(|k| {
                let c = -1.0 + (k as f64 + 0.5) * 2e-5;
                2.0 * PI * c * phase_hg(c as f32, g) as f64 * 2e-5
            })
            .sum();
        assert!(
            (m + g as f64).abs() < 1e-3,
            "g = {g}: phase_hg's mean cosine is {m}"
        );
        let mut rng = Uniform::new(5000 + a as u64);
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..N {
            let wo = rng.direction();
            let (wi, _) = sample_hg(wo, g, rng.next(), rng.next());
            let c = dot64(wo, wi);
            s += c;
            s2 += c * c;
        }
        let mean = s / N as f64;
        let se = ((s2 / N as f64 - mean * mean) / N as f64).sqrt();
        println!("g = {g}: E[wo . wi] = {mean:.5} +- {se:.5}");
        assert!(
            (mean + g as f64).abs() <= 5.0 * se + 1e-6,
            "g = {g}: E[wo . wi] = {mean} +- {se}, expected -g (pbrt-v4 convention)"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// The sun.

/// A sun of angular radius `deg` toward unit `dir`, 1 - cos computed in f64 as the host does.
fn sun(dir: V3, deg: f64) -> Sun {
    Sun {
        dir,
        one_minus_cos: (1.0 - deg.to_radians().cos()) as f32,
        radiance: Rgb::splat(1.0),
        present: 1,
    }
}

/// 1 - cos(a, b) of two f32 unit vectors, accurately: |a - b|^2 / 2 in f64.
fn one_minus_cos64(a: V3, b: V3) -> f64 {
    let d = [
        a.x as f64 - b.x as f64,
        a.y as f64 - b.y as f64,
        a.z as f64 - b.z as f64,
    ];
    0.5 * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
}

/// Sun directions: the poles, an axis and the default sun.
fn sun_dirs() -> Vec<V3> {
    let d = [0.8f64, 0.6, 0.25];
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    vec![
        V3::new(0.0, 0.0, 1.0),
        V3::new(0.0, 0.0, -1.0),
        V3::new(0.0, 1.0, 0.0),
        v3(d.map(|v| v / l)),
    ]
}

/// For radii 0.2666 (the real sun), 5, 30 and 45 degrees and each sun direction, 50,000 samples
/// (PCG32 seed 6000 + 10 radius-index + dir-index): every direction is a unit vector, lies in the
/// cone (1 - cos computed accurately in f64 <= (1 - cos alpha)(1 + 1e-5)), `covers` it (at least
/// 99.99% of the samples; observed: all. `covers` tested 1 - d . dir in f32 before, which
/// refused 0.3% of the real sun's samples at the rim), the pdf is
/// 1 / solid angle = `Sun::pdf` there; (1 - cos) / (1 - cos alpha) is uniform (20 bins,
/// chi-square, reject at p < 1e-4).
#[test]
fn sun_samples_are_uniform_in_the_cone() {
    const N: usize = 50_000;
    const BINS: usize = 20;
    for (a, deg) in [0.2666f64, 5.0, 30.0, 45.0].into_iter().enumerate() {
        for (b, dir) in sun_dirs().into_iter().enumerate() {
            let s = sun(dir, deg);
            let omc = s.one_minus_cos as f64;
            let expected_pdf = 1.0 / (2.0 * std::f32::consts::PI * s.one_minus_cos);
            let mut rng = Uniform::new(6000 + 10 * a as u64 + b as u64);
            let mut counts = vec![0u64; BINS];
            let mut uncovered = 0usize;
            for _ in 0..N {
                let x = s.sample(rng.next(), rng.next());
                assert!(!x.delta);
                assert!((len(x.dir) - 1.0).abs() <= 1e-6, "|dir| = {}", len(x.dir));
                assert_eq!(x.pdf, expected_pdf, "radius {deg}");
                let t = one_minus_cos64(x.dir, dir) / omc;
                assert!(
                    t <= 1.0 + 1e-5,
                    "radius {deg}, dir {dir:?}: sample {:?} at (1 - cos) / (1 - cos alpha) = {t}",
                    x.dir
                );
                if s.covers(x.dir) {
                    assert_eq!(s.pdf(x.dir), x.pdf);
                } else {
                    uncovered += 1;
                }
                counts[((t * BINS as f64) as usize).min(BINS - 1)] += 1;
            }
            let (stat, dof, pv) = chi_square(&counts, &[1.0 / BINS as f64; BINS]);
            println!(
                "radius {deg}, dir {dir:?}: uncovered {uncovered} of {N}, chi2 {stat:.1} dof \
                 {dof} p {pv:.3}"
            );
            assert!(
                uncovered <= N / 10_000,
                "radius {deg}, dir {dir:?}: `covers` refuses {uncovered} of {N} samples"
            );
            assert!(
                pv >= P_REJECT,
                "radius {deg}, dir {dir:?}: 1 - cos not uniform (chi2 {stat}, dof {dof}, p {pv}): \
                 {counts:?}"
            );
        }
    }
}

/// A delta sun (radius 0) returns its direction with `delta` set, and has no density and covers
/// no direction (not even its own); a sun that is not present covers nothing.
#[test]
fn delta_sun_returns_its_direction() {
    for dir in sun_dirs() {
        let s = sun(dir, 0.0);
        assert!(s.is_delta());
        let x = s.sample(0.37, 0.81);
        assert!(x.delta);
        assert_eq!(x.dir, dir);
        assert_eq!(x.pdf, 1.0);
        assert!(!s.covers(dir));
        assert_eq!(s.pdf(dir), 0.0);
        assert_eq!(s.radiance_toward(dir), Rgb::ZERO);
        let absent = Sun {
            present: 0,
            ..sun(dir, 5.0)
        };
        assert!(!absent.covers(dir));
        assert_eq!(absent.pdf(dir), 0.0);
    }
}

// ---------------------------------------------------------------------------------------------
// Geometry and math.

/// frame_from_z(n) gives (t, b) with t, b unit, t . b = t . n = b . n = 0 and t x b = n (all to
/// 2e-6 in f64) for 100,000 random unit vectors (PCG32 seed 7000) and hand-picked ones: the
/// poles (0, 0, +-1), the axes, and directions 1e-3 .. 1e-7 from either pole.
#[test]
fn frame_from_z_is_orthonormal_and_right_handed() {
    let mut ns: Vec<V3> = vec![
        V3::new(0.0, 0.0, 1.0),
        V3::new(0.0, 0.0, -1.0),
        V3::new(1.0, 0.0, 0.0),
        V3::new(-1.0, 0.0, 0.0),
        V3::new(0.0, 1.0, 0.0),
        V3::new(0.0, -1.0, 0.0),
    ];
    for e in [1e-3f64, 1e-5, 1e-7] {
        for z in [1.0f64, -1.0] {
            for (x, y) in [(e, 0.0), (0.0, e), (-e, e), (e * 0.6, -e * 0.8)] {
                let l = (x * x + y * y + z * z).sqrt();
                ns.push(v3([x / l, y / l, z / l]));
            }
        }
    }
    let mut rng = Uniform::new(7000);
    ns.extend((0..100_000).map(|_| rng.direction()));
    for n in ns {
        let (t, b) = frame_from_z(n);
        let c = cross(t, b);
        let checks = [
            len(t) - 1.0,
            len(b) - 1.0,
            dot64(t, b),
            dot64(t, n),
            dot64(b, n),
            c.x as f64 - n.x as f64,
            c.y as f64 - n.y as f64,
            c.z as f64 - n.z as f64,
        ];
        assert!(
            checks.iter().all(|e| e.abs() <= 2e-6),
            "frame_from_z({n:?}) = ({t:?}, {b:?}), t x b = {c:?}: errors {checks:?}"
        );
    }
}

/// Distance in units in the last place between two f32 of the same sign (or both near 0).
fn ulps(a: f32, b: f32) -> u64 {
    let key = |x: f32| {
        let i = x.to_bits() as i32;
        if i < 0 {
            i64::from(i32::MIN) - i64::from(i)
        } else {
            i64::from(i)
        }
    };
    (key(a) - key(b)).unsigned_abs()
}

/// atan2 against f64 atan2 rounded to f32 on a grid of (y, x): 0, +-1e-40 (subnormal), +-1e-30,
/// +-1e-3, +-0.5, +-1, +-1.5, +-7, +-1e3, +-1e30, +-f32::MAX and +-infinity on both axes, and
/// 200,000 random pairs (PCG32 seed 8000). Maximum error: 4 ulp (observed: 3 ulp, printed).
/// Documented differences from IEEE atan2, checked separately: the result lies in (-pi, pi], so
/// y = -0 with x < 0 gives +pi (not -pi), and (+-0, +-0) gives 0.
#[test]
fn atan2_is_within_a_few_ulp_of_f64() {
    let base = [
        0.0f32,
        1e-40,
        1e-30,
        1e-3,
        0.5,
        1.0,
        1.5,
        7.0,
        1e3,
        1e30,
        f32::MAX,
        f32::INFINITY,
    ];
    let mut values: Vec<f32> = base.iter().flat_map(|v| [*v, -*v]).collect();
    values.retain(|v| !(*v == 0.0 && v.is_sign_negative()));
    let mut pairs: Vec<(f32, f32)> = values
        .iter()
        .flat_map(|y| values.iter().map(move |x| (*y, *x)))
        .collect();
    let mut rng = Uniform::new(8000);
    for _ in 0..200_000 {
        let y = (rng.next() - 0.5) * 10f32.powi((rng.next() * 8.0) as i32 - 4);
        let x = (rng.next() - 0.5) * 10f32.powi((rng.next() * 8.0) as i32 - 4);
        pairs.push((y, x));
    }
    let mut worst = (0u64, 0.0f32, 0.0f32);
    let mut failures = Vec::new();
    for (y, x) in pairs {
        let got = atan2(y, x);
        let want = if y == 0.0 && x <= 0.0 && x == 0.0 {
            0.0
        } else {
            (y as f64).atan2(x as f64) as f32
        };
        let want = if y == 0.0 && x < 0.0 {
            std::f32::consts::PI
        } else {
            want
        };
        let e = if got.is_nan() {
            u64::MAX
        } else {
            ulps(got, want)
        };
        if e > worst.0 {
            worst = (e, y, x);
        }
        if e > 4 {
            failures.push(format!("atan2({y:e}, {x:e}) = {got:e}, f64 gives {want:e}"));
        }
    }
    assert!(
        failures.is_empty(),
        "{} failures: {failures:#?}",
        failures.len()
    );
    println!(
        "atan2: max error {} ulp at ({:e}, {:e})",
        worst.0, worst.1, worst.2
    );
    assert_eq!(atan2(-0.0, -1.0), std::f32::consts::PI);
    assert_eq!(atan2(0.0, -0.0), 0.0);
    assert!(atan2(f32::NAN, 1.0).is_nan() && atan2(1.0, f32::NAN).is_nan());
}
