//! `host`: renders and measures the jackknife transmittance estimators on the GPU or the CPU.

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
    host::cli::init_tracing();
    match host::cli::run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
