//! Scene files: `host render SCENE` and `host render --scene SCENE` (and `host eval`, `host
//! bench` and `host report --scene SCENE`, which take the keys they have flags for). A scene file is a TOML
//! table whose keys are `host render`'s flags without the leading dashes (`density-scale`,
//! `integrator`, `light`, ...) and whose values are the flags' values: a number, a string, `true`
//! for a switch, an array for a comma list (`camera = [128, 128, 608]`) or, for a flag given
//! several times (`light`), one entry per time. The flags' own reference is therefore the scene
//! format's (docs/reference/cli.md), and every flag is a key. A render's JSON summary records the
//! same table as `scene`, so `--scene out/render.json` renders it again.
//!
//! The file's settings come first and the flags given on the command line override them. Input
//! paths (`volume`, `env`) relative to the file resolve against the file's folder; output paths
//! (`out`, `json`) stay relative to the working directory, as on the command line, so that
//! rendering a scene never writes beside it unasked.

use anyhow::{anyhow, bail, Context, Result};
use clap::{ArgAction, ArgMatches, Command};
use engine::render_job::scene_record::{SceneRecord, SceneValue};
use std::ffi::OsString;
use std::path::{Path, PathBuf};

/// Argument ids of `host render` that are not settings of the scene.
const NOT_SETTINGS: &[&str] = &[
    "help",
    "version",
    "scene_file",
    "write_scene",
    "samples",
    "shard",
];

/// Subcommands without scene files.
const NO_SCENE: &[&str] = &["probe", "study", "merge", "help"];

/// Scene keys a command reads under another flag: `host report` evaluates a list of volumes.
const ALIASES: &[(&str, &str, &str)] = &[("report", "volume", "volumes")];

/// Scene keys whose flag of the same name means something else in a command: `host report
/// --out` is a folder, not the image; `json` is the render's summary, not an evaluation's or a
/// benchmark's report (which would otherwise replace the summary a scene was read from).
const FOREIGN: &[(&str, &str)] = &[("report", "out"), ("eval", "json"), ("bench", "json")];

/// Keys whose text values are input files (unless one of the listed names).
const INPUT_PATHS: &[(&str, &[&str])] = &[
    ("volume", engine::scene::procedural::NAMES),
    ("env", &["sky", "none"]),
];

/// One setting of a scene file, with the line it stands on (None in a JSON summary).
struct Setting {
    key: String,
    value: SceneValue,
    line: Option<usize>,
}

/// `host render`'s flags as clap sees them.
pub(super) fn render_command() -> Command {
    <super::render::RenderArgs as clap::Args>::augment_args(Command::new("render"))
}

/// The flags of the subcommand that reads a scene file: `render` (also the default), `eval`,
/// `bench`.
fn command_of(name: &str) -> Command {
    match name {
        "eval" => <super::eval::EvalArgs as clap::Args>::augment_args(Command::new("eval")),
        "bench" => <super::bench::BenchArgs as clap::Args>::augment_args(Command::new("bench")),
        "report" => <super::report::ReportArgs as clap::Args>::augment_args(Command::new("report")),
        "view" => <super::view::ViewArgs as clap::Args>::augment_args(Command::new("view")),
        _ => render_command(),
    }
}

