//! Shard files: the exact per-pixel totals of one sample range of a render (`host render
//! --samples A..B --shard FILE`), which `host merge` adds up into the images one render of all
//! samples gives, byte for byte.
//!
//! A shard (format 2) is the 8 bytes `JKSHARD2`, the length of a JSON header (u32,
//! little-endian), the FNV-1a 64-bit hash of the bytes before it and the header (u64,
//! little-endian), the header ([`ShardHeader`]: the render's resolved scene, image size, samples,
//! input files, who rendered it, and the length and hash of the totals), then for each image
//! the header names, every pixel's [`PixelTotals`] in row-major order. The header hash covers
//! the header and the header covers the totals, so no byte of a shard changes unnoticed; every
//! header field is checked against the totals' length before anything is allocated.

use crate::render::totals::PixelTotals;
use anyhow::{anyhow, bail, ensure, Context, Result};
use shared::params::RenderParams;
use std::io::Read;
use std::path::Path;

mod inputs;
pub use inputs::*;

/// The first bytes of every shard file: [`MAGIC_STEM`] and the format's digit.
const MAGIC: &[u8; 8] = b"JKSHARD2";
/// What every shard format's first bytes start with.
const MAGIC_STEM: &[u8; 7] = b"JKSHARD";
/// Bytes before the header: the magic, the header's length, the header hash.
const PREFIX_BYTES: u64 = 8 + 4 + 8;

/// Longest header read (a scene record with many lights is a few KB).
const MAX_HEADER_BYTES: u32 = 16 << 20;

/// Most images one shard holds (the image and the layers' passes).
const MAX_IMAGES: usize = 8;

/// Fewest and most bytes of one pixel's [`PixelTotals`] in a shard: five exact sums of 4 + 4 k
/// bytes (k limbs, 0 to [`crate::render::exact::LIMBS`]), then four u64 counts.
const MIN_TOTALS_BYTES: u64 = 5 * 4 + 4 * 8;
const MAX_TOTALS_BYTES: u64 = 5 * (4 + 4 * crate::render::exact::LIMBS as u64) + 4 * 8;

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
    /// The input files the render read ([`INPUT_KEYS`]: the volume file, the light probe, the
    /// scene file; an embedded volume or sky is no file), by size and hash. Those of
    /// [`CHECKED_INPUTS`] must be the same in every shard of a merge, and the merge checks the
    /// files it reads against them.
    pub inputs: Vec<InputFile>,
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

/// The FNV-1a 64-bit offset basis: the hash of no bytes.
const FNV_BASIS: u64 = 0xcbf2_9ce4_8422_2325;

/// FNV-1a, 64 bits, of `bytes` after the bytes whose hash is `h`.
fn fnv1a_more(h: u64, bytes: &[u8]) -> u64 {
    bytes
        .iter()
        .fold(h, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3))
}

/// FNV-1a, 64 bits.
fn fnv1a(bytes: &[u8]) -> u64 {
    fnv1a_more(FNV_BASIS, bytes)
}

/// A hash as a shard records it: 16 hex digits.
fn hex(h: u64) -> String {
    format!("{h:016x}")
}

/// Whether `s` is a hash as [`hex`] writes it.
fn is_hex(s: &str) -> bool {
    s.len() == 16
        && s.bytes()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
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
    hex(fnv1a(&all))
}

/// The hash of a shard's header: of the magic, the header's length and the header.
fn header_fnv1a(json: &[u8]) -> Result<u64> {
    let len = u32::try_from(json.len())
        .ok()
        .filter(|&l| l <= MAX_HEADER_BYTES)
        .with_context(|| format!("a shard header of {} bytes is too long", json.len()))?;
    let h = fnv1a_more(FNV_BASIS, MAGIC);
    Ok(fnv1a_more(fnv1a_more(h, &len.to_le_bytes()), json))
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
        payload_fnv1a: hex(fnv1a(&payload)),
        ..header.clone()
    };
    ensure!(
        images.len() == header.images.len()
            && images
                .iter()
                .all(|i| i.len() as u64 == u64::from(header.width) * u64::from(header.height)),
        "{}: a shard of {} images of {}x{} pixels was given {} images of {:?} pixels",
        path.display(),
        header.images.len(),
        header.width,
        header.height,
        images.len(),
        images.iter().map(Vec::len).collect::<Vec<_>>()
    );
    check_header(&header, header.payload_bytes)
        .with_context(|| format!("{}: writing a shard", path.display()))?;
    let json = serde_json::to_vec(&header)?;
    let hash = header_fnv1a(&json)?;
    crate::output::write_atomically(path, |tmp| {
        let mut bytes = Vec::with_capacity(PREFIX_BYTES as usize + json.len() + payload.len());
        bytes.extend_from_slice(MAGIC);
        bytes.extend_from_slice(&(json.len() as u32).to_le_bytes());
        bytes.extend_from_slice(&hash.to_le_bytes());
        bytes.extend_from_slice(&json);
        bytes.extend_from_slice(&payload);
        std::fs::write(tmp, bytes).with_context(|| format!("writing {}", path.display()))
    })
}

