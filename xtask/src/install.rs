//! Installs what a fresh machine lacks, idempotently: each function first checks, then
//! installs only what is missing, printing one `install:` line per action and keeping
//! the installer's own output for the error message if it fails.
//!
//! | what                                   | when                       | how                                        |
//! |----------------------------------------|----------------------------|--------------------------------------------|
//! | rustup targets wasm32, thumbv7em, thumbv6m | always                 | `rustup target add`                        |
//! | rustfmt, clippy                        | always                     | `rustup component add`                     |
//! | wasm-pack                              | wasm-pack step runs        | `cargo install wasm-pack --locked`         |
//! | wasm-bindgen (version of Cargo.lock)   | wasm-pack step runs        | `cargo install wasm-bindgen-cli --version =V --locked` |
//!
//! A `cargo install --locked` whose lock file names a dependency version the registry no
//! longer serves (yanked) is retried once without `--locked`.
//! | wasm-opt                               | wasm-pack step, root only  | `apt-get install -y binaryen`; without it, or older than [`MIN_WASM_OPT`], wasm-opt is turned off |
//! | chromium                               | browser tests, root only   | `apt-get install -y chromium`; otherwise the browser tests are skipped |
//! | qemu-system-arm                        | firmware runs, root only   | `apt-get install -y qemu-system-arm`; otherwise the step `firmware-qemu` is skipped |
//!
//! Nothing downloads a browser or a binary from outside the package registries.

use std::path::{Path, PathBuf};

use crate::exec::{available, is_root, Cmd};

/// Cross-compilation targets the steps build for.
pub const RUST_TARGETS: [&str; 3] = [
    "wasm32-unknown-unknown",
    "thumbv7em-none-eabihf",
    "thumbv6m-none-eabi",
];

/// Toolchain components the steps use.
pub const RUST_COMPONENTS: [&str; 2] = ["rustfmt", "clippy"];

/// The entries of `wanted` that are not lines of `installed` (the output of
/// `rustup target list --installed`).
pub fn missing<'a>(installed: &str, wanted: &[&'a str]) -> Vec<&'a str> {
    wanted
        .iter()
        .copied()
        .filter(|w| !installed.lines().any(|line| line.trim() == *w))
        .collect()
}

fn quietly(cmd: Cmd, root: &Path) -> Result<(), String> {
    println!("install: {cmd}");
    cmd.output(root).map(|_| ())
}

/// Adds the missing rustup targets and components of the active toolchain.
pub fn rust_toolchain(root: &Path) -> Result<(), String> {
    if !available("rustup") {
        println!("install: rustup not found; assuming the toolchain already has {RUST_TARGETS:?} and {RUST_COMPONENTS:?}");
        return Ok(());
    }
    let targets = Cmd::new("rustup", &["target", "list", "--installed"]).output(root)?;
    let targets = missing(&targets, &RUST_TARGETS);
    // A component is there when its cargo subcommand answers (rustup's proxies for
    // missing components fail); simpler than matching `<name>-<host triple>` lines.
    let components: Vec<&str> = RUST_COMPONENTS
        .into_iter()
        .filter(|c| {
            let subcommand = if *c == "rustfmt" { "fmt" } else { c };
            Cmd::cargo(&[subcommand, "--version"]).output(root).is_err()
        })
        .collect();
    if targets.is_empty() && components.is_empty() {
        println!(
            "install: nothing missing (targets {}; components {})",
            RUST_TARGETS.join(", "),
            RUST_COMPONENTS.join(", ")
        );
        return Ok(());
    }
    if !targets.is_empty() {
        quietly(Cmd::new("rustup", &["target", "add"]).args(&targets), root)?;
    }
    if !components.is_empty() {
        quietly(
            Cmd::new("rustup", &["component", "add"]).args(&components),
            root,
        )?;
    }
    Ok(())
}

/// `cargo install` of `package` (`args` may pin `--version`): with `--locked` first; if the
/// registry no longer has a locked dependency (yanked), once more without it.
pub fn cargo_install(package: &str, args: &[&str], root: &Path) -> Result<(), String> {
    let locked = Cmd::cargo(&["install", package, "--locked"]).args(args);
    match quietly(locked, root) {
        Ok(()) => Ok(()),
        Err(why) => {
            let reason = why
                .lines()
                .find(|line| line.starts_with("error"))
                .unwrap_or("see above");
            println!("install: --locked failed ({reason}); retrying without --locked");
            quietly(Cmd::cargo(&["install", package]).args(args), root)
        }
    }
}

/// `wasm-pack`, installed from crates.io when missing.
pub fn wasm_pack(root: &Path) -> Result<(), String> {
    if available("wasm-pack") {
        return Ok(());
    }
    cargo_install("wasm-pack", &[], root)
}

/// The version of `package` recorded in a Cargo.lock text.
pub fn lock_version(lock: &str, package: &str) -> Option<String> {
    let name_line = format!("name = \"{package}\"");
    let mut lines = lock.lines();
    while let Some(line) = lines.next() {
        if line.trim() == name_line {
            let version = lines.next()?.trim().strip_prefix("version = \"")?;
            return version.strip_suffix('"').map(str::to_string);
        }
    }
    None
}

