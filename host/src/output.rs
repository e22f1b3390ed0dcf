//! Image and summary output: linear EXR, tone-mapped PNG preview, JSON summary.

use anyhow::{Context, Result};
use std::path::Path;

/// Writes a single-channel linear image as an RGB EXR (all channels equal), f32, ZIP-compressed
/// scan lines in increasing order, written on one thread so equal images give equal bytes.
pub fn write_exr(path: &Path, w: u32, h: u32, values: &[f32]) -> Result<()> {
    use exr::prelude::*;
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
        let v = values[pos.y() * w as usize + pos.x()];
        (v, v, v)
    });
    let layer = Layer::new(
        (w as usize, h as usize),
        LayerAttributes::named("transmittance"),
        encoding,
        channels,
    );
    Image::from_layer(layer)
        .write()
        .non_parallel()
        .to_file(path)
        .with_context(|| format!("writing {}", path.display()))
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

/// Writes a grayscale sRGB PNG preview of linear values (clamped to [0, 1]).
pub fn write_png(path: &Path, w: u32, h: u32, values: &[f32]) -> Result<()> {
    let bytes: Vec<u8> = values.iter().map(|&v| srgb8(v)).collect();
    image::save_buffer(path, &bytes, w, h, image::ColorType::L8)
        .with_context(|| format!("writing {}", path.display()))
}

/// Writes any serializable value as pretty JSON.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    std::fs::write(path, text + "\n").with_context(|| format!("writing {}", path.display()))
}

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
