//! `host render` as a library call: checks, loads, packs, renders, writes the images and the
//! JSON summary.

pub mod layers;
pub mod lights;
pub mod merge;
pub mod options;
pub mod preview;
pub mod saved_view;
pub mod scene_record;
pub mod settings;
pub mod shard;
pub mod summary;

pub use lights::{direct_lights, lights_or_default};
pub use options::{
    check_render_flags, plan_render_outputs, plan_shard_output, RenderOptions, ShardOutput,
};
pub use settings::{Estimation, Exposure, Image, Lighting, PathDepth};
pub use summary::{Albedo, CameraSummary, IntegratorSettings, RenderSummary, SunSettings};

use crate::backend::job::Job;
use crate::backend::{Backend, BackendChoice};
use crate::lighting::SceneLights;
use crate::output::{write_json, write_png};
use crate::render::diagnostics::RayFlags;
use crate::render::shadow_map::ShadowSummary;
use crate::render::Resident;
use crate::scene::camera::occupied_world_bounds;
use crate::scene::{prepare_scene, Scene};
use crate::volume::VolumeData;
use anyhow::Result;
use shared::kernels::render::PixelOut;
use shared::params::{Integrator, RenderParams};
use std::path::Path;
use std::time::Instant;

/// `host render`: checks flags and outputs, loads, packs, renders (or, with
/// [`RenderOptions::merge`], adds up shard files), writes EXR + PNG (+ JSON), prints a summary.
pub fn run_render(args: &RenderOptions) -> Result<RenderSummary> {
    check_render_flags(args)?;
    let merge = !args.merge.is_empty();
    let totals = crate::render::keeps_totals(args.image.spp) || merge;
    crate::render::check_image_memory(args.image.width, args.image.height, 1, totals)?;
    let png = plan_render_outputs(args)?;
    let mut setup = Setup::new(args, args.image.spp)?;
    let resident = Resident::new(&setup.backend, &setup.scene.packed)?;
    let shadows = lit_shadows(
        args,
        &resident,
        &setup.params,
        &mut setup.lights,
        &setup.scene,
    )?;
    let (params, lights, backend) = (&setup.params, &setup.lights, &setup.backend);
    let (pixels, extra, elapsed_ms, built, shards) = if merge {
        let m = merge::merge(args, params, lights)?;
        (
            m.pixels,
            m.extra,
            m.elapsed_ms,
            Default::default(),
            Some(m.shards),
        )
    } else {
        let (pixels, elapsed_ms, built) = backend
            .timed(|| crate::render::render_resident_lit(&resident, params, lights, !args.quiet))?;
        let extra = extra_renders(args, backend, &resident, params, lights)?;
        (pixels, extra, elapsed_ms, built, None)
    };
    let flags = RayFlags::of(&pixels, args.image.spp);
    flags.warn(params);
    crate::render::diagnostics::check_finite(&pixels, args.image.width)?;
    let direct = args.integrator.is_some_and(Integrator::is_lit);
    let (mean, tone) = write_images(args, &png, &pixels, &extra, direct)?;
    let rays = pixels.len() as f64 * args.image.spp as f64;
    let samples: f64 = pixels.iter().map(|p| p.samples as f64).sum();
    let mut summary = summary::summarize(&summary::Rendered {
        args,
        scene: &setup.scene,
        params,
        backend,
        lights,
        shadows,
        png: &png,
        flags,
        mean,
        samples_per_ray: samples / rays,
        elapsed_ms,
        built,
        load_ms: setup.load_ms,
        per_ray: setup.per_ray,
    })?;
    summary.shards = shards;
    summary.preview = summary::PreviewSummary::of(args, tone);
    summary.layer_passes = layer_pass_flags(args, &extra);
    if let Some(path) = &args.json {
        write_json(path, &summary)?;
    }
    print_line(args, &summary, &setup.scene, built, mean);
    Ok(summary)
}

