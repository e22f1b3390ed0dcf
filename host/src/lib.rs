//! The `host` command line: flags parsed with clap into the options of the engine's and the
//! lab's library calls (`engine::render_job`, `lab::evaluate`, `lab::bench`, `lab::report`,
//! `lab::probe`, `studies`).

pub mod cli;
