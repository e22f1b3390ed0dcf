//! The lights of `--integrator direct` on the host: `EnvMap::load` of valid and hostile light
//! probes (written by the tests into a temporary directory), `lighting::build` edge cases and
//! its pmf over light kinds, and end-to-end runs of `host render --integrator direct` with good
//! and bad light flags; `--integrator restir`, `--lights random:N` and `host eval --equal-time`
//! end to end.

mod common;

use engine::lighting::env::{EnvMap, MAX_SIDE};
use engine::lighting::{build, EnvSource, LightingOptions, SceneLights, SunSpec};
use shared::sampling::lights::PointLight;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

// ---------------------------------------------------------------------------------------------
// Writing probes.

/// An uncompressed (flat) Radiance RGBE file of `w` x `h` pixels, row 0 first; the dimension
/// line is `-Y h +X w` (top to bottom, left to right).
fn write_hdr(path: &Path, w: u32, h: u32, pixels: &[[u8; 4]]) {
    let mut bytes = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    for p in pixels {
        bytes.extend_from_slice(p);
    }
    std::fs::write(path, bytes).unwrap();
}

/// The RGBE pixel of (c0, c1, c2) x 2^(e - 136), the decoding of Radiance and the image crate.
fn rgbe(c: [u8; 3], e: u8) -> [u8; 4] {
    [c[0], c[1], c[2], e]
}

/// An RGB OpenEXR file of `w` x `h` f32 texels from a texel function.
fn write_exr(path: &Path, w: usize, h: usize, f: impl Sync + Fn(usize, usize) -> [f32; 3]) {
    exr::prelude::write_rgb_file(path, w, h, |x, y| {
        let t = f(x, y);
        (t[0], t[1], t[2])
    })
    .unwrap();
}

/// An uncompressed scanline RGB OpenEXR file of `w` x `h` texels of radiance 1.
fn write_exr_scanlines(path: &Path, w: usize, h: usize) {
    use exr::prelude::*;
    let channels = SpecificChannels::rgb(|_: Vec2<usize>| (1.0f32, 1.0f32, 1.0f32));
    Image::from_encoded_channels((w, h), Encoding::UNCOMPRESSED, channels)
        .write()
        .to_file(path)
        .unwrap();
}

/// Offset of the value of the EXR header attribute `name` of type `kind`.
fn attribute(bytes: &[u8], name: &str, kind: &str) -> usize {
    let key = format!("{name}\0{kind}\0").into_bytes();
    bytes
        .windows(key.len())
        .position(|w| w == key)
        .unwrap_or_else(|| panic!("no {name} attribute"))
        + key.len()
        + 4
}

/// Writes little-endian i32 values at `at`.
fn put_i32(bytes: &mut [u8], at: usize, values: &[i32]) {
    for (k, v) in values.iter().enumerate() {
        bytes[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
    }
}

/// A header-consistent EXR that claims `w` x `h` texels but holds the blocks of a 4 x 64
/// uncompressed scanline image (one line per chunk): the `dataWindow` and `displayWindow` say
/// (0, 0, w - 1, h - 1) and `chunkCount` is h.
fn claiming(mut bytes: Vec<u8>, w: i32, h: i32) -> Vec<u8> {
    for name in ["dataWindow", "displayWindow"] {
        let at = attribute(&bytes, name, "box2i");
        put_i32(&mut bytes, at, &[0, 0, w - 1, h - 1]);
    }
    let at = attribute(&bytes, "chunkCount", "int");
    put_i32(&mut bytes, at, &[h]);
    bytes
}

/// Path as &str.
fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The error message of `load`, with its chain of causes.
fn load_error(path: &Path) -> String {
    match EnvMap::load(path) {
        Ok(m) => panic!(
            "{} loaded as a {}x{} map",
            path.display(),
            m.width,
            m.height
        ),
        Err(e) => format!("{e:#}"),
    }
}

/// Asserts that loading `path` fails with a message naming the file and containing `words`.
fn assert_load_refused(path: &Path, words: &[&str]) -> String {
    let msg = load_error(path);
    assert!(
        msg.contains(&format!("--env {}", path.display())),
        "the message does not name the file: {msg}"
    );
    for w in words {
        assert!(msg.contains(w), "message lacks {w:?}: {msg}");
    }
    msg
}

// ---------------------------------------------------------------------------------------------
// EnvMap::load.

/// A flat 3x2 .hdr loads as 3x2 with the exact texels of RGBE decoding c 2^(e - 136), row 0
/// first (the +y pole), column 0 first; the upper-case extension is accepted.
#[test]
fn valid_hdr_loads_with_its_size_and_texels() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("probe.HDR");
    let pixels = [
        rgbe([128, 64, 32], 129), // (1, 0.5, 0.25)
        rgbe([128, 128, 128], 130),
        rgbe([0, 0, 0], 0),
        rgbe([192, 0, 255], 128), // (0.75, 0, 0.99609375) / 2
        rgbe([1, 2, 3], 136),
        rgbe([255, 255, 255], 140),
    ];
    write_hdr(&path, 3, 2, &pixels);
    let map = EnvMap::load(&path).unwrap();
    assert_eq!((map.width, map.height), (3, 2));
    let expected: Vec<[f32; 3]> = pixels
        .iter()
        .map(|p| {
            let k = if p[3] == 0 {
                0.0
            } else {
                2f32.powi(p[3] as i32 - 136)
            };
            [p[0] as f32 * k, p[1] as f32 * k, p[2] as f32 * k]
        })
        .collect();
    assert_eq!(map.texels, expected);
    assert_eq!(map.texels[0], [1.0, 0.5, 0.25]);
}

/// A 5x3 RGB .exr loads as 5x3 with its f32 texels bit for bit (row-major from the top).
#[test]
fn valid_exr_loads_with_its_size_and_texels() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("probe.exr");
    let f = |x: usize, y: usize| {
        [
            x as f32 * 0.25 + 0.125,
            y as f32 * 3.5,
            1e-3 * (x + 7 * y) as f32,
        ]
    };
    write_exr(&path, 5, 3, f);
    let map = EnvMap::load(&path).unwrap();
    assert_eq!((map.width, map.height), (5, 3));
    let expected: Vec<[f32; 3]> = (0..3).flat_map(|y| (0..5).map(move |x| f(x, y))).collect();
    assert_eq!(map.texels, expected);
}

/// A missing file, a directory and an unknown extension are refused with the file's name and
/// the fix (`.exr`, `.hdr` or `sky`).
#[test]
fn missing_directory_and_png_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    assert_load_refused(&dir.path().join("missing.exr"), &["no such file", "sky"]);
    assert_load_refused(dir.path(), &["not a regular file"]);
    let png = dir.path().join("probe.png");
    image::RgbImage::new(4, 2).save(&png).unwrap();
    assert_load_refused(
        &png,
        &["unknown light probe format", "\"png\"", ".exr", ".hdr"],
    );
    let bare = dir.path().join("probe");
    std::fs::write(&bare, b"no extension").unwrap();
    assert_load_refused(&bare, &["unknown light probe format"]);
}

