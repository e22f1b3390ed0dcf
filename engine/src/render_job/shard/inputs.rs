//! The input files of a sharded render (the volume file, the light probe, the scene file): each
//! recorded in the shard by path, length and FNV-1a hash when the shard is rendered, compared
//! between the shards of one merge, and read again by `host merge` and `host eval
//! --reference-from`, which refuse a file that changed, is missing, or differs between shards.

use super::{fnv1a_more, hex, ShardHeader, FNV_BASIS};
use anyhow::{anyhow, bail, ensure, Context, Result};
use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

/// One input file of a render as its shards record it.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct InputFile {
    /// Which input: one of [`INPUT_KEYS`] (the flag that names it).
    pub key: String,
    /// Its absolute path where the shard was rendered (shards of other machines may name the
    /// same file by other paths).
    pub path: String,
    /// Its length in bytes and the FNV-1a 64-bit hash (hex) of its bytes.
    pub bytes: u64,
    pub fnv1a: String,
}

/// The keys of [`InputFile`]: the flags that name a render's input files.
pub const INPUT_KEYS: &[&str] = &["volume", "env", "scene"];

/// The inputs a merge reads, whose files it checks: the volume file and the light probe. The
/// scene file is recorded but not checked: a merge reads the scene the shard records (which
/// the header hash covers and the merge compares between shards), not the file, which may be
/// gone or rewritten since (a render's summary used as its scene is where the merge writes its
/// own summary).
pub const CHECKED_INPUTS: &[&str] = &["volume", "env"];

/// Input files by key ([`INPUT_KEYS`]) and path, as a render or an evaluation reads them.
pub type InputPaths = Vec<(&'static str, PathBuf)>;

/// The recorded inputs of `h` that a merge checks ([`CHECKED_INPUTS`]).
pub(super) fn checked(h: &ShardHeader) -> impl Iterator<Item = &InputFile> {
    h.inputs
        .iter()
        .filter(|i| CHECKED_INPUTS.contains(&i.key.as_str()))
}

/// A shard's checked inputs by key: their sizes and hashes, not their paths.
pub(super) fn identities(h: &ShardHeader) -> BTreeMap<&str, (u64, &str)> {
    checked(h)
        .map(|i| (i.key.as_str(), (i.bytes, i.fnv1a.as_str())))
        .collect()
}

/// An input key in words.
pub(super) fn input_name(key: &str) -> &'static str {
    match key {
        "volume" => "volume file",
        "env" => "light probe (--env)",
        "scene" => "scene file",
        _ => "input file",
    }
}

/// Refuses shard `h` (at `path`) rendered from other input files than shard `first`.
pub(super) fn check_same_inputs(
    path: &Path,
    h: &ShardHeader,
    first_path: &Path,
    first: &ShardHeader,
) -> Result<()> {
    if identities(h) == identities(first) {
        return Ok(());
    }
    let describe = |h: &ShardHeader, key: &str| match h.inputs.iter().find(|i| i.key == key) {
        Some(i) => format!("{} ({} bytes, hash {})", i.path, i.bytes, i.fnv1a),
        None => "none".to_owned(),
    };
    let (mine, theirs) = (identities(h), identities(first));
    let keys: Vec<&str> = CHECKED_INPUTS
        .iter()
        .copied()
        .filter(|k| mine.get(k) != theirs.get(k))
        .collect();
    bail!(
        "{}: rendered from other input files than {}: {}; render every shard of one render from \
         the same files",
        path.display(),
        first_path.display(),
        keys.iter()
            .map(|k| format!(
                "{} {} against {}",
                input_name(k),
                describe(h, k),
                describe(first, k)
            ))
            .collect::<Vec<_>>()
            .join("; ")
    )
}

/// The input files a render or an evaluation reads, by key: the volume `volume` unless it is an
/// embedded one (as the loader decides: a name of [`crate::scene::procedural::NAMES`] that is no file),
/// the light probe `env` if it is a file, and the scene file; each made absolute as the loader
/// would resolve it (from the working directory).
pub fn input_paths(
    volume: &str,
    env: Option<&crate::lighting::EnvSource>,
    scene_file: Option<&Path>,
) -> InputPaths {
    let absolute = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let mut inputs = Vec::new();
    if crate::scene::is_volume_file(volume) || !crate::scene::procedural::NAMES.contains(&volume) {
        inputs.push(("volume", absolute(Path::new(volume))));
    }
    if let Some(crate::lighting::EnvSource::File(p)) = env {
        inputs.push(("env", absolute(p)));
    }
    if let Some(p) = scene_file {
        inputs.push(("scene", absolute(p)));
    }
    inputs
}

