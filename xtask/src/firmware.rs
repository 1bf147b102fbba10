//! `cargo xtask firmware`: builds the firmware images (stream and whole frame, for
//! `thumbv7em-none-eabihf` and `thumbv6m-none-eabi`), runs each on an emulated Cortex-M
//! (`qemu-system-arm`, Arm MPS2 boards) and the same source on the host, and compares the
//! checksums.
//!
//! | target | kernels | board (QEMU machine) | host run of the same source |
//! |---|---|---|---|
//! | `thumbv7em-none-eabihf` | `f32` | `mps2-an386` (Cortex-M4F) | `cargo run --release -p lfdepth-firmware` |
//! | `thumbv6m-none-eabi` | Q16.16 | `mps2-an385` (Cortex-M3; Armv6-M code is a subset of Armv7-M) | the same with `--features q16` |
//!
//! The images are built with `--profile firmware --features qemu,panic-free` (and
//! `whole-frame` for the whole-frame image), so the image that runs is the one the
//! panic-free link check covers; they report through Arm semihosting (see
//! `firmware/src/device.rs`) and exit with a status. QEMU runs with `-icount shift=0`:
//! its virtual clock advances one nanosecond per guest instruction, and the image reads
//! the board's 25 MHz timer around each stage, so instructions = timer ticks × 40 (exact
//! to one tick, ±40 instructions per reading).
//!
//! One line per image and target (checksums, instructions), then the instructions per
//! stage, then each image's deepest stack by the static analysis of
//! `firmware/tools/stack_depth.py` (needs `python3`, `llvm-objdump` and `llvm-nm`; skipped
//! with a notice without them); fails on a checksum difference, a run that does not
//! report, a run past its time limit, or a stack above [`STACK_LIMITS`] (16 KiB).

use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::exec::Cmd;
use crate::install;

/// A firmware target: triple, kernels, QEMU machine, host features.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Target {
    pub triple: &'static str,
    pub kernels: &'static str,
    pub machine: &'static str,
    pub host_features: &'static str,
}

pub const TARGETS: [Target; 2] = [
    Target {
        triple: "thumbv7em-none-eabihf",
        kernels: "f32",
        machine: "mps2-an386",
        host_features: "",
    },
    Target {
        triple: "thumbv6m-none-eabi",
        kernels: "Q16",
        machine: "mps2-an385",
        host_features: "q16",
    },
];

/// The images: name (as both runs print it) and the cargo features of the device build.
pub const IMAGES: [(&str, &str); 2] = [
    ("stream", "qemu,panic-free"),
    ("whole-frame", "qemu,panic-free,whole-frame"),
];

/// The deepest stack (bytes, from the reset handler) each image may need: a
/// microcontroller's 16 KiB, the whole frame (alignment prelude and every stage)
/// included (docs/EMBEDDED.md, "Stack").
pub const STACK_LIMITS: [(&str, u64); 2] = [("stream", 16 * 1024), ("whole-frame", 16 * 1024)];

/// The depth `stack_depth.py` reports (`deepest stack from lfdepth_reset: N bytes`).
pub fn parse_stack(text: &str) -> Option<u64> {
    text.lines()
        .find_map(|l| l.strip_prefix("deepest stack from lfdepth_reset: "))
        .and_then(|rest| rest.strip_suffix(" bytes"))
        .and_then(|n| n.trim().parse().ok())
}

/// The static stack analysis of `elf`.
pub fn stack_depth(elf: &Path) -> Cmd {
    Cmd::new("python3", &["firmware/tools/stack_depth.py"]).arg(elf.to_string_lossy())
}

/// Instructions per tick of the boards' 25 MHz timer under `-icount shift=0`.
pub const INSTRUCTIONS_PER_TICK: u64 = 40;

/// Wall-clock limit of one QEMU run (the slowest, the Q16 stream, takes about a minute
/// on 2 loaded cores).
const QEMU_LIMIT: Duration = Duration::from_secs(600);