/// Truncated or garbled files are refused with the file's name: an .hdr cut inside its pixels,
/// an .hdr with only a header, an .hdr holding PNG bytes, an .exr cut in half, an empty .exr.
#[test]
fn truncated_and_garbled_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let hdr = dir.path().join("cut.hdr");
    write_hdr(&hdr, 8, 4, &[rgbe([128, 128, 128], 129); 32]);
    let bytes = std::fs::read(&hdr).unwrap();
    std::fs::write(&hdr, &bytes[..bytes.len() - 40]).unwrap();
    assert_load_refused(&hdr, &["Radiance .hdr"]);
    let header_only = dir.path().join("header.hdr");
    write_hdr(&header_only, 8, 4, &[]);
    assert_load_refused(&header_only, &["Radiance .hdr"]);
    let fake = dir.path().join("fake.hdr");
    let png = dir.path().join("p.png");
    image::RgbImage::new(4, 2).save(&png).unwrap();
    std::fs::copy(&png, &fake).unwrap();
    assert_load_refused(&fake, &[".hdr"]);
    let exr = dir.path().join("cut.exr");
    write_exr(&exr, 16, 8, |x, y| [x as f32, y as f32, 1.0]);
    let bytes = std::fs::read(&exr).unwrap();
    std::fs::write(&exr, &bytes[..bytes.len() / 2]).unwrap();
    assert_load_refused(&exr, &["OpenEXR"]);
    let empty = dir.path().join("empty.exr");
    std::fs::write(&empty, b"").unwrap();
    assert_load_refused(&empty, &["OpenEXR"]);
}

/// Malformed headers are refused with the file's name: an .hdr of 0 x 0 pixels, with a
/// negative or non-numeric size, with a flipped (+Y) orientation, without the `#?RADIANCE`
/// magic; an .exr with only a luminance (Y) channel.
#[test]
fn malformed_headers_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (name, header) in [
        (
            "zero.hdr",
            "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 0 +X 0\n",
        ),
        (
            "negative.hdr",
            "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y -4 +X 8\n",
        ),
        (
            "words.hdr",
            "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y four +X eight\n",
        ),
        (
            "flipped.hdr",
            "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n+Y 4 +X 8\n",
        ),
        ("nomagic.hdr", "FORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 8\n"),
    ] {
        let path = dir.path().join(name);
        let mut bytes = header.as_bytes().to_vec();
        bytes.extend(std::iter::repeat_n([128u8, 128, 128, 129], 32).flatten());
        std::fs::write(&path, bytes).unwrap();
        let msg = assert_load_refused(&path, &[".hdr"]);
        println!("{name}: {msg}");
    }
    let luma = dir.path().join("luma.exr");
    {
        use exr::prelude::*;
        let channel = AnyChannel::new("Y", FlatSamples::F32(vec![1.0; 8]));
        let layer = Layer::new(
            (4, 2),
            LayerAttributes::default(),
            Encoding::UNCOMPRESSED,
            AnyChannels::sort(SmallVec::from_vec(vec![channel])),
        );
        Image::from_layer(layer).write().to_file(&luma).unwrap();
    }
    let msg = assert_load_refused(&luma, &["OpenEXR"]);
    println!("luma.exr: {msg}");
}

/// Texels that are NaN, infinite or negative are refused, naming the texel (x, y) and the rule
/// (finite, non-negative), in .exr and (infinity is not representable in RGBE) the check itself.
#[test]
fn nan_infinite_and_negative_texels_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (name, bad) in [
        ("nan.exr", f32::NAN),
        ("inf.exr", f32::INFINITY),
        ("neg.exr", -1.0),
        ("negzero_small.exr", -1e-30),
    ] {
        let path = dir.path().join(name);
        write_exr(&path, 4, 3, |x, y| {
            if (x, y) == (2, 1) {
                [0.5, bad, 0.5]
            } else {
                [1.0; 3]
            }
        });
        assert_load_refused(&path, &["texel (2, 1)", "finite, non-negative"]);
    }
    let map = EnvMap {
        width: 2,
        height: 1,
        texels: vec![[1.0; 3], [0.0, f32::NAN, 0.0]],
    };
    let msg = format!("{:#}", map.check("--env test").unwrap_err());
    assert!(msg.contains("texel (1, 0)"), "{msg}");
}

/// Headers that claim a huge image are refused before any texel buffer is allocated, with the
/// size, the limit and the fix in the message (the files are a few hundred bytes: a reader that
/// allocated the claimed size would need 100+ GiB): .hdr of 100000 x 50000 and 16385 x 1;
/// .exr whose dataWindow claims 100000 x 50000, 16385 x 2 and 2^31 - 1 on a side.
#[test]
fn huge_claimed_sizes_are_refused_without_allocating() {
    let dir = tempfile::tempdir().unwrap();
    for (w, h) in [(100_000u32, 50_000u32), (MAX_SIDE + 1, 1)] {
        let path = dir.path().join(format!("huge_{w}x{h}.hdr"));
        write_hdr(&path, w, h, &[rgbe([128, 128, 128], 129); 16]);
        assert_load_refused(
            &path,
            &[&format!("{w}x{h}"), "larger than 16384", "downsample"],
        );
    }
    let small = dir.path().join("small.exr");
    write_exr_scanlines(&small, 4, 64);
    let bytes = std::fs::read(&small).unwrap();
    for (w, h) in [
        (100_000, 50_000),
        (MAX_SIDE as i32 + 1, 64),
        (64, MAX_SIDE as i32 + 1),
        (i32::MAX / 2, i32::MAX / 2),
        (MAX_SIDE as i32, MAX_SIDE as i32),
    ] {
        let path = dir.path().join(format!("huge_{w}x{h}.exr"));
        std::fs::write(&path, claiming(bytes.clone(), w, h)).unwrap();
        let msg = assert_load_refused(&path, &[]);
        println!("{w}x{h}: {msg}");
    }
}

/// A new-RLE Radiance file of `w` x `h` pixels (8 <= w < 32768), every pixel `p` (runs of 127).
fn write_rle_hdr(path: &Path, w: u32, h: u32, p: [u8; 4]) {
    let mut line = vec![2u8, 2, (w >> 8) as u8, (w & 255) as u8];
    for c in p {
        let mut left = w;
        while left > 0 {
            let n = left.min(127);
            line.extend_from_slice(&[128 + n as u8, c]);
            left -= n;
        }
    }
    let mut bytes = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    for _ in 0..h {
        bytes.extend_from_slice(&line);
    }
    std::fs::write(path, bytes).unwrap();
}

/// A valid 8192 x 5500 .hdr (45 M texels, 540 MB of f32: above the image crate's default
/// 512 MiB allocation limit, below MAX_SIDE; a 16k x 8k probe is 1.6 GB) loads: the limit on
/// probe size is MAX_SIDE, not the decoder's default.
#[test]
fn large_valid_hdr_within_max_side_loads() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.hdr");
    write_rle_hdr(&path, 8192, 5500, [128, 64, 32, 129]);
    let map = EnvMap::load(&path).unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!((map.width, map.height), (8192, 5500));
    assert_eq!(map.texels[0], [1.0, 0.5, 0.25]);
    assert_eq!(map.texels[map.texels.len() - 1], [1.0, 0.5, 0.25]);
}

/// Under a 1 GB address-space limit (`ulimit -v`), `host render --env` of files whose headers
/// claim huge images (.exr 16384 x 16384 = 3 GiB of texels and 100000 x 50000, .hdr 100000 x
/// 50000; a few hundred bytes each) exits 1 with an error naming the file: no allocation of the
/// claimed size, no abort.
#[test]
fn huge_headers_are_refused_under_a_memory_limit() {
    let dir = tempfile::tempdir().unwrap();
    let small = dir.path().join("small.exr");
    write_exr_scanlines(&small, 4, 64);
    let bytes = std::fs::read(&small).unwrap();
    let mut files = Vec::new();
    for (w, h) in [(MAX_SIDE as i32, MAX_SIDE as i32), (100_000, 50_000)] {
        let path = dir.path().join(format!("claims_{w}x{h}.exr"));
        std::fs::write(&path, claiming(bytes.clone(), w, h)).unwrap();
        files.push(path);
    }
    let hdr = dir.path().join("claims.hdr");
    write_hdr(&hdr, 100_000, 50_000, &[rgbe([128, 128, 128], 129); 16]);
    files.push(hdr);
    for f in files {
        let out = common::host_under_ulimit(1000000)
            .args([
                "render",
                "--integrator",
                "direct",
                "--env",
                s(&f),
                "--width",
                "8",
                "--height",
                "8",
                "--spp",
                "1",
                "--resolution",
                "8",
                "--backend",
                "cpu",
                "--quiet",
                "--out",
            ])
            .arg(dir.path().join("r.exr"))
            .output()
            .unwrap();
        assert_refused(&out, &[&format!("--env {}", f.display())]);
    }
}

