//! `host bench`: every transmittance estimator on the same rays, timed on the CPU and/or GPU,
//! with work-normalized variance, the goal ratios, and a sweep over volume resolution
//! and image size.

use anyhow::{bail, Context, Result};
use engine::backend::{Backend, BackendChoice};
use engine::estimators::EstimatorSpec;
use engine::render::{render_resident, Resident};
use engine::scene::SceneOptions;
use engine::volume::VolumeData;
use serde::Serialize;
use shared::kernels::render::PixelOut;
use shared::params::RenderParams;
use shared::volume::grid::Lookup;
use std::path::PathBuf;
use std::time::Instant;
use studies::plot::{self, Figure, Legend, LinePanel, Series, Style};

/// Where `host bench` runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchBackend {
    Cpu,
    Gpu,
    /// The CPU, then the GPU (skipped with a warning if there is none).
    Both,
}

/// What `host bench` times and where it writes the results.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    pub scene: SceneOptions,
    pub lookup: Lookup,
    /// The estimators to time.
    pub estimators: Vec<&'static EstimatorSpec>,
    pub backend: BenchBackend,
    pub width: u32,
    pub height: u32,
    /// Estimates per pixel per frame.
    pub spp: u32,
    pub n: u32,
    pub seed: u32,
    /// Timed frames per estimator.
    pub reps: u32,
    /// Untimed frames per estimator first.
    pub warmup: u32,
    /// Also sweep the embedded volume's resolution and the image size.
    pub sweep: bool,
    /// Volume resolutions of the sweep (8 to 1024).
    pub sweep_resolutions: Vec<u32>,
    /// Image sizes of the sweep (1 to 16384).
    pub sweep_sizes: Vec<u32>,
    /// Estimators of the sweep (and of `sweep_files`).
    pub sweep_estimators: Vec<&'static EstimatorSpec>,
    /// Volume files timed one by one (the sparse-volume series): load time, peak memory,
    /// pool and ns/ray of each, with the image and camera of `--width` and `--height`.
    pub sweep_files: Vec<PathBuf>,
    /// Plot of the sweep.
    pub plot: PathBuf,
    pub json: Option<PathBuf>,
    /// No progress lines.
    pub quiet: bool,
}

/// Timing and quality of one estimator on one backend.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub backend: String,
    pub device: String,
    pub estimator: String,
    /// Wall time per frame (submit to result on the host), median and minimum over the reps.
    pub frame_ms_median: f64,
    pub frame_ms_min: f64,
    pub frame_ms: Vec<f64>,
    /// GPU kernel time per frame from timestamp queries (median), if the device has them.
    pub kernel_ms_median: Option<f64>,
    /// Primary rays (estimates) per second at the median frame time.
    pub rays_per_s: f64,
    /// Wall time per estimate, ns.
    pub ns_per_ray: f64,
    /// High-resolution lookups per estimate.
    pub samples_per_ray: f64,
    /// Variance of one estimate, averaged over pixels (unbiased per-pixel sample variance).
    pub variance: f64,
    /// `variance * ns_per_ray`: the variance of a fixed time budget's mean, up to a constant
    /// (lower is better).
    pub work_normalized_variance: f64,
    /// GPU rows: the kernel, its SPIR-V module and the build of this row's pipeline.
    pub kernel: Option<KernelRow>,
}

/// The kernel a GPU row ran: its entry point, the size of its module (every variant; the
/// driver's specialization then removes what the row's constants cannot reach) and how long
/// the driver took to build the row's pipeline (on lavapipe a measure of the specialized code).
#[derive(Clone, Debug, Serialize)]
pub struct KernelRow {
    pub name: &'static str,
    pub module: engine::backend::gpu::module_stats::ModuleStats,
    /// Pipeline builds during the row's warm-up frames (0 when an earlier row built it).
    pub pipeline_build_ms: f64,
}

/// One of the goals, checked on one backend.
#[derive(Clone, Debug, Serialize)]
pub struct Goal {
    pub backend: String,
    pub what: String,
    pub ratio: f64,
    pub target: f64,
    pub met: bool,
}

