//! Shard files: the exact per-pixel totals of one sample range of a render (`host render
//! --samples A..B --shard FILE`), which `host merge` adds up into the images one render of all
//! samples gives, byte for byte.
//!
//! A shard is the 8 bytes `JKSHARD1`, the length of a JSON header (u32, little-endian), the
//! header ([`ShardHeader`]: the render's resolved scene, image size, samples, who rendered it),
//! then for each image the header names, every pixel's [`PixelTotals`] in row-major order.

use crate::totals::PixelTotals;
use anyhow::{bail, ensure, Context, Result};
use shared::params::RenderParams;
use std::io::Read;
use std::path::Path;

/// The first bytes of every shard file.
const MAGIC: &[u8; 8] = b"JKSHARD1";

/// Longest header read (a scene record with many lights is a few KB).
const MAX_HEADER_BYTES: u32 = 16 << 20;

/// What a shard holds beside its totals.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShardHeader {
    /// What the shard is of: [`RENDER`] (`host render --shard`), or [`EVAL_REFERENCE`] (`host
    /// eval --reference-shard`).
    #[serde(default = "render_kind")]
    pub kind: String,
    /// The render's resolved scene without the settings that only say how and where it runs
    /// (backend, outputs, progress): the same for every shard of one render.
    pub scene: super::scene_record::SceneRecord,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of the whole render.
    pub spp: u32,
    /// The samples this shard holds, [start, end).
    pub samples: [u32; 2],
    /// The renderer's sample block (`shared::kernels::render::SAMPLE_BLOCK`): shards of
    /// different blocks do not add up to one render's bytes.
    pub sample_block: u32,
    /// The images whose totals follow, in order: "image", and "camera-transmittance" for an
    /// integrator render with that layer.
    pub images: Vec<String>,
    /// FNV-1a 64-bit hash (hex) of what the kernels read beside the volume: the render's
    /// parameters and its lights (points, probe, sun, shadow map); equal for every shard of a
    /// render on every backend, and checked again by the merge.
    pub render_fnv1a: String,
    /// Bytes of the totals after the header, and their FNV-1a 64-bit hash (hex).
    pub payload_bytes: u64,
    pub payload_fnv1a: String,
    /// Who rendered it: not part of the result.
    pub backend: String,
    pub device: String,
    pub elapsed_ms: f64,
    pub host_version: String,
    pub command_line: Vec<String>,
}

/// [`ShardHeader::kind`] of a shard of `host render`.
pub const RENDER: &str = "render";
/// [`ShardHeader::kind`] of a shard of an evaluation's reference.
pub const EVAL_REFERENCE: &str = "eval-reference";

fn render_kind() -> String {
    RENDER.to_owned()
}

/// One image's totals of a shard.
pub type Totals = Vec<PixelTotals>;

/// FNV-1a, 64 bits.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    })
}

/// [`ShardHeader::render_fnv1a`] of a render.
pub fn render_fnv1a(params: &RenderParams, lights: &crate::lighting::SceneLights) -> String {
    let parts: [&[u8]; 5] = [
        bytemuck::bytes_of(params),
        bytemuck::cast_slice(&lights.points),
        bytemuck::bytes_of(&lights.lighting),
        bytemuck::cast_slice(&lights.env),
        bytemuck::cast_slice(&lights.shadow_map),
    ];
    let mut all = Vec::new();
    for p in parts {
        all.extend_from_slice(&(p.len() as u64).to_le_bytes());
        all.extend_from_slice(p);
    }
    format!("{:016x}", fnv1a(&all))
}

/// Writes `header` (its payload fields filled here) and `images`' totals to `path` (atomically).
pub fn write(path: &Path, header: &ShardHeader, images: &[Totals]) -> Result<()> {
    let mut payload = Vec::new();
    for image in images {
        for t in image {
            t.write(&mut payload);
        }
    }
    let header = ShardHeader {
        payload_bytes: payload.len() as u64,
        payload_fnv1a: format!("{:016x}", fnv1a(&payload)),
        ..header.clone()
    };
    let json = serde_json::to_vec(&header)?;
    crate::output::write_atomically(path, |tmp| {
        let mut bytes = Vec::with_capacity(12 + json.len() + payload.len());
        bytes.extend_from_slice(MAGIC);
        bytes.extend_from_slice(&(json.len() as u32).to_le_bytes());
        bytes.extend_from_slice(&json);
        bytes.extend_from_slice(&payload);
        std::fs::write(tmp, bytes).with_context(|| format!("writing {}", path.display()))
    })
}

/// Reads the header of shard `path`, refusing what is not a shard file.
pub fn read_header(path: &Path) -> Result<ShardHeader> {
    let mut file = open(path)?;
    header_of(path, &mut file)
}