/// A valid 16384 x 8192 probe (an 8.5 MB run-length .hdr; 2 GiB while rendering) under a
/// 1.5 GB address-space limit is refused before its texels are decoded, naming the file, the
/// memory it needs and a size that fits; it used to abort (issue 43, item 4).
#[test]
fn a_valid_probe_larger_than_the_memory_limit_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.hdr");
    write_rle_hdr(&path, MAX_SIDE, MAX_SIDE / 2, [128, 64, 32, 129]);
    let out = common::host_under_ulimit(1500000)
        .args(["render", "--integrator", "direct", "--env", s(&path)])
        .args([
            "--width",
            "8",
            "--height",
            "8",
            "--spp",
            "1",
            "--resolution",
            "8",
        ])
        .args(["--backend", "cpu", "--quiet", "--out"])
        .arg(dir.path().join("r.exr"))
        .output()
        .unwrap();
    assert_refused(
        &out,
        &[
            &format!("--env {}", path.display()),
            "16384x8192 light probe needs 2.0 GiB",
            "ulimit -v",
            "probe fits",
        ],
    );
}

// ---------------------------------------------------------------------------------------------
// lighting::build.

/// Options with no light at all; tests add what they need.
fn dark() -> LightingOptions {
    LightingOptions {
        env: EnvSource::None,
        env_scale: 1.0,
        env_rotate_deg: 0.0,
        sun: None,
        points: Vec::new(),
        albedo: [0.8, 0.6, 0.4],
    }
}

/// `build` around the unit sphere.
fn lights(opts: &LightingOptions) -> anyhow::Result<SceneLights> {
    build(opts, [0.0; 3], 1.0)
}

/// The pmf over (sun, env, points).
fn pmf(l: &SceneLights) -> [f32; 3] {
    [l.lighting.p_sun, l.lighting.p_env, l.lighting.p_points]
}

/// A sun spec toward `dir`.
fn sun(dir: [f32; 3], irradiance: Option<f32>, radius_deg: f32) -> Option<SunSpec> {
    Some(SunSpec {
        dir,
        irradiance,
        radius_deg,
    })
}

/// Asserts the pmf is finite, non-negative and sums to 1 (to 1e-6), and that every kind present
/// has at least its uniform share 0.1 / (kinds present) (none is starved).
fn assert_pmf_normalised(l: &SceneLights, what: &str) {
    let p = pmf(l);
    assert!(
        p.iter().all(|v| v.is_finite() && *v >= 0.0),
        "{what}: {p:?}"
    );
    let sum: f32 = p.iter().sum();
    assert!((sum - 1.0).abs() <= 1e-6, "{what}: pmf {p:?} sums to {sum}");
    let present = p.iter().filter(|v| **v > 0.0).count();
    for v in p.iter().filter(|v| **v > 0.0) {
        assert!(*v >= 0.1 / present as f32 - 1e-6, "{what}: {p:?}");
    }
}

/// Asserts every value of the map's data buffer is finite and non-negative.
fn assert_env_finite(l: &SceneLights, what: &str) {
    assert!(
        l.env.iter().all(|v| v.is_finite() && *v >= 0.0),
        "{what}: non-finite or negative values in the map data"
    );
}

/// No light at all: the pmf is all zero (nothing is ever sampled), no map, no sun, and the map
/// buffer is the single placeholder 0 (GPU buffers may not be empty).
#[test]
fn no_lights_give_an_all_zero_pmf() {
    let l = lights(&dark()).unwrap();
    assert_eq!(pmf(&l), [0.0; 3]);
    assert!(!l.lighting.env.present());
    assert_eq!(l.lighting.sun.present, 0);
    assert_eq!(l.env, vec![0.0]);
    assert_eq!(
        l.view().select_kind(0.0),
        shared::sampling::lighting::LightKind::None
    );
    assert_eq!(
        l.view().select_kind(0.999),
        shared::sampling::lighting::LightKind::None
    );
}

/// A sun of intensity 0 (delta or disk) is present but has weight 0: alone it gives an all-zero
/// pmf (no sample is wasted on it) and zero radiance, never NaN; with a point light the points
/// take the whole pmf.
#[test]
fn zero_intensity_sun_gets_no_probability() {
    for radius in [0.0, 0.5] {
        let l = lights(&LightingOptions {
            sun: sun([0.0, 1.0, 0.0], Some(0.0), radius),
            ..dark()
        })
        .unwrap();
        assert_eq!(pmf(&l), [0.0; 3], "radius {radius}");
        let r = l.lighting.sun.radiance;
        assert_eq!([r.r, r.g, r.b], [0.0; 3], "radius {radius}");
        let l = lights(&LightingOptions {
            sun: sun([0.0, 1.0, 0.0], Some(0.0), radius),
            points: vec![PointLight::new(
                shared::geometry::V3::new(0.0, 3.0, 0.0),
                5.0,
            )],
            ..dark()
        })
        .unwrap();
        assert_eq!(pmf(&l), [0.0, 0.0, 1.0], "radius {radius}");
    }
}

