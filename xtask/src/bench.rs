//! `cargo xtask bench [FILTER]`: the criterion benches of lfdepth-cli.

use std::path::Path;

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

/// The `cargo bench` command for this selection.
pub fn command(benches: &[&str], criterion_filter: Option<&str>) -> Cmd {
    let mut cmd = Cmd::cargo(&["bench", "-p", "lfdepth-cli"]);
    for bench in benches {
        cmd = cmd.args(&["--bench", bench]);
    }
    if let Some(filter) = criterion_filter {
        cmd = cmd.args(&["--", filter]);
    }
    cmd
}

pub fn run(root: &Path, filter: Option<&str>) -> bool {
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
    let cmd = command(&selected, criterion_filter);
    let result = cmd.run(root);
    println!(
        "\nCriterion reports: target/criterion/. Record numbers you cite in docs/BENCHMARKS.md, \
         with the command, the machine and a baseline measured in the same run."
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
            command(&["epi", "tv"], Some("q16")).to_string(),
            "cargo bench -p lfdepth-cli --bench epi --bench tv -- q16"
        );
    }
}
