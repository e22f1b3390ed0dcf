//! Image and summary output: linear EXR, tone-mapped PNG preview, JSON summary.

use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

pub mod inputs;
pub mod partials;

use inputs::{file_id, normalize};

/// Writes a single-channel linear image as an RGB EXR (all channels equal), f32, ZIP-compressed
/// scan lines in increasing order, written on one thread so equal images give equal bytes.
pub fn write_exr(path: &Path, w: u32, h: u32, values: &[f32]) -> Result<()> {
    write_exr_layer(path, w, h, "transmittance", |k| {
        let v = values[k];
        (v, v, v)
    })
}

/// Writes one ZIP-compressed RGB scanline layer named `name`; `pixel(k)` gives row-major pixel k.
fn write_exr_layer(
    path: &Path,
    w: u32,
    h: u32,
    name: &str,
    pixel: impl Fn(usize) -> (f32, f32, f32) + Sync,
) -> Result<()> {
    use exr::prelude::*;
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    let channels = SpecificChannels::rgb(|pos: Vec2<usize>| pixel(pos.y() * w as usize + pos.x()));
    let layer = Layer::new(
        (w as usize, h as usize),
        LayerAttributes::named(name),
        encoding,
        channels,
    );
    write_atomically(path, |tmp| {
        Image::from_layer(layer)
            .write()
            .non_parallel()
            .to_file(tmp)
            .map_err(|e| write_error(path, &e))
    })
}

/// sRGB encoding of a linear value in [0, 1].
pub fn srgb8(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// The error of an image encoder writing `path`: its message once (the exr and image crates'
/// I/O errors repeat their cause as their source, which `{:#}` would print twice).
fn write_error(path: &Path, e: &dyn std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!("writing {}: {e}", path.display())
}

/// Writes a grayscale sRGB PNG preview of linear values (clamped to [0, 1]).
pub fn write_png(path: &Path, w: u32, h: u32, values: &[f32]) -> Result<()> {
    let bytes: Vec<u8> = values.iter().map(|&v| srgb8(v)).collect();
    write_png_bytes(path, w, h, &bytes, image::ExtendedColorType::L8)
}

/// Writes an RGB8 PNG (false-colour images).
pub fn write_rgb_png(path: &Path, w: u32, h: u32, rgb: &[u8]) -> Result<()> {
    write_png_bytes(path, w, h, rgb, image::ExtendedColorType::Rgb8)
}

/// Encodes a PNG in memory, then writes it with one checked write: an encoder writing through
/// a buffer would lose an error of its last flush (a full disk) and leave a truncated file.
fn write_png_bytes(
    path: &Path,
    w: u32,
    h: u32,
    pixels: &[u8],
    color: image::ExtendedColorType,
) -> Result<()> {
    use image::ImageEncoder;
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(pixels, w, h, color)
        .map_err(|e| write_error(path, &e))?;
    write_bytes(path, &png)
}

/// Writes `bytes` (an encoded image, a text) to `path` with one checked write
/// ([`write_atomically`]): for encoders, encode in memory and call this, so that no buffered
/// writer's last flush can lose an error and leave a truncated file in place.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomically(path, |tmp| {
        std::fs::write(tmp, bytes).map_err(|e| write_error(path, &e))
    })
}

/// Writes any serializable value as pretty JSON.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    write_text(path, &(text + "\n"))
}

/// Writes a text file ([`write_atomically`]).
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    write_bytes(path, text.as_bytes())
}