/// `host render --samples A..B --shard FILE`: renders samples A..B of the render `args`
/// describes and writes their exact per-pixel totals to FILE (no image: `host merge` adds the
/// shards of a render up into its images).
pub fn run_shard(args: &RenderOptions, out: &ShardOutput) -> Result<shard::ShardHeader> {
    check_render_flags(args)?;
    out.check(args.image.spp)?;
    crate::render::check_image_memory(args.image.width, args.image.height, 1, true)?;
    plan_shard_output(args, &out.path)?;
    // The input files' identity, read before they are loaded (and not after hours of rendering).
    let inputs = shard::record_inputs(&shard::input_paths(
        &args.scene.volume,
        args.lighting.env.as_ref(),
        args.scene_file.as_deref(),
    ))?;
    // `--backend auto` weighs the shard's samples, not the whole render's.
    let mut setup = Setup::new(args, out.samples.1 - out.samples.0)?;
    let resident = Resident::new(&setup.backend, &setup.scene.packed)?;
    lit_shadows(
        args,
        &resident,
        &setup.params,
        &mut setup.lights,
        &setup.scene,
    )?;
    let (params, lights, backend) = (&setup.params, &setup.lights, &setup.backend);
    let samples = out.samples.0..out.samples.1;
    let ((images, names), elapsed_ms, _) = backend.timed(|| {
        let image =
            crate::render::render_totals(&resident, params, lights, samples.clone(), !args.quiet)?;
        let mut images = vec![image];
        let mut names = vec!["image".to_owned()];
        for (name, p) in options::extra_passes(args, params) {
            images.push(crate::render::render_totals(
                &resident,
                &p,
                lights,
                samples.clone(),
                false,
            )?);
            names.push(name.to_owned());
        }
        Ok((images, names))
    })?;
    let header = shard::ShardHeader {
        kind: shard::RENDER.into(),
        scene: args.scene_record.clone(),
        width: args.image.width,
        height: args.image.height,
        spp: args.image.spp,
        samples: [samples.start, samples.end],
        sample_block: shared::kernels::render::SAMPLE_BLOCK,
        images: names,
        render_fnv1a: shard::render_fnv1a(params, lights),
        inputs,
        payload_bytes: 0,
        payload_fnv1a: String::new(),
        backend: backend.kind().into(),
        device: backend.device(),
        elapsed_ms,
        host_version: env!("CARGO_PKG_VERSION").into(),
        command_line: std::env::args().collect(),
    };
    shard::write(&out.path, &header, &images)?;
    println!(
        "shard: samples {}..{} of {} ({}x{}) on {}: {:.1} ms -> {} (merge the shards with `host \
         merge`)",
        samples.start,
        samples.end,
        args.image.spp,
        args.image.width,
        args.image.height,
        backend.kind(),
        elapsed_ms,
        out.path.display()
    );
    Ok(header)
}

/// What every render (a whole one, a shard, a merge) sets up before its pixels: the backend,
/// the loaded scene, the lights and the kernels' parameters.
pub struct Setup {
    pub backend: Backend,
    pub scene: Scene,
    pub lights: SceneLights,
    pub params: RenderParams,
    /// Loop iterations one ray may take.
    pub per_ray: u64,
    pub load_ms: f64,
}

impl Setup {
    /// Opens the backend (the CPU for a merge, which renders nothing but a shadow map), loads
    /// and packs the volume, fits the backend to a job of `spp` samples per pixel, builds the
    /// lights and parameters.
    pub fn new(args: &RenderOptions, spp: u32) -> Result<Setup> {
        let choice = if args.merge.is_empty() {
            args.backend
        } else {
            BackendChoice::Cpu
        };
        // The backend first: a forced GPU that is missing fails before any loading, and the
        // pool is laid out in the pages the device binds.
        Self::with_backend(args, Backend::open(choice)?, choice, spp)
    }

