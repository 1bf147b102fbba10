//! Just enough Cargo.toml reading to list `[[bench]]` and `[[bin]]` targets and to read
//! a string field of a table (the workspace's version for the npm package).

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

/// The string value of `key = "…"` in `[table]`, e.g. `version` in `[workspace.package]`.
pub fn table_string(manifest: &str, table: &str, key: &str) -> Option<String> {
    let header = format!("[{table}]");
    let mut inside = false;
    for line in manifest.lines().map(str::trim) {
        if line.starts_with('[') {
            inside = line == header;
        } else if inside {
            let value = line
                .strip_prefix(key)
                .map(str::trim_start)
                .and_then(|rest| rest.strip_prefix('='))
                .map(str::trim)
                .and_then(|rest| rest.strip_prefix('"'))
                .and_then(|rest| rest.split_once('"'))
                .map(|(value, _)| value.to_string());
            if value.is_some() {
                return value;
            }
        }
    }
    None
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

    #[test]
    fn string_fields_come_only_from_their_table() {
        let manifest = r#"
[package]
version = "9.9.9"

[workspace.package]
versionless = "no"
version = "0.1.0"
license = "MIT OR Apache-2.0" # a comment
edition.workspace = true
"#;
        let get = |table, key| table_string(manifest, table, key);
        assert_eq!(
            get("workspace.package", "version").as_deref(),
            Some("0.1.0")
        );
        assert_eq!(get("package", "version").as_deref(), Some("9.9.9"));
        assert_eq!(
            get("workspace.package", "license").as_deref(),
            Some("MIT OR Apache-2.0")
        );
        assert_eq!(get("workspace.package", "edition"), None);
        assert_eq!(get("workspace", "version"), None);
    }
}