/// What an emulated run reported.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct DeviceReport {
    /// `stream 128x128` or `whole-frame 32x32`.
    pub image: String,
    pub checksum: Option<u32>,
    /// Timer ticks per stage, in the order the stages first ran.
    pub stages: Vec<(String, u64)>,
    pub total_ticks: u64,
}

fn hex(text: &str) -> Option<u32> {
    u32::from_str_radix(text.trim().strip_prefix("0x")?, 16).ok()
}

/// Reads the report an image prints through semihosting (`firmware/src/device.rs`).
pub fn parse_device(text: &str) -> Result<DeviceReport, String> {
    let mut report = DeviceReport::default();
    let mut total = None;
    for line in text.lines().map(str::trim) {
        if let Some(rest) = line.strip_prefix("stage ") {
            let (name, ticks) = rest
                .rsplit_once(": ")
                .ok_or_else(|| format!("unreadable stage line `{line}`"))?;
            let ticks = ticks
                .strip_suffix(" ticks")
                .and_then(|t| t.parse().ok())
                .ok_or_else(|| format!("unreadable stage line `{line}`"))?;
            report.stages.push((name.to_string(), ticks));
        } else if let Some(rest) = line.strip_prefix("total: ") {
            total = rest.strip_suffix(" ticks").and_then(|t| t.parse().ok());
        } else if let Some((image, rest)) = line.split_once(": checksum ") {
            report.image = image.to_string();
            report.checksum = hex(rest);
        } else if let Some(image) = line.strip_suffix(": error") {
            report.image = image.to_string();
        } else if line == "fault" {
            return Err("the image took a fault (HardFault or another exception)".into());
        }
    }
    report.total_ticks = total.ok_or("the image printed no `total:` line")?;
    if report.image.is_empty() {
        return Err("the image printed no result line".into());
    }
    Ok(report)
}

/// The `(image, checksum)` lines of the host binary (`stream 128x128: checksum 0x…, …`).
pub fn parse_host(text: &str) -> Vec<(String, u32)> {
    text.lines()
        .filter_map(|line| {
            let (image, rest) = line.split_once(": checksum ")?;
            let checksum = hex(rest.split(',').next()?)?;
            Some((image.trim().to_string(), checksum))
        })
        .collect()
}

/// The device build of `features` for both targets.
pub fn build(features: &str) -> Cmd {
    let mut cmd = Cmd::cargo(&["build", "-p", "lfdepth-firmware", "--profile", "firmware"])
        .args(&["--features", features]);
    for target in TARGETS {
        cmd = cmd.args(&["--target", target.triple]);
    }
    cmd.args(&["--target-dir", "target/nostd"])
        .env("RUSTFLAGS", "-D warnings")
}

/// Where cargo leaves the image of `triple`.
fn built(root: &Path, triple: &str) -> PathBuf {
    root.join(format!("target/nostd/{triple}/firmware/lfdepth-firmware"))
}

/// Where the image `image` of `triple` is kept for its run.
pub fn kept(root: &Path, triple: &str, image: &str) -> PathBuf {
    root.join(format!("target/nostd/qemu/{triple}-{image}.elf"))
}

/// The QEMU command line that runs `elf` on `machine`.
pub fn qemu(machine: &str, elf: &Path) -> Cmd {
    Cmd::new(
        "qemu-system-arm",
        &[
            "-M",
            machine,
            "-nographic",
            "-monitor",
            "none",
            "-serial",
            "none",
            "-semihosting-config",
            "enable=on,target=native",
            "-icount",
            "shift=0",
            "-kernel",
        ],
    )
    .arg(elf.to_string_lossy())
}

