//! Just enough Cargo.toml reading to list `[[bench]]` and `[[bin]]` targets.

/// The `name = "…"` of every `[[table]]` entry (e.g. `table = "bench"`), in order.
pub fn target_names(manifest: &str, table: &str) -> Vec<String> {
    let header = format!("[[{table}]]");
    let mut names = Vec::new();
    let mut inside = false;
    for line in manifest.lines().map(str::trim) {
        if line.starts_with('[') {
            inside = line == header;
        } else if inside {
            let value = line
                .strip_prefix("name")
                .map(str::trim_start)
                .and_then(|rest| rest.strip_prefix('='))
                .map(|rest| rest.trim().trim_matches('"'));
            if let Some(name) = value {
                names.push(name.to_string());
                inside = false;
            }
        }
    }
    names
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_come_only_from_the_asked_table() {
        let manifest = r#"
[package]
name = "lfdepth-cli"

[[bin]]
name = "lfdepth"

[[bench]]
name = "epi"
harness = false

[[bench]]
harness = false
name="tv"

[dependencies]
name = "not-a-target"
"#;
        assert_eq!(target_names(manifest, "bench"), ["epi", "tv"]);
        assert_eq!(target_names(manifest, "bin"), ["lfdepth"]);
        assert!(target_names(manifest, "test").is_empty());
    }
}
