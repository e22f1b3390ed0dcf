//! `host report`: a static, self-contained HTML viewer of `host eval` results, like the paper's
//! interactive supplemental: estimators side by side or under a slider, render / bias / std
//! images with colour bars, magnified insets and the numbers table.
//!
//! Every number and colour of the page comes from the eval JSON (or from the code that wrote the
//! images); the HTML template (`viewer.html`) holds only layout and behaviour. The data goes into
//! the page as a JSON literal, the images stay files referenced by relative paths, so the report
//! opens from `file://` without a server or network.

use crate::eval::{ColourMap, EvalHeader, EvalReport, IntegratorEvalReport};
use crate::eval_direct::DirectEvalReport;
use crate::eval_direct::ShadowEntry;
use crate::evaluate::EvalOptions;
use anyhow::{bail, Context, Result};
use engine::backend::BackendChoice;
use engine::scene::SceneOptions;
use serde::Serialize;
use shared::params::Integrator;
use shared::volume::grid::Lookup;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The viewer: layout, style and script; [`DATA_MARKER`] is replaced by the data.
const TEMPLATE: &str = include_str!("viewer.html");
/// Placeholder of the data inside `<script type="application/json">` in [`TEMPLATE`].
const DATA_MARKER: &str = "__REPORT_DATA__";

/// Everything the page shows.
#[derive(Serialize, Debug)]
pub struct ViewerData {
    pub title: String,
    pub generator: String,
    pub sets: Vec<Set>,
}

/// One evaluation (a volume's estimators, or its integrators): one tab of the viewer.
#[derive(Serialize, Debug)]
pub struct Set {
    /// Directory of its files inside the report, also its id in the page's URL hash.
    pub id: String,
    pub label: String,
    /// "estimators" or "integrators".
    pub kind: &'static str,
    /// Relative link to the eval JSON inside the report.
    pub json: String,
    /// (label, value) lines describing the evaluation.
    pub facts: Vec<[String; 2]>,
    pub width: u32,
    pub height: u32,
    pub modes: Vec<Mode>,
    /// The reference first, then each evaluated estimator or integrator.
    pub entries: Vec<Entry>,
    pub columns: Vec<Column>,
}

/// An image kind of a set: "render", "bias", "std".
#[derive(Serialize, Debug)]
pub struct Mode {
    pub id: &'static str,
    pub label: &'static str,
    /// What the pixels mean, shown under the colour bar.
    pub caption: String,
    /// Value -> colour of the PNGs, when it is a bounded map.
    pub colour_map: Option<ColourMap>,
}

/// The reference or one estimator / integrator.
#[derive(Serialize, Debug)]
pub struct Entry {
    pub name: String,
    pub about: String,
    pub reference: bool,
    pub unbiased: Option<bool>,
    /// Mode id -> its PNG and EXR (relative URLs); the reference has a render only.
    pub images: BTreeMap<&'static str, Image>,
    /// Column key -> value.
    pub values: BTreeMap<&'static str, f64>,
}

/// A tone-mapped or false-colour PNG and the linear EXR it shows.
#[derive(Serialize, Debug)]
pub struct Image {
    pub png: String,
    pub exr: String,
}

/// A column of the numbers table.
#[derive(Serialize, Debug, Clone)]
pub struct Column {
    pub key: &'static str,
    pub label: &'static str,
    /// Tooltip: the definition.
    pub title: &'static str,
    /// Decimals shown.
    pub digits: u32,
    /// Show a + on non-negative values.
    pub signed: bool,
    /// Which value is best: "min", "absmin", or "" (not marked).
    pub best: &'static str,
}

const fn column(
    key: &'static str,
    label: &'static str,
    title: &'static str,
    digits: u32,
    signed: bool,
    best: &'static str,
) -> Column {
    Column {
        key,
        label,
        title,
        digits,
        signed,
        best,
    }
}