/// The length and FNV-1a 64-bit hash (hex) of the regular file at `path`, read in pieces of
/// 1 MiB (a volume may be many GB).
pub fn file_identity(path: &Path) -> std::io::Result<(u64, String)> {
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file",
        ));
    }
    let mut file = std::fs::File::open(path)?;
    let mut buf = vec![0u8; 1 << 20];
    let (mut h, mut bytes) = (FNV_BASIS, 0u64);
    loop {
        let n = match file.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        h = fnv1a_more(h, &buf[..n]);
        bytes += n as u64;
    }
    Ok((bytes, hex(h)))
}

/// The [`ShardHeader::inputs`] of `inputs`: each file's absolute path, length and hash.
pub fn record_inputs(inputs: &[(&'static str, PathBuf)]) -> Result<Vec<InputFile>> {
    inputs
        .iter()
        .map(|(key, path)| {
            let (bytes, fnv1a) = file_identity(path).with_context(|| {
                format!(
                    "{}: cannot read the {} to record it in the shard",
                    path.display(),
                    input_name(key)
                )
            })?;
            Ok(InputFile {
                key: (*key).to_owned(),
                path: path.display().to_string(),
                bytes,
                fnv1a,
            })
        })
        .collect()
}

/// Checks that the input files `current` (by key, where this merge or evaluation reads them)
/// are those shard `h` (at `path`; [`plan_merge`] checked that the other shards agree) was
/// rendered from: the same keys of [`CHECKED_INPUTS`], each file present with the recorded
/// length and hash.
pub fn check_inputs(
    path: &Path,
    h: &ShardHeader,
    current: &[(&'static str, PathBuf)],
) -> Result<()> {
    let current: Vec<&(&str, PathBuf)> = current
        .iter()
        .filter(|(k, _)| CHECKED_INPUTS.contains(k))
        .collect();
    for (key, file) in current.iter().copied() {
        ensure!(
            checked(h).any(|i| i.key == *key),
            "{}: this run reads it as its {}, but shard {} was rendered without one ({}); render \
             the shards with the same input files, or run with theirs",
            file.display(),
            input_name(key),
            path.display(),
            recorded(h)
        );
    }
    for input in checked(h) {
        let Some((_, file)) = current.iter().copied().find(|(k, _)| *k == input.key) else {
            bail!(
                "{}: shard {} was rendered from the {} {}, which this run does not read; give \
                 it the same {} (or render the shards again with this run's inputs)",
                input.path,
                path.display(),
                input_name(&input.key),
                input.path,
                input_name(&input.key)
            );
        };
        let elsewhere = if Path::new(&input.path) == file.as_path() {
            String::new()
        } else {
            format!(" (at {} where it was rendered)", input.path)
        };
        let (bytes, fnv1a) = file_identity(file).map_err(|e| {
            anyhow!(
                "{}: the {} that shard {} was rendered from{elsewhere} is missing or unreadable \
                 ({e}); put that file back at {}, or render the shards again",
                file.display(),
                input_name(&input.key),
                path.display(),
                file.display()
            )
        })?;
        ensure!(
            (bytes, fnv1a.as_str()) == (input.bytes, input.fnv1a.as_str()),
            "{}: the {} changed since shard {} was rendered from it{elsewhere}: it is {bytes} \
             bytes of hash {fnv1a} where the shard records {} bytes of hash {}; put back the \
             file the shards were rendered from, or render every shard again",
            file.display(),
            input_name(&input.key),
            path.display(),
            input.bytes,
            input.fnv1a
        );
    }
    Ok(())
}

/// A shard's checked inputs in words.
pub(super) fn recorded(h: &ShardHeader) -> String {
    let files: Vec<String> = checked(h)
        .map(|i| format!("{} {}", input_name(&i.key), i.path))
        .collect();
    if files.is_empty() {
        return "it records no volume file or light probe".to_owned();
    }
    format!("it records {}", files.join(", "))
}