/// Writes file `path` through `write`, which is given a new temporary file in the same
/// directory (same extension, for writers that choose the format by it), then renames that into
/// place: an interrupted or failed write leaves the previous file, never a half-written one,
/// and no other name of the old file (a hard link) changes. A symbolic link at `path` is
/// written through: its target is replaced, the link stays. Refused, before anything is
/// written: a path that is an input of this process ([`inputs::protect`]) by any name, and an
/// existing path that is no regular file (a device, a FIFO, a socket), which the rename would
/// replace.
pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    inputs::refuse_input("writing", path)?;
    inputs::refuse_special("writing", path)?;
    let is_link = std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink());
    let target = if is_link {
        std::fs::canonicalize(path).unwrap_or_else(|_| path.to_owned())
    } else {
        path.to_owned()
    };
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_owned(),
        _ => PathBuf::from("."),
    };
    let name = target
        .file_name()
        .with_context(|| format!("{}: not a file path", path.display()))?;
    let suffix = temp_suffix(&target);
    let prefix = partials::prefix(&name.to_string_lossy());
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(&suffix);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // Like a plain create: 0666 less the umask (tempfile's default is 0600).
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let tmp = builder.tempfile_in(&dir).with_context(|| {
        format!(
            "writing {}: cannot create a temporary file in {}; check its permissions",
            path.display(),
            dir.display()
        )
    })?;
    let tmp_path = tmp.path().to_owned();
    partials::begin(&tmp_path);
    // Dropping `tmp` on an error removes the temporary file.
    let written = write(tmp.path()).and_then(|()| {
        tmp.persist(&target).map_err(|e| e.error).with_context(|| {
            format!(
                "writing {}: renaming the finished file into place",
                path.display()
            )
        })
    });
    partials::end(&tmp_path);
    written.map(drop)
}

/// The extension of a temporary file for `path` (".exr": writers choose the format by it);
/// none for an extension longer than 16 bytes, so the temporary name stays short.
fn temp_suffix(path: &Path) -> String {
    path.extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .filter(|s| s.len() <= 16)
        .unwrap_or_default()
}

/// The longest file name written ([`OutputPlan::check`] refuses longer ones before any work):
/// NAME_MAX of Linux's file systems.
pub const MAX_NAME_BYTES: usize = 255;

/// Creates the parent directory of `path` if needed.
pub fn ensure_parent(path: &Path) -> Result<()> {
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("creating directory {}", dir.display()))?;
        }
    }
    Ok(())
}

/// Whether a planned output is one file or a directory of files.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    File,
    Dir,
}

/// Every path a command will write, gathered before any work so that clashes and unwritable
/// paths are refused up front instead of after a long render (or by overwriting an output).
/// Outputs are compared with every input of the process ([`inputs::protect`]: the command
/// line's inputs and those named to any plan), by path and by file identity.
#[derive(Debug, Default)]
pub struct OutputPlan {
    /// (what writes it, for messages; the path as given; its absolute, normalized form; kind)
    entries: Vec<(String, PathBuf, PathBuf, Kind)>,
}

impl OutputPlan {
    /// An empty plan.
    pub fn new() -> Self {
        Self::default()
    }

    /// Plans a file written for `what` (a flag such as "--json", or "the PNG preview of --out").
    pub fn file(&mut self, what: &str, path: &Path) -> &mut Self {
        self.push(what, path, Kind::File)
    }

    /// Plans a directory whose files are written for `what`.
    pub fn dir(&mut self, what: &str, path: &Path) -> &mut Self {
        self.push(what, path, Kind::Dir)
    }

    /// Records a file the command reads (`what`, e.g. "--volume"), so no output of this
    /// process may replace it, by any name (links included): [`inputs::protect`].
    pub fn input(&mut self, what: &str, path: &Path) -> &mut Self {
        inputs::protect(what, path);
        self
    }

    /// Adds one entry.
    fn push(&mut self, what: &str, path: &Path, kind: Kind) -> &mut Self {
        self.entries
            .push((what.to_owned(), path.to_owned(), normalize(path), kind));
        self
    }

    /// Refuses clashes (two outputs on one path, an output on an input, an output that is a
    /// device, FIFO or socket, a file name too long to write), then checks that every output
    /// can be written, creating missing parent directories and output directories. Warns of
    /// temporary files that an interrupted earlier write left beside an output.
    pub fn check(&self) -> Result<()> {
        self.check_clashes()?;
        for (what, path, _, kind) in &self.entries {
            match kind {
                Kind::File => check_file(what, path)?,
                Kind::Dir => check_dir(what, path)?,
            }
        }
        for (what, path, _, kind) in &self.entries {
            if *kind == Kind::File {
                for stale in partials::stale(path) {
                    eprintln!(
                        "warning: {what} {}: {} is left from an interrupted write (or is being \
                         written by another process); remove it when no other run writes there",
                        path.display(),
                        stale.display()
                    );
                }
            }
        }
        Ok(())
    }