/// The sky with the sun below the horizon (and at the nadir, and grazing): the map is finite
/// and non-negative with a lit sky, the sun is present with finite radiance, the pmf sums to 1.
#[test]
fn sky_with_the_sun_below_the_horizon_is_finite() {
    for dir in [
        [0.3, -0.5, 0.2],
        [0.0, -1.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
    ] {
        let l = lights(&LightingOptions {
            env: EnvSource::Sky,
            sun: sun(dir, None, 0.5),
            ..dark()
        })
        .unwrap();
        let what = format!("sun {dir:?}");
        assert_env_finite(&l, &what);
        assert_pmf_normalised(&l, &what);
        assert!(l.lighting.env.present(), "{what}");
        assert!(l.lighting.p_env > 0.0 && l.lighting.p_sun > 0.0, "{what}");
        let r = l.lighting.sun.radiance;
        assert!(
            r.r.is_finite() && r.g.is_finite() && r.b.is_finite(),
            "{what}"
        );
    }
}

/// --env-scale 0 makes the map black: its CDFs fall back to uniform (finite), its probability
/// is 0, and the sky's sun takes the whole pmf; a black map alone gives an all-zero pmf.
#[test]
fn env_scale_zero_gives_the_map_no_probability() {
    let l = lights(&LightingOptions {
        env: EnvSource::Sky,
        env_scale: 0.0,
        ..dark()
    })
    .unwrap();
    assert_env_finite(&l, "sky x 0");
    let (w, h) = (l.lighting.env.width, l.lighting.env.height);
    assert!(l.env[..(3 * w * h) as usize].iter().all(|v| *v == 0.0));
    assert_eq!(pmf(&l), [1.0, 0.0, 0.0]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.exr");
    write_exr(&path, 4, 2, |_, _| [2.0; 3]);
    let l = lights(&LightingOptions {
        env: EnvSource::File(path),
        env_scale: 0.0,
        ..dark()
    })
    .unwrap();
    assert_env_finite(&l, "file x 0");
    assert_eq!(pmf(&l), [0.0; 3]);
}

/// Every combination of lights with positive power has a pmf summing to 1 with each kind's
/// uniform share: points only, sun only (delta and disk), a file probe only, the sky (with its
/// default sun), the sky with points, a probe with a sun and points.
#[test]
fn pmf_sums_to_one_whenever_a_light_exists() {
    let dir = tempfile::tempdir().unwrap();
    let probe: PathBuf = dir.path().join("g.exr");
    write_exr(&probe, 8, 4, |x, y| [x as f32, y as f32 + 0.5, 1.0]);
    let point = |i: f32| PointLight::new(shared::geometry::V3::new(0.5, 2.0, -1.0), i);
    let cases = [
        (
            "points",
            LightingOptions {
                points: vec![point(3.0), point(0.1)],
                ..dark()
            },
        ),
        (
            "delta sun",
            LightingOptions {
                sun: sun([1.0, 2.0, 3.0], Some(2.0), 0.0),
                ..dark()
            },
        ),
        (
            "disk sun",
            LightingOptions {
                sun: sun([1.0, 2.0, 3.0], None, 1.0),
                ..dark()
            },
        ),
        (
            "probe",
            LightingOptions {
                env: EnvSource::File(probe.clone()),
                ..dark()
            },
        ),
        (
            "sky",
            LightingOptions {
                env: EnvSource::Sky,
                ..dark()
            },
        ),
        (
            "sky + points",
            LightingOptions {
                env: EnvSource::Sky,
                points: vec![point(1e3)],
                ..dark()
            },
        ),
        (
            "probe + sun + points",
            LightingOptions {
                env: EnvSource::File(probe.clone()),
                env_scale: 7.0,
                env_rotate_deg: 45.0,
                sun: sun([0.0, 1.0, 0.0], Some(1e6), 0.2666),
                points: vec![point(1e-6)],
                ..dark()
            },
        ),
    ];
    for (what, opts) in cases {
        let l = lights(&opts).unwrap();
        assert_pmf_normalised(&l, what);
        assert_env_finite(&l, what);
    }
}

/// Bad options are refused by `build` (the API, not only the CLI parsers) with the flag's name:
/// a negative or NaN --env-scale, a non-finite --env-rotate, a zero or NaN sun direction, a
/// negative sun intensity, a sun radius outside [0, 45] degrees.
#[test]
fn bad_options_are_refused_by_build() {
    let refused = |opts: LightingOptions, words: &[&str]| {
        let msg = format!("{:#}", lights(&opts).unwrap_err());
        for w in words {
            assert!(msg.contains(w), "message lacks {w:?}: {msg}");
        }
    };
    let sky = || LightingOptions {
        env: EnvSource::Sky,
        ..dark()
    };
    refused(
        LightingOptions {
            env_scale: -1.0,
            ..sky()
        },
        &["--env-scale"],
    );
    refused(
        LightingOptions {
            env_scale: f32::NAN,
            ..sky()
        },
        &["--env-scale"],
    );
    refused(
        LightingOptions {
            env_rotate_deg: f32::INFINITY,
            ..sky()
        },
        &["--env-rotate"],
    );
    refused(
        LightingOptions {
            sun: sun([0.0; 3], None, 0.5),
            ..dark()
        },
        &["--sun", "non-zero"],
    );
    refused(
        LightingOptions {
            sun: sun([f32::NAN, 1.0, 0.0], None, 0.5),
            ..dark()
        },
        &["--sun"],
    );
    refused(
        LightingOptions {
            sun: sun([0.0, 1.0, 0.0], Some(-1.0), 0.5),
            ..dark()
        },
        &["--sun", "intensity"],
    );
    refused(
        LightingOptions {
            sun: sun([0.0, 1.0, 0.0], Some(1.0), 46.0),
            ..dark()
        },
        &["--sun", "radius"],
    );
}

/// Scales and intensities that overflow f32 radiance are refused, never rendered as infinity:
/// --env-scale 3e38 on a probe of radiance 2 (texels 6e38), and a sun of irradiance 1e36 on the
/// real sun's disk (radiance 1.5e40). So are radiances above `MAX_EMISSION` (1e12), which are
/// finite but overflow the integrators' f32 sums of squares (issue 43, item 2: --env-scale 1e30,
/// once accepted, rendered infinite pixels): 5e11 x 2 is accepted, 1e12 x 2 refused with the
/// largest safe scale.
#[test]
fn radiance_overflowing_f32_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let probe = dir.path().join("c.exr");
    write_exr(&probe, 4, 2, |_, _| [2.0; 3]);
    let file = || LightingOptions {
        env: EnvSource::File(probe.clone()),
        ..dark()
    };
    let msg = format!(
        "{:#}",
        lights(&LightingOptions {
            env_scale: 3e38,
            ..file()
        })
        .unwrap_err()
    );
    assert!(msg.contains("--env-scale"), "{msg}");
    let l = lights(&LightingOptions {
        env_scale: 5e11,
        ..file()
    })
    .unwrap();
    assert_env_finite(&l, "x 5e11");
    for scale in [1e12, 1e30] {
        let msg = format!(
            "{:#}",
            lights(&LightingOptions {
                env_scale: scale,
                ..file()
            })
            .unwrap_err()
        );
        assert!(
            msg.contains("c.exr") && msg.contains("1e12") && msg.contains("--env-scale 5.000e11"),
            "{msg}"
        );
    }
    let msg = format!(
        "{:#}",
        lights(&LightingOptions {
            sun: sun([0.0, 1.0, 0.0], Some(1e36), 0.2666),
            ..dark()
        })
        .unwrap_err()
    );
    assert!(msg.contains("--sun"), "{msg}");
}

// ---------------------------------------------------------------------------------------------
// The CLI.

/// The `host` binary.
fn host() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host"))
}

/// A 16x16, 1 spp render on the CPU backend with the flags `extra`.
fn render(out: &Path, extra: &[&str]) -> Output {
    host()
        .args([
            "render",
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            "1",
            "--resolution",
            "16",
            "--backend",
            "cpu",
            "--quiet",
            "--out",
            s(out),
        ])
        .args(extra)
        .output()
        .unwrap()
}

/// Renders `prefix` + each case's flags and asserts it is refused with all the case's words,
/// writing no image.
fn refuse_all(exr: &Path, prefix: &[&str], cases: Vec<(Vec<&str>, Vec<&str>)>) {
    for (flags, words) in cases {
        let mut args = prefix.to_vec();
        args.extend(&flags);
        let out = render(exr, &args);
        assert_refused(&out, &words);
        assert!(!exr.exists(), "{flags:?}: an image was written");
    }
}

/// The RGB pixels of a 16x16 EXR written by [`render`], row by row.
fn read_rgb16(exr: &Path) -> Vec<[f32; 3]> {
    let img = exr::prelude::read_first_rgba_layer_from_file(
        exr,
        |r, _| vec![[0.0f32; 3]; r.width() * r.height()],
        |px: &mut Vec<[f32; 3]>, p, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[p.y() * 16 + p.x()] = [r, g, b];
        },
    )
    .unwrap();
    img.layer_data.channel_data.pixels
}

