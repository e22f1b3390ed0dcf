//! `host`: renders and measures the jackknife transmittance estimators on the GPU or the CPU.

use host::cli::Command;
use host::commands::{run_eval, run_probe, run_render};
use std::process::ExitCode;

fn main() -> ExitCode {
    // Usage errors exit with 1 like every other error (clap's default is 2); --help and
    // --version print to stdout and exit with 0.
    let cli = match host::cli::parse() {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    let result = match &cli.command {
        None => run_render(&cli.render).map(|_| ()),
        Some(Command::Render(args)) => run_render(args).map(|_| ()),
        Some(Command::Probe(args)) => run_probe(args),
        Some(Command::Eval(args)) => run_eval(args),
        Some(Command::Study(args)) => host::study::run(args),
        Some(Command::Bench(args)) => host::bench::run(args).map(|_| ()),
        Some(Command::Report(args)) => host::report::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
