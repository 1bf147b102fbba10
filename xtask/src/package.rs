//! `cargo xtask package`: the npm package `lfdepth` in `target/npm/lfdepth/`, and its
//! tarball beside it (`npm pack`).
//!
//! The package is assembled from the wasm module built for the web with the feature
//! `png` (`wasm-pack` into `target/npm/pkg/`: the page's module plus `decodePng` and
//! `disparityPng`, which the page leaves out to stay small), the package's own files in
//! `wasm/npm/` (its Node entry `node.js` with `node.d.ts`, README, `examples/`), the
//! licence files of the repository, and a `package.json` written here with the
//! workspace's version, licence and repository. Its `exports` give Node `node.js` (the module instantiated on import)
//! and browsers and bundlers the wasm-bindgen module (`await init()` fetches the
//! `.wasm` beside it).

use std::path::{Path, PathBuf};

use crate::exec::Cmd;

/// The package's folder, relative to the repository root.
pub const PACKAGE_DIR: &str = "target/npm/lfdepth";

/// The package's name on npm.
pub const NAME: &str = "lfdepth";

/// Where wasm-pack writes the package's module, relative to the repository root.
pub const WASM_DIR: &str = "target/npm/pkg";

/// Files copied from [`WASM_DIR`] (wasm-pack's output).
const WASM_FILES: [&str; 4] = [
    "lfdepth_wasm.js",
    "lfdepth_wasm_bg.wasm",
    "lfdepth_wasm.d.ts",
    "lfdepth_wasm_bg.wasm.d.ts",
];

/// Files copied from `wasm/npm/`.
const OWN_FILES: [&str; 4] = ["node.js", "node.d.ts", "README.md", "examples/estimate.mjs"];

/// Files copied from the repository root.
const LICENCE_FILES: [&str; 2] = ["LICENSE-MIT", "LICENSE-APACHE"];

/// What `package.json` says besides the files: from `[workspace.package]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Metadata {
    pub version: String,
    pub license: String,
    pub repository: String,
}

impl Metadata {
    /// Reads `[workspace.package]` of the root Cargo.toml.
    pub fn read(root: &Path) -> Result<Self, String> {
        let path = root.join("Cargo.toml");
        let text = std::fs::read_to_string(&path)
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        let field = |key: &str| {
            crate::manifest::table_string(&text, "workspace.package", key).ok_or_else(|| {
                format!(
                    "{} has no `{key} = \"…\"` in [workspace.package]",
                    path.display()
                )
            })
        };
        Ok(Metadata {
            version: field("version")?,
            license: field("license")?,
            repository: field("repository")?,
        })
    }
}

/// A JSON string literal.
fn json_string(text: &str) -> String {
    let mut out = String::from("\"");
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// The package's `package.json`.
pub fn package_json(meta: &Metadata) -> String {
    let files: Vec<String> = WASM_FILES
        .iter()
        .chain(&OWN_FILES)
        .chain(&LICENCE_FILES)
        .map(|f| format!("    {}", json_string(f)))
        .collect();
    format!(
        r#"{{
  "name": "{NAME}",
  "version": {version},
  "description": "Dense disparity (depth) of a light field's centre view, in WebAssembly: the lfdepth pipeline for Node, bundlers and browsers",
  "license": {license},
  "repository": {{
    "type": "git",
    "url": {repository}
  }},
  "keywords": ["light field", "depth", "disparity", "stereo", "wasm"],
  "type": "module",
  "engines": {{
    "node": ">=18"
  }},
  "exports": {{
    ".": {{
      "browser": {{
        "types": "./lfdepth_wasm.d.ts",
        "default": "./lfdepth_wasm.js"
      }},
      "node": {{
        "types": "./node.d.ts",
        "default": "./node.js"
      }},
      "types": "./lfdepth_wasm.d.ts",
      "default": "./lfdepth_wasm.js"
    }},
    "./lfdepth_wasm_bg.wasm": "./lfdepth_wasm_bg.wasm",
    "./package.json": "./package.json"
  }},
  "main": "./node.js",
  "module": "./lfdepth_wasm.js",
  "browser": "./lfdepth_wasm.js",
  "types": "./lfdepth_wasm.d.ts",
  "sideEffects": [
    "./node.js"
  ],
  "files": [
{files}
  ]
}}
"#,
        version = json_string(&meta.version),
        license = json_string(&meta.license),
        repository = json_string(&meta.repository),
        files = files.join(",\n"),
    )
}