/// The command line with a scene file's settings inserted before the flags given, so that they
/// override the file's (the command accepts a flag twice and keeps the last). Unchanged when no
/// scene file is named; `host render SCENE` is read as `host render --scene SCENE`.
pub fn expand(args: Vec<OsString>) -> Result<Vec<OsString>> {
    let first = args
        .get(1)
        .and_then(|a| a.to_str())
        .unwrap_or("")
        .to_owned();
    if NO_SCENE.contains(&first.as_str()) {
        return Ok(args);
    }
    let mut args = args;
    let named = ["render", "eval", "bench", "report", "view"].contains(&first.as_str());
    let start = if named { 2 } else { 1 };
    let name = if named { first.as_str() } else { "render" };
    if name == "render" || name == "view" {
        if let Some(k) = positional(&command_of(name), &args[start..]) {
            // Without a subcommand, only a scene file is taken for one (not a mistyped
            // subcommand, which clap names).
            let tok = Path::new(&args[start + k]);
            let scene_like = tok.is_file()
                || tok.extension().is_some_and(|e| {
                    e.eq_ignore_ascii_case("toml") || e.eq_ignore_ascii_case("json")
                });
            if named || scene_like {
                args.insert(start + k, "--scene".into());
            }
        }
    }
    let user = &args[start..];
    let mut files = Vec::new();
    for (k, a) in user.iter().enumerate() {
        let a = a.to_string_lossy();
        if a == "--scene" {
            match user.get(k + 1) {
                Some(f) => files.push(PathBuf::from(f)),
                None => return Ok(args), // clap reports the missing value
            }
        } else if let Some(f) = a.strip_prefix("--scene=") {
            files.push(PathBuf::from(f));
        }
    }
    let file = match files.as_slice() {
        [] => return Ok(args),
        [f] => f.clone(),
        _ => bail!("--scene: give one scene file (got {})", files.len()),
    };
    let settings = load(&file)?;
    let cmd = command_of(name);
    let render = render_command();
    let given = given_keys(&cmd, user);
    let mut tokens = Vec::new();
    let mut unused = Vec::new();
    for s in &settings {
        let key = ALIASES
            .iter()
            .find(|(c, k, _)| *c == name && *k == s.key)
            .map_or(s.key.as_str(), |(_, _, flag)| *flag);
        let foreign = FOREIGN.contains(&(name, s.key.as_str()));
        let Some(arg) = find(&cmd, key).filter(|_| !foreign) else {
            // A key of `host render` that this command has no flag for.
            arg_of(&render, &file, s)?;
            unused.push(s.key.as_str());
            continue;
        };
        if given.iter().any(|g| g == key) {
            continue;
        }
        let value = resolve_input(&file, &s.key, &s.value);
        let t = tokens_of(arg, &value).map_err(|e| at(&file, s, &e))?;
        check_value(&cmd, &t).map_err(|e| at(&file, s, &e))?;
        tokens.extend(t);
    }
    if !unused.is_empty() {
        eprintln!(
            "note: host {name} has no flags for the scene keys {} of {}; they are not used",
            unused.join(", "),
            file.display()
        );
    }
    let mut out: Vec<OsString> = args[..start].to_vec();
    out.extend(tokens.into_iter().map(OsString::from));
    out.extend(args[start..].iter().cloned());
    Ok(out)
}

/// The index in `user` of the first token that is neither a flag nor a flag's value: the
/// positional SCENE of `host render SCENE` (anywhere among the flags).
fn positional(cmd: &Command, user: &[OsString]) -> Option<usize> {
    let mut value_next = false;
    for (k, a) in user.iter().enumerate() {
        let a = a.to_string_lossy();
        if value_next {
            value_next = false;
            continue;
        }
        if a == "--" {
            return None;
        }
        if let Some(long) = a.strip_prefix("--") {
            if !long.contains('=') {
                value_next = cmd
                    .get_arguments()
                    .find(|x| x.get_long() == Some(long))
                    .is_some_and(|x| x.get_action().takes_values());
            }
        } else if let Some(short) = a.strip_prefix('-').filter(|s| !s.is_empty()) {
            let mut chars = short.chars();
            let first = chars.next();
            value_next = chars.next().is_none()
                && cmd
                    .get_arguments()
                    .find(|x| x.get_short() == first)
                    .is_some_and(|x| x.get_action().takes_values());
        } else {
            return Some(k);
        }
    }
    None
}