/// Asserts that `out` failed cleanly (exit 1, `error:` first, no panic) with all `words`.
fn assert_refused(out: &Output, words: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "expected failure: {stderr}");
    assert!(stderr.starts_with("error:"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for w in words {
        assert!(stderr.contains(w), "stderr lacks {w:?}: {stderr}");
    }
}

/// `--integrator direct --env sky` writes an RGB EXR (channels B, G, R; finite, non-negative,
/// not all black) and a 16x16 PNG preview next to it; so does a `.hdr` probe rotated and scaled.
#[test]
fn direct_render_under_the_sky_writes_rgb_exr_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let probe = dir.path().join("probe.hdr");
    write_hdr(&probe, 8, 4, &[rgbe([128, 100, 60], 129); 32]);
    for (name, extra) in [
        ("sky", vec!["--env", "sky"]),
        (
            "sky_sun",
            vec![
                "--env",
                "sky",
                "--sun",
                "0,1,1,3,2",
                "--albedo",
                "0.9,0.5,0.2",
            ],
        ),
        (
            "probe",
            vec![
                "--env",
                s(&probe),
                "--env-scale",
                "2",
                "--env-rotate",
                "-90",
            ],
        ),
    ] {
        let exr = dir.path().join(format!("{name}.exr"));
        let mut args = vec!["--integrator", "direct"];
        args.extend(extra);
        let out = render(&exr, &args);
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let meta = exr::meta::MetaData::read_from_file(&exr, false).unwrap();
        let names: Vec<String> = meta.headers[0]
            .channels
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        assert_eq!(names, ["B", "G", "R"], "{name}: channels {names:?}");
        let px = read_rgb16(&exr);
        assert_eq!(px.len(), 256, "{name}");
        assert!(
            px.iter().flatten().all(|v| v.is_finite() && *v >= 0.0),
            "{name}: non-finite or negative pixels"
        );
        assert!(px.iter().flatten().any(|v| *v > 0.0), "{name}: black image");
        let png = image::open(exr.with_extension("png")).unwrap();
        assert_eq!((png.width(), png.height()), (16, 16), "{name}");
    }
}

/// Bad light flags exit with code 1 and a clear message naming the flag or file, and no output
/// is written: `--sun 0,0,0`, `--sun 1,1`, `--sun 0,1,0,-1`, `--sun 0,1,0,1,50`,
/// `--albedo 0.5,2,0.5`, `--albedo 0.5,0.5`, `--env missing.exr`, `--env` of a .png,
/// `--env-scale -1`, `--env-scale nan`, `--env-scale 3e38` (radiance overflow), `--env
/// constant:` with a negative, infinite or missing value or two values.
#[test]
fn bad_light_flags_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("r.exr");
    let png = dir.path().join("p.png");
    image::RgbImage::new(4, 2).save(&png).unwrap();
    let missing = dir.path().join("missing.exr");
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (vec!["--sun", "0,0,0"], vec!["--sun", "non-zero direction"]),
        (vec!["--sun", "1,1"], vec!["--sun", "x,y,z"]),
        (vec!["--sun", "0,1,0,-1"], vec!["--sun", "intensity >= 0"]),
        (vec!["--sun", "0,1,0,1,50"], vec!["--sun", "[0, 45]"]),
        (vec!["--albedo", "0.5,2,0.5"], vec!["--albedo", "[0, 1]"]),
        (vec!["--albedo", "0.5,0.5"], vec!["--albedo", "r,g,b"]),
        (
            vec!["--env", s(&missing)],
            vec!["--env", "missing.exr", "no such file"],
        ),
        (
            vec!["--env", s(&png)],
            vec!["--env", "p.png", "unknown light probe format"],
        ),
        (
            vec!["--env", "constant:-1"],
            vec!["--env", "constant:-1", "finite and >= 0"],
        ),
        (
            vec!["--env", "constant:1,2"],
            vec!["--env", "constant:1,2", "one value or three"],
        ),
        (
            vec!["--env", "constant:grey"],
            vec!["--env", "constant:R,G,B"],
        ),
        (vec!["--env", "constant:inf"], vec!["--env", "finite"]),
        (vec!["--env-scale", "-1"], vec!["--env-scale"]),
        (vec!["--env-scale", "nan"], vec!["--env-scale"]),
        (
            vec!["--env", "sky", "--env-scale", "3e38"],
            vec!["--env-scale"],
        ),
    ];
    refuse_all(&exr, &["--integrator", "direct"], cases);
}

/// Lights too bright for the integrators' f32 sums are refused before rendering, naming the light
/// and the largest accepted value (issue 43, item 2: each rendered infinite pixels at exit 0):
/// `--light 0,0,0,3e38` with `path` and `mis-jackknife`, a `.hdr` texel at the RGBE maximum.
#[test]
fn lights_beyond_the_f32_sums_are_refused_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("r.exr");
    let hdr = dir.path().join("max.hdr");
    write_hdr(&hdr, 2, 1, &[rgbe([255; 3], 255), rgbe([128; 3], 129)]);
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec![
                "--integrator",
                "path",
                "--env",
                "none",
                "--light",
                "0,0,0,3e38",
            ],
            vec!["light 1", "1e12", "intensity"],
        ),
        (
            vec!["--integrator", "mis-jackknife", "--light", "0,0,0,1e13"],
            vec!["--light 1", "1e12"],
        ),
        (
            vec!["--integrator", "direct", "--env", s(&hdr)],
            vec!["max.hdr", "brightest texel", "1e12", "--env-scale"],
        ),
    ];
    refuse_all(&exr, &[], cases);
}

/// Flags that do not apply are refused, not ignored: `--env sky`, `--sun`, `--env-scale` without
/// `--integrator direct`; an RGB `--albedo` with the scalar `mis-jackknife` integrator;
/// `--t-hat ratio` with `--integrator direct`.
#[test]
fn light_flags_outside_direct_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("r.exr");
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec!["--env", "sky"],
            vec!["--env", "only applies to --integrator direct"],
        ),
        (
            vec!["--sun", "0,1,0"],
            vec!["--sun", "only applies to --integrator direct"],
        ),
        (
            vec!["--integrator", "mis-jackknife", "--env-scale", "2"],
            vec!["--env-scale", "--integrator direct"],
        ),
        (
            vec!["--albedo", "0.2,0.3,0.4", "--integrator", "mis-jackknife"],
            vec!["--albedo", "scalar"],
        ),
        (
            vec!["--t-hat", "ratio", "--integrator", "direct"],
            vec!["--t-hat", "no effect with --integrator direct"],
        ),
    ];
    refuse_all(&exr, &[], cases);
}

/// `--integrator path` under the sky and under a probe with a sun and a point light writes a
/// finite, non-black RGB image; `--max-depth 1` and `--rr-depth 0` are accepted.
#[test]
fn path_render_writes_a_finite_rgb_image() {
    let dir = tempfile::tempdir().unwrap();
    let probe = dir.path().join("probe.hdr");
    write_hdr(&probe, 8, 4, &[rgbe([128, 100, 60], 129); 32]);
    for (name, extra) in [
        ("sky", vec!["--env", "sky", "--hg-g", "0.6"]),
        (
            "probe",
            vec![
                "--env",
                s(&probe),
                "--sun",
                "0,1,1,3,2",
                "--light",
                "0,0,0,2",
                "--albedo",
                "0.9,0.5,0.2",
                "--max-depth",
                "1",
                "--rr-depth",
                "0",
                "--estimator",
                "ratio",
            ],
        ),
    ] {
        let exr = dir.path().join(format!("{name}.exr"));
        let mut args = vec!["--integrator", "path"];
        args.extend(extra);
        let out = render(&exr, &args);
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let px = read_rgb16(&exr);
        assert!(
            px.iter().flatten().all(|v| v.is_finite() && *v >= 0.0),
            "{name}"
        );
        assert!(px.iter().flatten().any(|v| *v > 0.0), "{name}: black image");
    }
}

