//! `cargo xtask`: the one place where lfdepth's build and test orchestration lives.
//!
//! ```text
//! cargo xtask test [--quick]   every check CI runs (fmt, clippy, tests, no_std, wasm, docs, JS)
//! cargo xtask bench [--cpu NAME] [FILTER]   the criterion benches of lfdepth-cli
//! cargo xtask firmware        run the firmware images on an emulated Cortex-M (QEMU) and on the host
//! cargo xtask fuzz [SECONDS]   each cargo-fuzz target in fuzz/ for SECONDS (default 60)
//! cargo xtask web [--port N] [--no-build]   build web/pkg and serve the page (see [`web`])
//! cargo xtask types            regenerate the TypeScript type of the wasm options (see [`types`])
//! cargo xtask package [--no-build]   the npm package in target/npm/lfdepth and its tarball (see [`package`])
//! ```
//!
//! `test` first installs what the machine lacks (rustup targets and components), then runs
//! the steps in order, stopping at the first failure, and ends with a summary table and
//! the line `N passed, M failed, K skipped`. The steps, and how each optional one is
//! detected, are described in [`steps`]; what gets installed and how in [`install`].
//!
//! Only std is used: every step is an external command run with `std::process::Command`.

mod bench;
mod elf;
mod exec;
mod firmware;
mod fuzz;
mod install;
mod manifest;
mod package;
mod report;
mod steps;
mod types;
mod web;

use std::path::PathBuf;
use std::process::ExitCode;

/// What the user asked for.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Command {
    /// Run every check; `quick` leaves out release tests and everything wasm.
    Test { quick: bool },
    /// Run the criterion benches, optionally filtered, optionally built for one CPU.
    Bench {
        filter: Option<String>,
        cpu: Option<String>,
    },
    /// Run the firmware images under QEMU and on the host; compare their checksums.
    Firmware,
    /// Run each fuzz target for this many seconds.
    Fuzz { seconds: u64 },
    /// Build the wasm package and serve the page.
    Web(web::WebOptions),
    /// Regenerate the TypeScript type of the wasm package's options.
    Types,
    /// Assemble the npm package (building `web/pkg` first unless `build` is false) and
    /// pack it.
    Package { build: bool },
    /// Print usage.
    Help,
}

const USAGE: &str = "\
usage: cargo xtask <command>

commands:
  test [--quick]    run every check CI runs; --quick skips release tests and wasm/JS steps
  bench [--cpu NAME] [FILTER]
                    run the criterion benches (cargo bench -p lfdepth-cli); results go in
                    docs/BENCHMARKS.md; --cpu builds them for one CPU (rustc -C target-cpu=NAME,
                    e.g. x86-64-v3 or native) in target/cpu-NAME
  firmware          build the firmware images (stream, whole frame; thumbv7em f32, thumbv6m Q16),
                    run each under qemu-system-arm and on the host, print checksums and
                    instruction counts; fails on any difference (docs/EMBEDDED.md)
  fuzz [SECONDS]    run each fuzz target in fuzz/ for SECONDS (default 60); see docs/FUZZING.md
  web [--port N] [--no-build]
                    build the wasm package into web/pkg and serve web/ on 127.0.0.1
  types             write wasm/src/estimate_params.d.ts from the core's tunable table
  package [--no-build]
                    build web/pkg (unless --no-build), assemble the npm package `lfdepth` in
                    target/npm/lfdepth and pack it into target/npm/lfdepth-VERSION.tgz
  help              print this message";

/// Seconds each fuzz target runs when none are given.
const DEFAULT_FUZZ_SECONDS: u64 = 60;

/// Parses the arguments after `cargo xtask`.
fn parse_args(args: &[String]) -> Result<Command, String> {
    let mut rest = args.iter().map(String::as_str);
    let command = match rest.next() {
        None | Some("help" | "-h" | "--help") => return Ok(Command::Help),
        Some(c) => c,
    };
    let operands: Vec<&str> = rest.collect();
    match (command, operands.as_slice()) {
        ("test", []) => Ok(Command::Test { quick: false }),
        ("test", ["--quick"]) => Ok(Command::Test { quick: true }),
        ("test", other) => Err(format!(
            "`test` takes only --quick, not {}",
            other.join(" ")
        )),
        ("bench", options) => parse_bench(options),
        ("firmware", []) => Ok(Command::Firmware),
        ("firmware", other) => Err(format!(
            "`firmware` takes no options, not {}",
            other.join(" ")
        )),
        ("fuzz", []) => Ok(Command::Fuzz {
            seconds: DEFAULT_FUZZ_SECONDS,
        }),
        ("fuzz", [seconds]) => match seconds.parse::<u64>() {
            Ok(s) if s > 0 => Ok(Command::Fuzz { seconds: s }),
            _ => Err(format!(
                "`fuzz` takes a positive number of seconds, not `{seconds}`"
            )),
        },
        ("fuzz", _) => Err("`fuzz` takes at most one SECONDS".to_string()),
        ("web", options) => web::parse(options).map(Command::Web),
        ("types", []) => Ok(Command::Types),
        ("types", _) => Err("`types` takes no options".to_string()),
        ("package", []) => Ok(Command::Package { build: true }),
        ("package", ["--no-build"]) => Ok(Command::Package { build: false }),
        ("package", other) => Err(format!(
            "`package` takes only --no-build, not {}",
            other.join(" ")
        )),
        (other, _) => Err(format!("unknown command `{other}`")),
    }
}