/// "FILE:LINE: key `k`: message" (JSON summaries have no lines: "FILE: key ...").
fn at(file: &Path, s: &Setting, message: &str) -> anyhow::Error {
    match s.line {
        Some(line) => anyhow!("{}:{line}: key `{}`: {message}", file.display(), s.key),
        None => anyhow!("{}: scene key `{}`: {message}", file.display(), s.key),
    }
}

/// Largest scene file read (a scene is a few hundred bytes; a render's JSON summary a few KB).
const MAX_SCENE_BYTES: u64 = 16 << 20;

/// The settings of a TOML scene file, or of the `scene` of a JSON summary (`.json`).
fn load(file: &Path) -> Result<Vec<Setting>> {
    if let Ok(m) = std::fs::metadata(file) {
        if !m.is_file() {
            bail!(
                "--scene {}: not a regular file (a TOML scene, or the JSON summary of a render)",
                file.display()
            );
        }
        if m.len() > MAX_SCENE_BYTES {
            bail!(
                "--scene {}: {} bytes is not a scene file (at most {} MiB)",
                file.display(),
                m.len(),
                MAX_SCENE_BYTES >> 20
            );
        }
    }
    // The read itself is bounded: files such as /proc's report a size of 0 and can be longer.
    let mut text = String::new();
    std::fs::File::open(file)
        .and_then(|f| {
            use std::io::Read;
            f.take(MAX_SCENE_BYTES + 1).read_to_string(&mut text)
        })
        .with_context(|| {
            format!(
                "--scene {}: cannot read the scene file (a TOML scene, or the JSON summary of a \
                 render)",
                file.display()
            )
        })?;
    if text.len() as u64 > MAX_SCENE_BYTES {
        bail!(
            "--scene {}: longer than {} MiB, so not a scene file",
            file.display(),
            MAX_SCENE_BYTES >> 20
        );
    }
    if file
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
    {
        return from_json(file, &text);
    }
    from_toml(file, &text)
}

/// The keys of a TOML table, each with its value and line.
fn from_toml(file: &Path, text: &str) -> Result<Vec<Setting>> {
    let doc = toml_edit::ImDocument::parse(text)
        .map_err(|e| anyhow!("{}: not a TOML scene file: {e}", file.display()))?;
    let line_of = |span: Option<std::ops::Range<usize>>| {
        span.map(|r| text[..r.start.min(text.len())].matches('\n').count() + 1)
    };
    let table = doc.as_table();
    let mut settings = Vec::new();
    for (key, item) in table.iter() {
        let line = line_of(table.key(key).and_then(|k| k.span()));
        let value = match item.as_value() {
            Some(v) => from_toml_value(v),
            None => Err(format!(
                "a table: every key of a scene file is a flag of `host render` at the top level \
                 (`{key}-...` keys instead of a [{key}] table)"
            )),
        };
        let mut setting = Setting {
            key: key.to_owned(),
            value: SceneValue::Switch(false),
            line,
        };
        match value {
            Ok(v) => setting.value = v,
            Err(e) => return Err(at(file, &setting, &e)),
        }
        settings.push(setting);
    }
    Ok(settings)
}

/// A TOML value as a scene value (no dates, no inline tables).
fn from_toml_value(v: &toml_edit::Value) -> Result<SceneValue, String> {
    use toml_edit::Value as V;
    Ok(match v {
        V::String(s) => SceneValue::Text(s.value().clone()),
        V::Integer(i) => SceneValue::Integer(*i.value()),
        V::Float(f) => SceneValue::Number(*f.value()),
        V::Boolean(b) => SceneValue::Switch(*b.value()),
        V::Array(a) => SceneValue::List(
            a.iter()
                .map(from_toml_value)
                .collect::<Result<Vec<_>, String>>()?,
        ),
        V::Datetime(_) => return Err("a date is not a flag's value".into()),
        V::InlineTable(_) => return Err("an inline table is not a flag's value".into()),
    })
}

