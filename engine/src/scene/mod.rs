//! The scene of a command: the volume (embedded or a file), how it is packed into bricks and
//! super-voxels, and the camera framing it.

pub mod bricks;
pub mod camera;
pub mod procedural;
pub mod supervoxel_info;
pub mod traversal;

use crate::volume::{Volume, VolumeData};
use anyhow::{bail, Result};
use camera::{make_camera, occupied_world_bounds, world_to_index, CameraSpec};
use shared::volume::grid::Lookup;
use std::path::Path;

/// Defaults of the scene and render options (the CLI shows them as its defaults).
pub mod defaults {
    /// `--volume`.
    pub const VOLUME: &str = "cloud";
    /// `--resolution`.
    pub const RESOLUTION: u32 = 256;
    /// `--brick-size`.
    pub const BRICK_SIZE: u32 = super::bricks::DEFAULT_BRICK_SIZE;
    /// `--width` and `--height` of `host render`.
    pub const SIZE: u32 = 512;
    /// `--spp` of `host render`.
    pub const SPP: u32 = 4;
    /// `--fov` in degrees.
    pub const FOV: f32 = 40.0;
    /// `--albedo`.
    pub const ALBEDO: f32 = 0.8;
    /// `--exposure`.
    pub const EXPOSURE: f32 = 1.0;
    /// `--rr-depth` of `path`.
    pub const RR_DEPTH: u32 = 5;
    /// `--max-depth` of `path`.
    pub const MAX_DEPTH: u32 = 64;
    /// `--n`.
    pub const N: u32 = 10;
    /// `--f-delta`.
    pub const F_DELTA: f32 = 0.6;
}

/// The volume and the camera, shared by `host render`, `host eval` and `host bench`.
#[derive(Debug, Clone)]
pub struct SceneOptions {
    /// Embedded volume name or a .vdb / .nvdb file.
    pub volume: String,
    /// Grid to read from a file.
    pub grid: Option<String>,
    /// Set negative densities of a file to 0 instead of refusing it.
    pub clamp_negative: bool,
    /// Voxels per axis of an embedded volume (None: [`defaults::RESOLUTION`]); refused with a
    /// file, which has its own grid.
    pub resolution: Option<u32>,
    /// Extinction per unit of stored density (None: the volume's own).
    pub density_scale: Option<f32>,
    /// Voxels per brick along each axis.
    pub brick_size: u32,
    /// How the super-voxel statistics are stored.
    pub supervoxel_format: jackknife::SupervoxelFormat,
    /// Fixed or adaptive super-voxels.
    pub supervoxels: SupervoxelOptions,
    /// Camera position (None: framing the volume).
    pub camera: Option<[f32; 3]>,
    /// Point the camera looks at (None: the volume's center).
    pub look_at: Option<[f32; 3]>,
    /// Vertical field of view in degrees.
    pub fov: f32,
    /// The volume's up axis (rotated to the renderer's +y).
    pub up: camera::UpAxis,
}

impl SceneOptions {
    /// Voxels per axis of an embedded volume: `--resolution` or its default.
    pub fn embedded_resolution(&self) -> u32 {
        self.resolution.unwrap_or(defaults::RESOLUTION)
    }
}

impl Default for SceneOptions {
    fn default() -> Self {
        SceneOptions {
            volume: defaults::VOLUME.into(),
            grid: None,
            clamp_negative: false,
            resolution: None,
            density_scale: None,
            brick_size: defaults::BRICK_SIZE,
            supervoxel_format: jackknife::SupervoxelFormat::F32,
            supervoxels: SupervoxelOptions::default(),
            camera: None,
            look_at: None,
            fov: defaults::FOV,
            up: camera::UpAxis::Y,
        }
    }
}

/// `--supervoxels`, `--cell-size`, `--split-ratio` and `--split-occupancy` as given.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SupervoxelOptions {
    /// `--supervoxels adaptive`.
    pub adaptive: bool,
    /// Voxels per cell axis of a subdivided brick (default [`jackknife::DEFAULT_CELL_SIZE`]).
    pub cell_size: Option<u32>,
    /// Split ratio (default [`jackknife::DEFAULT_SPLIT_RATIO`]).
    pub split_ratio: Option<f32>,
    /// Split occupancy (default [`jackknife::DEFAULT_SPLIT_OCCUPANCY`]).
    pub split_occupancy: Option<f32>,
}