/// What `host report` evaluates or imports, and where it writes the viewer.
#[derive(Debug, Clone)]
pub struct ReportOptions {
    /// Directory for index.html and one subdirectory per evaluation.
    pub out: PathBuf,
    /// Volumes to evaluate now, embedded names or files (None: cloud unless `from_eval` is
    /// given).
    pub volumes: Option<Vec<String>>,
    /// Estimators of the new evaluations (shadow-map entries only with lit integrators).
    pub estimators: Vec<ShadowEntry>,
    /// Also evaluate these integrators per volume (empty: none).
    pub integrators: Vec<Integrator>,
    /// Existing `host eval` outputs (directories or JSON files).
    pub from_eval: Vec<PathBuf>,
    /// Grid, density scale, embedded resolution and camera of every volume of `volumes` (its
    /// `volume` is not read; `resolution` reaches embedded volumes, `grid` files).
    pub scene: SceneOptions,
    pub lookup: Lookup,
    pub n: u32,
    pub width: u32,
    pub height: u32,
    /// Estimates per pixel of the transmittance evaluations.
    pub spp: u32,
    /// Samples per pixel of the integrator evaluations (reference: 16 x this).
    pub integrator_spp: u32,
    pub seed: u32,
    pub backend: BackendChoice,
    pub bias_scale: f32,
    pub std_scale: f32,
    /// No progress bars.
    pub quiet: bool,
}

/// `host report`: runs or loads the evaluations, copies their files, writes index.html.
pub fn run(args: &ReportOptions) -> Result<()> {
    anyhow::ensure!(
        args.bias_scale.is_finite()
            && args.bias_scale > 0.0
            && args.std_scale.is_finite()
            && args.std_scale > 0.0,
        "--bias-scale and --std-scale must be finite and > 0"
    );
    let out = &args.out;
    engine::output::OutputPlan::new()
        .dir("--out", out)
        .check()?;
    let mut used = Vec::new();
    let mut sources: Vec<(String, PathBuf)> = Vec::new();
    // Read every --from-eval first, with every file it names: a typo or a missing image should
    // not cost the evaluations, nor leave a half-copied report.
    for path in &args.from_eval {
        let json = eval_json_path(path)?;
        let id = unique_id(&slug(&label_of(&json)), &mut used);
        import(&json, out, &id, true)?;
        sources.push((id, json));
    }
    let volumes = match (&args.volumes, args.from_eval.is_empty()) {
        (Some(list), _) => list.clone(),
        (None, true) => vec!["cloud".to_string()],
        (None, false) => Vec::new(),
    };
    if !volumes.is_empty() {
        crate::evaluate::rays_only(&args.estimators)?;
    }
    for volume in &volumes {
        engine::scene::check_volume_spec(volume).context("--volumes")?;
    }
    check_scene_flags(&args.scene, &volumes)?;
    for volume in &volumes {
        anyhow::ensure!(!volume.is_empty(), "--volumes: empty volume name");
        let base = slug(&volume_label(volume));
        let id = unique_id(&base, &mut used);
        let dir = out.join(&id);
        let mut eval = eval_options(args, volume, dir.clone());
        crate::evaluate::run_eval(&eval).with_context(|| format!("evaluating {volume}"))?;
        sources.push((id, dir.join("eval.json")));
        if !args.integrators.is_empty() {
            let id = unique_id(&format!("{base}-integrators"), &mut used);
            let dir = out.join(&id);
            eval.integrators = args.integrators.clone();
            eval.image.spp = args.integrator_spp;
            eval.reference_spp = Some(16 * args.integrator_spp);
            eval.out_dir = dir.clone();
            crate::evaluate::run_eval(&eval)
                .with_context(|| format!("evaluating the integrators on {volume}"))?;
            sources.push((id, dir.join("eval.json")));
        }
    }
    let mut sets = Vec::new();
    for (id, json) in &sources {
        sets.extend(import(json, out, id, false)?);
    }
    let data = ViewerData {
        title: "Jackknife transmittance: comparison viewer".into(),
        generator: format!(
            "host report {} (jackknife transmittance, Peters 2025)",
            env!("CARGO_PKG_VERSION")
        ),
        sets,
    };
    let html = render_html(&data)?;
    let index = out.join("index.html");
    engine::output::write_text(&index, &html)?;
    println!("wrote {}", index.display());
    Ok(())
}

