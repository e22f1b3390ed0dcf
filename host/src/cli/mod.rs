//! Command-line interface, the only module that uses clap: the flags of every subcommand
//! (`host render` is the default), parsed into the library's option structs and run.

pub mod applicable;
pub mod bench;
pub mod eval;
pub mod inputs;
pub mod merge;
pub mod parsers;
pub mod probe;
pub mod reference;
pub mod render;
pub mod report;
pub mod restir;
pub mod scene_file;
pub mod study;
pub mod view;
pub mod view_rules;

pub use bench::BenchArgs;
pub use eval::EvalArgs;
pub use merge::MergeArgs;
pub use parsers::*;
pub use probe::ProbeArgs;
pub use render::{RenderArgs, SceneArgs};
pub use report::ReportArgs;
pub use study::{StudyArgs, StudyCommand};

use anyhow::Result;
use clap::{Parser, Subcommand};

/// Jackknife transmittance (Peters 2025) on a Vulkan GPU or the CPU, from one Rust source.
///
/// Without a subcommand, `host` renders (same flags as `host render`).
#[derive(Parser, Debug)]
#[command(
    version,
    about,
    args_conflicts_with_subcommands = true,
    override_usage = "host [OPTIONS] [SCENE]\n       host <COMMAND>"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    #[command(flatten)]
    pub render: RenderArgs,
    /// `host` was run without any argument: it renders [`QUICK_START`].
    #[arg(skip)]
    pub quick_start: bool,
}

/// What `host` without any argument renders: the embedded cloud lit by the default sky and sun
/// (direct illumination, the paper's Fig. 1 setting, shadow rays by the jackknife), sized to
/// take a few seconds on two CPU cores.
pub const QUICK_START: [&str; 9] = [
    "render",
    "--integrator",
    "direct",
    "--width",
    "384",
    "--height",
    "384",
    "--spp",
    "16",
];

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a primary-ray transmittance image (like the paper's Fig. 8): EXR + PNG + JSON.
    #[command(
        override_usage = "host render [OPTIONS] [SCENE]\n       SCENE: a TOML scene file or \
        a render's JSON summary (the same as --scene SCENE)"
    )]
    Render(RenderArgs),
    /// Evaluate Eq. 4 on simulated normal optical-depth pairs and compare with exp(-tau).
    Probe(ProbeArgs),
    /// Measure bias, std, RMSE, samples/ray and time of estimators against a reference.
    Eval(EvalArgs),
    /// Reproduce the paper's statistical experiments (Table 1, Fig. 2-7, App. A).
    Study(StudyArgs),
    /// Time every estimator on the same rays (CPU and/or GPU), with work-normalized variance and
    /// an optional sweep over volume resolution and image size.
    Bench(BenchArgs),
    /// Write a static HTML viewer comparing estimators (side by side, slider, insets, numbers)
    /// from new `host eval` runs or existing eval output directories.
    Report(ReportArgs),
    /// An interactive window: the render accumulating sample by sample, the camera on the mouse
    /// and keys, estimators switched live and side by side; screenshots and scene files that
    /// `host render` reproduces.
    #[command(override_usage = "host view [OPTIONS] [SCENE]")]
    View(view::ViewArgs),
    /// Add the shard files of a render (`host render --samples A..B --shard FILE`) into its
    /// images and JSON summary: the bytes one render of all samples gives.
    Merge(MergeArgs),
}

/// Parses the command line like `Cli::parse`, recording which render flags the user gave.
pub fn parse() -> Result<Cli, clap::Error> {
    let mut raw: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let quick_start = raw.len() == 1;
    if quick_start {
        raw.extend(QUICK_START.iter().map(Into::into));
    }
    let typed = typed_flags(&raw);
    let argv = scene_file::expand(raw).map_err(|e| {
        clap::Error::raw(clap::error::ErrorKind::ValueValidation, format!("{e:#}\n"))
    })?;
    let mut cli = parse_from(argv)?;
    cli.quick_start = quick_start;
    match &mut cli.command {
        None => cli.render.typed = typed,
        Some(Command::Render(args)) => args.typed = typed,
        Some(Command::View(args)) => args.render.typed = typed,
        Some(_) => {}
    }
    Ok(cli)
}

/// The long flag names (`json` for `--json` or `--json=FILE`, `out` for `-o`) typed in `argv`
/// itself, before a scene file's settings are inserted.
fn typed_flags(argv: &[std::ffi::OsString]) -> Vec<String> {
    scene_file::given_keys(
        &scene_file::render_command(),
        argv.get(1..).unwrap_or_default(),
    )
}