    /// Refuses two outputs on the same path and outputs on inputs.
    fn check_clashes(&self) -> Result<()> {
        for (i, (what, path, norm, kind)) in self.entries.iter().enumerate() {
            if *kind == Kind::File {
                inputs::refuse_input(what, path)?;
            } else if let Some(input) = inputs::all().iter().find(|inp| inp.path == *norm) {
                bail!(
                    "{what} {} would overwrite the input {}; choose another output path",
                    path.display(),
                    input.what
                );
            }
            let id = file_id(path).filter(|_| *kind == Kind::File);
            for (what2, path2, norm2, kind2) in &self.entries[..i] {
                let linked = id.is_some() && *kind2 == Kind::File && file_id(path2) == id;
                let same = linked || norm == norm2 && (*kind == Kind::File || *kind2 == Kind::File);
                if same {
                    bail!(
                        "{what2} and {what} are the same path ({} and {}): one would overwrite \
                         the other; give them different paths",
                        path2.display(),
                        path.display()
                    );
                }
            }
        }
        Ok(())
    }
}

/// Checks that file `path` can be written: not a directory, its directory exists (created if
/// missing) and accepts a new file, or the existing file opens for writing (not truncated).
fn check_file(what: &str, path: &Path) -> Result<()> {
    anyhow::ensure!(
        path.file_name().is_some(),
        "{what} {}: not a file path; give a file name",
        path.display()
    );
    anyhow::ensure!(
        !path.is_dir(),
        "{what} {} is a directory; give a file path",
        path.display()
    );
    let name_bytes = path.file_name().map_or(0, |n| n.as_encoded_bytes().len());
    anyhow::ensure!(
        name_bytes <= MAX_NAME_BYTES,
        "{what} {}: the file name is {name_bytes} bytes, longer than file systems allow \
         ({MAX_NAME_BYTES}); give a shorter name",
        path.display()
    );
    // Metadata only: opening a FIFO would block.
    inputs::refuse_special(what, path)?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_owned(),
        _ => PathBuf::from("."),
    };
    create_dir(what, path, &dir)?;
    if path.is_file() {
        std::fs::OpenOptions::new()
            .append(true)
            .open(path)
            .map(drop)
            .with_context(|| format!("{what} {} exists and cannot be written", path.display()))
    } else {
        probe_dir(what, path, &dir)
    }
}

/// Checks that directory `path` exists (created if missing) and accepts new files.
fn check_dir(what: &str, path: &Path) -> Result<()> {
    anyhow::ensure!(
        !path.exists() || path.is_dir(),
        "{what} {} exists and is not a directory; give a directory path",
        path.display()
    );
    create_dir(what, path, path)?;
    probe_dir(what, path, path)
}

/// Creates `dir` (and its parents) for output `path` of `what`, with an error naming both.
fn create_dir(what: &str, path: &Path, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| {
        format!(
            "{what} {}: cannot create directory {}; check the path (is a parent a file?) and \
             its permissions",
            path.display(),
            dir.display()
        )
    })
}

/// Creates and removes a probe file in `dir`, proving that `what` can write there.
fn probe_dir(what: &str, path: &Path, dir: &Path) -> Result<()> {
    let probe = dir.join(format!(".host-write-probe-{}", std::process::id()));
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .with_context(|| {
            format!(
                "{what} {}: cannot write in directory {}; check its permissions or choose \
                 another path",
                path.display(),
                dir.display()
            )
        })?;
    std::fs::remove_file(&probe)
        .with_context(|| format!("removing the write probe {}", probe.display()))
}

/// Seconds between the progress lines of a bar whose stderr is no terminal (a log file).
pub const PROGRESS_LOG_SECS: u64 = 30;

/// A progress bar over `len` units on stderr (hidden when `quiet`). When stderr is no terminal
/// (a batch job's log), a line with the percentage, elapsed time and ETA every
/// [`PROGRESS_LOG_SECS`] seconds instead, none for work that ends sooner.
pub fn progress(len: u64, what: &str, quiet: bool) -> indicatif::ProgressBar {
    if quiet {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        let weak = bar.downgrade();
        let what = what.to_owned();
        std::thread::spawn(move || log_progress(&weak, &what));
    }
    bar.set_style(
        indicatif::ProgressStyle::with_template(&format!(
            "{{spinner}} {what} [{{bar:40}}] {{percent:>3}}% {{elapsed_precise}} eta {{eta}}"
        ))
        .expect("valid template")
        .progress_chars("=> "),
    );
    bar
}

