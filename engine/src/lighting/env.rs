//! Environment maps (light probes): reading equirectangular `.exr` and `.hdr` files, and the data
//! buffer `shared::sampling::env` samples (texels, then the marginal and conditional CDFs of
//! luminance x sin(theta), built in f64).

use anyhow::{bail, ensure, Context, Result};
use std::path::Path;

/// Largest map side accepted (16384 x 8192 RGB texels are 1.5 GiB of f32).
pub const MAX_SIDE: u32 = 16384;

/// Bytes a light probe holds per texel at its peak while loaded and rendered on the CPU: its
/// RGB f32 texels and their conditional CDF, one buffer ([`EnvMap::data`]). Measured: peak RSS
/// of `host render --backend cpu --integrator direct --env` of a 16384 x 8192 .hdr at 16^3,
/// 2.06 GiB for 134 M texels.
pub const BYTES_PER_TEXEL: u64 = 16;

/// Refuses a `w` x `h` probe whose peak ([`BYTES_PER_TEXEL`]) exceeds the memory this process
/// may still allocate (free memory, `ulimit -v`, the cgroup's limit), before any texel memory is
/// allocated: an allocation past a limit aborts the process.
fn check_memory(path: &Path, w: u64, h: u64, available: Option<u64>) -> Result<()> {
    let need = w * h * BYTES_PER_TEXEL;
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    if let Some(available) = available {
        let side = |s: u64| {
            let mut s = s;
            while s > 1 && s * s / 2 * BYTES_PER_TEXEL > available {
                s /= 2;
            }
            s
        };
        ensure!(
            need <= available,
            "--env {}: the {w}x{h} light probe needs {:.1} GiB ({BYTES_PER_TEXEL} bytes per \
             texel: RGB and its sampling tables), more than the {:.1} GiB of memory available \
             (the least of free memory, `ulimit -v` and the cgroup's limit); downsample it (a \
             {}x{} probe fits)",
            path.display(),
            gib(need),
            gib(available),
            side(w),
            side(w) / 2
        );
    }
    Ok(())
}

/// An equirectangular RGB map: row 0 at the +y pole, column 0 at phi = 0 (+x).
#[derive(Debug, Clone)]
pub struct EnvMap {
    pub width: u32,
    pub height: u32,
    /// Linear RGB radiance, row-major.
    pub texels: Vec<[f32; 3]>,
}

/// Refuses an `--env` path that is not a regular file (checked before any work, and again when
/// the probe is read).
pub fn check_path(path: &Path) -> Result<()> {
    ensure!(
        path.is_file(),
        "--env {}: {} (give an equirectangular .exr or .hdr light probe, or `sky`)",
        path.display(),
        if path.exists() {
            "not a regular file (a directory, FIFO or device)"
        } else {
            "no such file"
        }
    );
    Ok(())
}

impl EnvMap {
    /// One radiance in every direction (`--env constant:R,G,B`): a 1 x 1 map, which
    /// `shared::sampling::env` samples uniformly over the sphere.
    pub fn uniform(rgb: [f32; 3]) -> Self {
        EnvMap {
            width: 1,
            height: 1,
            texels: vec![rgb],
        }
    }

    /// A 4 x 2 map of one radiance everywhere (sampled by texel, as a light probe).
    pub fn constant(rgb: [f32; 3]) -> Self {
        EnvMap {
            width: 4,
            height: 2,
            texels: vec![rgb; 8],
        }
    }

