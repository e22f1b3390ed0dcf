//! The sun's moment shadow map (`--shadows msm4|msm6`, Peters et al. 2017): its options, its
//! orthographic frame over the volume, its build on a backend (both passes of
//! `shared::kernels::shadow_map`), and what the JSON summary reports about it.

use crate::lighting::SceneLights;
use crate::render::Resident;
use anyhow::{ensure, Result};
use shared::geometry::V3;
use shared::kernels::launch::Launch;
use shared::kernels::shadow_map::MsmPass;
use shared::params::RenderParams;
use shared::shadows::map::{MsmDesc, MsmFilter, Shadows, MAX_FILTER_RADIUS};
use std::time::Instant;

/// `--msm-res` default: texels per side.
pub const DEFAULT_RESOLUTION: u32 = 512;
/// Smallest and largest `--msm-res` (the raw pass holds 24 bytes a texel: 2048^2 texels fit
/// lavapipe's 128 MiB storage buffers).
pub const MIN_RESOLUTION: u32 = 8;
pub const MAX_RESOLUTION: u32 = 2048;

/// Which shadow-map family `--shadows` asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ShadowKind {
    /// Shadow rays through `--estimator`.
    Rays,
    /// Four moments (Hamburger, Algorithm 1).
    Msm4,
    /// Six moments.
    Msm6,
}

/// How the moments are stored (`--msm-storage`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MsmStorage {
    /// 16-bit unorm after the quantization transform Theta_4* (four moments only).
    U16,
    /// 32-bit floats.
    F32,
}

/// The shadow options of a `direct` or `path` render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowOptions {
    pub kind: ShadowKind,
    /// None: 16 bits for four moments, 32 for six.
    pub storage: Option<MsmStorage>,
    /// Texels per side.
    pub resolution: u32,
    pub filter: MsmFilter,
    /// Prefilter radius in texels (0 without a filter).
    pub radius: u32,
}

impl Default for ShadowOptions {
    fn default() -> Self {
        ShadowOptions {
            kind: ShadowKind::Rays,
            storage: None,
            resolution: DEFAULT_RESOLUTION,
            filter: MsmFilter::None,
            radius: 0,
        }
    }
}

impl ShadowOptions {
    /// The storage actually used.
    pub fn storage(&self) -> MsmStorage {
        match (self.storage, self.kind) {
            (Some(s), _) => s,
            (None, ShadowKind::Msm4) => MsmStorage::U16,
            (None, _) => MsmStorage::F32,
        }
    }

    /// The `shared` mode of these options.
    pub fn mode(&self) -> Shadows {
        match (self.kind, self.storage()) {
            (ShadowKind::Rays, _) => Shadows::Rays,
            (ShadowKind::Msm4, MsmStorage::U16) => Shadows::Msm4U16,
            (ShadowKind::Msm4, MsmStorage::F32) => Shadows::Msm4,
            (ShadowKind::Msm6, _) => Shadows::Msm6,
        }
    }

    /// Refuses settings that cannot be built, naming the flag and the fix.
    pub fn check(&self) -> Result<()> {
        ensure!(
            !(self.kind == ShadowKind::Msm6 && self.storage == Some(MsmStorage::U16)),
            "--msm-storage u16: the six-moment map is stored as f32 only (the quantization \
             transform of the paper is for four moments); drop --msm-storage or use --shadows msm4"
        );
        ensure!(
            (MIN_RESOLUTION..=MAX_RESOLUTION).contains(&self.resolution),
            "--msm-res {}: must be {MIN_RESOLUTION} to {MAX_RESOLUTION} texels per side",
            self.resolution
        );
        ensure!(
            self.radius <= MAX_FILTER_RADIUS,
            "--msm-filter radius {}: at most {MAX_FILTER_RADIUS} texels",
            self.radius
        );
        Ok(())
    }
}