/// Refuses `--resolution` when no volume is embedded and `--grid` when none is a file: each
/// would be ignored.
fn check_scene_flags(scene: &SceneOptions, volumes: &[String]) -> Result<()> {
    let files = volumes
        .iter()
        .filter(|v| engine::scene::is_volume_file(v))
        .count();
    if let (Some(n), true) = (scene.resolution, files == volumes.len()) {
        bail!(
            "--resolution {n} sets the size of embedded volumes, and no volume to evaluate is one \
             (--volumes, default cloud unless --from-eval is given): drop --resolution"
        );
    }
    if let (Some(grid), 0) = (&scene.grid, files) {
        bail!(
            "--grid {grid:?} picks a grid of a volume file, and no volume to evaluate is one \
             (--volumes): drop --grid"
        );
    }
    Ok(())
}

/// `host eval` options for one volume of the report (defaults of `host eval` for the rest).
fn eval_options(args: &ReportOptions, volume: &str, out_dir: PathBuf) -> EvalOptions {
    let file = engine::scene::is_volume_file(volume);
    EvalOptions {
        scene: SceneOptions {
            volume: volume.into(),
            resolution: args.scene.resolution.filter(|_| !file),
            grid: args.scene.grid.clone().filter(|_| file),
            ..args.scene.clone()
        },
        lookup: args.lookup,
        estimators: args.estimators.clone(),
        n: args.n,
        image: engine::render_job::Image {
            width: args.width,
            height: args.height,
            spp: args.spp,
            seed: args.seed,
            ..EvalOptions::default().image
        },
        backend: args.backend,
        out_dir,
        json: None,
        bias_scale: args.bias_scale,
        std_scale: args.std_scale,
        quiet: args.quiet,
        ..EvalOptions::default()
    }
}

/// The eval JSON of a `--from-eval` argument: the file itself, or eval.json in the directory.
fn eval_json_path(path: &Path) -> Result<PathBuf> {
    if path.is_dir() {
        let json = path.join("eval.json");
        anyhow::ensure!(
            json.is_file(),
            "--from-eval {}: the directory has no eval.json (is it a `host eval --out-dir`?)",
            path.display()
        );
        Ok(json)
    } else if path.is_file() {
        Ok(path.to_path_buf())
    } else {
        bail!("--from-eval {}: no such file or directory", path.display())
    }
}

/// Name of an evaluation from its JSON path: the directory's name for eval.json.
fn label_of(json: &Path) -> String {
    let stem = json.file_stem().and_then(|s| s.to_str()).unwrap_or("eval");
    if stem == "eval" {
        if let Some(dir) = json
            .canonicalize()
            .ok()
            .and_then(|p| p.parent().map(Path::to_path_buf))
            .and_then(|d| d.file_name().map(|n| n.to_string_lossy().into_owned()))
        {
            return dir;
        }
    }
    stem.to_string()
}

/// Directory name of a `--volumes` entry: the embedded name, or a file's stem.
fn volume_label(volume: &str) -> String {
    let path = Path::new(volume);
    if path.exists() {
        if let Some(stem) = path.file_stem() {
            return stem.to_string_lossy().into_owned();
        }
    }
    volume.to_string()
}