/// `--env constant:R,G,B` (a world colour): `path` renders it, the pixels whose camera rays
/// miss the volume are exactly its radiance, the JSON names it, and a scene written with
/// `--write-scene` keeps it (not read as a file next to the scene) and renders the same bytes.
#[test]
fn constant_env_renders_and_round_trips_through_a_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("c.exr");
    let flags = [
        "--integrator",
        "path",
        "--env",
        "constant:0.5,0.75,1.25",
        "--fov",
        "90",
    ];
    let summary = dir.path().join("c.json");
    let mut first = flags.to_vec();
    first.extend(["--json", s(&summary)]);
    ok(&render(&exr, &first));
    let json = read_json(&summary);
    let text = json.to_string();
    assert!(text.contains("constant:0.5,0.75,1.25"), "{text}");
    let px = read_rgb16(&exr);
    assert_eq!(
        px[0],
        [0.5, 0.75, 1.25],
        "a corner pixel (its rays miss the volume)"
    );
    assert!(px.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    let scene = dir.path().join("sub").join("s.toml");
    std::fs::create_dir_all(scene.parent().unwrap()).unwrap();
    let mut args = flags.to_vec();
    args.extend(["--write-scene", s(&scene)]);
    ok(&render(&dir.path().join("unused.exr"), &args));
    let toml = std::fs::read_to_string(&scene).unwrap();
    assert!(toml.contains("\"constant:0.5,0.75,1.25\""), "{toml}");
    let again = dir.path().join("again.exr");
    ok(&render(&again, &["--scene", s(&scene)]));
    assert_eq!(
        std::fs::read(&exr).unwrap(),
        std::fs::read(&again).unwrap(),
        "the scene file's render differs"
    );
}

/// The path-only flags are refused elsewhere, and their ranges are checked.
#[test]
fn path_flags_are_refused_outside_path_and_out_of_range() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("r.exr");
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec!["--integrator", "direct", "--rr-depth", "3"],
            vec!["--rr-depth", "only applies to --integrator path"],
        ),
        (
            vec!["--max-depth", "8"],
            vec!["--max-depth", "only applies to --integrator path"],
        ),
        (
            vec!["--integrator", "path", "--max-depth", "0"],
            vec!["--max-depth", "0"],
        ),
        (
            vec!["--integrator", "path", "--t-hat", "ratio"],
            vec!["--t-hat", "no effect"],
        ),
    ];
    refuse_all(&exr, &[], cases);
}

/// A 12 x 9, 2-spp `host eval --integrators INTEGRATORS --estimators ESTIMATORS` of a 16^3
/// volume on the CPU (reference at 4 spp) into `out_dir` and `json`, with `extra` flags.
fn small_eval(
    out_dir: &Path,
    json: &Path,
    integrators: &str,
    estimators: &str,
    extra: &[&str],
) -> Output {
    host()
        .args([
            "eval",
            "--integrators",
            integrators,
            "--estimators",
            estimators,
            "--resolution",
            "16",
            "--width",
            "12",
            "--height",
            "9",
            "--spp",
            "2",
            "--reference-spp",
            "4",
            "--backend",
            "cpu",
            "--quiet",
            "--out-dir",
            s(out_dir),
            "--json",
            s(json),
        ])
        .args(extra)
        .output()
        .unwrap()
}

/// `host eval --integrators direct,path` writes one entry per integrator and estimator, a
/// reference and an insets strip per integrator; mixing them with a single-scattering
/// integrator is refused.
#[test]
fn eval_of_direct_and_path_writes_entries_references_and_insets() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("eval");
    let json = dir.path().join("eval.json");
    let eval = |integrators: &str, estimators: &str| {
        small_eval(&out_dir, &json, integrators, estimators, &[])
    };
    let out = eval("direct,path", "jackknife,ratio");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let names: Vec<&str> = report["entries"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "direct/jackknife",
            "direct/ratio",
            "path/jackknife",
            "path/ratio"
        ]
    );
    for e in report["entries"].as_array().unwrap() {
        for field in [
            "smape",
            "mean_bias",
            "mean_bias_se",
            "mean_std",
            "mean_radiance",
        ] {
            assert!(e[field].as_f64().unwrap().is_finite(), "{field}: {e}");
        }
    }
    for r in report["references"].as_array().unwrap() {
        let insets = image::open(r["insets"].as_str().unwrap()).unwrap();
        // Reference + 2 entries, each 2 x (9 / 3) = 6 pixels wide, 4-pixel gaps.
        assert_eq!((insets.width(), insets.height()), (3 * 6 + 2 * 4, 6));
    }
    // The report viewer imports it: one tab per integrator, with the equal-time column.
    let report_dir = dir.path().join("report");
    let out = host()
        .args([
            "report",
            "--from-eval",
            s(&json),
            "--out",
            s(&report_dir),
            "--quiet",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let html = std::fs::read_to_string(report_dir.join("index.html")).unwrap();
    for needle in ["direct/jackknife", "path/ratio", "var_time", "std^2 x ms"] {
        assert!(html.contains(needle), "index.html lacks {needle}");
    }
    let mixed = eval("direct,free-flight", "jackknife");
    assert_refused(&mixed, &["--integrators", "evaluated together or alone"]);
}

/// Bad moment-shadow-map flags exit with code 1, name the flag and the fix, and write nothing:
/// a map without a sun, map flags without `--shadows msm*` or without `direct`/`path`, u16
/// storage of six moments, resolutions and filter radii out of range, malformed filters.
#[test]
fn bad_shadow_map_flags_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("r.exr");
    let direct = |v: &[&'static str]| {
        let mut a = vec!["--integrator", "direct"];
        a.extend(v);
        a
    };
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            direct(&["--env", "none", "--light", "0,0,0,1", "--shadows", "msm4"]),
            vec!["--shadows msm4", "--sun"],
        ),
        (
            direct(&["--sun", "0,1,0", "--msm-res", "64"]),
            vec!["--msm-res", "--shadows msm4 or msm6"],
        ),
        (
            direct(&["--sun", "0,1,0", "--msm-filter", "box:2"]),
            vec!["--msm-filter", "--shadows"],
        ),
        (
            vec!["--shadows", "msm4"],
            vec!["--shadows", "--integrator direct"],
        ),
        (
            vec!["--integrator", "mis-jackknife", "--shadows", "msm6"],
            vec!["--shadows", "--integrator direct"],
        ),
        (
            direct(&[
                "--sun",
                "0,1,0",
                "--shadows",
                "msm6",
                "--msm-storage",
                "u16",
            ]),
            vec!["--msm-storage u16", "f32"],
        ),
        (
            direct(&["--sun", "0,1,0", "--shadows", "msm4", "--msm-res", "4"]),
            vec!["--msm-res"],
        ),
        (
            direct(&["--sun", "0,1,0", "--shadows", "msm4", "--msm-res", "4096"]),
            vec!["--msm-res"],
        ),
        (
            direct(&[
                "--sun",
                "0,1,0",
                "--shadows",
                "msm4",
                "--msm-filter",
                "box:0",
            ]),
            vec!["--msm-filter", "box:R"],
        ),
        (
            direct(&[
                "--sun",
                "0,1,0",
                "--shadows",
                "msm4",
                "--msm-filter",
                "gauss:65",
            ]),
            vec!["--msm-filter", "1 to 64"],
        ),
        (
            direct(&[
                "--sun",
                "0,1,0",
                "--shadows",
                "msm4",
                "--msm-filter",
                "tent:2",
            ]),
            vec!["--msm-filter", "gauss:R"],
        ),
        (
            direct(&["--sun", "0,1,0", "--shadows", "msm5"]),
            vec!["--shadows", "msm5"],
        ),
    ];
    refuse_all(&exr, &[], cases);
}