/// Opens `path` for reading: a regular file only (a device or a fifo would be read without end).
fn open(path: &Path) -> Result<std::fs::File> {
    let meta = std::fs::metadata(path)
        .with_context(|| format!("{}: cannot read this shard file", path.display()))?;
    ensure!(
        meta.is_file(),
        "{}: not a regular file; give the shard files `host render --shard` wrote",
        path.display()
    );
    std::fs::File::open(path).with_context(|| format!("{}: cannot open", path.display()))
}

fn header_of(path: &Path, file: &mut std::fs::File) -> Result<ShardHeader> {
    let not_a_shard = || {
        anyhow::anyhow!(
            "{}: not a shard file (it does not start with {}); give the files `host render \
             --samples A..B --shard FILE` wrote",
            path.display(),
            String::from_utf8_lossy(MAGIC)
        )
    };
    let mut head = [0u8; 12];
    file.read_exact(&mut head).map_err(|_| not_a_shard())?;
    if &head[..8] != MAGIC {
        return Err(not_a_shard());
    }
    let len = u32::from_le_bytes(head[8..12].try_into().expect("4 bytes"));
    ensure!(
        len <= MAX_HEADER_BYTES,
        "{}: a shard header of {len} bytes is not plausible; the file is damaged",
        path.display()
    );
    let mut json = vec![0u8; len as usize];
    file.read_exact(&mut json)
        .with_context(|| format!("{}: the shard's header is cut short", path.display()))?;
    serde_json::from_slice(&json)
        .with_context(|| format!("{}: the shard's header is not valid", path.display()))
}

/// Reads the header and totals of shard `path`; a payload of the wrong length or hash (a file
/// cut short or damaged) is refused.
pub fn read(path: &Path) -> Result<(ShardHeader, Vec<Totals>)> {
    let mut file = open(path)?;
    let header = header_of(path, &mut file)?;
    let mut payload = Vec::new();
    file.take(header.payload_bytes.saturating_add(1))
        .read_to_end(&mut payload)
        .with_context(|| format!("reading {}", path.display()))?;
    ensure!(
        payload.len() as u64 == header.payload_bytes
            && format!("{:016x}", fnv1a(&payload)) == header.payload_fnv1a,
        "{}: the shard's totals are {} bytes where its header says {} (hash {}); the file was cut \
         short or changed: render this sample range again",
        path.display(),
        payload.len(),
        header.payload_bytes,
        header.payload_fnv1a
    );
    let pixels = header.width as usize * header.height as usize;
    let mut view = payload.as_slice();
    let mut images = Vec::new();
    for name in &header.images {
        let mut image = Vec::with_capacity(pixels);
        for _ in 0..pixels {
            match PixelTotals::read(&mut view) {
                Some(t) => image.push(t),
                None => bail!(
                    "{}: the totals of image `{name}` are damaged at pixel {}",
                    path.display(),
                    image.len()
                ),
            }
        }
        images.push(image);
    }
    ensure!(
        view.is_empty(),
        "{}: {} bytes follow the shard's totals; the file is damaged",
        path.display(),
        view.len()
    );
    Ok((header, images))
}

/// Checks that `headers` (of `paths`) are shards of `kind` of one render whose sample ranges
/// cover its samples once each; returns their order by first sample.
pub fn plan_merge(paths: &[&Path], headers: &[ShardHeader], kind: &str) -> Result<Vec<usize>> {
    ensure!(!headers.is_empty(), "no shard files to merge");
    for (path, h) in paths.iter().zip(headers) {
        ensure!(
            h.kind == kind,
            "{} is a shard of {} where {} is asked for: {}",
            path.display(),
            kind_name(&h.kind),
            kind_name(kind),
            if h.kind == EVAL_REFERENCE {
                "give it to `host eval --reference-from`"
            } else {
                "give it to `host merge`"
            }
        );
    }
    let first = &headers[0];
    for (path, h) in paths.iter().zip(headers).skip(1) {
        let same = rendered(&h.scene) == rendered(&first.scene)
            && (h.width, h.height, h.spp, h.sample_block)
                == (first.width, first.height, first.spp, first.sample_block)
            && h.images == first.images
            && h.render_fnv1a == first.render_fnv1a;
        if !same {
            let (mine, theirs) = (rendered(&h.scene), rendered(&first.scene));
            let keys: Vec<String> = mine
                .iter()
                .filter(|(k, v)| theirs.get(*k) != Some(v))
                .map(|(k, _)| k.clone())
                .chain(theirs.keys().filter(|k| !mine.contains_key(*k)).cloned())
                .collect();
            bail!(
                "{} is not a shard of the same render as {}: {}",
                path.display(),
                paths[0].display(),
                if keys.is_empty() && h.render_fnv1a != first.render_fnv1a {
                    format!(
                        "the same scene, but other parameters or lights (render hash {} against \
                         {}): a different host version or input file",
                        h.render_fnv1a, first.render_fnv1a
                    )
                } else if keys.is_empty() {
                    format!(
                        "image {}x{} at {} spp (block {}, images {:?}) against {}x{} at {} spp \
                         (block {}, images {:?})",
                        h.width,
                        h.height,
                        h.spp,
                        h.sample_block,
                        h.images,
                        first.width,
                        first.height,
                        first.spp,
                        first.sample_block,
                        first.images
                    )
                } else {
                    format!("their scenes differ in {}", keys.join(", "))
                }
            );
        }
    }
    let mut order: Vec<usize> = (0..headers.len()).collect();
    order.sort_by_key(|&i| headers[i].samples);
    let mut next = 0;
    for &i in &order {
        let [a, b] = headers[i].samples;
        ensure!(
            a == next,
            "{}",
            if a < next {
                format!(
                    "{} (samples {a}..{b}) overlaps the samples of another shard (up to {next}); \
                     each sample range may be merged once",
                    paths[i].display()
                )
            } else {
                format!(
                    "samples {next}..{a} of the render's {} are in no shard given; render them \
                     with --samples {next}..{a} and merge again",
                    first.spp
                )
            }
        );
        next = b;
    }
    ensure!(
        next == first.spp,
        "samples {next}..{} of the render's {} are in no shard given; render them with --samples \
         {next}..{} and merge again",
        first.spp,
        first.spp,
        first.spp
    );
    Ok(order)
}