/// One point of the sweep.
#[derive(Clone, Debug, Serialize)]
pub struct SweepPoint {
    pub backend: String,
    pub estimator: String,
    /// Voxels per axis of the volume.
    pub resolution: u32,
    /// Image width = height.
    pub size: u32,
    pub frame_ms_median: f64,
    pub ns_per_ray: f64,
    pub samples_per_ray: f64,
    /// Why the point is missing (e.g. the volume exceeds a GPU buffer), if it is.
    pub skipped: Option<String>,
    /// Wall time to generate (or load) and pack the volume, once per resolution.
    pub prepare_ms: f64,
    /// Bricks of the grid, those holding a nonzero voxel, and the bytes of their voxel pool.
    pub bricks: usize,
    pub occupied_bricks: usize,
    pub pool_bytes: u64,
    /// The volume (a file of `--sweep-files`, else the embedded volume's name) and its grid.
    pub volume: String,
    pub dims: [u32; 3],
    /// For `--sweep-files` (Linux): the process's resident memory before the volume was
    /// loaded (the renderer, the GPU driver, memory kept from earlier points) and its peak while
    /// the volume was loaded and packed (VmHWM after resetting it); their difference is what
    /// loading took.
    pub rss_before_bytes: Option<u64>,
    pub peak_rss_bytes: Option<u64>,
}

/// Everything `host bench` measured.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub volume: String,
    pub lookup: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub n: u32,
    pub seed: u32,
    pub reps: u32,
    pub threads: usize,
    /// Iterations of one super-voxel traversal per pixel-centre camera ray that meets the grid
    /// (Alg. 2 takes one such traversal, Alg. 1 a second; delta and ratio tracking one up to
    /// their last collision): skipped spans, bricks and cells.
    pub steps_per_traversal: engine::scene::traversal::ReadsPerRay,
    pub rows: Vec<Row>,
    pub goals: Vec<Goal>,
    pub sweep_resolution: Vec<SweepPoint>,
    pub sweep_size: Vec<SweepPoint>,
    /// One point per backend and sweep estimator for each file of `--sweep-files`.
    pub sweep_files: Vec<SweepPoint>,
}

/// Parses a comma-separated list of estimator names ("all": every one).
pub fn parse_estimators(list: &str, flag: &str) -> Result<Vec<&'static EstimatorSpec>> {
    crate::eval::parse_list_of(list, flag)
}

/// Parses the comma-separated whole numbers of `flag`, each in `range`.
pub fn parse_numbers(
    list: &str,
    flag: &str,
    range: std::ops::RangeInclusive<u32>,
) -> Result<Vec<u32>> {
    list.split(',')
        .map(|s| {
            let v: u32 = s
                .trim()
                .parse()
                .with_context(|| format!("{flag}: {s:?} is not a whole number"))?;
            anyhow::ensure!(
                range.contains(&v),
                "{flag}: {v} is outside {}..={}",
                range.start(),
                range.end()
            );
            Ok(v)
        })
        .collect()
}

/// The backends to time, each opened once.
fn backends(choice: BenchBackend) -> Result<Vec<Backend>> {
    let mut out = Vec::new();
    if choice != BenchBackend::Gpu {
        out.push(Backend::Cpu);
    }
    match choice {
        BenchBackend::Cpu => {}
        BenchBackend::Gpu => out.push(Backend::open(BackendChoice::Gpu)?),
        BenchBackend::Both => match Backend::open(BackendChoice::Gpu) {
            Ok(b) => out.push(b),
            Err(e) => tracing::warn!("{e:#}; timing the CPU only"),
        },
    }
    Ok(out)
}

/// The pages the volumes are packed in: the largest any of `backends` binds (the CPU reads
/// every layout as one page).
fn page_log2(backends: &[Backend]) -> u32 {
    backends
        .iter()
        .map(Backend::page_log2)
        .max()
        .unwrap_or(shared::volume::pages::GPU_PAGE_LOG2)
}

/// Kernel time since the last call, if `backend` is a GPU with timestamps.
fn kernel_ns(backend: &Backend) -> Option<u64> {
    match backend {
        Backend::Gpu(g) => g.take_kernel_ns(),
        Backend::Cpu => None,
    }
}

/// Median of a non-empty list.
fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let m = s.len() / 2;
    if s.len() % 2 == 1 {
        s[m]
    } else {
        0.5 * (s[m - 1] + s[m])
    }
}

/// What [`frames`] measured.
struct Frames {
    pixels: Vec<PixelOut>,
    /// Wall time per timed frame, ms.
    wall: Vec<f64>,
    /// GPU kernel time per timed frame, ms (empty without timestamps).
    kernel: Vec<f64>,
    /// Pipeline builds during the warm-up frames, ms.
    build_ms: f64,
}