/// Builds the package's wasm module into [`WASM_DIR`].
pub fn build(root: &Path) -> Result<(), String> {
    crate::web::wasm_pack(root, "../target/npm/pkg", &["png"])
}

/// Writes the package into [`PACKAGE_DIR`] from an already built [`WASM_DIR`]; returns
/// its folder.
pub fn assemble(root: &Path) -> Result<PathBuf, String> {
    let meta = Metadata::read(root)?;
    let dir = root.join(PACKAGE_DIR);
    if dir.exists() {
        std::fs::remove_dir_all(&dir)
            .map_err(|e| format!("cannot clear {}: {e}", dir.display()))?;
    }
    let sources = WASM_FILES
        .iter()
        .map(|f| (root.join(WASM_DIR).join(f), *f))
        .chain(
            OWN_FILES
                .iter()
                .map(|f| (root.join("wasm/npm").join(f), *f)),
        )
        .chain(LICENCE_FILES.iter().map(|f| (root.join(f), *f)));
    for (from, name) in sources {
        if !from.is_file() {
            let hint = if from.starts_with(root.join(WASM_DIR)) {
                ": build it with `cargo xtask package`"
            } else {
                ""
            };
            return Err(format!("{} is missing{hint}", from.display()));
        }
        let to = dir.join(name);
        if let Some(parent) = to.parent() {
            std::fs::create_dir_all(parent)
                .map_err(|e| format!("cannot create {}: {e}", parent.display()))?;
        }
        std::fs::copy(&from, &to)
            .map_err(|e| format!("cannot copy {} to {}: {e}", from.display(), to.display()))?;
    }
    let json = dir.join("package.json");
    std::fs::write(&json, package_json(&meta))
        .map_err(|e| format!("cannot write {}: {e}", json.display()))?;
    Ok(dir)
}

/// `cargo xtask package [--no-build]`: builds the wasm module (unless told not to),
/// assembles the package and packs it with `npm pack` into `target/npm/`.
pub fn run(root: &Path, build: bool) -> bool {
    let result = (|| {
        if build {
            crate::install::wasm_pack(root)?;
            crate::install::wasm_bindgen(root)?;
            self::build(root)?;
        }
        let dir = assemble(root)?;
        println!("package: {}", dir.display());
        let out = root.join("target/npm");
        Cmd::new("npm", &["pack", "--pack-destination"])
            .arg(out.to_string_lossy())
            .dir(&dir)
            .run(root)?;
        let meta = Metadata::read(root)?;
        println!(
            "tarball: {}",
            out.join(format!("{NAME}-{}.tgz", meta.version)).display()
        );
        Ok::<(), String>(())
    })();
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
    fn package_json_carries_the_workspace_metadata_and_every_file() {
        let meta = Metadata {
            version: "1.2.3".into(),
            license: "MIT OR Apache-2.0".into(),
            repository: "https://example.invalid/\"x\"".into(),
        };
        let json = package_json(&meta);
        assert!(json.contains(r#""name": "lfdepth","#), "{json}");
        assert!(json.contains(r#""version": "1.2.3","#), "{json}");
        assert!(
            json.contains(r#""url": "https://example.invalid/\"x\"""#),
            "{json}"
        );
        for file in WASM_FILES.iter().chain(&OWN_FILES).chain(&LICENCE_FILES) {
            assert!(json.contains(&format!("\"{file}\"")), "{file}");
        }
        // Node gets the entry that instantiates the module on import.
        let node = json.find(r#""node": {"#).unwrap();
        assert!(json[node..].starts_with(
            "\"node\": {\n        \"types\": \"./node.d.ts\",\n        \"default\": \"./node.js\""
        ));
    }

    #[test]
    fn metadata_comes_from_the_workspace_manifest() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
        let meta = Metadata::read(root).unwrap();
        assert_eq!(meta.version, env!("CARGO_PKG_VERSION"));
        assert_eq!(meta.license, "MIT OR Apache-2.0");
    }

    #[test]
    fn a_missing_wasm_build_says_how_to_make_it() {
        let dir = std::env::temp_dir().join(format!("xtask-package-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("Cargo.toml"),
            "[workspace.package]\nversion = \"0.1.0\"\nlicense = \"MIT\"\nrepository = \"r\"\n",
        )
        .unwrap();
        let error = assemble(&dir).unwrap_err();
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(error.contains("lfdepth_wasm.js is missing"), "{error}");
        assert!(error.contains("cargo xtask package"), "{error}");
    }
}