/// Reads the header of shard `path`, refusing what is not a shard file, a header changed or
/// damaged since it was written (by its hash) and a header whose fields do not fit its totals'
/// length.
pub fn read_header(path: &Path) -> Result<ShardHeader> {
    let mut file = open(path)?;
    header_of(path, &mut file).map(|(h, _)| h)
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

/// The error of a shard whose bytes are not those written: `what` says which.
fn damaged(path: &Path, what: impl std::fmt::Display) -> anyhow::Error {
    anyhow!(
        "{}: the shard file was changed or damaged after it was written ({what}); render that \
         shard again",
        path.display()
    )
}

/// Reads and checks the header of the shard open as `file`; returns it and the length of the
/// totals that follow it in the file (checked against the header).
fn header_of(path: &Path, file: &mut std::fs::File) -> Result<(ShardHeader, u64)> {
    let not_a_shard = || {
        anyhow!(
            "{}: not a shard file (it does not start with {}); give the files `host render \
             --samples A..B --shard FILE` wrote",
            path.display(),
            String::from_utf8_lossy(MAGIC)
        )
    };
    let file_bytes = file
        .metadata()
        .with_context(|| format!("{}: cannot read this shard file", path.display()))?
        .len();
    let mut magic = [0u8; 8];
    file.read_exact(&mut magic).map_err(|_| not_a_shard())?;
    if &magic != MAGIC {
        if magic.starts_with(MAGIC_STEM) && magic[7].is_ascii_digit() {
            let older = magic[7] < MAGIC[7];
            bail!(
                "{}: a shard of format {} written by {} version of host, which this version \
                 (format {}) does not read; {}",
                path.display(),
                char::from(magic[7]),
                if older { "an older" } else { "a newer" },
                char::from(MAGIC[7]),
                if older {
                    "render it again with this version"
                } else {
                    "merge it with the version that wrote it"
                }
            );
        }
        return Err(not_a_shard());
    }
    let mut rest = [0u8; 12];
    file.read_exact(&mut rest)
        .map_err(|_| damaged(path, "it ends inside its first 20 bytes"))?;
    let (len, hash) = rest.split_at(4);
    let len = u32::from_le_bytes(len.try_into().context("4 bytes")?);
    let hash = u64::from_le_bytes(hash.try_into().context("8 bytes")?);
    let after_header = PREFIX_BYTES
        .checked_add(u64::from(len))
        .filter(|&end| len <= MAX_HEADER_BYTES && end <= file_bytes)
        .ok_or_else(|| {
            damaged(
                path,
                format!("a header of {len} bytes in a file of {file_bytes} bytes"),
            )
        })?;
    let mut json = vec![0u8; len as usize];
    file.read_exact(&mut json)
        .map_err(|_| damaged(path, "the header is cut short"))?;
    let actual = header_fnv1a(&json)?;
    if actual != hash {
        return Err(damaged(
            path,
            format!(
                "its header's hash is {} where the file says {}",
                hex(actual),
                hex(hash)
            ),
        ));
    }
    let header: ShardHeader = serde_json::from_slice(&json)
        .map_err(|e| damaged(path, format!("its header does not read: {e}")))?;
    let payload = file_bytes - after_header;
    check_header(&header, payload).map_err(|e| damaged(path, format!("{e:#}")))?;
    Ok((header, payload))
}

/// Checks every field of `h` that the merge relies on: a known kind, a non-empty image, a
/// sample range that a render writes, 1 to [`MAX_IMAGES`] images of distinct names, known
/// inputs, hashes in their form, and totals of `payload` bytes (those after the header) that
/// fit the image's pixels (checked arithmetic: no claim of the header is allocated before it).
fn check_header(h: &ShardHeader, payload: u64) -> Result<()> {
    ensure!(
        h.kind == RENDER || h.kind == EVAL_REFERENCE,
        "the shard kind `{}` is neither `{RENDER}` nor `{EVAL_REFERENCE}`",
        h.kind
    );
    ensure!(
        h.width > 0 && h.height > 0,
        "an image of {}x{} pixels",
        h.width,
        h.height
    );
    ensure!(
        h.spp > 0 && h.sample_block > 0,
        "{} samples per pixel in blocks of {}",
        h.spp,
        h.sample_block
    );
    let [a, b] = h.samples;
    ensure!(
        a < b && b <= h.spp && a % h.sample_block == 0 && (b % h.sample_block == 0 || b == h.spp),
        "samples {a}..{b} of {} in blocks of {}: not a range a shard holds",
        h.spp,
        h.sample_block
    );
    ensure!(
        !h.images.is_empty() && h.images.len() <= MAX_IMAGES,
        "it lists {} images where a shard holds 1 to {MAX_IMAGES}",
        h.images.len()
    );
    for (k, name) in h.images.iter().enumerate() {
        ensure!(
            !name.is_empty() && !h.images[..k].contains(name),
            "image {k} is named {name:?}: empty or twice"
        );
    }
    ensure!(
        h.kind != RENDER || h.images[0] == "image",
        "a render's shard whose first image is {:?}, not \"image\"",
        h.images[0]
    );
    ensure!(
        is_hex(&h.render_fnv1a) && is_hex(&h.payload_fnv1a),
        "hashes {:?} and {:?} are not 16 hex digits",
        h.render_fnv1a,
        h.payload_fnv1a
    );
    for (k, input) in h.inputs.iter().enumerate() {
        ensure!(
            INPUT_KEYS.contains(&input.key.as_str())
                && !h.inputs[..k].iter().any(|i| i.key == input.key)
                && !input.path.is_empty()
                && is_hex(&input.fnv1a),
            "the input {:?} ({:?}, hash {:?}) is not one of {INPUT_KEYS:?} once with a path and \
             a hash",
            input.key,
            input.path,
            input.fnv1a
        );
    }
    ensure!(
        h.payload_bytes == payload,
        "its header says {} bytes of totals where {payload} follow it",
        h.payload_bytes
    );
    let totals = u64::from(h.width)
        .checked_mul(u64::from(h.height))
        .and_then(|p| p.checked_mul(h.images.len() as u64));
    let fits = totals.is_some_and(|n| {
        n.checked_mul(MIN_TOTALS_BYTES)
            .is_some_and(|min| min <= payload)
            && n.checked_mul(MAX_TOTALS_BYTES)
                .is_none_or(|max| payload <= max)
    });
    ensure!(
        fits,
        "{} bytes of totals cannot be {} image{} of {}x{} pixels ({MIN_TOTALS_BYTES} to \
         {MAX_TOTALS_BYTES} bytes per pixel)",
        payload,
        h.images.len(),
        if h.images.len() == 1 { "" } else { "s" },
        h.width,
        h.height
    );
    Ok(())
}

/// Reads the header and totals of shard `path`; a header or totals changed or damaged since
/// the shard was written (a file cut short, edited, or grown) are refused.
pub fn read(path: &Path) -> Result<(ShardHeader, Vec<Totals>)> {
    let mut file = open(path)?;
    let (header, payload_bytes) = header_of(path, &mut file)?;
    // At most what the file held when its header was checked (plus one byte: a file that grew
    // since is refused, not read without end).
    let mut payload = Vec::new();
    file.take(payload_bytes.saturating_add(1))
        .read_to_end(&mut payload)
        .with_context(|| format!("reading {}", path.display()))?;
    let hash = hex(fnv1a(&payload));
    if payload.len() as u64 != header.payload_bytes || hash != header.payload_fnv1a {
        return Err(damaged(
            path,
            format!(
                "its totals are {} bytes of hash {hash} where its header says {} bytes of hash {}",
                payload.len(),
                header.payload_bytes,
                header.payload_fnv1a
            ),
        ));
    }
    // check_header bounded the pixels by the payload's length: these allocations are at most a
    // few times the file's size.
    let pixels = header.width as usize * header.height as usize;
    let mut view = payload.as_slice();
    let mut images = Vec::new();
    for name in &header.images {
        let mut image = Vec::with_capacity(pixels);
        for _ in 0..pixels {
            match PixelTotals::read(&mut view) {
                Some(t) => image.push(t),
                None => {
                    return Err(damaged(
                        path,
                        format!(
                            "the totals of image `{name}` do not read at pixel {}",
                            image.len()
                        ),
                    ))
                }
            }
        }
        images.push(image);
    }
    if !view.is_empty() {
        return Err(damaged(
            path,
            format!("{} bytes follow the totals of its images", view.len()),
        ));
    }
    Ok((header, images))
}

/// Checks that `headers` (of `paths`) are shards of `kind` of one render, rendered from the
/// same input files (by size and hash; their paths may differ), whose sample ranges cover its
/// samples once each; returns their order by first sample.
pub fn plan_merge(paths: &[&Path], headers: &[ShardHeader], kind: &str) -> Result<Vec<usize>> {
    ensure!(
        paths.len() == headers.len(),
        "{} shard files but {} headers",
        paths.len(),
        headers.len()
    );
    let (Some(first), Some(first_path)) = (headers.first(), paths.first()) else {
        bail!("no shard files to merge");
    };
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
    for (path, h) in paths.iter().zip(headers).skip(1) {
        // Other input files first: they also change the render hash.
        check_same_inputs(path, h, first_path, first)?;
        let (mine, theirs) = (rendered(h), rendered(first));
        let keys = super::scene_record::differing_keys(&mine, &theirs);
        let same = keys.is_empty()
            && (h.width, h.height, h.spp, h.sample_block)
                == (first.width, first.height, first.spp, first.sample_block)
            && h.images == first.images
            && h.render_fnv1a == first.render_fnv1a;
        if !same {
            bail!(
                "{} is not a shard of the same render as {}: {}",
                path.display(),
                first_path.display(),
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
                    "samples {next}..{a} of the {} {} are in no shard given; {}",
                    noun(first),
                    first.spp,
                    advice(first, next, a)
                )
            }
        );
        next = b;
    }
    ensure!(
        next == first.spp,
        "samples {next}..{} of the {} {} are in no shard given; {}",
        first.spp,
        noun(first),
        first.spp,
        advice(first, next, first.spp)
    );
    Ok(order)
}