/// Frames of one estimator: `warmup` untimed, `reps` timed. Every frame must give the same
/// pixels (same seed).
fn frames(
    resident: &Resident,
    backend: &Backend,
    params: &RenderParams,
    warmup: u32,
    reps: u32,
) -> Result<Frames> {
    let mut build_ms = 0.0;
    for _ in 0..warmup {
        let (_, _, built) = backend.timed(|| render_resident(resident, params, &[], false))?;
        build_ms += built.ms();
    }
    let (mut wall, mut kernel) = (Vec::new(), Vec::new());
    let mut first: Option<Vec<PixelOut>> = None;
    for _ in 0..reps {
        kernel_ns(backend);
        // Without a pipeline build (the first frame's with `--warmup 0`).
        let (pixels, ms, _) = backend.timed(|| render_resident(resident, params, &[], false))?;
        wall.push(ms);
        if let Some(ns) = kernel_ns(backend) {
            kernel.push(ns as f64 * 1e-6);
        }
        match &first {
            None => first = Some(pixels),
            Some(f) => anyhow::ensure!(
                bytemuck::cast_slice::<PixelOut, u8>(f)
                    == bytemuck::cast_slice::<PixelOut, u8>(&pixels),
                "internal: two frames with the same seed differ on {}",
                backend.kind()
            ),
        }
    }
    Ok(Frames {
        pixels: first.expect("reps >= 1"),
        wall,
        kernel,
        build_ms,
    })
}

/// Mean per-pixel variance of one estimate and mean lookups per estimate.
fn quality(pixels: &[PixelOut], spp: u32) -> (f64, f64) {
    let n = pixels.len().max(1) as f64;
    let bessel = spp as f64 / (spp as f64 - 1.0);
    let var = pixels
        .iter()
        .map(|p| {
            let m = p.t_mean as f64;
            ((p.t2_mean as f64 - m * m) * bessel).max(0.0)
        })
        .sum::<f64>()
        / n;
    let samples = pixels.iter().map(|p| p.samples as f64).sum::<f64>() / (n * spp as f64);
    (var, samples)
}

/// The sweep's estimators, resolutions and sizes, checked (before any work is done).
#[allow(clippy::type_complexity)]
fn sweep_lists(args: &BenchOptions) -> Result<(Vec<&'static EstimatorSpec>, Vec<u32>, Vec<u32>)> {
    let name = args.scene.volume.as_str();
    if !engine::scene::procedural::NAMES.contains(&name) {
        bail!(
            "--sweep needs an embedded volume (--volume {}), not {name:?}",
            engine::scene::procedural::NAMES.join("|")
        );
    }
    let in_range = |list: &[u32], flag: &str, range: std::ops::RangeInclusive<u32>| match list
        .iter()
        .find(|v| !range.contains(v))
    {
        Some(v) => bail!("{flag}: {v} is outside {}..={}", range.start(), range.end()),
        None => Ok(list.to_vec()),
    };
    Ok((
        args.sweep_estimators.clone(),
        in_range(&args.sweep_resolutions, "--sweep-resolutions", 8..=1024)?,
        in_range(&args.sweep_sizes, "--sweep-sizes", 1..=16384)?,
    ))
}

/// Checks a `--sweep-files` path before any work: a readable regular file named `.vdb` or
/// `.nvdb` (its contents are read when its turn comes).
fn check_sweep_file(f: &std::path::Path) -> Result<()> {
    let meta = std::fs::metadata(f).with_context(|| {
        format!(
            "--sweep-files {}: cannot read it; check the path",
            f.display()
        )
    })?;
    anyhow::ensure!(
        meta.is_file(),
        "--sweep-files {}: not a regular file (a directory, FIFO or device); pass .vdb or .nvdb \
         files",
        f.display()
    );
    let ext = f
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    anyhow::ensure!(
        matches!(ext.as_deref(), Some("vdb" | "nvdb")),
        "--sweep-files {}: not a volume file; pass .vdb (OpenVDB) or .nvdb (NanoVDB) files",
        f.display()
    );
    std::fs::File::open(f).map(drop).with_context(|| {
        format!(
            "--sweep-files {}: cannot open it; check its permissions",
            f.display()
        )
    })
}

