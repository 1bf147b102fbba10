//! `cargo xtask bench [--cpu NAME] [FILTER]`: the criterion benches of lfdepth-cli.
//!
//! `--cpu NAME` builds the benches with `rustc -C target-cpu=NAME` (for example
//! `x86-64-v3`, AVX2 + FMA, or `native`). Core is safe code and cannot pick vector
//! instructions at run time, so the default build uses the target's baseline (SSE2 on
//! x86-64); a build for the machine at hand shows what its wider vectors give. It goes to
//! its own target directory, `target/cpu-NAME`, so that neither build invalidates the
//! other and criterion's saved baselines never compare two different builds.

use std::path::{Path, PathBuf};

use crate::exec::Cmd;
use crate::manifest::target_names;

/// Which benches to run and the criterion filter to pass: a FILTER that names a bench
/// runs that whole bench; any other FILTER runs every bench, keeping matching ids.
pub fn select<'a>(
    benches: &'a [String],
    filter: Option<&'a str>,
) -> (Vec<&'a str>, Option<&'a str>) {
    match filter {
        Some(f) if benches.iter().any(|b| b == f) => (vec![f], None),
        other => (benches.iter().map(String::as_str).collect(), other),
    }
}

/// Where a build for `cpu` goes, below the repository root `root`.
pub fn cpu_target_dir(root: &Path, cpu: &str) -> PathBuf {
    root.join("target").join(format!("cpu-{cpu}"))
}

/// The `cargo bench` command for this selection, built for `cpu` when one is named.
/// The target directory is given as `CARGO_TARGET_DIR`, an absolute path, because
/// criterion reads that variable (not cargo's `--target-dir`) to place its reports,
/// from the bench's own working directory.
pub fn command(
    root: &Path,
    benches: &[&str],
    criterion_filter: Option<&str>,
    cpu: Option<&str>,
) -> Cmd {
    let mut cmd = Cmd::cargo(&["bench", "-p", "lfdepth-cli"]);
    if let Some(cpu) = cpu {
        cmd = cmd
            .env(
                "CARGO_TARGET_DIR",
                &cpu_target_dir(root, cpu).to_string_lossy(),
            )
            .env("RUSTFLAGS", &format!("-C target-cpu={cpu}"));
    }
    for bench in benches {
        cmd = cmd.args(&["--bench", bench]);
    }
    if let Some(filter) = criterion_filter {
        cmd = cmd.args(&["--", filter]);
    }
    cmd
}

/// Whether rustc knows `cpu` for the host: it only warns about an unknown name and then
/// builds for the baseline, which would pass a baseline measurement off as a CPU's.
fn check_cpu(cpu: &str) -> Result<(), String> {
    let listing = std::process::Command::new("rustc")
        .args(["--print", "target-cpus"])
        .output()
        .map_err(|e| format!("cannot run `rustc --print target-cpus`: {e}"))?;
    let text = String::from_utf8_lossy(&listing.stdout);
    if known_cpu(&text, cpu) {
        Ok(())
    } else {
        Err(format!(
            "rustc does not know the CPU `{cpu}`; `rustc --print target-cpus` lists the \
             names (for example x86-64-v3 or native)"
        ))
    }
}

/// Whether `cpu` is one of the names in `rustc --print target-cpus` output (one per
/// line, the name first, then an optional description).
fn known_cpu(listing: &str, cpu: &str) -> bool {
    listing
        .lines()
        .skip(1)
        .any(|line| line.split_whitespace().next() == Some(cpu))
}

pub fn run(root: &Path, filter: Option<&str>, cpu: Option<&str>) -> bool {
    if let Some(cpu) = cpu {
        if let Err(why) = check_cpu(cpu) {
            eprintln!("error: {why}");
            return false;
        }
    }
    let manifest = match std::fs::read_to_string(root.join("cli/Cargo.toml")) {
        Ok(text) => text,
        Err(e) => {
            eprintln!("error: cannot read cli/Cargo.toml: {e}");
            return false;
        }
    };
    let benches = target_names(&manifest, "bench");
    if benches.is_empty() {
        eprintln!("error: cli/Cargo.toml declares no [[bench]]");
        return false;
    }
    let (selected, criterion_filter) = select(&benches, filter);
    let cmd = command(root, &selected, criterion_filter, cpu);
    let result = cmd.run(root);
    let reports = match cpu {
        Some(cpu) => cpu_target_dir(root, cpu).join("criterion"),
        None => root.join("target").join("criterion"),
    };
    println!(
        "\nCriterion reports: {}/. Record numbers you cite in docs/BENCHMARKS.md, \
         with the command, the machine and a baseline measured in the same run.",
        reports.display()
    );
    match result {
        Ok(()) => true,
        Err(why) => {
            eprintln!("error: {why}");
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bench_name_selects_that_bench_and_anything_else_filters_ids() {
        let benches: Vec<String> = ["epi", "tv"].iter().map(|s| s.to_string()).collect();
        assert_eq!(select(&benches, None), (vec!["epi", "tv"], None));
        assert_eq!(select(&benches, Some("tv")), (vec!["tv"], None));
        assert_eq!(
            select(&benches, Some("q16")),
            (vec!["epi", "tv"], Some("q16"))
        );
        assert_eq!(
            command(Path::new("/repo"), &["epi", "tv"], Some("q16"), None).to_string(),
            "cargo bench -p lfdepth-cli --bench epi --bench tv -- q16"
        );
        let for_cpu = command(Path::new("/repo"), &["pipeline"], None, Some("x86-64-v3"));
        assert_eq!(
            for_cpu.to_string(),
            "CARGO_TARGET_DIR=/repo/target/cpu-x86-64-v3 RUSTFLAGS=-C target-cpu=x86-64-v3 \
             cargo bench -p lfdepth-cli --bench pipeline"
        );
    }

    #[test]
    fn cpu_names_are_checked_against_rustc_listing() {
        let listing = "Available CPUs for this target:\n    native      - Select the CPU of the current host.\n    x86-64-v3\n    znver4\n";
        assert!(known_cpu(listing, "x86-64-v3"));
        assert!(known_cpu(listing, "native"));
        assert!(!known_cpu(listing, "x86-64-v9"));
        assert!(!known_cpu(listing, "Available"));
    }
}
