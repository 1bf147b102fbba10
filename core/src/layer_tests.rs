//! The layers of `docs/ARCHITECTURE.md`, checked on the source: a stage never names the
//! plan layer (`plan`, `options`, `schedule`, `pipeline`, `stream`), and a foundation
//! module names neither the plan layer nor a stage. A name re-exported at the crate root
//! (`crate::Plan`) counts as its module.

extern crate std;
use std::fs;
use std::path::{Path, PathBuf};
use std::string::{String, ToString};
use std::vec::Vec;

const PLAN_LAYER: [&str; 5] = ["plan", "options", "schedule", "pipeline", "stream"];
const STAGES: [&str; 6] = ["align", "epi", "refine", "geofill", "median", "tv"];
const FOUNDATION: [&str; 7] = [
    "scalar",
    "float",
    "geometry",
    "lightfield",
    "error",
    "progress",
    "setup",
];

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// The `.rs` files of module `name`: `name.rs` and everything under `name/`.
fn module_files(name: &str) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let file = src().join(std::format!("{name}.rs"));
    if file.is_file() {
        files.push(file);
    }
    let mut dirs = std::vec![src().join(name)];
    while let Some(dir) = dirs.pop() {
        let Ok(entries) = fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    files
}

/// `(name, module)` of every `pub use module::{…}` / `pub use module::name` in lib.rs.
fn root_exports() -> Vec<(String, String)> {
    let lib = fs::read_to_string(src().join("lib.rs")).unwrap();
    let mut exports = Vec::new();
    for line in lib.lines() {
        let Some(path) = line.trim().strip_prefix("pub use ") else {
            continue;
        };
        let path = path.trim_end_matches(';');
        let Some((module, names)) = path.split_once("::") else {
            continue;
        };
        for name in names.trim_matches(|c| c == '{' || c == '}').split(',') {
            let name = name.trim();
            if !name.is_empty() {
                exports.push((name.to_string(), module.to_string()));
            }
        }
    }
    exports
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The crate modules `text` names through `crate::` paths: `crate::a::…`,
/// `crate::{a::…, b}`, and root re-exports (`crate::Plan` names `plan`).
fn named_modules(text: &str, exports: &[(String, String)]) -> Vec<String> {
    let mut names = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find("crate::") {
        let before = rest[..at].chars().next_back();
        rest = &rest[at + "crate::".len()..];
        if before.is_some_and(is_ident) {
            continue;
        }
        let group = if let Some(inner) = rest.strip_prefix('{') {
            // The group's first-level names (nested groups name paths inside them).
            let mut depth = 0usize;
            let end = inner
                .char_indices()
                .find(|&(_, c)| {
                    match c {
                        '{' => depth += 1,
                        '}' if depth == 0 => return true,
                        '}' => depth -= 1,
                        _ => {}
                    }
                    false
                })
                .map_or(inner.len(), |(i, _)| i);
            let mut firsts = Vec::new();
            let mut depth = 0usize;
            let mut start = true;
            let mut current = String::new();
            for c in inner[..end].chars() {
                match c {
                    '{' => depth += 1,
                    '}' => depth = depth.saturating_sub(1),
                    ',' if depth == 0 => start = true,
                    c if start && is_ident(c) => current.push(c),
                    _ if start && !current.is_empty() => {
                        firsts.push(core::mem::take(&mut current));
                        start = false;
                    }
                    _ => {}
                }
            }
            if !current.is_empty() {
                firsts.push(current);
            }
            firsts
        } else {
            std::vec![rest
                .chars()
                .take_while(|&c| is_ident(c))
                .collect::<String>()]
        };
        for name in group {
            let module = exports
                .iter()
                .find(|(export, _)| *export == name)
                .map_or(name, |(_, module)| module.clone());
            names.push(module);
        }
    }
    names
}

/// `file: module` for every file of `modules` that names one of `forbidden`.
fn violations(modules: &[&str], forbidden: &[&str]) -> Vec<String> {
    let exports = root_exports();
    let mut found = Vec::new();
    for module in modules {
        let files = module_files(module);
        assert!(!files.is_empty(), "no source for module `{module}`");
        for file in files {
            let text = fs::read_to_string(&file).unwrap();
            for name in named_modules(&text, &exports) {
                if forbidden.contains(&name.as_str()) {
                    found.push(std::format!("{}: crate::{name}", file.display()));
                }
            }
        }
    }
    found
}

#[test]
fn stages_do_not_import_the_plan_layer() {
    let found = violations(&STAGES, &PLAN_LAYER);
    assert!(
        found.is_empty(),
        "a stage takes its Setup, not the plan: {found:#?}"
    );
}

#[test]
fn foundations_import_neither_stages_nor_the_plan_layer() {
    let forbidden: Vec<&str> = STAGES.iter().chain(&PLAN_LAYER).copied().collect();
    let found = violations(&FOUNDATION, &forbidden);
    assert!(found.is_empty(), "a foundation module looks up: {found:#?}");
}

#[test]
fn the_scanner_sees_every_form_of_path() {
    let exports = root_exports();
    assert!(exports.contains(&("Plan".to_string(), "plan".to_string())));
    let text = "use crate::plan::Plan;\n\
                use crate::{error::Result, schedule::{Step, State}};\n\
                fn f(p: &crate::Plan) {}\n\
                let x = mycrate::stream::X; // not this crate\n\
                /// [`crate::pipeline::run`]";
    assert_eq!(
        named_modules(text, &exports),
        ["plan", "error", "schedule", "plan", "pipeline"]
    );
    // The plan imports every stage: the scan must see it.
    assert!(!violations(&["plan"], &["epi"]).is_empty());
}