/// Checks every output and input path of `host bench` before any work.
fn plan_outputs(args: &BenchOptions) -> Result<()> {
    let mut plan = engine::output::OutputPlan::new();
    if args.sweep {
        plot::check_format(&args.plot)?;
        plan.file("--plot", &args.plot);
    }
    if let Some(json) = &args.json {
        plan.file("--json", json);
    }
    plan.input("--volume", std::path::Path::new(&args.scene.volume));
    for f in &args.sweep_files {
        check_sweep_file(f)?;
        plan.input("--sweep-files", f);
    }
    plan.check()
}

/// Times the estimator `name` (its `params`) on `backend`: `--warmup` frames, then `--reps`
/// timed frames of `rays` rays each.
fn time_estimator(
    resident: &Resident,
    backend: &Backend,
    params: &RenderParams,
    name: &str,
    args: &BenchOptions,
    rays: f64,
) -> Result<Row> {
    let Frames {
        pixels,
        wall,
        kernel,
        build_ms,
    } = frames(resident, backend, params, args.warmup, args.reps)
        .with_context(|| format!("{name} on {}", backend.kind()))?;
    let (variance, samples_per_ray) = quality(&pixels, args.spp);
    let med = median(&wall);
    let ns_per_ray = med * 1e6 / rays;
    Ok(Row {
        backend: backend.kind().into(),
        device: backend.device(),
        estimator: name.into(),
        frame_ms_median: med,
        frame_ms_min: wall.iter().copied().fold(f64::INFINITY, f64::min),
        frame_ms: wall,
        kernel_ms_median: (!kernel.is_empty()).then(|| median(&kernel)),
        rays_per_s: rays / (med * 1e-3),
        ns_per_ray,
        samples_per_ray,
        variance,
        work_normalized_variance: variance * ns_per_ray,
        kernel: matches!(backend, Backend::Gpu(_)).then(|| {
            let k = engine::backend::gpu::Kernel::TransmittanceCs;
            KernelRow {
                name: k.name(),
                module: engine::backend::gpu::module_stats::module_stats(k.spirv()),
                pipeline_build_ms: build_ms,
            }
        }),
    })
}

/// `host bench`.
pub fn run(args: &BenchOptions) -> Result<BenchReport> {
    engine::render::check_image_memory(
        args.width,
        args.height,
        1,
        engine::render::keeps_totals(args.spp),
    )?;
    let lookup = args.lookup;
    let specs = args.estimators.clone();
    if args.sweep {
        sweep_lists(args)?;
    }
    plan_outputs(args)?;
    let file_specs = if args.sweep_files.is_empty() {
        Vec::new()
    } else {
        args.sweep_estimators.clone()
    };
    let backends = backends(args.backend)?;
    let scene = engine::scene::prepare_scene(
        &args.scene,
        lookup,
        args.width,
        args.height,
        page_log2(&backends),
        Some(engine::io::TopologyCheck(&cpu_check(&args.scene))),
    )?;
    let base = RenderParams {
        n: args.n,
        f_delta: engine::defaults::F_DELTA,
        pixel_jitter: 1,
        ..scene.params(args.width, args.height, args.spp, args.seed)
    };
    let rays = f64::from(args.width) * f64::from(args.height) * f64::from(args.spp);
    let steps_per_traversal = engine::scene::traversal::reads_per_ray(&scene.packed, &base);
    if !args.quiet {
        tracing::info!(
            "bench: {} {}x{}x{}, {}x{} px, {} spp, {} reps (+{} warm-up), {} CPU threads",
            scene.volume.name(),
            scene.volume.dims()[0],
            scene.volume.dims()[1],
            scene.volume.dims()[2],
            args.width,
            args.height,
            args.spp,
            args.reps,
            args.warmup,
            rayon::current_num_threads()
        );
    }
    let mut rows = Vec::new();
    for backend in &backends {
        if let Some(why) = backend.cannot_hold(&scene.packed) {
            tracing::warn!("skipping {}: {why}", backend.device());
            continue;
        }
        let resident = Resident::new(backend, &scene.packed)?;
        for spec in &specs {
            let mut params = base;
            spec.apply(&mut params);
            let row = time_estimator(&resident, backend, &params, spec.name, args, rays)?;
            if !args.quiet {
                tracing::info!(
                    "  {:<4} {:<20} {:9.1} ms/frame  {:7.1} ns/ray  {:6.2} lookups/ray  var {:.5}",
                    row.backend,
                    row.estimator,
                    row.frame_ms_median,
                    row.ns_per_ray,
                    row.samples_per_ray,
                    row.variance
                );
            }
            rows.push(row);
        }
    }
    let goals = goals(&rows);
    let (sweep_resolution, sweep_size) = if args.sweep {
        sweep(args, &backends, base)?
    } else {
        (Vec::new(), Vec::new())
    };
    let volume = scene.volume.name().to_owned();
    drop(scene);
    let sweep_files = sweep_files(args, &backends, base, &file_specs)?;
    let report = BenchReport {
        volume,
        lookup: engine::scene::lookup_name(args.lookup),
        width: args.width,
        height: args.height,
        spp: args.spp,
        n: args.n,
        seed: args.seed,
        reps: args.reps,
        threads: rayon::current_num_threads(),
        steps_per_traversal,
        rows,
        goals,
        sweep_resolution,
        sweep_size,
        sweep_files,
    };
    print_report(&report);
    if args.sweep {
        plot::save(&args.plot, &SweepFigure(&report))?;
        println!("sweep plot: {}", args.plot.display());
    }
    if let Some(path) = &args.json {
        engine::output::write_json(path, &report)?;
    }
    Ok(report)
}