    /// [`Setup::new`] on `backend`, opened for `choice` (`host view` opens its GPU for its
    /// window).
    pub fn with_backend(
        args: &RenderOptions,
        backend: Backend,
        choice: BackendChoice,
        spp: u32,
    ) -> Result<Setup> {
        let t_load = Instant::now();
        let scene = load_scene(args, &backend)?;
        let load_ms = t_load.elapsed().as_secs_f64() * 1e3;
        let probe = render_params(args, &scene, &[]);
        let job = Job::render(args.integrator, args.image.width, args.image.height, spp)
            .wide_if(crate::backend::cpu::renders_wide(&scene.packed, &probe));
        let backend = backend.fit(choice, &scene.packed, &job)?;
        if !args.quiet {
            log_scene(args, &scene, &backend, load_ms);
        }
        let lights = render_lights(args, &scene.volume)?;
        let params = render_params(args, &scene, &lights.points);
        let per_ray = crate::render::loop_iterations_per_ray(&params, &scene.packed.desc);
        let backend = fall_back_from_long_rays(args, backend, per_ray, &scene.volume);
        Ok(Setup {
            backend,
            scene,
            lights,
            params,
            per_ray,
            load_ms,
        })
    }
}

/// The sun's shadow rays or moment shadow map of a `direct`-family render, built into `lights`
/// (None for other renders).
pub fn lit_shadows(
    args: &RenderOptions,
    resident: &Resident,
    params: &RenderParams,
    lights: &mut SceneLights,
    scene: &Scene,
) -> Result<Option<ShadowSummary>> {
    if !args.integrator.is_some_and(Integrator::is_lit) {
        return Ok(None);
    }
    build_shadows(args, resident, params, lights, &scene.volume).map(Some)
}

/// Loads and packs `--volume` in the pages `backend` binds, refusing grids it cannot hold
/// before any voxel is read.
fn load_scene(args: &RenderOptions, backend: &Backend) -> Result<Scene> {
    let check = backend.topology_check(args.backend, args.scene.brick_size);
    prepare_scene(
        &args.scene,
        args.estimation.lookup,
        args.image.width,
        args.image.height,
        backend.page_log2(),
        Some(crate::io::TopologyCheck(&check)),
    )
}

/// The volume's name, with the grid read from a file.
fn volume_label(scene: &Scene) -> String {
    match &scene.grid {
        Some(grid) => format!("{} (grid '{grid}')", scene.volume.name()),
        None => scene.volume.name().to_owned(),
    }
}

/// The info lines of a render before it starts: the volume as packed, and the backend.
fn log_scene(args: &RenderOptions, scene: &Scene, backend: &Backend, load_ms: f64) {
    let (vol, packed) = (&scene.volume, &scene.packed);
    tracing::info!(
        "volume {} {}x{}x{} (density scale {}, {} bricks of {}^3, {} occupied: {:.1} MiB of voxels), prepared in {load_ms:.0} ms",
        volume_label(scene),
        vol.dims()[0],
        vol.dims()[1],
        vol.dims()[2],
        scene.density_scale,
        packed.grid_bricks().len(),
        args.scene.brick_size,
        packed.occupied_bricks(),
        std::mem::size_of_val(packed.voxels.as_slice()) as f64 / (1 << 20) as f64
    );
    tracing::info!("backend: {} ({})", backend.kind(), backend.device());
}

/// The lights of a render: those of `direct`, `path` and `restir` (resampled points for
/// `restir`), or the point lights of the single-scattering integrators.
pub fn render_lights(args: &RenderOptions, vol: &dyn VolumeData) -> Result<SceneLights> {
    if args.integrator.is_some_and(Integrator::is_lit) {
        let mut l = direct_lights(args, vol)?;
        if args.integrator.is_some_and(|i| i.unit().resamples_points) {
            l.resample_points();
        }
        Ok(l)
    } else {
        Ok(SceneLights::points_only(&lights::scene_lights(args, vol)?))
    }
}