/// `--shadows msm4|msm6` renders `direct` and `path` under a delta sun; the JSON reports the
/// map (storage, resolution, filter, build time, bytes) and no fallback, and the image is close
/// to the shadow-ray render's (mean radiance within 20%: 1 spp of a 16^3 volume, whose shadows
/// a prefilter of one 32-texel map texel already blurs) but not identical.
#[test]
fn shadow_map_renders_report_the_map() {
    let dir = tempfile::tempdir().unwrap();
    let mean = |json: &Path| -> (f64, serde_json::Value) {
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
        (v["mean_L"].as_f64().unwrap(), v)
    };
    for integrator in ["direct", "path"] {
        let base = ["--integrator", integrator, "--sun", "0.7,0.6,-0.45,3,0"];
        let rays_exr = dir.path().join(format!("{integrator}-rays.exr"));
        let rays_json = dir.path().join(format!("{integrator}-rays.json"));
        let mut args = base.to_vec();
        args.extend(["--json", s(&rays_json)]);
        let out = render(&rays_exr, &args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let (l_rays, v) = mean(&rays_json);
        assert_eq!(v["integrator"]["shadows"]["shadows"], "rays");
        for (shadows, extra, storage, bytes_per_texel) in [
            ("msm4", vec![], "u16", 8),
            (
                "msm4",
                vec!["--msm-storage", "f32", "--msm-filter", "gauss:2"],
                "f32",
                16,
            ),
            ("msm6", vec!["--msm-filter", "box:1"], "f32", 24),
        ] {
            let exr = dir
                .path()
                .join(format!("{integrator}-{shadows}-{storage}.exr"));
            let json = exr.with_extension("json");
            let mut args = base.to_vec();
            args.extend(["--shadows", shadows, "--msm-res", "32", "--json", s(&json)]);
            args.extend(extra.iter().copied());
            let out = render(&exr, &args);
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            let (l, v) = mean(&json);
            let m = &v["integrator"]["shadows"];
            assert_eq!(m["shadows"], shadows, "{m}");
            assert_eq!(m["map"]["storage"], storage, "{m}");
            assert_eq!(m["map"]["resolution"], 32, "{m}");
            assert_eq!(m["map"]["bytes"], 32 * 32 * bytes_per_texel, "{m}");
            assert!(m["map"]["build_ms"].as_f64().unwrap() >= 0.0, "{m}");
            assert_eq!(v["msm_fallback_rays"], 0, "{v}");
            assert!(
                (l - l_rays).abs() < 0.2 * l_rays && l != l_rays,
                "{integrator} {shadows}: mean L {l} vs shadow rays {l_rays}"
            );
        }
    }
}

/// `host eval --integrators direct --estimators jackknife,msm4:16,msm6` under a delta sun: map
/// entries are named `direct/msm4-16`, `direct/msm6-512`, report their map and, like every
/// entry, their paired error against the exact-shadow image (the map's paired error is its
/// bias: nonzero; the report viewer still reads the file); malformed map entries and a map
/// without a sun are refused.
#[test]
fn eval_of_shadow_maps_reports_maps_and_paired_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("eval");
    let json = dir.path().join("eval.json");
    let eval = |estimators: &str, lights: &[&str]| {
        small_eval(&out_dir, &json, "direct", estimators, lights)
    };
    let sun = ["--env", "none", "--sun", "0.7,0.6,-0.45,3,0"];
    let out = eval("jackknife,msm4:16,msm6", &sun);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let entries = report["entries"].as_array().unwrap();
    let names: Vec<&str> = entries
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        ["direct/jackknife", "direct/msm4-16", "direct/msm6-512"]
    );
    for e in entries {
        assert!(e["paired_rms"].as_f64().unwrap().is_finite(), "{e}");
    }
    assert!(entries[0]["shadow_map"].is_null());
    assert_eq!(entries[1]["shadow_map"]["resolution"], 16);
    assert_eq!(entries[1]["shadow_map"]["bytes"], 16 * 16 * 8);
    assert_eq!(entries[2]["shadow_map"]["storage"], "f32");
    assert!(entries[1]["paired_rms"].as_f64().unwrap() > 0.0);
    assert!(out_dir.join("direct-exact.exr").exists());
    let out = host()
        .args(["report", "--from-eval", s(&json), "--out"])
        .arg(dir.path().join("report"))
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for (estimators, words) in [
        ("msm4:3", vec!["--estimators", "msm4:3", "8 to 2048"]),
        ("msm4:x", vec!["--estimators", "msm4:x"]),
        ("jackknife:64", vec!["--estimators", "only msm4 and msm6"]),
        ("msm7", vec!["--estimators", "msm7"]),
    ] {
        assert_refused(&eval(estimators, &sun), &words);
    }
    assert_refused(
        &eval("msm4", &["--env", "none", "--light", "0,0,0,1"]),
        &["--estimators msm4-512", "--sun"],
    );
}