/// The map's orthographic frame for a sun toward `sun_dir` over the world box [lo, hi]: the
/// light travels along -sun_dir; square texels over the box's projection (one texel of margin
/// on each side), depth over its extent along the light.
pub fn frame(lo: [f64; 3], hi: [f64; 3], sun_dir: V3, resolution: u32) -> MsmDesc {
    let d = norm([-sun_dir.x as f64, -sun_dir.y as f64, -sun_dir.z as f64]);
    // A helper axis far from d, then u, v orthonormal to d.
    let a = if d[1].abs() < 0.9 {
        [0.0, 1.0, 0.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let u = norm(cross(a, d));
    let v = cross(d, u);
    let (mut min, mut max) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for c in 0..8 {
        let p = [0, 1, 2].map(|k| if c >> k & 1 == 1 { hi[k] } else { lo[k] });
        for (k, axis) in [u, v, d].iter().enumerate() {
            let s = dot(p, *axis);
            min[k] = min[k].min(s);
            max[k] = max[k].max(s);
        }
    }
    let n = resolution as f64;
    let side = (max[0] - min[0]).max(max[1] - min[1]).max(1e-6) * n / (n - 2.0);
    let cu = 0.5 * (min[0] + max[0]);
    let cv = 0.5 * (min[1] + max[1]);
    // Depth: a small margin so points on the box's faces lie strictly inside.
    let len = (max[2] - min[2]).max(1e-6);
    let (d0, depth) = (min[2] - 1e-3 * len, len * 1.002);
    let origin: [f64; 3] =
        [0, 1, 2].map(|k| (cu - 0.5 * side) * u[k] + (cv - 0.5 * side) * v[k] + d0 * d[k]);
    let f = |p: [f64; 3]| V3::new(p[0] as f32, p[1] as f32, p[2] as f32);
    MsmDesc {
        origin: f(origin),
        width: resolution,
        axis_u: f(u.map(|x| x * side)),
        height: resolution,
        axis_v: f(v.map(|x| x * side)),
        depth_len: depth as f32,
        dir: f(d),
        ones: u32::MAX,
        dequant: shared::shadows::msm::U16_DEQUANT,
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    a.map(|x| x / l)
}

/// What the JSON summary reports about the map.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ShadowSummary {
    pub shadows: ShadowKind,
    /// Absent with shadow rays.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub map: Option<MapSummary>,
}

/// The built map.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct MapSummary {
    pub storage: MsmStorage,
    pub resolution: u32,
    /// `none`, `box` or `gauss`.
    pub filter: String,
    pub filter_radius: u32,
    /// Wall time of both passes on the backend, including the read-back.
    pub build_ms: f64,
    /// Bytes of the stored map (the render reads these).
    pub bytes: u64,
}

/// Builds the sun's map on `resident`'s backend into `lights` (its frame and mode in the
/// `Lighting` block, its words in `shadow_map`); `bounds` is the world box holding the
/// volume's density. With shadow rays, nothing is built.
pub fn build_into(
    resident: &Resident,
    params: &RenderParams,
    lights: &mut SceneLights,
    bounds: ([f64; 3], [f64; 3]),
    opts: &ShadowOptions,
) -> Result<ShadowSummary> {
    opts.check()?;
    if opts.kind == ShadowKind::Rays {
        lights.lighting.shadows = Shadows::Rays as u32;
        lights.shadow_map = vec![0];
        return Ok(ShadowSummary {
            shadows: ShadowKind::Rays,
            map: None,
        });
    }
    ensure!(
        lights.lighting.sun.present != 0,
        "--shadows {}: the moment shadow map is the sun's, and this scene has none (--light and \
         --lights replace the default sky and its sun); add --sun x,y,z (or --env sky, whose \
         sun it is), or use --shadows rays",
        name(opts.kind)
    );
    let mode = opts.mode();
    let mut l = lights.lighting;
    l.shadows = mode as u32;
    l.shadow_map = frame(bounds.0, bounds.1, l.sun.dir, opts.resolution);
    let pass = MsmPass {
        launch: Launch {
            count: opts.resolution * opts.resolution,
            ..Launch::default()
        },
        filter: opts.filter as u32,
        radius: if opts.filter == MsmFilter::None {
            0
        } else {
            opts.radius
        },
        _pad: [0; 2],
    };
    let start = Instant::now();
    let words = resident.build_shadow_map(params, &l, &pass)?;
    let build_ms = start.elapsed().as_secs_f64() * 1e3;
    lights.lighting = l;
    lights.shadow_map = words;
    Ok(ShadowSummary {
        shadows: opts.kind,
        map: Some(MapSummary {
            storage: opts.storage(),
            resolution: opts.resolution,
            filter: format!("{:?}", opts.filter).to_lowercase(),
            filter_radius: pass.radius,
            build_ms,
            bytes: std::mem::size_of_val(lights.shadow_map.as_slice()) as u64,
        }),
    })
}

/// The flag spelling of a kind.
pub fn name(kind: ShadowKind) -> &'static str {
    match kind {
        ShadowKind::Rays => "rays",
        ShadowKind::Msm4 => "msm4",
        ShadowKind::Msm6 => "msm6",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every corner of the box projects inside the map (texels and depth), and the frame's axes
    /// are orthogonal to the light.
    #[test]
    fn the_frame_covers_the_box() {
        for sun in [
            V3::new(0.0, 1.0, 0.0),
            V3::new(0.6, 0.6, -0.5291503),
            V3::new(1.0, 0.0, 0.0),
            V3::new(-0.3, -0.2, 0.9327379),
        ] {
            let (lo, hi) = ([-1.0, -0.5, -2.0], [1.5, 0.5, 0.25]);
            let desc = frame(lo, hi, sun, 64);
            assert!(desc.axis_u.dot(desc.dir).abs() < 1e-5);
            assert!(desc.axis_v.dot(desc.dir).abs() < 1e-5);
            for c in 0..8 {
                let p = [0, 1, 2].map(|k| if c >> k & 1 == 1 { hi[k] } else { lo[k] } as f32);
                let (u, v, z) = desc.project(V3::new(p[0], p[1], p[2]));
                assert!(u > 0.99 && u < 63.01, "{sun:?} u {u}");
                assert!(v > 0.99 && v < 63.01, "{sun:?} v {v}");
                assert!(z > -1.0 && z < 1.0, "{sun:?} z {z}");
            }
        }
    }
}