/// Settings of a render's scene that say how and where it runs, not what it renders: shards
/// of one render may differ in them.
pub const RUN_KEYS: &[&str] = &["backend", "quiet", "out", "json"];

/// `scene` without [`RUN_KEYS`]: what must agree between shards.
fn rendered(scene: &super::scene_record::SceneRecord) -> super::scene_record::SceneRecord {
    scene
        .iter()
        .filter(|(k, _)| !RUN_KEYS.contains(&k.as_str()))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect()
}

/// One shard of a merged render, as its JSON summary lists it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ShardSummary {
    pub file: String,
    pub samples: [u32; 2],
    pub backend: String,
    pub device: String,
    pub elapsed_ms: f64,
}

/// A shard kind in words.
fn kind_name(kind: &str) -> &'static str {
    if kind == EVAL_REFERENCE {
        "an evaluation's reference"
    } else {
        "a render"
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::ExactSum;

    fn header(samples: [u32; 2]) -> ShardHeader {
        ShardHeader {
            kind: RENDER.into(),
            scene: [(
                "spp".to_owned(),
                super::super::scene_record::SceneValue::Integer(8),
            )]
            .into_iter()
            .collect(),
            width: 2,
            height: 1,
            spp: 8,
            samples,
            sample_block: 4,
            images: vec!["image".into()],
            render_fnv1a: "0".into(),
            payload_bytes: 0,
            payload_fnv1a: String::new(),
            backend: "cpu".into(),
            device: "test".into(),
            elapsed_ms: 1.0,
            host_version: "0".into(),
            command_line: vec![],
        }
    }

    /// A shard reads back as written; a cut or changed file and a non-shard are refused.
    #[test]
    fn round_trip_and_damage() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.shard");
        let totals = vec![
            PixelTotals {
                t: ExactSum::of(0.25),
                samples: 7,
                ..Default::default()
            },
            PixelTotals::default(),
        ];
        write(&path, &header([0, 4]), std::slice::from_ref(&totals)).unwrap();
        let (h, images) = read(&path).unwrap();
        assert_eq!(images, vec![totals]);
        assert_eq!(h.samples, [0, 4]);
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();
        let e = format!("{:#}", read(&path).unwrap_err());
        assert!(e.contains("cut short or changed"), "{e}");
        let mut changed = bytes.clone();
        *changed.last_mut().unwrap() ^= 1;
        std::fs::write(&path, &changed).unwrap();
        assert!(read(&path).is_err());
        std::fs::write(&path, b"P6 not a shard").unwrap();
        let e = format!("{:#}", read(&path).unwrap_err());
        assert!(e.contains("not a shard file"), "{e}");
        let e = format!("{:#}", read(dir.path()).unwrap_err());
        assert!(e.contains("not a regular file"), "{e}");
    }

    /// Merging needs the same render and every sample exactly once; the order is by sample.
    #[test]
    fn merge_plan() {
        let p = [Path::new("x"), Path::new("y"), Path::new("z")];
        let ok = plan_merge(&p[..2], &[header([4, 8]), header([0, 4])], RENDER).unwrap();
        assert_eq!(ok, [1, 0]);
        let e = plan_merge(&p[..1], &[header([0, 4])], RENDER)
            .unwrap_err()
            .to_string();
        assert!(e.contains("samples 4..8") && e.contains("no shard"), "{e}");
        let e = plan_merge(
            &p,
            &[header([0, 4]), header([0, 4]), header([4, 8])],
            RENDER,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("overlaps"), "{e}");
        let mut other = header([4, 8]);
        other.scene.insert(
            "seed".into(),
            super::super::scene_record::SceneValue::Integer(3),
        );
        let e = plan_merge(&p[..2], &[header([0, 4]), other], RENDER)
            .unwrap_err()
            .to_string();
        assert!(e.contains("differ in seed"), "{e}");
    }
}