/// "render's" or "reference's" samples, by the shard's kind.
fn noun(h: &ShardHeader) -> &'static str {
    if h.kind == EVAL_REFERENCE {
        "reference's"
    } else {
        "render's"
    }
}

/// How to render the missing samples `a..b`, in the flags of the command that writes shards
/// of this kind.
fn advice(h: &ShardHeader, a: u32, b: u32) -> String {
    if h.kind == EVAL_REFERENCE {
        format!(
            "render them with `host eval ... --reference-shard FILE --reference-samples {a}..{b}` \
             and give every shard to --reference-from again"
        )
    } else {
        format!(
            "render them with `host render ... --samples {a}..{b} --shard FILE` and merge again"
        )
    }
}

/// Settings of a render's scene that say how and where it runs, not what it renders: shards
/// of one render may differ in them.
pub const RUN_KEYS: &[&str] = &["backend", "quiet", "out", "json"];

/// The scene of `h` without [`RUN_KEYS`] and without the paths of the input files it records
/// (those are compared by size and hash: another machine may keep them elsewhere): what must
/// agree between shards.
fn rendered(h: &ShardHeader) -> super::scene_record::SceneRecord {
    h.scene
        .iter()
        .filter(|(k, _)| !RUN_KEYS.contains(&k.as_str()))
        .filter(|(k, _)| !checked(h).any(|i| &i.key == *k))
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
    use super::super::scene_record::SceneValue;
    use super::*;
    use crate::render::exact::ExactSum;
    use std::path::PathBuf;

    fn header(samples: [u32; 2]) -> ShardHeader {
        ShardHeader {
            kind: RENDER.into(),
            scene: [("spp".to_owned(), SceneValue::Integer(8))]
                .into_iter()
                .collect(),
            width: 2,
            height: 1,
            spp: 8,
            samples,
            sample_block: 4,
            images: vec!["image".into()],
            render_fnv1a: "0000000000000000".into(),
            inputs: vec![],
            payload_bytes: 0,
            payload_fnv1a: String::new(),
            backend: "cpu".into(),
            device: "test".into(),
            elapsed_ms: 1.0,
            host_version: "0".into(),
            command_line: vec![],
        }
    }

    /// The totals of a 2 x 1 image.
    fn totals() -> Totals {
        vec![
            PixelTotals {
                t: ExactSum::of(0.25),
                samples: 7,
                ..Default::default()
            },
            PixelTotals::default(),
        ]
    }

    /// A shard of [`header`] and [`totals`] written to `dir`; its path and bytes.
    fn shard(dir: &Path, samples: [u32; 2]) -> (PathBuf, Vec<u8>) {
        let path = dir.join(format!("s{}.shard", samples[0]));
        write(&path, &header(samples), &[totals()]).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        (path, bytes)
    }

    /// The header (as JSON) and the totals of shard bytes.
    fn parts(bytes: &[u8]) -> (serde_json::Value, Vec<u8>) {
        let len = u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
        let json = &bytes[20..20 + len];
        (
            serde_json::from_slice(json).unwrap(),
            bytes[20 + len..].to_vec(),
        )
    }

    /// A shard of header `json` and totals `payload` with a header hash that fits (what one who
    /// knows the format can write).
    fn forge(json: &serde_json::Value, payload: &[u8]) -> Vec<u8> {
        let json = serde_json::to_vec(json).unwrap();
        let mut bytes = MAGIC.to_vec();
        bytes.extend_from_slice(&(json.len() as u32).to_le_bytes());
        bytes.extend_from_slice(&header_fnv1a(&json).unwrap().to_le_bytes());
        bytes.extend_from_slice(&json);
        bytes.extend_from_slice(payload);
        bytes
    }

    /// `read` of `bytes` (written to `path`) fails naming the file; its message.
    fn refused(path: &Path, bytes: &[u8]) -> String {
        std::fs::write(path, bytes).unwrap();
        let e = format!("{:#}", read(path).expect_err("read refuses"));
        assert!(e.contains(&path.display().to_string()), "{e}");
        e
    }

    /// [`refused`], and `read_header` fails as well (before any totals are read).
    fn header_refused(path: &Path, bytes: &[u8]) -> String {
        let e = refused(path, bytes);
        let h = format!("{:#}", read_header(path).expect_err("read_header refuses"));
        assert!(h.contains(&path.display().to_string()), "{h}");
        e
    }

    /// FNV-1a 64 as published ("" and "a"), in one piece and in pieces.
    #[test]
    fn shard_fnv1a_is_the_published_hash() {
        assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a_more(fnv1a(b"ab"), b"cd"), fnv1a(b"abcd"));
    }

    /// A shard reads back as written; a cut, grown or changed file, a non-shard and a
    /// directory are refused.
    #[test]
    fn shard_round_trip_and_damage() {
        let dir = tempfile::tempdir().unwrap();
        let (path, bytes) = shard(dir.path(), [0, 4]);
        let (h, images) = read(&path).unwrap();
        assert_eq!(images, vec![totals()]);
        assert_eq!(h.samples, [0, 4]);
        assert_eq!(read_header(&path).unwrap(), h);
        let e = header_refused(&path, &bytes[..bytes.len() - 1]);
        assert!(
            e.contains("changed or damaged") && e.contains("render that shard again"),
            "{e}"
        );
        let mut grown = bytes.clone();
        grown.push(0);
        header_refused(&path, &grown);
        let mut changed = bytes.clone();
        *changed.last_mut().unwrap() ^= 1;
        std::fs::write(&path, &changed).unwrap();
        let e = format!("{:#}", read(&path).unwrap_err());
        assert!(e.contains("changed or damaged"), "{e}");
        header_refused(&path, &bytes[..15]);
        std::fs::write(&path, b"P6 not a shard").unwrap();
        let e = format!("{:#}", read(&path).unwrap_err());
        assert!(e.contains("not a shard file"), "{e}");
        let e = format!("{:#}", read(dir.path()).unwrap_err());
        assert!(e.contains("not a regular file"), "{e}");
    }

    /// Any change of a header's bytes (its sample range, its image size, its hash, its length)
    /// is refused by the header hash, naming the file and the fix.
    #[test]
    fn shard_header_edits_are_refused_by_its_hash() {
        let dir = tempfile::tempdir().unwrap();
        let (path, bytes) = shard(dir.path(), [0, 4]);
        let edit = |from: &str, to: &str| {
            assert_eq!(from.len(), to.len());
            let at = bytes
                .windows(from.len())
                .position(|w| w == from.as_bytes())
                .unwrap_or_else(|| panic!("{from} not in the header"));
            let mut b = bytes.clone();
            b[at..at + to.len()].copy_from_slice(to.as_bytes());
            b
        };
        for (from, to) in [
            ("\"samples\":[0,4]", "\"samples\":[4,8]"),
            ("\"width\":2", "\"width\":1"),
            ("\"backend\":\"cpu\"", "\"backend\":\"gpu\""),
        ] {
            let e = header_refused(&path, &edit(from, to));
            assert!(
                e.contains("changed or damaged")
                    && e.contains("render that shard again")
                    && e.contains(&path.display().to_string()),
                "{to}: {e}"
            );
        }
        for at in [8, 12, 19] {
            let mut b = bytes.clone();
            b[at] ^= 1;
            let e = header_refused(&path, &b);
            assert!(e.contains("changed or damaged"), "byte {at}: {e}");
        }
    }

    /// Headers whose hash fits but whose fields are wrong (no images, a huge image, a sample
    /// range no render writes, totals of another length, unknown kinds and inputs) are refused
    /// before anything they claim is allocated, without a panic.
    #[test]
    fn shard_headers_that_lie_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let (path, bytes) = shard(dir.path(), [0, 4]);
        let (json, payload) = parts(&bytes);
        // The forgery of the unchanged header reads: the forger's hash is the writer's.
        std::fs::write(&path, forge(&json, &payload)).unwrap();
        assert!(read(&path).is_ok());
        type Edit = Box<dyn Fn(&mut serde_json::Value)>;
        let edits: Vec<(&str, Edit)> = vec![
            (
                "no images",
                Box::new(|j| j["images"] = serde_json::json!([])),
            ),
            (
                "an image twice",
                Box::new(|j| j["images"] = serde_json::json!(["image", "image"])),
            ),
            (
                "no image first",
                Box::new(|j| j["images"] = serde_json::json!(["depth"])),
            ),
            (
                "nine images",
                Box::new(|j| {
                    let names: Vec<String> = (0..9).map(|k| format!("i{k}")).collect();
                    j["images"] = names.into();
                    j["images"][0] = "image".into();
                }),
            ),
            (
                "100000 x 100000 pixels",
                Box::new(|j| {
                    j["width"] = 100000.into();
                    j["height"] = 100000.into();
                }),
            ),
            (
                "4294967295^2 pixels",
                Box::new(|j| {
                    j["width"] = u32::MAX.into();
                    j["height"] = u32::MAX.into();
                }),
            ),
            ("3 pixels", Box::new(|j| j["width"] = 3.into())),
            ("1 pixel", Box::new(|j| j["width"] = 1.into())),
            ("width 0", Box::new(|j| j["width"] = 0.into())),
            (
                "samples 4..2",
                Box::new(|j| j["samples"] = serde_json::json!([4, 2])),
            ),
            (
                "samples past spp",
                Box::new(|j| j["samples"] = serde_json::json!([0, 12])),
            ),
            (
                "samples off the blocks",
                Box::new(|j| j["samples"] = serde_json::json!([1, 4])),
            ),
            ("block 0", Box::new(|j| j["sample_block"] = 0.into())),
            ("spp 0", Box::new(|j| j["spp"] = 0.into())),
            (
                "more payload",
                Box::new(|j| j["payload_bytes"] = u64::MAX.into()),
            ),
            ("another kind", Box::new(|j| j["kind"] = "other".into())),
            ("a bad hash", Box::new(|j| j["payload_fnv1a"] = "x".into())),
            (
                "an unknown input",
                Box::new(|j| {
                    j["inputs"] = serde_json::json!([
                        {"key": "nope", "path": "/x", "bytes": 1, "fnv1a": "0000000000000000"}
                    ])
                }),
            ),
            (
                "an input twice",
                Box::new(|j| {
                    let one = serde_json::json!(
                        {"key": "volume", "path": "/x", "bytes": 1, "fnv1a": "0000000000000000"}
                    );
                    j["inputs"] = serde_json::json!([one.clone(), one]);
                }),
            ),
            (
                "no inputs field",
                Box::new(|j| {
                    j.as_object_mut().unwrap().remove("inputs");
                }),
            ),
        ];
        for (what, edit) in &edits {
            let mut j = json.clone();
            edit(&mut j);
            // One pixel of two pixels' totals fits the header's bounds: the totals refuse it.
            let e = if *what == "1 pixel" {
                refused(&path, &forge(&j, &payload))
            } else {
                header_refused(&path, &forge(&j, &payload))
            };
            assert!(
                e.contains("changed or damaged") && e.contains("render that shard again"),
                "{what}: {e}"
            );
        }
        // A header that says it is longer than the file.
        let mut long = forge(&json, &payload);
        long[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
        header_refused(&path, &long);
    }

    /// Shards of format 1 and of a newer format are refused, saying which version to use.
    #[test]
    fn shard_formats_other_than_this_one_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let (path, bytes) = shard(dir.path(), [0, 4]);
        let mut old = bytes.clone();
        old[7] = b'1';
        let e = header_refused(&path, &old);
        assert!(
            e.contains("older version") && e.contains("render it again"),
            "{e}"
        );
        old[7] = b'9';
        let e = header_refused(&path, &old);
        assert!(e.contains("newer version"), "{e}");
    }

    /// Merging needs the same render and every sample exactly once; the order is by sample.
    #[test]
    fn shard_merge_plan() {
        let p = [Path::new("x"), Path::new("y"), Path::new("z")];
        let ok = plan_merge(&p[..2], &[header([4, 8]), header([0, 4])], RENDER).unwrap();
        assert_eq!(ok, [1, 0]);
        let e = plan_merge(&p[..1], &[header([0, 4])], RENDER)
            .unwrap_err()
            .to_string();
        assert!(e.contains("samples 4..8") && e.contains("no shard"), "{e}");
        assert!(e.contains("--samples 4..8 --shard"), "{e}");
        // An evaluation's reference names eval's flags.
        let mut reference = header([0, 4]);
        reference.kind = EVAL_REFERENCE.into();
        let e = plan_merge(&p[..1], &[reference], EVAL_REFERENCE)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--reference-samples 4..8"), "{e}");
        assert!(!e.contains("--samples 4"), "{e}");
        let e = plan_merge(
            &p,
            &[header([0, 4]), header([0, 4]), header([4, 8])],
            RENDER,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("overlaps"), "{e}");
        let mut other = header([4, 8]);
        other.scene.insert("seed".into(), SceneValue::Integer(3));
        let e = plan_merge(&p[..2], &[header([0, 4]), other], RENDER)
            .unwrap_err()
            .to_string();
        assert!(e.contains("differ in seed"), "{e}");
        assert!(plan_merge(&p[..2], &[header([0, 4])], RENDER).is_err());
        assert!(plan_merge(&[], &[], RENDER).is_err());
    }

    /// A header of `samples` rendered from the volume `path` of hash `fnv1a`.
    fn from_volume(samples: [u32; 2], path: &str, fnv1a: &str) -> ShardHeader {
        let mut h = header(samples);
        h.scene
            .insert("volume".into(), SceneValue::Text(path.into()));
        h.inputs = vec![InputFile {
            key: "volume".into(),
            path: path.into(),
            bytes: 3,
            fnv1a: fnv1a.into(),
        }];
        h
    }

    /// Shards rendered from the same input files at other paths merge; from other files, or
    /// with and without a file, they do not, naming the file.
    #[test]
    fn shard_merge_plan_compares_inputs_by_identity() {
        let p = [Path::new("x"), Path::new("y")];
        let (same, other) = ("00000000000000aa", "00000000000000bb");
        let a = from_volume([0, 4], "/one/v.vdb", same);
        let b = from_volume([4, 8], "/two/v.vdb", same);
        plan_merge(&p, &[a.clone(), b], RENDER).unwrap();
        let b = from_volume([4, 8], "/one/v.vdb", other);
        let e = plan_merge(&p, &[a.clone(), b], RENDER)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("other input files")
                && e.contains("volume file /one/v.vdb (3 bytes, hash 00000000000000bb)"),
            "{e}"
        );
        let mut b = header([4, 8]);
        b.scene
            .insert("volume".into(), SceneValue::Text("/one/v.vdb".into()));
        let e = plan_merge(&p, &[a.clone(), b], RENDER)
            .unwrap_err()
            .to_string();
        assert!(e.contains("volume"), "{e}");
        // Scene files are not compared (the scenes are).
        let mut b = from_volume([4, 8], "/two/v.vdb", same);
        b.inputs.push(InputFile {
            key: "scene".into(),
            path: "/two/s.toml".into(),
            bytes: 9,
            fnv1a: other.into(),
        });
        plan_merge(&p, &[a, b], RENDER).unwrap();
    }

    /// Input files are recorded by absolute path, length and FNV-1a of their bytes (read in
    /// pieces); a file changed, missing, not a file, or read under another key is refused
    /// naming it and the shard; the same bytes at another path pass.
    #[test]
    fn shard_inputs_are_checked_by_length_and_hash() {
        let dir = tempfile::tempdir().unwrap();
        let vol = dir.path().join("v.vdb");
        let big: Vec<u8> = (0..3_000_017u32).map(|i| (i * 7 + i / 13) as u8).collect();
        std::fs::write(&vol, &big).unwrap();
        assert_eq!(
            file_identity(&vol).unwrap(),
            (big.len() as u64, hex(fnv1a(&big)))
        );
        std::fs::write(&vol, b"abc").unwrap();
        let current: InputPaths = vec![("volume", vol.clone())];
        let inputs = record_inputs(&current).unwrap();
        assert_eq!(
            inputs,
            [InputFile {
                key: "volume".into(),
                path: vol.display().to_string(),
                bytes: 3,
                fnv1a: hex(fnv1a(b"abc")),
            }]
        );
        let mut h = header([0, 8]);
        h.inputs = inputs;
        let s = Path::new("p0.shard");
        check_inputs(s, &h, &current).unwrap();
        let copy = dir.path().join("elsewhere.vdb");
        std::fs::write(&copy, b"abc").unwrap();
        check_inputs(s, &h, &[("volume", copy.clone())]).unwrap();
        std::fs::write(&vol, b"abd").unwrap();
        let e = check_inputs(s, &h, &current).unwrap_err().to_string();
        assert!(
            e.starts_with(&vol.display().to_string())
                && e.contains("volume file changed since shard p0.shard")
                && e.contains("render every shard again"),
            "{e}"
        );
        std::fs::remove_file(&vol).unwrap();
        let e = check_inputs(s, &h, &current).unwrap_err().to_string();
        assert!(e.contains("missing") && e.contains("p0.shard"), "{e}");
        std::fs::create_dir(&vol).unwrap();
        let e = check_inputs(s, &h, &current).unwrap_err().to_string();
        assert!(e.contains("not a regular file"), "{e}");
        let e = check_inputs(s, &h, &[]).unwrap_err().to_string();
        assert!(e.contains("does not read"), "{e}");
        let e = check_inputs(s, &h, &[("volume", copy.clone()), ("env", copy)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("rendered without one"), "{e}");
        assert!(record_inputs(&[("volume", dir.path().join("none.vdb"))]).is_err());
        // The scene file is recorded, not checked: a merge reads the scene the shard records.
        let scene = dir.path().join("s.toml");
        std::fs::write(&scene, b"spp = 8").unwrap();
        h.inputs = record_inputs(&[("scene", scene.clone())]).unwrap();
        std::fs::remove_file(&scene).unwrap();
        check_inputs(s, &h, &[]).unwrap();
        check_inputs(s, &h, &[("scene", dir.path().join("other.toml"))]).unwrap();
    }

    /// Embedded volumes and skies are no input files; files are made absolute.
    #[test]
    fn shard_input_paths() {
        use crate::lighting::EnvSource;
        assert!(input_paths("cloud", Some(&EnvSource::Sky), None).is_empty());
        let got = input_paths(
            "v.vdb",
            Some(&EnvSource::File("p.hdr".into())),
            Some(Path::new("s.toml")),
        );
        let keys: Vec<&str> = got.iter().map(|(k, _)| *k).collect();
        assert_eq!(keys, ["volume", "env", "scene"]);
        assert!(got.iter().all(|(_, p)| p.is_absolute()), "{got:?}");
    }
}