/// The kernels' parameters of a render: camera, image, estimator, and the integrator's
/// settings with the collision cap fitted to a GPU invocation's loop budget.
pub fn render_params(
    args: &RenderOptions,
    scene: &Scene,
    points: &[shared::sampling::lights::PointLight],
) -> RenderParams {
    let mut params = RenderParams {
        n: args.estimation.n,
        f_delta: args.estimation.f_delta,
        pixel_jitter: 1,
        roulette: args.estimation.ratio_roulette as u32,
        sampler: args.image.sampler as u32,
        ..scene.params(
            args.image.width,
            args.image.height,
            args.image.spp,
            args.image.seed,
        )
    };
    args.estimation.estimator.apply(&mut params);
    if let Some(integrator) = args.integrator {
        params.integrator = integrator as u32;
        params.light_count = points.len() as u32;
        params.albedo = args.lighting.albedo[0];
        params.hg_g = args.lighting.hg_g;
        params.t_hat = args.estimation.t_hat as u32;
        params.rr_depth = args.path.rr_depth;
        params.max_depth = args.path.max_depth;
        args.restir.apply(&mut params);
        if integrator.is_lit() {
            // A safeguard: lower the tracking loops' collision cap if one invocation would not
            // fit.
            params = crate::render::fit_collision_cap(&params, &scene.packed.desc);
        }
    }
    params
}

/// Under `--backend auto`, the CPU instead of a GPU on which one ray could exceed an
/// invocation's loop budget (with a warning).
fn fall_back_from_long_rays(
    args: &RenderOptions,
    backend: Backend,
    per_ray: u64,
    vol: &dyn VolumeData,
) -> Backend {
    match backend {
        Backend::Gpu(_)
            if args.backend == BackendChoice::Auto && per_ray > crate::render::LOOP_BUDGET =>
        {
            tracing::warn!(
                "one ray may need {per_ray} loop iterations through this {}x{}x{} grid, more than \
                 a GPU invocation may run; falling back to the CPU backend",
                vol.dims()[0],
                vol.dims()[1],
                vol.dims()[2]
            );
            Backend::Cpu
        }
        b => b,
    }
}

/// The sun's shadow rays or its moment shadow map (`--shadows`), built into `lights`.
fn build_shadows(
    args: &RenderOptions,
    resident: &Resident,
    params: &RenderParams,
    lights: &mut SceneLights,
    vol: &dyn VolumeData,
) -> Result<ShadowSummary> {
    let s = crate::render::shadow_map::build_into(
        resident,
        params,
        lights,
        occupied_world_bounds(vol),
        &args.shadows,
    )?;
    if let (Some(m), false) = (&s.map, args.quiet) {
        tracing::info!(
            "moment shadow map of the sun ({}, {}x{} texels, {:?}, {} bytes) built in {:.1} ms",
            crate::render::shadow_map::name(s.shadows),
            m.resolution,
            m.resolution,
            m.storage,
            m.bytes,
            m.build_ms
        );
    }
    Ok(s)
}

/// The passes the layers need beyond the image (`options::extra_passes`), by name: the same
/// camera rays rendered without the integrator, or to their first collision.
fn extra_renders(
    args: &RenderOptions,
    backend: &Backend,
    resident: &Resident,
    params: &RenderParams,
    lights: &SceneLights,
) -> Result<Vec<(&'static str, Vec<PixelOut>)>> {
    let mut out = Vec::new();
    for (name, p) in options::extra_passes(args, params) {
        let (pixels, _, _) =
            backend.timed(|| crate::render::render_resident_lit(resident, &p, lights, false))?;
        out.push((name, pixels));
    }
    Ok(out)
}