/// Parses `argv` (a scene file's settings already expanded into it), recording which render
/// flags it gave.
fn parse_from(argv: Vec<std::ffi::OsString>) -> Result<Cli, clap::Error> {
    use clap::{CommandFactory, FromArgMatches};
    // A flag given twice keeps its last value: a scene file's settings come first.
    let matches = Cli::command()
        .args_override_self(true)
        .mut_subcommand("render", |c| c.args_override_self(true))
        .mut_subcommand("eval", |c| c.args_override_self(true))
        .mut_subcommand("bench", |c| c.args_override_self(true))
        .mut_subcommand("report", |c| c.args_override_self(true))
        .mut_subcommand("view", |c| c.args_override_self(true))
        .try_get_matches_from(argv)?;
    let mut cli = Cli::from_arg_matches(&matches)?;
    let (render, sub) = match &mut cli.command {
        Some(Command::Render(args)) => (args, matches.subcommand_matches("render")),
        Some(Command::View(args)) => (&mut args.render, matches.subcommand_matches("view")),
        None => (&mut cli.render, Some(&matches)),
        Some(_) => return Ok(cli),
    };
    if let Some(m) = sub {
        scene_file::note_given(render, m);
    }
    Ok(cli)
}

/// Runs the parsed command through the library. The caller records its inputs first
/// ([`inputs::protect`]), so that no output can replace one.
pub fn run(cli: &Cli) -> Result<()> {
    // The environment is input too: checked before any work.
    engine::backend::gpu::forced_max_buffer_bytes()?;
    if cli.quick_start {
        eprintln!(
            "host: no command given, so the quick start: the embedded cloud under the default \
             sky and sun, direct illumination with jackknife shadow rays (`host {}`); `host \
             render` renders the camera rays' transmittance by any --estimator, `host --help` \
             lists every command",
            QUICK_START.join(" ")
        );
    }
    match &cli.command {
        None => render(&cli.render),
        Some(Command::Render(args)) => render(args),
        Some(Command::Probe(args)) => lab::probe::run_probe(&args.options()),
        Some(Command::Eval(args)) => lab::evaluate::run_eval(&args.options()?),
        Some(Command::Study(args)) => studies::run(&args.options()),
        Some(Command::Bench(args)) => lab::bench::run(&args.options()?).map(|_| ()),
        Some(Command::Report(args)) => lab::report::run(&args.options()?),
        Some(Command::Merge(args)) => merge::run(args),
        Some(Command::View(args)) => view(args),
    }
}

/// The workspace's crates whose events [`init_tracing`] prints (tracing targets are crate paths;
/// other crates' events are dropped).
pub const OUR_CRATES: [&str; 10] = [
    "host",
    "viewer",
    "engine",
    "lab",
    "studies",
    "output",
    "vulkan_backend",
    "volume_io",
    "jackknife",
    "shared",
];

/// `host render`: the flags the user gave must apply, then the library renders.
fn render(args: &RenderArgs) -> Result<()> {
    let options = args.options();
    applicable::check(&options, &args.given)?;
    if let Some(path) = &args.write_scene {
        // A written scene always renders: the checks `host render` makes of it come first.
        engine::render_job::check_render_flags(&options)?;
        let mut plan = engine::output::OutputPlan::new();
        if let Some(scene) = &args.scene_file {
            plan.input("--scene", scene);
        }
        plan.file("--write-scene", path).check()?;
        engine::output::write_text(path, &scene_file::to_toml(&args.record))?;
        println!(
            "wrote the scene to {} (render it with `host render {}`)",
            path.display(),
            path.display()
        );
        return Ok(());
    }
    if let Some(shard) = args.shard_output() {
        // A scene's `json` (every written summary holds one) is a run key: the merge writes
        // the summary there; only a --json typed here asks for a summary the shard cannot write.
        anyhow::ensure!(
            !args.typed.iter().any(|g| g == "json"),
            "--json: a shard writes no summary; `host merge` writes the render's JSON when the \
             shards are added up"
        );
        return engine::render_job::run_shard(&options, &shard).map(|_| ());
    }
    engine::render_job::run_render(&options).map(|_| ())
}

/// `host view`: the flags the user gave must apply, then the viewer opens its window.
fn view(args: &view::ViewArgs) -> Result<()> {
    let r = &args.render;
    anyhow::ensure!(
        r.write_scene.is_none() && r.shard.is_none(),
        "--write-scene and --shard belong to `host render`; in the viewer, P saves the view's \
         scene file"
    );
    let options = args.options();
    applicable::check(&options.render, &r.given)?;
    viewer::run(&options, &view_rules::CliRules)
}

