//! The `host` command line: its flags parsed into the options of the engine's and the lab's
//! library calls (`engine::render_job`, `lab::evaluate`, `lab::bench`, `lab::report`,
//! `lab::probe`, `studies`).

pub mod cli;
