//! `cargo xtask fuzz [SECONDS]`: every cargo-fuzz target of `fuzz/` for SECONDS each.
//!
//! cargo-fuzz passes `-Z` flags to rustc, so it needs nightly: a `nightly` rustup
//! toolchain when one is installed, otherwise the stable one with `RUSTC_BOOTSTRAP=1`
//! (see docs/FUZZING.md for what was checked). cargo-fuzz itself is installed with
//! `cargo install cargo-fuzz --locked` when missing. Crashes land in
//! `fuzz/artifacts/<target>/`.

use std::path::Path;
use std::time::Instant;

use crate::exec::{available, Cmd};
use crate::install;
use crate::manifest::target_names;
use crate::report::{self, Outcome, StepResult};

/// `cargo fuzz run` for one target, on nightly when there is one.
pub fn command(target: &str, seconds: u64, nightly: bool) -> Cmd {
    let cmd = if nightly {
        Cmd::new("cargo", &["+nightly", "fuzz", "run", target])
    } else {
        Cmd::new("cargo", &["fuzz", "run", target]).env("RUSTC_BOOTSTRAP", "1")
    };
    cmd.arg("--").arg(format!("-max_total_time={seconds}"))
}

pub fn run(root: &Path, seconds: u64) -> bool {
    let targets = match std::fs::read_to_string(root.join("fuzz/Cargo.toml")) {
        Ok(manifest) => target_names(&manifest, "bin"),
        Err(e) => {
            eprintln!("error: cannot read fuzz/Cargo.toml: {e}");
            return false;
        }
    };
    if !available("cargo-fuzz") {
        if let Err(why) = install::cargo_install("cargo-fuzz", &[], root) {
            eprintln!("error: {why}");
            return false;
        }
    }
    let nightly = Cmd::new("rustup", &["run", "nightly", "rustc", "--version"])
        .output(root)
        .is_ok();
    let mut results = Vec::new();
    for target in &targets {
        let cmd = command(target, seconds, nightly);
        println!("\n==> fuzz {target} for {seconds} s");
        let start = Instant::now();
        let outcome = match cmd.run(root) {
            Ok(()) => Outcome::Passed,
            Err(why) => Outcome::Failed(why),
        };
        results.push(StepResult {
            name: target.clone(),
            outcome,
            seconds: start.elapsed().as_secs_f64(),
        });
    }
    println!("\n{}", report::summary(&results));
    println!("Crashes, if any: fuzz/artifacts/<target>/. Record runs in docs/FUZZING.md.");
    report::counts(&results).1 == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stable_needs_bootstrap_and_nightly_does_not() {
        assert_eq!(
            command("plan_validate", 30, true).to_string(),
            "cargo +nightly fuzz run plan_validate -- -max_total_time=30"
        );
        assert_eq!(
            command("cfg_parse", 5, false).to_string(),
            "RUSTC_BOOTSTRAP=1 cargo fuzz run cfg_parse -- -max_total_time=5"
        );
    }
}