    /// Reads `path` (`.exr`: the first layer's R, G, B; `.hdr`: Radiance RGBE) and checks that
    /// every texel is finite and non-negative.
    pub fn load(path: &Path) -> Result<Self> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        check_path(path)?;
        let map = match ext.as_str() {
            "exr" => read_exr(path)?,
            "hdr" => read_hdr(path)?,
            _ => bail!(
                "--env {}: unknown light probe format {ext:?}; use an equirectangular .exr or \
                 .hdr file, or `sky`",
                path.display()
            ),
        };
        map.check(&format!("--env {}", path.display()))?;
        Ok(map)
    }

    /// Refuses empty, oversized, non-finite or negative maps (`what` names the input).
    pub fn check(&self, what: &str) -> Result<()> {
        ensure!(
            self.width >= 1 && self.height >= 1,
            "{what}: the light probe has no texels"
        );
        ensure!(
            self.width <= MAX_SIDE && self.height <= MAX_SIDE,
            "{what}: {}x{} texels is larger than {MAX_SIDE} on a side; downsample the probe",
            self.width,
            self.height
        );
        ensure!(
            self.texels.len() == (self.width * self.height) as usize,
            "{what}: texel count does not match its size"
        );
        if let Some((k, t)) = self
            .texels
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|v| !v.is_finite() || *v < 0.0))
        {
            bail!(
                "{what}: texel ({}, {}) is {:?}; a light probe needs finite, non-negative radiance",
                k as u32 % self.width,
                k as u32 / self.width,
                t
            );
        }
        Ok(())
    }

    /// The data buffer of `shared::sampling::env` with every texel times `scale`: texels, the
    /// marginal CDF over rows and one conditional CDF per row of luminance x sin(theta).
    /// Returns (data, the integral of the scaled luminance over the sphere, int Y d omega).
    /// Consumes the map: its texels become the buffer's first part in place, so the peak is
    /// the buffer ([`BYTES_PER_TEXEL`]), not the buffer and a copy of the texels.
    pub fn data(self, scale: f32) -> Result<(Vec<f32>, f64)> {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut data: Vec<f32> = match bytemuck::allocation::try_cast_vec(self.texels) {
            Ok(flat) => flat,
            Err((_, texels)) => texels.into_iter().flatten().collect(),
        };
        let len = shared::sampling::env::EnvDesc::data_len(self.width, self.height);
        data.try_reserve_exact(len.saturating_sub(data.len()))
            .map_err(|_| {
                anyhow::anyhow!(
                    "cannot allocate {:.1} GiB for the light probe's sampling tables; downsample \
                     the probe",
                    len as f64 * 4.0 / (1u64 << 30) as f64
                )
            })?;
        for v in data.iter_mut() {
            *v *= scale;
        }
        let lum = |t: &[f32]| 0.2126 * t[0] as f64 + 0.7152 * t[1] as f64 + 0.0722 * t[2] as f64;
        // Per-texel weight f = Y sin(theta at the row centre); row sums give the marginal.
        let mut rows = vec![0.0f64; h];
        let mut f = vec![0.0f64; w];
        let mut integral = 0.0f64;
        for (j, row_sum) in rows.iter_mut().enumerate() {
            let theta = std::f64::consts::PI * (j as f64 + 0.5) / h as f64;
            let s = theta.sin();
            for (i, fi) in f.iter_mut().enumerate() {
                *fi = lum(&data[3 * (j * w + i)..3 * (j * w + i) + 3]) * s;
            }
            *row_sum = f.iter().sum();
            integral += *row_sum;
        }
        data.extend(cdf(&rows));
        for (j, &row_sum) in rows.iter().enumerate() {
            let s = (std::f64::consts::PI * (j as f64 + 0.5) / h as f64).sin();
            for (i, fi) in f.iter_mut().enumerate() {
                *fi = lum(&data[3 * (j * w + i)..3 * (j * w + i) + 3]) * s;
            }
            debug_assert_eq!(f.iter().sum::<f64>().to_bits(), row_sum.to_bits());
            data.extend(cdf(&f));
        }
        // Sum of Y sin(theta) dtheta dphi over texels of size (pi / h) x (2 pi / w); a 1 x 1
        // map is one radiance everywhere (shared::sampling::env): exactly 4 pi Y.
        let integral = if w == 1 && h == 1 {
            4.0 * std::f64::consts::PI * lum(&data[0..3])
        } else {
            integral * (std::f64::consts::PI / h as f64) * (2.0 * std::f64::consts::PI / w as f64)
        };
        Ok((data, integral))
    }
}

/// The CDF (n + 1 values from 0 to 1) of non-negative weights, in f64 and rounded once to f32;
/// all-zero weights give the uniform CDF.
fn cdf(f: &[f64]) -> Vec<f32> {
    let total: f64 = f.iter().sum();
    let n = f.len();
    let mut out = Vec::with_capacity(n + 1);
    let mut acc = 0.0f64;
    out.push(0.0);
    for (k, v) in f.iter().enumerate() {
        acc += if total > 0.0 {
            v / total
        } else {
            1.0 / n as f64
        };
        out.push(if k + 1 == n { 1.0 } else { acc.min(1.0) as f32 });
    }
    out
}

