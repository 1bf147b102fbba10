//! `cargo xtask`: build and test orchestration.

mod web;

use std::path::PathBuf;
use std::process::ExitCode;

/// The repository root: xtask lives one level below it.
fn repo_root() -> PathBuf {
    let manifest_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    manifest_dir
        .parent()
        .map(PathBuf::from)
        .unwrap_or(manifest_dir)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    match args.split_first() {
        Some((&"web", rest)) => match web::parse(rest) {
            Ok(options) if web::run(&repo_root(), &options) => ExitCode::SUCCESS,
            Ok(_) => ExitCode::FAILURE,
            Err(message) => {
                eprintln!("error: {message}");
                ExitCode::from(2)
            }
        },
        _ => {
            println!("usage: cargo xtask test|web [--port N] [--no-build]|bench");
            ExitCode::SUCCESS
        }
    }
}
