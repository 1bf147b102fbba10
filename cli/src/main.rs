//! `lfdepth`: the command-line tool. Parses arguments, runs the command, and turns any
//! failure into a one-line `error: …` and a non-zero exit status.

use std::process::ExitCode;

use clap::Parser;
use lfdepth_cli::commands::{run, Cli};

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