impl SupervoxelOptions {
    /// The builder's mode; refuses `--cell-size`, `--split-ratio` and `--split-occupancy`
    /// without `adaptive`, which
    /// would be ignored.
    pub fn mode(&self) -> Result<jackknife::Supervoxels> {
        if !self.adaptive {
            if self.cell_size.is_some() {
                bail!("--cell-size only applies to --supervoxels adaptive; add it or drop --cell-size");
            }
            if self.split_ratio.is_some() {
                bail!(
                    "--split-ratio only applies to --supervoxels adaptive; add it or drop --split-ratio"
                );
            }
            if self.split_occupancy.is_some() {
                bail!(
                    "--split-occupancy only applies to --supervoxels adaptive; add it or drop \
                     --split-occupancy"
                );
            }
            return Ok(jackknife::Supervoxels::Fixed);
        }
        Ok(jackknife::Supervoxels::Adaptive {
            cell: self.cell_size.unwrap_or(jackknife::DEFAULT_CELL_SIZE),
            ratio: self.split_ratio.unwrap_or(jackknife::DEFAULT_SPLIT_RATIO),
            occupancy: self
                .split_occupancy
                .unwrap_or(jackknife::DEFAULT_SPLIT_OCCUPANCY),
        })
    }

    /// "fixed" or "adaptive".
    pub fn name(&self) -> &'static str {
        if self.adaptive {
            "adaptive"
        } else {
            "fixed"
        }
    }
}

/// Lower-case name of a lookup mode (JSON summaries).
pub fn lookup_name(lookup: Lookup) -> String {
    format!("{lookup:?}").to_lowercase()
}

/// Whether `--volume` names a file (it exists, or ends in .vdb / .nvdb) rather than an embedded
/// volume.
pub fn is_volume_file(spec: &str) -> bool {
    let path = Path::new(spec);
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    path.exists() || ext.eq_ignore_ascii_case("vdb") || ext.eq_ignore_ascii_case("nvdb")
}

/// Checks `--volume` before any work: a volume file that exists as a regular file, or an
/// embedded volume's name.
pub fn check_volume_spec(spec: &str) -> Result<()> {
    if is_volume_file(spec) {
        let path = Path::new(spec);
        anyhow::ensure!(
            path.is_file(),
            "{spec}: {}",
            if path.exists() {
                "not a regular file (a directory, FIFO or device); give a .vdb or .nvdb file"
            } else {
                "no such file"
            }
        );
        return Ok(());
    }
    anyhow::ensure!(
        procedural::NAMES.contains(&spec),
        "{spec:?} is neither a file nor an embedded volume; embedded volumes: {}",
        procedural::NAMES.join(", ")
    );
    Ok(())
}

/// An embedded volume by name or a volume file by path, with its default density scale and, for
/// a file, the name of the grid read; `check` sees the bounding box before any voxel is read
/// or generated.
pub fn load_volume(
    scene: &SceneOptions,
    check: Option<crate::io::TopologyCheck>,
) -> Result<(Volume, f32, Option<String>)> {
    let spec = scene.volume.as_str();
    let path = Path::new(spec);
    if is_volume_file(spec) {
        if let Some(n) = scene.resolution {
            bail!(
                "--resolution {n}: {} is a volume file, whose grid has its own voxel counts; \
                 --resolution sets the size of an embedded volume (drop it)",
                path.display()
            );
        }
        let options = crate::io::LoadOptions {
            grid: scene.grid.as_deref(),
            clamp_negative: scene.clamp_negative,
            check_topology: check,
            ..Default::default()
        };
        let loaded = crate::io::load_volume_with(path, &options)?;
        if loaded.clamped_negative > 0 {
            tracing::warn!(
                "--clamp-negative set {} negative densities of {} to 0",
                loaded.clamped_negative,
                path.display()
            );
        }
        return Ok((loaded.volume, 1.0, Some(loaded.grid)));
    }
    let resolution = scene.embedded_resolution();
    if let (Some(grid), true) = (&scene.grid, procedural::NAMES.contains(&spec)) {
        bail!(
            "--grid {grid:?}: the embedded volume {spec:?} is one density field without grids; \
             --grid picks a grid of a .vdb or .nvdb file (drop it, or give --volume a file)"
        );
    }
    if let Some(check) = check {
        let n = u64::from(resolution);
        (check.0)(&crate::io::Topology {
            dims: [n; 3],
            tile_voxels: 0,
        })?;
    }
    match procedural::by_name(spec, resolution) {
        Some(v) => Ok((v, procedural::default_density_scale(spec), None)),
        None => bail!(
            "--volume {spec:?} is neither a file nor an embedded volume; embedded volumes: {}",
            procedural::NAMES.join(", ")
        ),
    }
}