fn ok(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn read_json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// A `restir` render of 300 random lights writes a non-black RGB image and records the
/// integrator's settings, the scatter and the light count.
#[test]
fn restir_render_records_its_settings() {
    let dir = tempfile::tempdir().unwrap();
    let (exr, json) = (dir.path().join("r.exr"), dir.path().join("r.json"));
    let out = render(
        &exr,
        &[
            "--integrator",
            "restir",
            "--lights",
            "random:300,4",
            "--restir-candidates",
            "6",
            "--json",
            s(&json),
        ],
    );
    ok(&out);
    let j = read_json(&json);
    let i = &j["integrator"];
    assert_eq!(i["name"], "restir");
    assert_eq!(i["random_lights"], "random:300,4");
    assert_eq!(i["point_lights"], 300);
    assert_eq!(i["restir"]["candidates"], 6);
    assert_eq!(i["restir"]["target"], "jackknife");
    assert_eq!(i["restir"]["target_n"], 4);
    assert!(i["restir"]["target_floor"].as_f64().unwrap() > 0.0);
    assert_eq!(i["restir"]["passes"], 0);
    // The point lights are resampled on their own: no share of the kinds' pmf.
    assert_eq!(i["light_pmf"][2], 0.0);
    assert!(j["mean_L"].as_f64().unwrap() > 0.0);
    // `direct` with the same lights records them too (and gives them the whole pmf).
    let out = render(
        &exr,
        &[
            "--integrator",
            "direct",
            "--lights",
            "random:300,4",
            "--json",
            s(&json),
        ],
    );
    ok(&out);
    let j = read_json(&json);
    assert_eq!(j["integrator"]["point_lights"], 300);
    assert_eq!(j["integrator"]["light_pmf"][2], 1.0);
    assert!(j["integrator"].get("restir").is_none());
}

/// `restir` with two spatial reuse passes (balance heuristic, capped confidence) renders a
/// non-black image on the CPU and records the reuse settings.
#[test]
fn restir_with_spatial_reuse_records_its_settings() {
    let dir = tempfile::tempdir().unwrap();
    let (exr, json) = (dir.path().join("r.exr"), dir.path().join("r.json"));
    let out = render(
        &exr,
        &[
            "--integrator",
            "restir",
            "--lights",
            "random:64,2",
            "--restir-candidates",
            "4",
            "--restir-passes",
            "2",
            "--restir-neighbours",
            "4",
            "--restir-radius",
            "5",
            "--restir-mis",
            "balance",
            "--restir-m-cap",
            "40",
            "--json",
            s(&json),
        ],
    );
    ok(&out);
    let j = read_json(&json);
    let r = &j["integrator"]["restir"];
    assert_eq!(r["passes"], 2);
    assert_eq!(r["neighbours"], 4);
    assert_eq!(r["radius"], 5);
    assert_eq!(r["mis"], "balance");
    assert_eq!(r["m_cap"], 40);
    assert!(j["mean_L"].as_f64().unwrap() > 0.0);
    assert!(exr.exists());
}

/// `host eval --integrators direct,restir --equal-time`: one `direct` reference for both, the
/// entries in order, the second with a timing run and a calibrated spp.
#[test]
fn eval_of_direct_and_restir_at_equal_time() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("eval");
    let json = dir.path().join("eval.json");
    let out = host()
        .args([
            "eval",
            "--integrators",
            "direct,restir",
            "--estimators",
            "ratio",
            "--lights",
            "random:64",
            "--equal-time",
            "--resolution",
            "16",
            "--width",
            "12",
            "--height",
            "9",
            "--spp",
            "16",
            "--reference-spp",
            "32",
            "--backend",
            "cpu",
            "--quiet",
            "--out-dir",
            s(&out_dir),
            "--json",
            s(&json),
        ])
        .output()
        .unwrap();
    ok(&out);
    let r = read_json(&json);
    let entries = r["entries"].as_array().unwrap();
    let names: Vec<&str> = entries
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["direct/ratio", "restir/ratio"]);
    assert_eq!(entries[0]["spp"], 16);
    assert!(entries[0].get("calibration").is_none());
    let c = &entries[1]["calibration"];
    assert_eq!(c["spp"], 2, "a timing run at --spp / 8");
    assert!(c["ms"].as_f64().unwrap() > 0.0);
    assert_eq!(c["budget_ms"], entries[0]["elapsed_ms"]);
    assert!(entries[1]["spp"].as_u64().unwrap() >= 1);
    // The SMAPE moved to the budget: smape x sqrt(elapsed / budget).
    let f = |v: &serde_json::Value| v.as_f64().unwrap();
    let moved =
        f(&entries[1]["smape"]) * (f(&entries[1]["elapsed_ms"]) / f(&c["budget_ms"])).sqrt();
    assert!(
        (f(&c["smape_at_budget"]) - moved).abs() <= 1e-12 * moved,
        "{c}"
    );
    for e in entries {
        for f in ["smape", "mean_bias", "mean_bias_se", "mean_std"] {
            assert!(e[f].as_f64().unwrap().is_finite(), "{f}: {e}");
        }
        // The CPU builds no pipelines.
        assert_eq!(e["pipeline_build_ms"], 0.0, "{e}");
    }
    let refs = r["references"].as_array().unwrap();
    assert_eq!(refs.len(), 2);
    for rf in refs {
        assert_eq!(rf["reference"], "direct/ratio at 32 spp");
        assert_eq!(rf["exr"], refs[0]["exr"], "one reference image for both");
    }
    assert!(out_dir.join("direct-reference.exr").exists());
    assert!(!out_dir.join("restir-reference.exr").exists());
    assert!(out_dir.join("restir-ratio.exr").exists());
}

/// Bad `restir`, `--lights` and `--equal-time` flags exit with code 1, name the flag, and write
/// nothing.
#[test]
fn bad_restir_and_many_light_flags_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("r.exr");
    let restir = |v: &[&'static str]| {
        let mut a = vec!["--integrator", "restir"];
        a.extend(v);
        a
    };
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            restir(&["--restir-candidates", "0"]),
            vec!["--restir-candidates", "1..=1024"],
        ),
        (
            restir(&["--restir-candidates", "5000"]),
            vec!["--restir-candidates"],
        ),
        (restir(&["--restir-n", "0"]), vec!["--restir-n"]),
        (
            restir(&["--restir-floor", "0"]),
            vec!["--restir-floor", "(0, 1]"],
        ),
        (restir(&["--restir-floor", "-1"]), vec!["--restir-floor"]),
        (restir(&["--restir-floor", "nan"]), vec!["--restir-floor"]),
        (
            restir(&["--restir-target", "exact"]),
            vec!["--restir-target", "unshadowed"],
        ),
        (
            restir(&["--lights", "random:0"]),
            vec!["--lights", "random:N"],
        ),
        (
            restir(&["--lights", "random:12,x"]),
            vec!["--lights", "random:N"],
        ),
        (
            vec!["--integrator", "direct", "--restir-candidates", "4"],
            vec!["--restir-candidates", "--integrator restir"],
        ),
        (
            vec!["--integrator", "direct", "--restir-passes", "1"],
            vec!["--restir-passes", "--integrator restir"],
        ),
        (
            restir(&["--restir-passes", "17"]),
            vec!["--restir-passes", "0..=16"],
        ),
        (
            restir(&["--restir-passes", "1", "--restir-neighbours", "0"]),
            vec!["--restir-neighbours", "1..=64"],
        ),
        (
            restir(&["--restir-passes", "1", "--restir-radius", "0"]),
            vec!["--restir-radius"],
        ),
        (
            restir(&["--restir-passes", "1", "--restir-mis", "talbot"]),
            vec!["--restir-mis", "pairwise"],
        ),
        (
            restir(&["--restir-neighbours", "5"]),
            vec!["--restir-neighbours", "--restir-passes 1"],
        ),
        (
            vec!["--lights", "random:8"],
            vec!["--lights", "--integrator direct"],
        ),
        (
            vec!["--integrator", "mis-jackknife", "--lights", "random:8"],
            vec!["--lights"],
        ),
    ];
    for (flags, words) in cases {
        let out = render(&exr, &flags);
        assert_refused(&out, &words);
        assert!(!exr.exists(), "{flags:?}: an image was written");
    }
    let eval = |extra: &[&str]| {
        host()
            .args([
                "eval",
                "--resolution",
                "16",
                "--width",
                "8",
                "--height",
                "8",
                "--spp",
                "2",
            ])
            .args(["--backend", "cpu", "--quiet", "--out-dir"])
            .arg(dir.path().join("e"))
            .args(extra)
            .output()
            .unwrap()
    };
    assert_refused(&eval(&["--equal-time"]), &["--equal-time", "--integrators"]);
    assert_refused(&eval(&["--lights", "random:5"]), &["--lights"]);
    assert_refused(
        &eval(&["--integrators", "direct", "--restir-n", "3"]),
        &["--restir-*", "--integrators restir"],
    );
    assert_refused(
        &eval(&[
            "--integrators",
            "direct,restir",
            "--estimators",
            "jackknife,msm4",
            "--sun",
            "0,1,0",
            "--equal-time",
        ]),
        &["--equal-time", "msm"],
    );
    assert!(!dir.path().join("e").join("eval.json").exists());
}

/// A missing `--env` is refused before the volume is read (it was refused only after loading
/// the volume, seconds into a large file; issue 43, item 6): with a volume file that would fail
/// to load, the error is the probe's.
#[test]
fn a_missing_probe_is_refused_before_the_volume_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let volume =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/malformed/empty_file.vdb");
    let missing = dir.path().join("missing.exr");
    let (exr, ev) = (dir.path().join("r.exr"), dir.path().join("ev"));
    for sub in ["render", "eval"] {
        let tail = if sub == "render" {
            ["--integrator", "direct", "--out", s(&exr)]
        } else {
            ["--integrators", "direct", "--out-dir", s(&ev)]
        };
        let out = host()
            .args([
                sub,
                "--backend",
                "cpu",
                "--width",
                "16",
                "--height",
                "16",
                "--spp",
                "2",
            ])
            .args(["--volume", s(&volume), "--env", s(&missing)])
            .args(tail)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{sub}: {stderr}");
        assert!(
            stderr.contains("missing.exr: no such file"),
            "{sub}: {stderr}"
        );
        assert!(!stderr.contains("empty_file.vdb"), "{sub}: {stderr}");
    }
}