/// Lower-case letters, digits, '-' and '_' only (safe in paths, URLs and the hash).
fn slug(s: &str) -> String {
    let mut out: String = s
        .chars()
        .map(|c| {
            let c = c.to_ascii_lowercase();
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .collect();
    out = out.trim_matches('-').to_string();
    if out.is_empty() {
        "eval".into()
    } else {
        out
    }
}

fn unique_id(base: &str, used: &mut Vec<String>) -> String {
    let mut id = base.to_string();
    let mut k = 2;
    while used.contains(&id) {
        id = format!("{base}-{k}");
        k += 1;
    }
    used.push(id.clone());
    id
}

/// A loaded eval JSON.
enum Loaded {
    Estimators(EvalReport),
    Integrators(IntegratorEvalReport),
    /// `host eval --integrators direct,path`: shadow-ray estimators per integrator.
    Lit(DirectEvalReport),
}

/// Reads and parses an eval JSON; errors name the file.
fn load(json: &Path) -> Result<Loaded> {
    let text =
        std::fs::read_to_string(json).with_context(|| format!("reading {}", json.display()))?;
    let value: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: not valid JSON", json.display()))?;
    let stale = "(written by an older `host eval`? run it again)";
    if value.get("references").is_some() {
        serde_json::from_value(value)
            .map(Loaded::Lit)
            .with_context(|| {
                format!(
                    "{}: not a `host eval --integrators direct,path` report {stale}",
                    json.display()
                )
            })
    } else if value.get("integrators").is_some() {
        serde_json::from_value(value)
            .map(Loaded::Integrators)
            .with_context(|| {
                format!(
                    "{}: not a `host eval --integrators` report {stale}",
                    json.display()
                )
            })
    } else if value.get("estimators").is_some() {
        serde_json::from_value(value)
            .map(Loaded::Estimators)
            .with_context(|| format!("{}: not a `host eval` report {stale}", json.display()))
    } else {
        bail!(
            "{}: not a `host eval` report (no \"estimators\" or \"integrators\")",
            json.display()
        )
    }
}

/// Copies the files of one evaluation into `out/id/` (unless they are there already) and
/// makes its [`Set`]s (one; a `direct,path` evaluation one per integrator).
fn import(json: &Path, out: &Path, id: &str, dry: bool) -> Result<Vec<Set>> {
    let loaded = load(json)?;
    let src_dir = json
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let dest_dir = out.join(id);
    if !dry {
        std::fs::create_dir_all(&dest_dir)
            .with_context(|| format!("creating {}", dest_dir.display()))?;
    }
    let mut files = Files {
        json,
        src_dir,
        dest_dir: &dest_dir,
        id,
        dry,
    };
    let json_link = files.copy_named(json, "eval.json")?;
    Ok(match loaded {
        Loaded::Estimators(r) => vec![estimator_set(&r, &mut files, id, json_link)?],
        Loaded::Integrators(r) => vec![integrator_set(&r, &mut files, id, json_link)?],
        Loaded::Lit(r) => lit_sets(&r, &mut files, id, &json_link)?,
    })
}

/// Where an evaluation's files are and where they go.
struct Files<'a> {
    json: &'a Path,
    src_dir: &'a Path,
    dest_dir: &'a Path,
    id: &'a str,
    /// Only find the files (a check before any evaluation or copy).
    dry: bool,
}

impl Files<'_> {
    /// Finds a file named in the JSON (beside the JSON, else at the path as written), copies it
    /// into the report and returns its URL relative to index.html.
    fn copy(&mut self, stored: &str) -> Result<String> {
        let path = Path::new(stored);
        let name = path
            .file_name()
            .with_context(|| format!("{}: {stored:?} is not a file name", self.json.display()))?;
        let beside = self.src_dir.join(name);
        let found = if beside.is_file() {
            beside
        } else if path.is_file() {
            path.to_path_buf()
        } else {
            bail!(
                "{}: {stored} not found (neither at that path nor in {})",
                self.json.display(),
                self.src_dir.display()
            )
        };
        self.copy_named(&found, &name.to_string_lossy())
    }

    fn copy_named(&mut self, from: &Path, name: &str) -> Result<String> {
        let to = self.dest_dir.join(name);
        let same = match (from.canonicalize(), to.canonicalize()) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        };
        if !same && !self.dry {
            engine::output::write_atomically(&to, |tmp| {
                std::fs::copy(from, tmp)
                    .map(drop)
                    .with_context(|| format!("copying {} to {}", from.display(), to.display()))
            })?;
        }
        Ok(format!("{}/{}", url_escape(self.id), url_escape(name)))
    }

    fn image(&mut self, png: &str, exr: &str) -> Result<Image> {
        Ok(Image {
            png: self.copy(png)?,
            exr: self.copy(exr)?,
        })
    }
}