/// The `scene` object of a render's JSON summary.
fn from_json(file: &Path, text: &str) -> Result<Vec<Setting>> {
    let j: serde_json::Value = serde_json::from_str(text)
        .map_err(|e| anyhow!("{}: not a JSON summary: {e}", file.display()))?;
    let scene = j.get("scene").with_context(|| {
        format!(
            "{}: this JSON has no `scene` (a render's summary records its scene; re-render \
             with this version's `host render --json`, or pass a TOML scene file)",
            file.display()
        )
    })?;
    let record: SceneRecord = serde_json::from_value(scene.clone()).map_err(|e| {
        anyhow!(
            "{}: `scene` is not a table of settings: {e}",
            file.display()
        )
    })?;
    Ok(record
        .into_iter()
        .map(|(key, value)| Setting {
            key,
            value,
            line: None,
        })
        .collect())
}

/// The flag of `cmd` that key `key` names (None for the ids that are no setting).
fn find<'a>(cmd: &'a Command, key: &str) -> Option<&'a clap::Arg> {
    cmd.get_arguments()
        .find(|a| a.get_long() == Some(key) && !NOT_SETTINGS.contains(&a.get_id().as_str()))
}

/// The flag a setting names, refusing keys that are no flag of `cmd`.
fn arg_of<'a>(cmd: &'a Command, file: &Path, s: &Setting) -> Result<&'a clap::Arg> {
    find(cmd, &s.key).ok_or_else(|| {
        let mut close: Vec<&str> = cmd
            .get_arguments()
            .filter(|a| !NOT_SETTINGS.contains(&a.get_id().as_str()))
            .filter_map(|a| a.get_long())
            .filter(|l| similar(l, &s.key))
            .collect();
        close.sort_unstable();
        let hint = if close.is_empty() {
            String::new()
        } else {
            format!(" (did you mean {}?)", close.join(", "))
        };
        at(
            file,
            s,
            &format!(
                "unknown key{hint}; the keys are `host render`'s flags without the dashes \
                 (docs/reference/cli.md, host render)"
            ),
        )
    })
}

/// Whether two flag names look alike: one contains the other, or at most two edits apart.
fn similar(a: &str, b: &str) -> bool {
    a.contains(b) || b.contains(a) || edits(a, b) <= 2
}

/// Levenshtein distance of two names.
fn edits(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let next = (row[j + 1] + 1)
                .min(row[j] + 1)
                .min(diagonal + usize::from(ca != *cb));
            diagonal = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

/// The keys the command line gives itself (`--key`, `--key=v`, `-o`, `-q`).
pub(super) fn given_keys(cmd: &Command, user: &[OsString]) -> Vec<String> {
    let mut keys = Vec::new();
    for a in user {
        let a = a.to_string_lossy();
        if let Some(long) = a.strip_prefix("--") {
            keys.push(long.split('=').next().unwrap_or(long).to_owned());
        } else if let Some(short) = a.strip_prefix('-').and_then(|s| s.chars().next()) {
            let long = cmd
                .get_arguments()
                .find(|x| x.get_short() == Some(short))
                .and_then(|x| x.get_long());
            if let Some(long) = long {
                keys.push(long.to_owned());
            }
        }
    }
    keys
}

/// The file an input setting names (`volume`, `env`, unless one of their names such as `cloud`
/// or `sky`, or an `env` of `constant:R,G,B`), else None.
fn input_path<'a>(key: &str, value: &'a SceneValue) -> Option<&'a Path> {
    let (_, names) = INPUT_PATHS.iter().find(|(k, _)| *k == key)?;
    match value {
        SceneValue::Text(t) if key == "env" && t.starts_with("constant:") => None,
        SceneValue::Text(t) if !names.contains(&t.as_str()) => Some(Path::new(t)),
        _ => None,
    }
}