/// `bench [--cpu NAME] [FILTER]`.
fn parse_bench(options: &[&str]) -> Result<Command, String> {
    let (cpu, rest) = match options {
        ["--cpu", name, rest @ ..] => (Some((*name).to_string()), rest),
        ["--cpu"] => return Err("`--cpu` needs a CPU name, e.g. x86-64-v3".to_string()),
        rest => (None, rest),
    };
    match rest {
        [] => Ok(Command::Bench { filter: None, cpu }),
        [filter] if !filter.starts_with('-') => Ok(Command::Bench {
            filter: Some((*filter).to_string()),
            cpu,
        }),
        _ => Err(format!(
            "`bench` takes [--cpu NAME] [FILTER], not `{}`",
            options.join(" ")
        )),
    }
}

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
    let command = match parse_args(&args) {
        Ok(c) => c,
        Err(message) => {
            eprintln!("error: {message}\n\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let root = repo_root();
    let ok = match command {
        Command::Help => {
            println!("{USAGE}");
            true
        }
        Command::Test { quick } => steps::run_all(&root, quick),
        Command::Bench { filter, cpu } => bench::run(&root, filter.as_deref(), cpu.as_deref()),
        Command::Firmware => match firmware::run(&root) {
            Ok(()) => true,
            Err(why) => {
                eprintln!("error: {why}");
                false
            }
        },
        Command::Fuzz { seconds } => fuzz::run(&root, seconds),
        Command::Web(options) => web::run(&root, &options),
        Command::Types => types::run(&root),
        Command::Package { build } => package::run(&root, build),
    };
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &[&str]) -> Result<Command, String> {
        let owned: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        parse_args(&owned)
    }

    #[test]
    fn commands_and_options_parse() {
        assert_eq!(parse(&[]), Ok(Command::Help));
        assert_eq!(parse(&["--help"]), Ok(Command::Help));
        assert_eq!(parse(&["test"]), Ok(Command::Test { quick: false }));
        assert_eq!(
            parse(&["test", "--quick"]),
            Ok(Command::Test { quick: true })
        );
        assert_eq!(
            parse(&["bench"]),
            Ok(Command::Bench {
                filter: None,
                cpu: None
            })
        );
        assert_eq!(
            parse(&["bench", "epi"]),
            Ok(Command::Bench {
                filter: Some("epi".into()),
                cpu: None
            })
        );
        assert_eq!(
            parse(&["bench", "--cpu", "x86-64-v3", "cotton_default"]),
            Ok(Command::Bench {
                filter: Some("cotton_default".into()),
                cpu: Some("x86-64-v3".into())
            })
        );
        assert_eq!(
            parse(&["fuzz"]),
            Ok(Command::Fuzz {
                seconds: DEFAULT_FUZZ_SECONDS
            })
        );
        assert_eq!(parse(&["fuzz", "300"]), Ok(Command::Fuzz { seconds: 300 }));
        assert_eq!(parse(&["types"]), Ok(Command::Types));
        assert!(parse(&["types", "--check"]).is_err());
        assert_eq!(parse(&["firmware"]), Ok(Command::Firmware));
        assert_eq!(parse(&["package"]), Ok(Command::Package { build: true }));
        assert_eq!(
            parse(&["package", "--no-build"]),
            Ok(Command::Package { build: false })
        );
        assert!(parse(&["package", "--publish"])
            .unwrap_err()
            .contains("--publish"));
    }

    #[test]
    fn bad_arguments_are_reported() {
        assert!(parse(&["test", "--slow"]).unwrap_err().contains("--slow"));
        assert!(parse(&["bench", "a", "b"]).is_err());
        assert!(parse(&["bench", "--cpu"]).unwrap_err().contains("CPU name"));
        assert!(parse(&["bench", "--fast"]).unwrap_err().contains("--fast"));
        assert!(parse(&["fuzz", "0"]).unwrap_err().contains("positive"));
        assert!(parse(&["fuzz", "ten"]).unwrap_err().contains("ten"));
        assert!(parse(&["build"]).unwrap_err().contains("build"));
        assert!(parse(&["firmware", "x"]).unwrap_err().contains("x"));
    }
}
