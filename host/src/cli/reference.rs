//! The CLI reference page (`docs/reference/cli.md`), generated from the clap definitions so that
//! every flag, its value, default and accepted values appear as `--help` states them;
//! `host/tests/cli_reference.rs` checks the committed page against it.

use super::Cli;
use clap::{Arg, Command, CommandFactory};
use std::fmt::Write;

/// The whole reference page as markdown.
pub fn markdown() -> String {
    let mut cmd = Cli::command();
    cmd.build();
    let mut out = String::from(
        "# Reference: the command line\n\n\
         Generated from the clap definitions by `host::cli::reference::markdown` and checked by\n\
         `host/tests/cli_reference.rs`; regenerate it with\n\
         `JK_WRITE_CLI_REFERENCE=1 cargo test --release -p host --test cli_reference`.\n\
         `host SUBCOMMAND --help` prints the same text. [Book contents](../README.md)\n\n",
    );
    let _ = writeln!(out, "## `host`\n\n{}\n", about(&cmd));
    out.push_str("Its flags: [`host render`](#host-render).\n\n");
    for sub in subcommands(&cmd) {
        command(&mut out, sub, "host");
    }
    out
}

/// The section of `cmd` (its name after `parent`), then those of its subcommands.
fn command(out: &mut String, cmd: &Command, parent: &str) {
    let name = format!("{parent} {}", cmd.get_name());
    let _ = writeln!(out, "## `{name}`\n\n{}\n", about(cmd));
    let args: Vec<&Arg> = cmd.get_arguments().filter(|a| shown(a)).collect();
    for a in &args {
        argument(out, a);
    }
    if !args.is_empty() {
        out.push('\n');
    }
    for sub in subcommands(cmd) {
        command(out, sub, &name);
    }
}

/// The subcommands of `cmd` but clap's own `help`.
fn subcommands(cmd: &Command) -> impl Iterator<Item = &Command> {
    cmd.get_subcommands().filter(|c| c.get_name() != "help")
}

/// Whether `a` belongs on the page (clap's own `--help` and `--version` and hidden flags do
/// not).
fn shown(a: &Arg) -> bool {
    !a.is_hide_set() && !matches!(a.get_id().as_str(), "help" | "version")
}

/// One bullet: the flag and its value, then its help, default and accepted values.
fn argument(out: &mut String, a: &Arg) {
    let value = a
        .get_value_names()
        .map(|v| {
            v.iter()
                .map(|n| format!("<{n}>"))
                .collect::<Vec<_>>()
                .join(" ")
        })
        .filter(|_| a.get_action().takes_values());
    let flag = match (a.get_long(), a.get_short()) {
        (Some(l), Some(s)) => format!("-{s}, --{l}"),
        (Some(l), None) => format!("--{l}"),
        (None, Some(s)) => format!("-{s}"),
        (None, None) => String::new(),
    };
    let head = match (flag.is_empty(), value) {
        (true, Some(v)) => v,
        (true, None) => a.get_id().as_str().to_owned(),
        (false, Some(v)) => format!("{flag} {v}"),
        (false, None) => flag,
    };
    let mut help = a
        .get_long_help()
        .or(a.get_help())
        .map(|h| one_line(&h.to_string()))
        .unwrap_or_default();
    if !help.is_empty() && !help.ends_with(['.', ']']) {
        help.push('.');
    }
    let _ = write!(out, "- `{head}`: {help}");
    let defaults: Vec<String> = a
        .get_default_values()
        .iter()
        .map(|d| d.to_string_lossy().into_owned())
        .collect();
    // A switch's default (`false`) says nothing.
    if !defaults.is_empty() && a.get_action().takes_values() {
        let _ = write!(out, " Default: `{}`.", defaults.join(","));
    }
    let values: Vec<String> = a
        .get_possible_values()
        .iter()
        .filter(|v| !v.is_hide_set())
        .map(|v| match v.get_help() {
            Some(h) => format!("`{}` ({})", v.get_name(), one_line(&h.to_string())),
            None => format!("`{}`", v.get_name()),
        })
        .collect();
    if !values.is_empty() && a.get_action().takes_values() {
        let _ = write!(out, " Values: {}.", values.join("; "));
    }
    out.push('\n');
}

/// The command's long description, or its short one.
fn about(cmd: &Command) -> String {
    cmd.get_long_about()
        .or(cmd.get_about())
        .map(|s| s.to_string().trim().to_owned())
        .unwrap_or_default()
}

/// `text` with its line breaks and runs of spaces as single spaces.
fn one_line(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}