/// The rays of the layers' extra passes that a loop bound changed (a tracking collision cap),
/// each warned about: the same counts on every backend.
fn layer_pass_flags(
    args: &RenderOptions,
    extra: &[(&'static str, Vec<PixelOut>)],
) -> Vec<summary::LayerPass> {
    extra
        .iter()
        .map(|(name, pixels)| {
            let flags = RayFlags::of(pixels, args.image.spp);
            if flags.capped_rays > 0 {
                tracing::warn!(
                    "the {name} layer's pass: {} of {} rays reached a loop bound of their \
                     estimator, which changed their estimate (the depth pass counts such a ray \
                     as not colliding); lower --density-scale or use a smaller --brick-size",
                    flags.capped_rays,
                    flags.rays
                );
            }
            summary::LayerPass {
                name: (*name).to_owned(),
                capped_rays: flags.capped_rays,
            }
        })
        .collect()
}

/// Writes the EXR (linear) and its PNG preview ([`preview`]); returns the image's mean (T, or
/// L's luminance channel for integrators) and the preview's view transform.
pub fn write_images(
    args: &RenderOptions,
    png: &Path,
    pixels: &[PixelOut],
    extra: &[(&'static str, Vec<PixelOut>)],
    direct: bool,
) -> Result<(f64, preview::Preview)> {
    let pass = |name: &str| {
        extra
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, p)| p.as_slice())
    };
    let inputs = layers::LayerInputs {
        pixels,
        spp: args.image.spp,
        camera: pass(layers::Layer::CameraTransmittance.name()),
        depth: pass(layers::Layer::Depth.name()),
        albedo: args.lighting.albedo,
    };
    let t: Vec<f32> = pixels.iter().map(|p| p.t_mean).collect();
    let mean = t.iter().map(|&v| v as f64).sum::<f64>() / t.len() as f64;
    let extra: Vec<(String, crate::output::LayerValues)> = args
        .layers
        .iter()
        .map(|l| {
            let values = l.values(&inputs);
            (l.name().to_owned(), values)
        })
        .collect();
    let tone = preview::Preview::of(
        args.integrator,
        args.exposure.gain,
        !args.exposure.fixed,
        pixels,
    );
    if direct {
        let rgb: Vec<[f32; 3]> = pixels
            .iter()
            .map(|p| [p.rgb_mean.r, p.rgb_mean.g, p.rgb_mean.b])
            .collect();
        let (w, h) = (args.image.width, args.image.height);
        crate::output::write_exr_layers(&args.out, w, h, "radiance", &rgb, &extra)?;
        crate::output::write_rgb_png(png, w, h, &tone.rgb_bytes(pixels))?;
        return Ok((mean, tone));
    }
    // The image's part: the single-scattering integrators' grey image is radiance too.
    let part = if args.integrator.is_some() {
        "radiance"
    } else {
        "transmittance"
    };
    let rgb: Vec<[f32; 3]> = t.iter().map(|&v| [v, v, v]).collect();
    let (w, h) = (args.image.width, args.image.height);
    crate::output::write_exr_layers(&args.out, w, h, part, &rgb, &extra)?;
    let preview: Vec<f32> = t.iter().map(|&v| tone.grey(v)).collect();
    write_png(png, args.image.width, args.image.height, &preview)?;
    Ok((mean, tone))
}

/// The one line a render prints when it is done.
fn print_line(
    args: &RenderOptions,
    summary: &RenderSummary,
    scene: &Scene,
    built: crate::backend::gpu::BuildTime,
    mean: f64,
) {
    let compiled = match built.count {
        0 => String::new(),
        n => format!(
            " (+ {:.1} s compiling {n} GPU pipeline{} on first use)",
            built.wall.as_secs_f64(),
            if n == 1 { "" } else { "s" }
        ),
    };
    let ran = match &summary.shards {
        Some(shards) => format!(
            "merged from {} shard{} ({:.1} ms of rendering)",
            shards.len(),
            if shards.len() == 1 { "" } else { "s" },
            summary.elapsed_ms
        ),
        None => format!(
            "on {}: {:.1} ms{compiled}",
            summary.backend, summary.elapsed_ms
        ),
    };
    println!(
        "{} {}x{} spp {} {ran}, {:.2} samples/ray, mean {} {:.5} -> {} (volume {})",
        summary.estimator,
        args.image.width,
        args.image.height,
        args.image.spp,
        summary.mean_samples_per_ray,
        if args.integrator.is_some() { "L" } else { "T" },
        mean,
        args.out.display(),
        volume_label(scene)
    );
}