/// Percent-encodes everything but unreserved characters (one path segment).
fn url_escape(s: &str) -> String {
    let mut out = String::new();
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || b"-_.~".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

/// How an evaluation's PNGs show radiance (reports written before the view transform had a
/// gain say their exposure).
fn view_caption(gain: Option<f32>, exposure: f32) -> String {
    match gain {
        Some(g) => format!("shown as filmic({g:.3} x L) (automatic exposure of the reference)"),
        None => format!("shown at exposure {exposure}"),
    }
}

/// The grey ramp of the transmittance PNGs: T in [0, 1], sRGB-encoded (`output::write_png`).
fn transmittance_map() -> ColourMap {
    crate::eval::colour_map("transmittance, sRGB-encoded", 0.0, 1.0, |v| {
        let s = engine::output::srgb8(v);
        [s, s, s]
    })
}

const ESTIMATOR_COLUMNS: &[Column] = &[
    column(
        "mean_bias",
        "bias",
        "mean over pixels of (pixel mean - reference)",
        5,
        true,
        "absmin",
    ),
    column(
        "mean_abs_bias",
        "|bias|",
        "mean over pixels of |pixel mean - reference|; includes the Monte Carlo noise of the mean, compare with the noise floor",
        5,
        false,
        "min",
    ),
    column(
        "abs_bias_noise_floor",
        "noise floor",
        "mean of std * sqrt(2 / (pi spp)): the |bias| an unbiased estimator with this std would show",
        5,
        false,
        "",
    ),
    column(
        "mean_std",
        "std",
        "mean per-pixel standard deviation of one estimate",
        4,
        false,
        "min",
    ),
    column(
        "rmse",
        "RMSE",
        "sqrt(mean of bias^2 + std^2): the error of one estimate",
        4,
        false,
        "min",
    ),
    column(
        "mean_samples_per_ray",
        "samples/ray",
        "high-resolution lookups per ray",
        2,
        false,
        "min",
    ),
    column(
        "elapsed_ms",
        "time (ms)",
        "time to render all spp of the image",
        0,
        false,
        "min",
    ),
];

const INTEGRATOR_COLUMNS: &[Column] = &[
    column(
        "smape",
        "SMAPE",
        "mean over pixels of |L - L_ref| / ((L + L_ref) / 2 + 0.01) (Fig. 12)",
        4,
        false,
        "min",
    ),
    column(
        "mean_bias",
        "bias",
        "mean over pixels of (L - L_ref)",
        5,
        true,
        "absmin",
    ),
    column(
        "mean_abs_error",
        "|error|",
        "mean over pixels of |L - L_ref|",
        5,
        false,
        "min",
    ),
    column(
        "mean_radiance",
        "mean L",
        "mean radiance of the image",
        5,
        false,
        "",
    ),
    column(
        "mean_samples_per_ray",
        "lookups/ray",
        "high-resolution lookups per camera ray",
        2,
        false,
        "min",
    ),
    column(
        "ms_per_frame",
        "ms/spp",
        "time per sample per pixel (one frame)",
        1,
        false,
        "min",
    ),
    column(
        "elapsed_ms",
        "time (ms)",
        "time to render all spp of the image",
        0,
        false,
        "min",
    ),
];

/// The facts every set starts with: volume, backend, image size and spp.
fn common_facts(h: &EvalHeader) -> Vec<[String; 2]> {
    vec![
        ["volume".into(), h.volume.clone()],
        ["backend".into(), format!("{}: {}", h.backend, h.device)],
        ["image".into(), format!("{} x {}", h.width, h.height)],
        ["spp".into(), h.spp.to_string()],
    ]
}

/// The first entry of every set: the reference render, with no values.
fn reference_entry(about: &str, image: Image) -> Entry {
    Entry {
        name: "reference".into(),
        about: about.into(),
        reference: true,
        unbiased: None,
        images: BTreeMap::from([("render", image)]),
        values: BTreeMap::new(),
    }
}

fn estimator_set(r: &EvalReport, files: &mut Files, id: &str, json: String) -> Result<Set> {
    let mut facts = common_facts(&r.header);
    facts.extend([
        ["N".into(), r.n.to_string()],
        ["lookup".into(), r.lookup.clone()],
        ["seed".into(), r.header.seed.to_string()],
        ["reference".into(), r.reference.clone()],
        [
            "statistics over".into(),
            format!(
                "{} pixels (reference transmittance below 1)",
                r.evaluated_pixels
            ),
        ],
    ]);
    let reference = files.image(&r.reference_png, &r.reference_exr)?;
    let mut entries = vec![reference_entry(&r.reference, reference)];
    for e in &r.estimators {
        entries.push(Entry {
            name: e.name.clone(),
            about: e.about.clone(),
            reference: false,
            unbiased: Some(e.unbiased),
            images: BTreeMap::from([
                ("render", files.image(&e.mean_png, &e.mean_exr)?),
                ("bias", files.image(&e.bias_png, &e.bias_exr)?),
                ("std", files.image(&e.std_png, &e.std_exr)?),
            ]),
            values: BTreeMap::from([
                ("mean_bias", e.mean_bias),
                ("mean_abs_bias", e.mean_abs_bias),
                ("abs_bias_noise_floor", e.abs_bias_noise_floor),
                ("mean_std", e.mean_std),
                ("rmse", e.rmse),
                ("mean_samples_per_ray", e.mean_samples_per_ray),
                ("elapsed_ms", e.elapsed_ms),
            ]),
        });
    }
    Ok(Set {
        id: id.into(),
        label: id.into(),
        kind: "estimators",
        json,
        facts,
        width: r.header.width,
        height: r.header.height,
        modes: vec![
            Mode {
                id: "render",
                label: "render",
                caption: format!("mean transmittance of {} estimates per pixel", r.header.spp),
                colour_map: Some(transmittance_map()),
            },
            Mode {
                id: "bias",
                label: "bias",
                caption: "bias: pixel mean - reference (blue: under, red: over)".into(),
                colour_map: Some(r.bias_colour_map.clone()),
            },
            Mode {
                id: "std",
                label: "std",
                caption: "standard deviation of one estimate".into(),
                colour_map: Some(r.std_colour_map.clone()),
            },
        ],
        entries,
        columns: ESTIMATOR_COLUMNS.to_vec(),
    })
}

fn integrator_set(
    r: &IntegratorEvalReport,
    files: &mut Files,
    id: &str,
    json: String,
) -> Result<Set> {
    let mut facts = common_facts(&r.header);
    facts.extend([
        ["lights".into(), r.lights.to_string()],
        ["seed".into(), r.header.seed.to_string()],
        ["reference".into(), r.reference.clone()],
    ]);
    let reference = files.image(&r.reference_png, &r.reference_exr)?;
    let mut entries = vec![reference_entry(&r.reference, reference)];
    for e in &r.integrators {
        entries.push(Entry {
            name: e.name.clone(),
            about: format!("single scattering, {}", e.name),
            reference: false,
            unbiased: None,
            images: BTreeMap::from([("render", files.image(&e.png, &e.exr)?)]),
            values: BTreeMap::from([
                ("smape", e.smape),
                ("mean_bias", e.mean_bias),
                ("mean_abs_error", e.mean_abs_error),
                ("mean_radiance", e.mean_radiance),
                ("mean_samples_per_ray", e.mean_samples_per_ray),
                ("ms_per_frame", e.ms_per_frame),
                ("elapsed_ms", e.elapsed_ms),
            ]),
        });
    }
    Ok(Set {
        id: id.into(),
        label: id.into(),
        kind: "integrators",
        json,
        facts,
        width: r.header.width,
        height: r.header.height,
        modes: vec![Mode {
            id: "render",
            label: "render",
            caption: format!(
                "radiance L, {} spp, {}, sRGB-encoded",
                r.header.spp,
                view_caption(r.preview_gain, r.exposure)
            ),
            colour_map: None,
        }],
        entries,
        columns: INTEGRATOR_COLUMNS.to_vec(),
    })
}

/// The columns of a `direct` / `path` set (shadow-ray estimators under the same lights).
const LIT_COLUMNS: &[Column] = &[
    column(
        "smape",
        "SMAPE",
        "mean over pixels of |Y - Y_ref| / ((Y + Y_ref) / 2 + 0.01), luminance",
        4,
        false,
        "min",
    ),
    column(
        "mean_bias",
        "bias",
        "mean over pixels of (Y - Y_ref)",
        5,
        true,
        "absmin",
    ),
    column(
        "mean_bias_se",
        "bias s.e.",
        "standard error of the bias, from the per-pixel variances of both images",
        5,
        false,
        "",
    ),
    column(
        "mean_std",
        "std",
        "mean over pixels of the standard deviation of one sample's luminance",
        4,
        false,
        "min",
    ),
    column(
        "lookups_per_ray",
        "lookups/ray",
        "high-resolution lookups per camera sample (free flights and shadow rays)",
        2,
        false,
        "min",
    ),
    column(
        "ms_per_spp",
        "ms/spp",
        "render time per sample per pixel (one frame)",
        1,
        false,
        "min",
    ),
    column(
        "var_time",
        "std^2 x ms",
        "equal-time comparison: variance of one sample times the time of one frame; at equal \
         time the noise variance of each image is proportional to it (lower is better)",
        3,
        false,
        "min",
    ),
];

/// One set per integrator of a `host eval --integrators direct,path` report: its reference,
/// then its shadow-ray estimators.
fn lit_sets(r: &DirectEvalReport, files: &mut Files, id: &str, json: &str) -> Result<Vec<Set>> {
    let mut sets = Vec::new();
    for reference in &r.references {
        let mut facts = common_facts(&r.header);
        facts.extend([
            ["integrator".into(), reference.integrator.clone()],
            ["seed".into(), r.header.seed.to_string()],
            ["reference".into(), reference.reference.clone()],
            [
                "light pmf".into(),
                format!(
                    "sun {:.3}, map {:.3}, points {:.3}",
                    r.light_pmf[0], r.light_pmf[1], r.light_pmf[2]
                ),
            ],
        ]);
        let image = files.image(&reference.png, &reference.exr)?;
        let mut entries = vec![reference_entry(&reference.reference, image)];
        let prefix = format!("{}/", reference.integrator);
        for e in r.entries.iter().filter(|e| e.name.starts_with(&prefix)) {
            let ms_per_spp = e.elapsed_ms / r.header.spp as f64;
            entries.push(Entry {
                name: e.name.clone(),
                about: format!(
                    "{} with {} shadow rays",
                    reference.integrator,
                    &e.name[prefix.len()..]
                ),
                reference: false,
                unbiased: None,
                images: BTreeMap::from([("render", files.image(&e.png, &e.exr)?)]),
                values: BTreeMap::from([
                    ("smape", e.smape),
                    ("mean_bias", e.mean_bias),
                    ("mean_bias_se", e.mean_bias_se),
                    ("mean_std", e.mean_std),
                    ("lookups_per_ray", e.lookups_per_ray),
                    ("ms_per_spp", ms_per_spp),
                    ("var_time", e.mean_std * e.mean_std * ms_per_spp),
                ]),
            });
        }
        sets.push(Set {
            id: format!("{id}-{}", reference.integrator),
            label: format!("{id} ({})", reference.integrator),
            kind: "integrators",
            json: json.into(),
            facts,
            width: r.header.width,
            height: r.header.height,
            modes: vec![Mode {
                id: "render",
                label: "render",
                caption: format!(
                    "RGB radiance, {} spp, {}, sRGB-encoded",
                    r.header.spp,
                    view_caption(r.preview_gain, 1.0)
                ),
                colour_map: None,
            }],
            entries,
            columns: LIT_COLUMNS.to_vec(),
        });
    }
    Ok(sets)
}

/// The page: the template with the data as a JSON literal that cannot end its `<script>`.
pub fn render_html(data: &ViewerData) -> Result<String> {
    let json = serde_json::to_string(data).context("serializing the report data")?;
    // '<', '>' and '&' occur only inside JSON strings, where \u escapes mean the same; so no
    // "</script>" or "<!--" can appear in the literal.
    let json = json
        .replace('<', "\\u003c")
        .replace('>', "\\u003e")
        .replace('&', "\\u0026");
    anyhow::ensure!(
        TEMPLATE.matches(DATA_MARKER).count() == 1,
        "viewer template must hold the data marker once"
    );
    Ok(TEMPLATE.replace(DATA_MARKER, &json))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_cannot_close_the_script_tag() {
        let data = ViewerData {
            title: "</script><script>alert(1)</script> <!-- & >".into(),
            generator: String::new(),
            sets: Vec::new(),
        };
        let html = render_html(&data).unwrap();
        let start = html.find("id=\"report-data\"").unwrap();
        let rest = &html[start..];
        let literal = &rest[rest.find('>').unwrap() + 1..rest.find("</script>").unwrap()];
        assert!(
            !literal.contains('<') && !literal.contains('>'),
            "{literal}"
        );
        let back: serde_json::Value = serde_json::from_str(literal).unwrap();
        assert_eq!(back["title"], data.title.as_str());
    }

    #[test]
    fn slugs_and_urls_are_plain() {
        assert_eq!(slug("Cloud (procedural 256^3)"), "cloud--procedural-256-3");
        assert_eq!(slug("..."), "eval");
        assert_eq!(url_escape("a b#c.png"), "a%20b%23c.png");
        let mut used = Vec::new();
        assert_eq!(unique_id("cloud", &mut used), "cloud");
        assert_eq!(unique_id("cloud", &mut used), "cloud-2");
    }
}