/// Prints the library's diagnostics on stderr as before: `warning: <message>` for warnings,
/// the bare message for progress and info lines; only events of the workspace's crates, INFO and above, or
/// down to the level that the environment variable `JK_LOG` names (`debug`: e.g. each GPU
/// pipeline's build time).
pub fn init_tracing() {
    use tracing_subscriber::layer::SubscriberExt;
    use tracing_subscriber::util::SubscriberInitExt;
    let layer = tracing_subscriber::fmt::layer()
        .with_ansi(false)
        .with_writer(std::io::stderr)
        .event_format(PlainFormat);
    let level = match std::env::var("JK_LOG") {
        Err(_) => tracing::Level::INFO,
        Ok(v) => match v.to_ascii_lowercase().as_str() {
            "" | "info" => tracing::Level::INFO,
            "error" => tracing::Level::ERROR,
            "warn" => tracing::Level::WARN,
            "debug" => tracing::Level::DEBUG,
            "trace" => tracing::Level::TRACE,
            _ => {
                eprintln!(
                    "warning: JK_LOG={v:?} is not a level (error, warn, info, debug, trace); \
                     using info"
                );
                tracing::Level::INFO
            }
        },
    };
    let filter = tracing_subscriber::filter::Targets::new()
        .with_targets(OUR_CRATES.iter().map(|&target| (target, level)));
    // A second call (a subscriber already set) keeps the first one.
    let _ = tracing_subscriber::registry()
        .with(layer)
        .with(filter)
        .try_init();
}

/// The stderr format of [`init_tracing`]: the message, prefixed with `warning: ` for warnings
/// and `error: ` for errors.
struct PlainFormat;

impl<S, N> tracing_subscriber::fmt::FormatEvent<S, N> for PlainFormat
where
    S: tracing::Subscriber + for<'a> tracing_subscriber::registry::LookupSpan<'a>,
    N: for<'a> tracing_subscriber::fmt::FormatFields<'a> + 'static,
{
    fn format_event(
        &self,
        ctx: &tracing_subscriber::fmt::FmtContext<'_, S, N>,
        mut writer: tracing_subscriber::fmt::format::Writer<'_>,
        event: &tracing::Event<'_>,
    ) -> std::fmt::Result {
        match *event.metadata().level() {
            tracing::Level::WARN => write!(writer, "warning: ")?,
            tracing::Level::ERROR => write!(writer, "error: ")?,
            _ => {}
        }
        ctx.field_format().format_fields(writer.by_ref(), event)?;
        writeln!(writer)
    }
}

#[cfg(test)]
mod tests {
    use super::OUR_CRATES;

    /// Every workspace crate that emits tracing events is one whose events `init_tracing`
    /// prints: a crate missing from the list would have its warnings dropped silently.
    #[test]
    fn every_crate_that_logs_is_printed() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let workspace = std::fs::read_to_string(root.join("Cargo.toml")).unwrap();
        let members = workspace
            .lines()
            .find(|l| l.starts_with("members"))
            .expect("a members line");
        let names: Vec<&str> = members
            .split('"')
            .skip(1)
            .step_by(2)
            .filter(|m| !m.is_empty())
            .collect();
        assert!(names.contains(&"engine") && names.contains(&"host"));
        let mut checked = 0;
        for member in names {
            let manifest = std::fs::read_to_string(root.join(member).join("Cargo.toml")).unwrap();
            if manifest.lines().any(|l| l.starts_with("tracing ")) {
                let name = manifest
                    .lines()
                    .find_map(|l| l.strip_prefix("name = \""))
                    .and_then(|l| l.strip_suffix('"'))
                    .expect("a package name")
                    .replace('-', "_");
                assert!(
                    OUR_CRATES.contains(&name.as_str()),
                    "{name} logs with tracing but init_tracing drops its events"
                );
                checked += 1;
            }
        }
        assert!(checked >= 4, "only {checked} crates with tracing found");
    }

    /// `host render` without flags renders what the engine's `RenderOptions::default()`
    /// describes: the command line's defaults and the engine's cannot drift apart.
    #[test]
    fn render_defaults_are_the_engines() {
        let cli = super::parse_from(vec!["host".into(), "render".into()]).unwrap();
        let Some(super::Command::Render(args)) = &cli.command else {
            panic!("a render command");
        };
        let flags = args.options();
        let engine = engine::render_job::RenderOptions::default();
        assert_eq!(flags.image, engine.image);
        assert_eq!(flags.estimation, engine.estimation);
        assert_eq!(flags.lighting, engine.lighting);
        assert_eq!(flags.path, engine.path);
        assert_eq!(flags.exposure, engine.exposure);
        assert_eq!(flags.restir, engine.restir);
        assert_eq!(flags.integrator, engine.integrator);
        assert_eq!(flags.backend, engine.backend);
        assert_eq!(flags.layers, engine.layers);
        // A changed default is seen: the comparison is not vacuous.
        let changed = super::parse_from(vec![
            "host".into(),
            "render".into(),
            "--n".into(),
            "11".into(),
        ])
        .unwrap();
        let Some(super::Command::Render(args)) = &changed.command else {
            panic!("a render command");
        };
        assert_ne!(args.options().estimation, engine.estimation);
    }
}