/// The values of one extra EXR layer, row-major.
#[derive(Clone, Debug, PartialEq)]
pub enum LayerValues {
    /// One channel, `Y`.
    Y(Vec<f32>),
    /// Three channels, `R`, `G`, `B`.
    Rgb(Vec<[f32; 3]>),
}

/// The progress lines of a bar on a stderr that is no terminal, until the bar is finished or
/// dropped.
fn log_progress(weak: &indicatif::WeakProgressBar, what: &str) {
    loop {
        for _ in 0..PROGRESS_LOG_SECS {
            std::thread::sleep(std::time::Duration::from_secs(1));
            match weak.upgrade() {
                Some(bar) if !bar.is_finished() => {}
                _ => return,
            }
        }
        let Some(bar) = weak.upgrade() else { return };
        let (pos, len) = (bar.position(), bar.length().unwrap_or(0).max(1));
        let secs = |d: std::time::Duration| d.as_secs();
        eprintln!(
            "{what}: {:.0}% ({pos} of {len}), {} s elapsed, eta {} s",
            100.0 * pos as f64 / len as f64,
            secs(bar.elapsed()),
            secs(bar.eta())
        );
    }
}

/// Writes a linear RGB image as the layer `name` of an OpenEXR file, followed by one layer per
/// entry of `layers` (name, values: channel `Y`, or `R`, `G`, `B`): f32, ZIP-compressed scan
/// lines in increasing order, written on one thread so equal images give equal bytes. Without
/// `layers` the file is [`write_exr_rgb`]'s.
pub fn write_exr_layers(
    path: &Path,
    w: u32,
    h: u32,
    name: &str,
    rgb: &[[f32; 3]],
    layers: &[(String, LayerValues)],
) -> Result<()> {
    use exr::prelude::*;
    if layers.is_empty() {
        return write_exr_layer(path, w, h, name, |k| (rgb[k][0], rgb[k][1], rgb[k][2]));
    }
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    let size = (w as usize, h as usize);
    let rgb_channels = |rgb: &[[f32; 3]]| {
        let channel = |c: usize| -> Vec<f32> { rgb.iter().map(|p| p[c]).collect() };
        AnyChannels::sort(SmallVec::from_vec(vec![
            AnyChannel::new("R", FlatSamples::F32(channel(0))),
            AnyChannel::new("G", FlatSamples::F32(channel(1))),
            AnyChannel::new("B", FlatSamples::F32(channel(2))),
        ]))
    };
    let main = rgb_channels(rgb);
    let mut all = vec![Layer::new(
        size,
        LayerAttributes::named(name),
        encoding,
        main,
    )];
    for (layer, values) in layers {
        let channels = match values {
            LayerValues::Y(y) => AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new(
                "Y",
                FlatSamples::F32(y.clone()),
            )])),
            LayerValues::Rgb(rgb) => rgb_channels(rgb),
        };
        all.push(Layer::new(
            size,
            LayerAttributes::named(layer.as_str()),
            encoding,
            channels,
        ));
    }
    let image = Image::from_layers(
        ImageAttributes::new(IntegerBounds::from_dimensions(size)),
        all,
    );
    write_atomically(path, |tmp| {
        image
            .write()
            .non_parallel()
            .to_file(tmp)
            .map_err(|e| write_error(path, &e))
    })
}

/// Writes a linear RGB OpenEXR image (row-major texels).
pub fn write_exr_rgb(path: &Path, w: u32, h: u32, rgb: &[[f32; 3]]) -> Result<()> {
    write_exr_layer(path, w, h, "radiance", |k| {
        let v = rgb[k];
        (v[0], v[1], v[2])
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A write that fails leaves the previous file as it was and no temporary file.
    #[test]
    fn a_failed_write_leaves_the_previous_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.json");
        std::fs::write(&path, "previous").unwrap();
        let err = write_atomically(&path, |tmp| {
            std::fs::write(tmp, "half")?;
            anyhow::bail!("interrupted")
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "previous");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        write_text(&path, "new").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