/// An input path relative to the scene file, made relative to its folder.
fn resolve_input(file: &Path, key: &str, value: &SceneValue) -> SceneValue {
    match input_path(key, value) {
        Some(p) if p.is_relative() => {
            let dir = file.parent().unwrap_or(Path::new(""));
            SceneValue::Text(dir.join(p).display().to_string())
        }
        _ => value.clone(),
    }
}

/// Fills what the parsed `host render` flags `m` say beyond their values: which flags were
/// given, and the resolved scene.
pub fn note_given(render: &mut super::render::RenderArgs, m: &ArgMatches) {
    render.given = m
        .ids()
        .filter(|id| m.value_source(id.as_str()) == Some(clap::parser::ValueSource::CommandLine))
        .map(|id| id.as_str().to_owned())
        .collect();
    render.record = record(m);
    // The sampler has no clap default (it follows `--layers`): the record names the one used.
    if !render.record.contains_key("sampler") {
        let name = engine::render_job::summary::sampler_name(render.sampler());
        render
            .record
            .insert("sampler".into(), SceneValue::Text(name.into()));
    }
}

/// The clap id of the `host render` flag a scene key names (None: not a setting).
pub fn flag_id(key: &str) -> Option<String> {
    find(&render_command(), key).map(|a| a.get_id().as_str().to_owned())
}

/// Parses the `host render` flags `tokens` (a shard's scene, then flags that override it) as
/// the command line would.
pub fn parse_render(tokens: Vec<OsString>) -> Result<super::render::RenderArgs, clap::Error> {
    use clap::FromArgMatches;
    let argv = std::iter::once(OsString::from("render")).chain(tokens);
    let m = render_command()
        .args_override_self(true)
        .try_get_matches_from(argv)?;
    let mut render = super::render::RenderArgs::from_arg_matches(&m)?;
    note_given(&mut render, &m);
    Ok(render)
}

/// The `host render` flags of a recorded scene (a shard's), as command-line tokens; `source`
/// names it in errors (a key this version has no flag for, a value it refuses).
pub fn record_tokens(rec: &SceneRecord, source: &Path) -> Result<Vec<OsString>> {
    let cmd = render_command();
    let mut tokens = Vec::new();
    for (key, value) in rec {
        let arg = find(&cmd, key).with_context(|| {
            format!(
                "{}: the scene key `{key}` is not a flag of this host version ({}); merge with                  the version that rendered it",
                source.display(),
                env!("CARGO_PKG_VERSION")
            )
        })?;
        let t = tokens_of(arg, value)
            .map_err(|e| anyhow!("{}: scene key `{key}`: {e}", source.display()))?;
        tokens.extend(t.into_iter().map(OsString::from));
    }
    Ok(tokens)
}

/// A scalar's text as the flag reads it.
fn scalar_text(v: &SceneValue) -> Result<String, String> {
    match v {
        SceneValue::Integer(i) => Ok(i.to_string()),
        SceneValue::Number(x) => Ok(x.to_string()),
        SceneValue::Text(t) => Ok(t.clone()),
        SceneValue::Switch(_) => Err("true or false is only the value of a switch".into()),
        SceneValue::List(_) => Err("a list inside a list".into()),
    }
}

/// The command-line tokens of one setting of flag `arg`.
fn tokens_of(arg: &clap::Arg, v: &SceneValue) -> Result<Vec<String>, String> {
    let flag = format!("--{}", arg.get_long().unwrap_or_default());
    match arg.get_action() {
        ArgAction::SetTrue => match v {
            SceneValue::Switch(true) => Ok(vec![flag]),
            SceneValue::Switch(false) => Ok(vec![]),
            _ => Err("a switch: true or false".into()),
        },
        ArgAction::Append => {
            let items: Vec<&SceneValue> = match v {
                SceneValue::List(items) => items.iter().collect(),
                one => vec![one],
            };
            let mut t = Vec::new();
            for item in items {
                t.push(flag.clone());
                t.push(list_text(item)?);
            }
            Ok(t)
        }
        _ => Ok(vec![flag, list_text(v)?]),
    }
}

