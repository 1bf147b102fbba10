//! Helpers shared by the integration tests: the shared data folder, the binary, and
//! small light-field fixtures written to temporary folders.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use lfdepth_cli::io::png::{self, Image, Samples};

/// `../shared/data`, or `None` (after a loud SKIPPED line) when it is absent.
pub fn shared_data(test: &str) -> Option<PathBuf> {
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data"));
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!(
            "SKIPPED: ../shared/data not found: {test} needs {}",
            dir.display()
        );
        None
    }
}

/// `path` as a command-line argument (the tests' paths are UTF-8).
pub fn arg(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// Runs the `lfdepth` binary.
pub fn lfdepth(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lfdepth"))
        .args(args)
        .output()
        .expect("the lfdepth binary runs")
}

/// Runs the `lfdepth` binary with arguments that end in `--json`, asserts that it
/// succeeded (showing its stderr otherwise) and parses what it printed.
pub fn lfdepth_json(args: &[&str]) -> serde_json::Value {
    let out = lfdepth(args);
    assert!(
        out.status.success(),
        "lfdepth {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("lfdepth --json prints one JSON value")
}

/// Asserts a clean failure: non-zero exit, no panic, one `error: …` line on stderr
/// containing every one of `needles`. Returns the message.
pub fn assert_fails(output: &Output, needles: &[&str]) -> String {
    let stderr = String::from_utf8_lossy(&output.stderr).to_string();
    assert!(
        !output.status.success(),
        "expected failure, got success; stderr: {stderr}"
    );
    assert_eq!(output.status.code(), Some(1), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let line = stderr
        .lines()
        .find(|l| l.starts_with("error: "))
        .unwrap_or_else(|| panic!("no `error: ` line in {stderr}"))
        .to_string();
    for needle in needles {
        assert!(line.contains(needle), "`{needle}` not in `{line}`");
    }
    line
}

/// A deterministic 8-bit view: gray (1 channel) or RGB.
pub fn view(width: usize, height: usize, channels: usize, seed: usize) -> Image {
    let samples = (0..width * height * channels)
        .map(|i| ((i * 31 + seed * 17) % 251) as u8)
        .collect();
    Image {
        width,
        height,
        channels,
        samples: Samples::Eight(samples),
    }
}

/// Writes `count` HCI-named gray views (`input_Cam000.png` …) of `size`×`size`.
pub fn hci_views(dir: &Path, count: usize, size: usize) {
    for i in 0..count {
        png::write(
            &dir.join(format!("input_Cam{i:03}.png")),
            &view(size, size, 1, i),
        )
        .unwrap();
    }
}

/// Writes `NAME_RR_CC.png` gray views for rows and columns `first..first+rows/cols`.
pub fn row_col_views(dir: &Path, name: &str, rows: usize, cols: usize, first: usize, size: usize) {
    for r in 0..rows {
        for c in 0..cols {
            let path = dir.join(format!("{name}_{:02}_{:02}.png", r + first, c + first));
            png::write(&path, &view(size, size, 1, r * cols + c)).unwrap();
        }
    }
}

/// Runs `lfdepth synth --scene SCENE --out OUT FLAGS…` and returns what it did, for
/// tests that expect it to fail.
pub fn synth_command(out: &Path, scene: &str, flags: &[&str]) -> Output {
    let mut args = vec!["synth", "--scene", scene, "--out", arg(out)];
    args.extend_from_slice(flags);
    lfdepth(&args)
}

/// Writes the synthetic scene `scene` of `size`² views into the folder `out` (views,
/// ground truth, `parameters.cfg`; the default 9×9 grid unless `flags` choose another),
/// asserts that `synth` succeeded (showing its stderr otherwise) and returns `out`.
pub fn synth_scene(out: &Path, scene: &str, size: usize, flags: &[&str]) -> PathBuf {
    let size = size.to_string();
    let mut all = vec!["--size", &size];
    all.extend_from_slice(flags);
    let run = synth_command(out, scene, &all);
    assert!(
        run.status.success(),
        "lfdepth synth --scene {scene} {}: {}",
        all.join(" "),
        String::from_utf8_lossy(&run.stderr)
    );
    out.to_path_buf()
}

/// The bit patterns of the disparity map `estimate` writes for `scene` with `extra`
/// flags, so that maps compare exactly (NaN included).
pub fn estimate_bits(scene: &Path, out: &Path, extra: &[&str]) -> Vec<u32> {
    let mut args = vec!["estimate", arg(scene), "-o", arg(out), "--quiet"];
    args.extend_from_slice(extra);
    let output = lfdepth(&args);
    assert!(
        output.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    lfdepth_cli::io::pfm::read(out)
        .unwrap()
        .data
        .iter()
        .map(|v| v.to_bits())
        .collect()
}

/// A fresh temporary folder (removed when dropped).
pub fn temp() -> tempfile::TempDir {
    tempfile::tempdir().expect("a temporary folder")
}

/// Appends one PNG chunk (length, type, data, CRC) to `out`.
pub fn png_chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    let mut body = kind.to_vec();
    body.extend_from_slice(data);
    out.extend_from_slice(&body);
    out.extend_from_slice(&crc32fast::hash(&body).to_be_bytes());
}

/// A PNG whose header declares `width`×`height` (possibly zero) with a valid CRC, and
/// one empty IDAT chunk.
pub fn png_with_header(width: u32, height: u32) -> Vec<u8> {
    let chunk = png_chunk;
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&width.to_be_bytes());
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    chunk(
        &mut out,
        b"IDAT",
        &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
    );
    chunk(&mut out, b"IEND", &[]);
    out
}

/// Scores `lfdepth eval --dataset ../shared/data/hci FLAGS` and asserts each scene's
/// BadPix0.07 % and MSE×100 below its `limits` (backgammon, then cotton: the order
/// `eval` lists them); `what` names the run in the output. Skips loudly without the data.
pub fn assert_hci_below(test: &str, what: &str, flags: &[&str], limits: [(&str, f64, f64); 2]) {
    let Some(data) = shared_data(test) else {
        return;
    };
    let hci = data.join("hci");
    let mut args = vec!["eval", "--dataset", arg(&hci)];
    args.extend_from_slice(flags);
    args.push("--json");
    let v = lfdepth_json(&args);
    let scenes = v["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), limits.len(), "{v}");
    for (s, (name, bad_max, mse_max)) in scenes.iter().zip(limits) {
        assert_eq!(s["scene"].as_str(), Some(name));
        let bad = s["badpix007"].as_f64().unwrap();
        let mse = s["mse100"].as_f64().unwrap();
        eprintln!("{name}: {what} {bad:.3} % / {mse:.3} (BadPix0.07 / MSE×100)");
        assert!(
            bad < bad_max,
            "{name}: {what}: BadPix0.07 {bad:.3} % ≥ {bad_max}"
        );
        assert!(
            mse < mse_max,
            "{name}: {what}: MSE×100 {mse:.3} ≥ {mse_max}"
        );
    }
}