/// A `wasm-bindgen` CLI of exactly the version the wasm crate links, installed from
/// crates.io when missing, so wasm-pack never tries to download one.
pub fn wasm_bindgen(root: &Path) -> Result<(), String> {
    let lock = std::fs::read_to_string(root.join("Cargo.lock"))
        .map_err(|e| format!("cannot read Cargo.lock: {e}"))?;
    let version =
        lock_version(&lock, "wasm-bindgen").ok_or("Cargo.lock has no wasm-bindgen entry")?;
    let installed = Cmd::new("wasm-bindgen", &["--version"])
        .output(root)
        .unwrap_or_default();
    if installed.split_whitespace().nth(1) == Some(version.as_str()) {
        return Ok(());
    }
    cargo_install(
        "wasm-bindgen-cli",
        &["--version", &format!("={version}")],
        root,
    )
}

/// Installs a Debian package (as root only): `apt-get update`, then `apt-get install -y`.
fn apt_install(package: &str, root: &Path) -> Result<(), String> {
    let env = ("DEBIAN_FRONTEND", "noninteractive");
    quietly(
        Cmd::new("apt-get", &["update", "-qq"]).env(env.0, env.1),
        root,
    )?;
    quietly(
        Cmd::new("apt-get", &["install", "-y", "-qq", package]).env(env.0, env.1),
        root,
    )
}

/// Oldest binaryen whose `wasm-opt` the wasm-pack step uses. Debian bookworm's 108 was
/// seen here to turn wasm-bindgen 0.2.130's externref table into one Node 20 rejects at
/// `initSync` ("Table.set(): Argument 1 is invalid"), even with every `--enable-*` flag;
/// versions from 116 on are trusted but were not tested here.
pub const MIN_WASM_OPT: u32 = 116;

/// The number in `wasm-opt --version` output (`wasm-opt version 108 (…)`).
pub fn binaryen_version(text: &str) -> Option<u32> {
    let rest = text.split("version").nth(1)?;
    let digits: String = rest
        .trim_start()
        .chars()
        .take_while(char::is_ascii_digit)
        .collect();
    digits.parse().ok()
}

/// Whether the wasm-pack step may run `wasm-opt`: it is on PATH (after installing Debian
/// `binaryen` when root) and not older than [`MIN_WASM_OPT`]. `Err` says why not.
pub fn wasm_opt(root: &Path) -> Result<(), String> {
    if !available("wasm-opt") {
        if !is_root() {
            return Err("wasm-opt not found and installing binaryen needs root".into());
        }
        apt_install("binaryen", root)?;
    }
    let text = Cmd::new("wasm-opt", &["--version"]).output(root)?;
    match binaryen_version(&text) {
        Some(v) if v >= MIN_WASM_OPT => Ok(()),
        Some(v) => Err(format!(
            "wasm-opt {v} is older than {MIN_WASM_OPT} and breaks wasm-bindgen's output"
        )),
        None => Err(format!("cannot read the version of wasm-opt from {text:?}")),
    }
}

/// The path of a Chromium executable, after installing Debian `chromium` when root;
/// `Err` says why there is none.
pub fn chromium(root: &Path) -> Result<PathBuf, String> {
    // An absolute path: playwright-core's `executablePath` does not search PATH.
    let find = || {
        std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default())
            .map(|dir| dir.join("chromium"))
            .chain([PathBuf::from("/usr/bin/chromium")])
            .find(|path| path.is_file() && available(&path.to_string_lossy()))
    };
    if let Some(path) = find() {
        return Ok(path);
    }
    if !is_root() {
        return Err(
            "chromium is not installed and installing it needs root (apt-get install chromium)"
                .into(),
        );
    }
    apt_install("chromium", root)?;
    find().ok_or_else(|| "apt-get installed chromium but it does not start".into())
}

/// `qemu-system-arm` (the firmware images' emulator), after installing Debian
/// `qemu-system-arm` when root; `Err` says why there is none.
pub fn qemu(root: &Path) -> Result<(), String> {
    if available("qemu-system-arm") {
        return Ok(());
    }
    if !is_root() {
        return Err("qemu-system-arm is not installed and installing it needs root (apt-get install qemu-system-arm)".into());
    }
    apt_install("qemu-system-arm", root)?;
    if available("qemu-system-arm") {
        Ok(())
    } else {
        Err("apt-get installed qemu-system-arm but it does not start".into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_targets_are_found() {
        let targets = "thumbv6m-none-eabi\nx86_64-unknown-linux-gnu\n";
        assert_eq!(
            missing(targets, &RUST_TARGETS),
            ["wasm32-unknown-unknown", "thumbv7em-none-eabihf"]
        );
        let all = "  wasm32-unknown-unknown\nthumbv7em-none-eabihf\nthumbv6m-none-eabi\n";
        assert!(missing(all, &RUST_TARGETS).is_empty());
        // A longer name is another target.
        assert_eq!(
            missing("thumbv6m-none-eabi-x\n", &["thumbv6m-none-eabi"]),
            ["thumbv6m-none-eabi"]
        );
    }

    #[test]
    fn binaryen_versions_are_read() {
        assert_eq!(binaryen_version("wasm-opt version 108\n"), Some(108));
        assert_eq!(
            binaryen_version("wasm-opt version 123 (version_123)"),
            Some(123)
        );
        assert_eq!(binaryen_version("wasm-opt"), None);
    }

    #[test]
    fn lock_versions_are_read() {
        let lock = "[[package]]\nname = \"wasm-bindgen\"\nversion = \"0.2.130\"\n\n[[package]]\nname = \"wasm-bindgen-macro\"\nversion = \"0.2.131\"\n";
        assert_eq!(
            lock_version(lock, "wasm-bindgen").as_deref(),
            Some("0.2.130")
        );
        assert_eq!(
            lock_version(lock, "wasm-bindgen-macro").as_deref(),
            Some("0.2.131")
        );
        assert_eq!(lock_version(lock, "js-sys"), None);
    }
}