/// A value as one flag value: a list joined by commas.
fn list_text(v: &SceneValue) -> Result<String, String> {
    match v {
        SceneValue::List(items) => Ok(items
            .iter()
            .map(scalar_text)
            .collect::<Result<Vec<_>, String>>()?
            .join(",")),
        other => scalar_text(other),
    }
}

/// Parses one setting's tokens alone, so that a wrong value is reported at its key and line.
fn check_value(cmd: &Command, tokens: &[String]) -> Result<(), String> {
    let argv = std::iter::once(cmd.get_name().to_owned()).chain(tokens.iter().cloned());
    match cmd.clone().try_get_matches_from(argv) {
        Ok(_) => Ok(()),
        Err(e) => {
            let text = e.to_string();
            let text = text.trim_start_matches("error: ");
            let first = text.lines().next().unwrap_or_default().trim().to_owned();
            Err(first)
        }
    }
}

/// The resolved scene of a parsed `host render` command line: every setting given (by the
/// scene file or a flag) and the default of every flag that applies to any render (the defaults
/// of flags that apply to some integrators only are left out: the command line refuses such
/// flags elsewhere). Input files are recorded as absolute paths.
pub fn record(m: &ArgMatches) -> SceneRecord {
    let cmd = render_command();
    let mut rec = SceneRecord::new();
    for arg in cmd.get_arguments() {
        let id = arg.get_id().as_str();
        let Some(long) = arg.get_long() else { continue };
        if NOT_SETTINGS.contains(&id) {
            continue;
        }
        let given = m.value_source(id) == Some(clap::parser::ValueSource::CommandLine);
        let default = m.value_source(id) == Some(clap::parser::ValueSource::DefaultValue);
        if !(given || default && !super::applicable::restricted(id)) {
            continue;
        }
        let value = match arg.get_action() {
            ArgAction::SetTrue => SceneValue::Switch(m.get_flag(id)),
            ArgAction::Append => {
                let Some(occ) = m.get_raw_occurrences(id) else {
                    continue;
                };
                SceneValue::List(
                    occ.flat_map(|o| o.map(|v| parse_text(&v.to_string_lossy())))
                        .collect(),
                )
            }
            _ => {
                let Some(mut raw) = m.get_raw(id) else {
                    continue;
                };
                let Some(v) = raw.next() else { continue };
                parse_text(&v.to_string_lossy())
            }
        };
        rec.insert(long.to_owned(), absolute_input(long, value));
    }
    rec
}

/// A flag value's text as a scene value: a number where it reads back as the same text, a list
/// of numbers for a comma list of them, else the text.
fn parse_text(s: &str) -> SceneValue {
    if s.contains(',') {
        let parts: Vec<SceneValue> = s.split(',').map(number).collect();
        if parts.iter().all(|p| !matches!(p, SceneValue::Text(_))) {
            return SceneValue::List(parts);
        }
        return SceneValue::Text(s.to_owned());
    }
    number(s)
}

/// `s` as an integer or a finite number if it prints back as `s`, else as text.
fn number(s: &str) -> SceneValue {
    if let Ok(i) = s.parse::<i64>() {
        if i.to_string() == s {
            return SceneValue::Integer(i);
        }
    }
    if let Ok(x) = s.parse::<f64>() {
        if x.is_finite() && x.to_string() == s {
            return SceneValue::Number(x);
        }
    }
    SceneValue::Text(s.to_owned())
}

/// An input path as an absolute one (so a scene renders from any folder).
fn absolute_input(key: &str, value: SceneValue) -> SceneValue {
    match input_path(key, &value).map(std::path::absolute) {
        Some(Ok(p)) => SceneValue::Text(p.display().to_string()),
        _ => value,
    }
}

pub use engine::render_job::scene_record::to_toml;