/// `1234567` as `1,234,567`.
pub fn grouped(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// One result line: image, target, checksums, instructions.
struct Row {
    image: String,
    target: Target,
    host: Option<u32>,
    device: Result<DeviceReport, String>,
}

impl Row {
    fn matches(&self) -> bool {
        matches!((&self.device, self.host), (Ok(d), Some(h)) if d.checksum == Some(h))
    }
}

fn checksum(c: Option<u32>) -> String {
    c.map_or_else(|| "none".to_string(), |c| format!("{c:#010x}"))
}

/// Builds, runs and compares everything; prints the table; `Err` says what failed.
pub fn run(root: &Path) -> Result<(), String> {
    install::rust_toolchain(root)?;
    install::qemu(root)?;
    for (image, features) in IMAGES {
        build(features).run(root)?;
        for target in TARGETS {
            let to = kept(root, target.triple, image);
            if let Some(dir) = to.parent() {
                std::fs::create_dir_all(dir)
                    .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
            }
            std::fs::copy(built(root, target.triple), &to)
                .map_err(|e| format!("cannot copy the {image} image to {}: {e}", to.display()))?;
        }
    }
    let mut rows = Vec::new();
    for target in TARGETS {
        let mut host = Cmd::cargo(&["run", "--release", "-p", "lfdepth-firmware"]);
        if !target.host_features.is_empty() {
            host = host.args(&["--features", target.host_features]);
        }
        println!("$ {host}");
        let host = parse_host(&host.output(root)?);
        for (image, _) in IMAGES {
            let elf = kept(root, target.triple, image);
            let device = qemu(target.machine, &elf)
                .output_within(root, QEMU_LIMIT)
                .and_then(|(text, ok)| {
                    print!("{text}");
                    let report = parse_device(&text)?;
                    if ok {
                        Ok(report)
                    } else {
                        Err(format!("qemu-system-arm exited with a failure: {text}"))
                    }
                });
            let name = device
                .as_ref()
                .map_or_else(|_| image.to_string(), |d| d.image.clone());
            let host = host
                .iter()
                .find(|(h, _)| *h == name || h.split(' ').next() == Some(image))
                .map(|(_, c)| *c);
            rows.push(Row {
                image: name,
                target,
                host,
                device,
            });
        }
    }
    println!();
    let mut failures = Vec::new();
    for row in &rows {
        let target = format!("{} ({})", row.target.triple, row.target.kernels);
        match &row.device {
            Ok(d) => {
                let verdict = if row.matches() { "equal" } else { "DIFFERENT" };
                println!(
                    "{:<18} {:<30} {:<11} host {}  qemu {}  {verdict}  {} instructions",
                    row.image,
                    target,
                    row.target.machine,
                    checksum(row.host),
                    checksum(d.checksum),
                    grouped(d.total_ticks * INSTRUCTIONS_PER_TICK),
                );
            }
            Err(why) => println!(
                "{:<18} {:<30} {:<11} host {}  qemu FAILED: {why}",
                row.image,
                target,
                row.target.machine,
                checksum(row.host)
            ),
        }
        if !row.matches() {
            failures.push(format!("{} on {}", row.image, row.target.triple));
        }
    }
    println!("\ninstructions per stage (timer ticks × {INSTRUCTIONS_PER_TICK}):");
    for row in &rows {
        if let Ok(d) = &row.device {
            let stages: Vec<String> = d
                .stages
                .iter()
                .map(|(name, ticks)| format!("{name} {}", grouped(ticks * INSTRUCTIONS_PER_TICK)))
                .collect();
            println!(
                "{} on {}: {}",
                row.image,
                row.target.triple,
                stages.join(", ")
            );
        }
    }
    if ["python3", "llvm-objdump", "llvm-nm"]
        .iter()
        .all(|p| crate::exec::available(p))
    {
        println!("\ndeepest stack (firmware/tools/stack_depth.py):");
        for (image, limit) in STACK_LIMITS {
            for target in TARGETS {
                let elf = kept(root, target.triple, image);
                let depth = parse_stack(&stack_depth(&elf).output(root)?);
                let verdict = match depth {
                    Some(d) if d <= limit => "within",
                    _ => "ABOVE",
                };
                println!(
                    "{image:<18} {:<30} {} bytes, {verdict} the limit of {} bytes",
                    target.triple,
                    depth.map_or_else(|| "unreadable".to_string(), grouped),
                    grouped(limit),
                );
                if verdict != "within" {
                    failures.push(format!(
                        "the {image} image's stack on {} is above {limit} bytes",
                        target.triple
                    ));
                }
            }
        }
    } else {
        println!("\nSKIPPED: the stack check needs python3, llvm-objdump and llvm-nm on PATH");
    }
    if failures.is_empty() {
        println!("\nevery emulated checksum equals the host's, every stack within its limit");
        Ok(())
    } else {
        Err(format!(
            "emulated run differs from the host, failed or needs too much stack: {}",
            failures.join("; ")
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_reports_are_read() {
        let text = "stream 128x128: checksum 0x6fc09da7\nstage sensor: 10 ticks\n\
                    stage epi horizontal: 25 ticks\ntotal: 40 ticks\n";
        let report = parse_device(text).unwrap();
        assert_eq!(report.image, "stream 128x128");
        assert_eq!(report.checksum, Some(0x6fc0_9da7));
        assert_eq!(
            report.stages,
            [
                ("sensor".to_string(), 10),
                ("epi horizontal".to_string(), 25)
            ]
        );
        assert_eq!(report.total_ticks, 40);
        let error = parse_device("stream 128x128: error\ntotal: 3 ticks\n").unwrap();
        assert_eq!(error.checksum, None);
        assert!(parse_device("fault\n").unwrap_err().contains("fault"));
        assert!(parse_device("stream 128x128: checksum 0x1\n")
            .unwrap_err()
            .contains("total"));
        assert!(parse_device("stage x: many ticks\ntotal: 1 ticks\n").is_err());
    }

    #[test]
    fn host_lines_are_read() {
        let text = "whole-frame 32x32: checksum 0xf9b3a2b9, 628080 scratch bytes, mean |d - gt| = 0.2453 px\n\
                    stream 128x128: checksum 0x6fc09da7, 243448 scratch bytes, mean |d - gt| = 0.0021 px\n";
        assert_eq!(
            parse_host(text),
            [
                ("whole-frame 32x32".to_string(), 0xf9b3_a2b9),
                ("stream 128x128".to_string(), 0x6fc0_9da7)
            ]
        );
    }

    #[test]
    fn stack_depth_is_read() {
        let text = "deepest stack from lfdepth_reset: 15108 bytes\n    1776  lfdepth_reset\n";
        assert_eq!(parse_stack(text), Some(15108));
        assert_eq!(parse_stack("recursion: f"), None);
        assert!(STACK_LIMITS.iter().all(|&(_, l)| l == 16 * 1024));
    }

    #[test]
    fn only_equal_checksums_pass() {
        let report = |checksum| DeviceReport {
            image: "stream 128x128".into(),
            checksum,
            stages: Vec::new(),
            total_ticks: 1,
        };
        let row = |host, device| Row {
            image: "stream 128x128".into(),
            target: TARGETS[0],
            host,
            device,
        };
        assert!(row(Some(7), Ok(report(Some(7)))).matches());
        assert!(!row(Some(7), Ok(report(Some(8)))).matches());
        assert!(!row(Some(7), Ok(report(None))).matches());
        assert!(!row(None, Ok(report(Some(7)))).matches());
        assert!(!row(Some(7), Err("fault".into())).matches());
    }

    #[test]
    fn builds_and_runs_are_the_documented_commands() {
        let text = build("qemu,panic-free").to_string();
        assert!(text.starts_with("RUSTFLAGS=-D warnings cargo build -p lfdepth-firmware --profile firmware --features qemu,panic-free --target thumbv7em-none-eabihf --target thumbv6m-none-eabi --target-dir target/nostd"), "{text}");
        let text = qemu("mps2-an386", Path::new("a.elf")).to_string();
        assert!(
            text.contains("-M mps2-an386") && text.contains("-icount shift=0 -kernel a.elf"),
            "{text}"
        );
        assert_eq!(grouped(0), "0");
        assert_eq!(grouped(999), "999");
        assert_eq!(grouped(1_234_567), "1,234,567");
    }
}