/// A loaded and packed volume with the camera framing it.
pub struct Scene {
    pub volume: Volume,
    pub packed: bricks::PackedVolume,
    pub density_scale: f32,
    pub camera: shared::camera::Camera,
    pub world_to_index: shared::geometry::Affine3x4,
    /// The grid read from a volume file (None for embedded volumes).
    pub grid: Option<String>,
    /// World bounds of the occupied voxels (after `--up`), [lo, hi].
    pub world_bounds: [[f64; 3]; 2],
    pub up: camera::UpAxis,
}

impl Scene {
    /// Render parameters of this scene's camera for an image of `width` x `height` pixels at
    /// `spp` samples each with seed `seed`; every other field at its default, for the caller's
    /// struct update.
    pub fn params(
        &self,
        width: u32,
        height: u32,
        spp: u32,
        seed: u32,
    ) -> shared::params::RenderParams {
        shared::params::RenderParams {
            camera: self.camera,
            world_to_index: self.world_to_index,
            width,
            height,
            spp,
            seed,
            ..Default::default()
        }
    }
}

/// Loads the volume of `--volume` (`check`: see [`load_volume`]), packs it (its pool in pages
/// of 2^`page_log2` words: see [`crate::backend::Backend::page_log2`]) and sets up the camera for a `w` x `h`
/// image.
pub fn prepare_scene(
    args: &SceneOptions,
    lookup: Lookup,
    w: u32,
    h: u32,
    page_log2: u32,
    check: Option<crate::io::TopologyCheck>,
) -> Result<Scene> {
    anyhow::ensure!(
        args.fov.is_finite() && args.fov > 0.0 && args.fov < 180.0,
        "--fov must be in (0, 180) degrees (got {})",
        args.fov
    );
    // A spinner while loading and packing (seconds for production-size files); drawn only when
    // stderr is a terminal.
    let bar =
        indicatif::ProgressBar::new_spinner().with_message(format!("loading {}", args.volume));
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    let prepared = (|| -> Result<_> {
        let (mut volume, default_scale, grid) = load_volume(args, check)?;
        let turned = args.up.apply(volume.index_to_world());
        volume.set_index_to_world(turned);
        let density_scale = args.density_scale.unwrap_or(default_scale);
        bar.set_message(format!(
            "packing {} ({} voxels held {})",
            args.volume,
            volume.dims().iter().map(|&d| u64::from(d)).product::<u64>(),
            volume.storage()
        ));
        let packed = bricks::pack_paged(
            &volume,
            density_scale,
            args.brick_size,
            args.supervoxel_format,
            args.supervoxels.mode()?,
            lookup,
            page_log2,
        )?;
        Ok((volume, grid, density_scale, packed))
    })();
    // Cleared on errors too, so the spinner never stays above an error message.
    bar.finish_and_clear();
    let (volume, grid, density_scale, packed) = prepared?;
    report_underflow(&volume, &packed.underflow, density_scale)?;
    let spec = CameraSpec {
        position: args.camera,
        look_at: args.look_at,
        fov_deg: args.fov,
    };
    let bounds = occupied_world_bounds(&volume);
    let camera = make_camera(&spec, bounds, w, h)?;
    let world_to_index = world_to_index(volume.index_to_world())?;
    Ok(Scene {
        volume,
        packed,
        density_scale,
        camera,
        world_to_index,
        grid,
        world_bounds: [bounds.0, bounds.1],
        up: args.up,
    })
}

/// Warns (with a count) about nonzero densities that became 0 as scaled f16 values; refuses a
/// volume all of whose nonzero densities did, which would render as empty.
fn report_underflow(vol: &dyn VolumeData, u: &bricks::Underflow, scale: f32) -> Result<()> {
    let Some(([x, y, z], density)) = u.first else {
        return Ok(());
    };
    let (name, voxel) = (vol.name(), vol.describe_voxel(x, y, z));
    let what = format!(
        "{name}: {} of {} nonzero densities (first: {voxel}, density {density}) become 0: \
         times --density-scale {scale:e} they are below f32's smallest value, or more than 2^40 \
         below the largest density (the range of the f16 voxels)",
        u.count, u.nonzero
    );
    anyhow::ensure!(
        u.count < u.nonzero,
        "{what}: the volume would render as empty; raise --density-scale"
    );
    tracing::warn!("{what}; raise --density-scale if they matter");
    Ok(())
}