/// The goal ratios on each backend, where both estimators were timed.
fn goals(rows: &[Row]) -> Vec<Goal> {
    let find = |backend: &str, name: &str| {
        rows.iter()
            .find(|r| r.backend == backend && r.estimator == name)
    };
    let mut out = Vec::new();
    for backend in ["cpu", "gpu"] {
        let Some(jk) = find(backend, "jackknife") else {
            continue;
        };
        let time = |other: &str, target: f64| {
            find(backend, other).map(|o| {
                (
                    format!("time jackknife / {other}"),
                    jk.ns_per_ray / o.ns_per_ray,
                    target,
                )
            })
        };
        let wnv = find(backend, "track-length").map(|o| {
            (
                "std^2*time jackknife / track-length".to_string(),
                jk.work_normalized_variance / o.work_normalized_variance,
                0.3,
            )
        });
        for (what, ratio, target) in [
            time("track-length", 1.2),
            time("ratio", 0.4),
            time("unbiased-rm", 0.3),
            wnv,
        ]
        .into_iter()
        .flatten()
        {
            out.push(Goal {
                backend: backend.into(),
                what,
                ratio,
                target,
                met: ratio <= target,
            });
        }
    }
    out
}

/// Times the sweep estimators over volume resolutions (image fixed) and image sizes (volume
/// fixed at `--resolution`).
fn sweep(
    args: &BenchOptions,
    backends: &[Backend],
    base: RenderParams,
) -> Result<(Vec<SweepPoint>, Vec<SweepPoint>)> {
    let name = args.scene.volume.as_str();
    let (specs, resolutions, sizes) = sweep_lists(args)?;
    let lookup = args.lookup;
    let mut by_resolution = Vec::new();
    let mut by_size = Vec::new();
    let cases: Vec<(u32, u32, bool)> = resolutions
        .iter()
        .map(|&r| (r, args.width, true))
        .chain(
            sizes
                .iter()
                .map(|&s| (args.scene.embedded_resolution(), s, false)),
        )
        .collect();
    let mut cached: Option<(u32, engine::scene::Scene, f64)> = None;
    for (resolution, size, is_resolution) in cases {
        if cached.as_ref().is_none_or(|(r, _, _)| *r != resolution) {
            let mut scene_args = args.scene.clone();
            scene_args.resolution = Some(resolution);
            let t = Instant::now();
            let scene = engine::scene::prepare_scene(
                &scene_args,
                lookup,
                size,
                size,
                page_log2(backends),
                Some(engine::io::TopologyCheck(&cpu_check(&scene_args))),
            )?;
            if !args.quiet {
                tracing::info!(
                    "sweep: {name} {resolution}^3 prepared in {:.1} s ({} of {} bricks occupied, \
                     {:.1} MiB of voxels)",
                    t.elapsed().as_secs_f64(),
                    scene.packed.occupied_bricks(),
                    scene.packed.grid_bricks().len(),
                    std::mem::size_of_val(scene.packed.voxels.as_slice()) as f64
                        / f64::from(1 << 20)
                );
            }
            cached = Some((resolution, scene, t.elapsed().as_secs_f64() * 1e3));
        }
        let (_, scene, prepare_ms) = cached.as_ref().expect("just set");
        let params = RenderParams {
            // The camera frames the volume the same way at every resolution (same world box).
            camera: engine::scene::camera::make_camera(
                &engine::scene::camera::CameraSpec {
                    position: args.scene.camera,
                    look_at: args.scene.look_at,
                    fov_deg: args.scene.fov,
                },
                engine::scene::camera::occupied_world_bounds(&scene.volume),
                size,
                size,
            )?,
            world_to_index: scene.world_to_index,
            width: size,
            height: size,
            ..base
        };
        let points = time_points(
            args,
            backends,
            &specs,
            scene,
            &params,
            *prepare_ms,
            [None; 2],
        )?;
        if is_resolution {
            by_resolution.extend(points);
        } else {
            by_size.extend(points);
        }
    }
    Ok((by_resolution, by_size))
}

