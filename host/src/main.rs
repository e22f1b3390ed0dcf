//! `host`: renders and measures the jackknife transmittance estimators on the GPU or the CPU.

use std::process::ExitCode;

fn main() -> ExitCode {
    // Rust's runtime ignores SIGPIPE, so a closed stdout pipe (`host probe | head -1`) made the
    // next println! panic; restore the default, which ends the process quietly as it does any
    // Unix tool (outputs are renamed into place, so none is left half written).
    #[cfg(unix)]
    // SAFETY: at start-up, before any other thread exists; SIG_DFL is a valid disposition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // An interrupted or killed run (Ctrl-C, SIGTERM, SIGHUP) leaves no temporary file of a
    // write in progress (outputs are renamed into place, so none is left half written). A
    // handler that cannot be installed (one already is) leaves the signals' default.
    let _ = ctrlc::set_handler(|| {
        engine::output::partials::remove_all();
        eprintln!("error: interrupted; no output was left half written");
        std::process::exit(130);
    });
    // Usage errors exit with 1 like every other error (clap's default is 2); --help and
    // --version print to stdout and exit with 0.
    let cli = match host::cli::parse() {
        Ok(cli) => cli,
        Err(e) => {
            if e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
                eprintln!("error: a subcommand is required, one of the commands below\n");
            }
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    host::cli::init_tracing();
    // Every input the command names, protected from every output before any work.
    host::cli::inputs::protect(&cli);
    match host::cli::run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