/// The first layer of an OpenEXR file as RGB (a missing channel reads as 0; alpha is ignored).
fn read_exr(path: &Path) -> Result<EnvMap> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        // Nothing is allocated from the header alone: a header that claims a huge image over
        // missing blocks is refused by the reader before the first texel arrives.
        |resolution, _| ExrTexels {
            width: resolution.width(),
            height: resolution.height(),
            texels: Vec::new(),
            failed: false,
            available: volume_io::available_memory(),
        },
        |t: &mut ExrTexels, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            t.set(pos.x(), pos.y(), [r, g, b])
        },
    )
    .with_context(|| format!("--env {}: not a readable RGB OpenEXR file", path.display()))?;
    let ExrTexels {
        width: w,
        height: h,
        texels,
        failed,
        available,
    } = image.layer_data.channel_data.pixels;
    ensure!(
        w as u64 <= MAX_SIDE as u64 && h as u64 <= MAX_SIDE as u64,
        "--env {}: {w}x{h} texels is larger than {MAX_SIDE} on a side; downsample the probe",
        path.display()
    );
    check_memory(path, w as u64, h as u64, available)?;
    ensure!(
        !failed,
        "--env {}: cannot allocate memory for {w}x{h} RGB texels ({:.1} GiB); downsample the probe",
        path.display(),
        (w * h * 12) as f64 / (1u64 << 30) as f64
    );
    Ok(EnvMap {
        width: w as u32,
        height: h as u32,
        texels,
    })
}

/// The texels of an OpenEXR layer being read, allocated (fallibly) when the first one arrives.
struct ExrTexels {
    width: usize,
    height: usize,
    texels: Vec<[f32; 3]>,
    /// The image is larger than [`MAX_SIDE`], needs more than `available` or its texels could
    /// not be allocated.
    failed: bool,
    /// The memory this process may still allocate, if known.
    available: Option<u64>,
}

impl ExrTexels {
    /// Stores texel (x, y), allocating all texels first (nothing when oversized).
    fn set(&mut self, x: usize, y: usize, rgb: [f32; 3]) {
        if self.texels.is_empty() && !self.failed {
            let n = self.width * self.height;
            let fits = self.width <= MAX_SIDE as usize
                && self.height <= MAX_SIDE as usize
                && self
                    .available
                    .is_none_or(|a| n as u64 * BYTES_PER_TEXEL <= a);
            if !fits || self.texels.try_reserve_exact(n).is_err() {
                self.failed = true;
                return;
            }
            self.texels.resize(n, [0.0; 3]);
        }
        if let Some(t) = self.texels.get_mut(y * self.width + x) {
            *t = rgb;
        }
    }
}

/// A reader of `path` as Radiance RGBE, whatever its bytes look like (a PNG renamed .hdr is
/// not decoded as 8-bit sRGB "radiance").
fn hdr_reader(path: &Path) -> Result<image::ImageReader<std::io::BufReader<std::fs::File>>> {
    let file = std::fs::File::open(path)
        .with_context(|| format!("--env {}: cannot open", path.display()))?;
    Ok(image::ImageReader::with_format(
        std::io::BufReader::new(file),
        image::ImageFormat::Hdr,
    ))
}

/// A Radiance `.hdr` (RGBE) file.
fn read_hdr(path: &Path) -> Result<EnvMap> {
    let (w, h) = hdr_reader(path)?
        .into_dimensions()
        .with_context(|| format!("--env {}: not a Radiance .hdr file", path.display()))?;
    ensure!(
        w <= MAX_SIDE && h <= MAX_SIDE,
        "--env {}: {w}x{h} texels is larger than {MAX_SIDE} on a side; downsample the probe",
        path.display()
    );
    check_memory(path, w.into(), h.into(), volume_io::available_memory())?;
    // The decoder's default 512 MiB allocation limit would refuse valid probes above 44 M texels
    // (a 16k x 8k probe is 1.6 GB); the size was bounded by MAX_SIDE above.
    let mut reader = hdr_reader(path)?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(12 * w as u64 * h as u64 + (64 << 20));
    reader.limits(limits);
    let img = reader
        .decode()
        .with_context(|| {
            format!(
                "--env {}: not a readable Radiance .hdr file",
                path.display()
            )
        })?
        .into_rgb32f();
    // In place where the buffer's capacity allows (it does: the decoder allocates exactly).
    let texels = match bytemuck::allocation::try_cast_vec(img.into_raw()) {
        Ok(texels) => texels,
        Err((_, raw)) => raw.as_chunks::<3>().0.to_vec(),
    };
    Ok(EnvMap {
        width: w,
        height: h,
        texels,
    })
}