/// Times the sweep estimators on each file of `--sweep-files` (the image of `--width` x
/// `--height`, the camera framing each volume): one volume in memory at a time, its peak
/// resident memory measured from a reset high-water mark.
fn sweep_files(
    args: &BenchOptions,
    backends: &[Backend],
    base: RenderParams,
    specs: &[&'static EstimatorSpec],
) -> Result<Vec<SweepPoint>> {
    let mut points = Vec::new();
    for file in &args.sweep_files {
        let mut scene_args = args.scene.clone();
        scene_args.volume = file.display().to_string();
        // --resolution sizes the embedded volume of the main benchmark, not these files.
        scene_args.resolution = None;
        let rss_before_bytes = reset_peak_rss().then(|| memory_line("VmRSS:")).flatten();
        let t = Instant::now();
        let scene = engine::scene::prepare_scene(
            &scene_args,
            args.lookup,
            args.width,
            args.height,
            page_log2(backends),
            Some(engine::io::TopologyCheck(&cpu_check(&scene_args))),
        )
        .with_context(|| format!("--sweep-files {}", file.display()))?;
        let prepare_ms = t.elapsed().as_secs_f64() * 1e3;
        let peak_rss_bytes = rss_before_bytes.and_then(|_| memory_line("VmHWM:"));
        let d = scene.volume.dims();
        if !args.quiet {
            tracing::info!(
                "sweep-files: {} {}x{}x{} prepared in {:.1} s (RSS {} before, peak {}; {} of {} \
                 bricks occupied, {:.1} MiB of voxels)",
                file.display(),
                d[0],
                d[1],
                d[2],
                prepare_ms / 1e3,
                mib(rss_before_bytes),
                mib(peak_rss_bytes),
                scene.packed.occupied_bricks(),
                scene.packed.grid_bricks().len(),
                std::mem::size_of_val(scene.packed.voxels.as_slice()) as f64 / f64::from(1 << 20)
            );
        }
        let params = RenderParams {
            camera: scene.camera,
            world_to_index: scene.world_to_index,
            ..base
        };
        points.extend(time_points(
            args,
            backends,
            specs,
            &scene,
            &params,
            prepare_ms,
            [rss_before_bytes, peak_rss_bytes],
        )?);
    }
    Ok(points)
}

/// Times each of `specs` with `params` (its image size, the camera) on each backend that can
/// hold `scene`'s volume (the others get a point that says why not): one sweep point each.
fn time_points(
    args: &BenchOptions,
    backends: &[Backend],
    specs: &[&'static EstimatorSpec],
    scene: &engine::scene::Scene,
    params: &RenderParams,
    prepare_ms: f64,
    [rss_before_bytes, peak_rss_bytes]: [Option<u64>; 2],
) -> Result<Vec<SweepPoint>> {
    let (w, h) = (params.width, params.height);
    let rays = f64::from(w) * f64::from(h) * f64::from(args.spp);
    let dims = scene.volume.dims();
    let mut points = Vec::new();
    for backend in backends {
        let skipped = backend.cannot_hold(&scene.packed);
        let resident = match &skipped {
            None => Some(Resident::new(backend, &scene.packed)?),
            Some(_) => None,
        };
        for spec in specs {
            let mut p = *params;
            spec.apply(&mut p);
            let mut point = SweepPoint {
                backend: backend.kind().into(),
                estimator: spec.name.into(),
                resolution: dims.into_iter().max().unwrap_or(0),
                size: w,
                frame_ms_median: f64::NAN,
                ns_per_ray: f64::NAN,
                samples_per_ray: f64::NAN,
                skipped: skipped.clone(),
                prepare_ms,
                bricks: scene.packed.grid_bricks().len(),
                occupied_bricks: scene.packed.occupied_bricks(),
                pool_bytes: std::mem::size_of_val(scene.packed.voxels.as_slice()) as u64,
                volume: scene.volume.name().to_owned(),
                dims,
                rss_before_bytes,
                peak_rss_bytes,
            };
            if let Some(resident) = &resident {
                let Frames { pixels, wall, .. } =
                    frames(resident, backend, &p, 1, args.reps.min(3))?;
                point.frame_ms_median = median(&wall);
                point.ns_per_ray = point.frame_ms_median * 1e6 / rays;
                point.samples_per_ray = quality(&pixels, args.spp).1;
            }
            if !args.quiet {
                tracing::info!(
                    "  {:<4} {:<14} {}x{}x{} {w:>5}x{h} {:9.1} ms {:8.1} ns/ray {}",
                    point.backend,
                    point.estimator,
                    dims[0],
                    dims[1],
                    dims[2],
                    point.frame_ms_median,
                    point.ns_per_ray,
                    point.skipped.as_deref().unwrap_or("")
                );
            }
            points.push(point);
        }
    }
    Ok(points)
}

/// Resets the process's peak resident memory (Linux: `5` to /proc/self/clear_refs); false where
/// that is not possible.
fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// A memory line of /proc/self/status (e.g. "VmHWM:", the peak resident memory since the last
/// reset) in bytes, if known.
fn memory_line(key: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(key))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// "N MiB" or "-".
fn mib(bytes: Option<u64>) -> String {
    bytes.map_or("-".into(), |b| {
        format!("{:.0} MiB", b as f64 / f64::from(1 << 20))
    })
}

/// Prints the table, the goals and the sweep's flatness.
fn print_report(r: &BenchReport) {
    println!(
        "{} | {}x{} px, {} spp, N = {}, {} lookups, {} reps, {} CPU threads",
        r.volume, r.width, r.height, r.spp, r.n, r.lookup, r.reps, r.threads
    );
    println!(
        "super-voxel steps per traversal {:.2} (bricks and skipped spans {:.2})",
        r.steps_per_traversal.supervoxels, r.steps_per_traversal.bricks
    );
    println!(
        "{:<4} {:<20} {:>10} {:>10} {:>10} {:>8} {:>11} {:>9} {:>9} {:>11}",
        "",
        "estimator",
        "ms median",
        "ms min",
        "kernel ms",
        "ns/ray",
        "Mrays/s",
        "lookups",
        "var",
        "var*ns"
    );
    for row in &r.rows {
        println!(
            "{:<4} {:<20} {:>10.1} {:>10.1} {:>10} {:>8.1} {:>11.3} {:>9.2} {:>9.5} {:>11.4}",
            row.backend,
            row.estimator,
            row.frame_ms_median,
            row.frame_ms_min,
            row.kernel_ms_median
                .map_or("-".to_string(), |k| format!("{k:.1}")),
            row.ns_per_ray,
            row.rays_per_s * 1e-6,
            row.samples_per_ray,
            row.variance,
            row.work_normalized_variance
        );
    }
    if let Some(k) = r.rows.iter().find_map(|row| row.kernel.as_ref()) {
        let m = k.module;
        println!(
            "kernel {}: {} bytes, {} instructions, {} branches, {} loops, {} loads, {} functions \
             (before specialization)",
            k.name, m.bytes, m.instructions, m.branches, m.loops, m.loads, m.functions
        );
    }
    for row in r.rows.iter().filter(|row| row.kernel.is_some()) {
        let k = row.kernel.as_ref().expect("filtered");
        println!(
            "pipeline {} / {}: built in {:.0} ms",
            k.name, row.estimator, k.pipeline_build_ms
        );
    }
    for g in &r.goals {
        println!(
            "goal {:<4} {:<40} {:>6.2} (target <= {:.1}) {}",
            g.backend,
            g.what,
            g.ratio,
            g.target,
            if g.met { "met" } else { "MISSED" }
        );
    }
    for p in &r.sweep_files {
        println!(
            "sweep-files {:<4} {:<14} {}x{}x{}: prepared {:.0} ms, RSS {} before, peak {}, pool \
             {:.1} MiB, {:.1} ns/ray {}",
            p.backend,
            p.estimator,
            p.dims[0],
            p.dims[1],
            p.dims[2],
            p.prepare_ms,
            mib(p.rss_before_bytes),
            mib(p.peak_rss_bytes),
            p.pool_bytes as f64 / f64::from(1 << 20),
            p.ns_per_ray,
            p.skipped.as_deref().unwrap_or("")
        );
    }
    for backend in ["cpu", "gpu"] {
        let pts: Vec<&SweepPoint> = r
            .sweep_resolution
            .iter()
            .filter(|p| p.backend == backend && p.estimator == "jackknife" && p.skipped.is_none())
            .collect();
        if pts.len() >= 2 {
            let ns: Vec<f64> = pts.iter().map(|p| p.ns_per_ray).collect();
            let (lo, hi) = (
                ns.iter().copied().fold(f64::INFINITY, f64::min),
                ns.iter().copied().fold(0.0, f64::max),
            );
            let mid = 0.5 * (lo + hi);
            println!(
                "sweep {backend}: jackknife ns/ray over {}^3..{}^3: {lo:.1}..{hi:.1} (±{:.0}% around the midpoint; goal ±30%)",
                pts[0].resolution,
                pts[pts.len() - 1].resolution,
                100.0 * (hi - lo) / (2.0 * mid)
            );
        }
    }
}

/// Two panels: ns per ray against volume resolution and against image size.
struct SweepFigure<'a>(&'a BenchReport);

impl Figure for SweepFigure<'_> {
    fn size(&self) -> (u32, u32) {
        (1200, 500)
    }

    fn draw<DB: plotters::prelude::DrawingBackend>(
        &self,
        root: &plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    ) -> Result<()> {
        use plot::Drawn;
        let panels = root.split_evenly((1, 2));
        let r = self.0;
        for (area, (points, x_of, x_label, title)) in panels.iter().zip([
            (
                &r.sweep_resolution,
                (|p: &SweepPoint| p.resolution as f64) as fn(&SweepPoint) -> f64,
                "voxels per axis",
                format!("cost per ray vs volume resolution ({}^2 px)", r.width),
            ),
            (
                &r.sweep_size,
                |p: &SweepPoint| p.size as f64,
                "image width = height (px)",
                "cost per ray vs image size".to_string(),
            ),
        ]) {
            let valid: Vec<&SweepPoint> =
                points.iter().filter(|p| p.ns_per_ray.is_finite()).collect();
            if valid.is_empty() {
                continue;
            }
            let xs = valid.iter().map(|p| x_of(p));
            let (x0, x1) = xs.fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(x), b.max(x)));
            let ys = valid.iter().map(|p| p.ns_per_ray);
            let (y0, y1) = ys.fold((f64::INFINITY, 0.0f64), |(a, b), y| (a.min(y), b.max(y)));
            let mut panel = LinePanel::new(
                &title,
                x_label,
                "wall time per ray (ns)",
                (x0 / 1.2, x1 * 1.2),
                (y0 / 1.5, y1 * 1.5),
            );
            panel.log_x = true;
            panel.log_y = true;
            panel.legend = Legend::UpperRight;
            let colors = [
                plot::BLUE,
                plot::ORANGE,
                plot::GREEN,
                plot::RED,
                plot::PURPLE,
            ];
            let mut names: Vec<&str> = valid.iter().map(|p| p.estimator.as_str()).collect();
            names.dedup();
            names.sort();
            names.dedup();
            for backend in ["cpu", "gpu"] {
                for (k, name) in names.iter().enumerate() {
                    let pts: Vec<(f64, f64)> = valid
                        .iter()
                        .filter(|p| p.backend == backend && p.estimator == *name)
                        .map(|p| (x_of(p), p.ns_per_ray))
                        .collect();
                    if pts.is_empty() {
                        continue;
                    }
                    let color = colors[k % colors.len()];
                    let style = if backend == "cpu" {
                        Style::Line
                    } else {
                        Style::Dashed
                    };
                    let label = format!("{name} ({backend})");
                    panel
                        .series
                        .push(Series::new(&label, color, style, pts.clone()));
                    panel
                        .series
                        .push(Series::new("", color, Style::Markers(3), pts));
                }
            }
            panel.draw(area)?;
        }
        root.present().drawn()
    }
}

/// The topology check of every backend (memory to pack, the pool's reach); the GPU's limits are
/// checked per backend after packing ([`Backend::cannot_hold`]), where a bench skips a backend.
fn cpu_check(
    scene: &SceneOptions,
) -> impl Fn(&engine::io::Topology) -> Result<()> + Sync + std::panic::RefUnwindSafe {
    Backend::Cpu.topology_check(BackendChoice::Cpu, scene.brick_size)
}
