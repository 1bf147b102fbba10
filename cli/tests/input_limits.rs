//! Bounded memory on hostile input, through the binary: image headers are checked
//! against the caps before any pixel is decoded, views of another size are named,
//! typed sizes and thread counts are checked against stated maxima, and negative
//! numbers reach the options' own range checks.

mod common;

use std::path::Path;
use std::process::Output;
use std::time::{Duration, Instant};

use common::{arg, assert_fails, lfdepth};

/// A valid PNG signature and `IHDR` declaring `width`×`height` gray pixels of `bits`
/// bits (RGB when `rgb`), then a `paDd` ancillary chunk of `padding` zero bytes (which decoders skip)
/// and an empty image stream: a small file whose header promises a huge image, and
/// whose size passes the check of the header against the file's length.
fn png_header_only(width: u32, height: u32, bits: u8, rgb: bool, padding: usize) -> Vec<u8> {
    let chunk = common::png_chunk;
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&width.to_be_bytes());
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[bits, if rgb { 2 } else { 0 }, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    chunk(&mut out, b"paDd", &vec![0; padding]);
    chunk(
        &mut out,
        b"IDAT",
        &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
    );
    chunk(&mut out, b"IEND", &[]);
    out
}

fn estimate(dir: &Path, extra: &[&str]) -> Output {
    let out = dir.parent().unwrap().join("out.pfm");
    let mut args = vec!["estimate", arg(dir), "-o", arg(&out), "--quiet"];
    args.extend_from_slice(extra);
    lfdepth(&args)
}

/// Asserts a clap usage error (exit 2) whose message holds every needle and is not
/// clap's "unexpected argument".
fn assert_usage_error(output: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(!stderr.contains("unexpected argument"), "{stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "`{needle}` not in {stderr}");
    }
}

#[test]
fn a_huge_png_header_is_refused_before_decoding() {
    let dir = common::temp();
    let views = dir.path().join("views");
    std::fs::create_dir(&views).unwrap();
    common::hci_views(&views, 9, 16);
    // 60000² 1-bit pixels: 450 MB of rows and 3.6 GB once expanded to 8 bits; the file
    // (≈ 440 KB) is large enough that the header is not refused as corrupt.
    let hostile = png_header_only(60000, 60000, 1, false, 440_000);
    std::fs::write(views.join("input_Cam004.png"), &hostile).unwrap();
    let start = Instant::now();
    assert_fails(
        &estimate(&views, &[]),
        &["input_Cam004.png", "60000x60000", "--max-view-pixels"],
    );
    assert!(start.elapsed() < Duration::from_secs(10));
    // RGB of 20000² (1.2 GB once decoded): refused the same way.
    let rgb = png_header_only(20000, 20000, 8, true, 1_200_000);
    std::fs::write(views.join("input_Cam004.png"), &rgb).unwrap();
    let start = Instant::now();
    assert_fails(
        &estimate(&views, &[]),
        &["input_Cam004.png", "20000x20000", "--max-view-pixels"],
    );
    assert!(start.elapsed() < Duration::from_secs(10));
    // Every view hostile: the first one is refused, nothing is decoded.
    for i in 0..9 {
        std::fs::write(views.join(format!("input_Cam{i:03}.png")), &hostile).unwrap();
    }
    let start = Instant::now();
    assert_fails(
        &estimate(&views, &[]),
        &["input_Cam000.png", "--max-view-pixels"],
    );
    assert!(start.elapsed() < Duration::from_secs(10));
    // As an evaluation mask too.
    let gt = dir.path().join("gt.pfm");
    lfdepth_cli::io::pfm::write(
        &gt,
        &lfdepth_cli::io::pfm::Pfm::new(40, 40, vec![0.0; 1600]).unwrap(),
    )
    .unwrap();
    let mask = views.join("input_Cam000.png");
    assert_fails(
        &lfdepth(&["eval", arg(&gt), "--gt", arg(&gt), "--mask", arg(&mask)]),
        &["input_Cam000.png", "--max-view-pixels"],
    );
}

#[test]
fn the_whole_light_field_is_capped_from_the_headers() {
    let dir = common::temp();
    let views = dir.path().join("views");
    std::fs::create_dir(&views).unwrap();
    // 17x17 views of 8000² 1-bit pixels each pass the per-view cap (64 Mi) but are
    // 18.5 G pixels together.
    let big = png_header_only(8000, 8000, 1, false, 8_000);
    for i in 0..289 {
        std::fs::write(views.join(format!("input_Cam{i:03}.png")), &big).unwrap();
    }
    let start = Instant::now();
    assert_fails(
        &estimate(&views, &["--grid", "17x17"]),
        &["289 views of 8000x8000", "--max-pixels"],
    );
    assert!(start.elapsed() < Duration::from_secs(10));
}

#[test]
fn the_caps_can_be_set_and_are_named() {
    let dir = common::temp();
    let views = dir.path().join("views");
    std::fs::create_dir(&views).unwrap();
    common::hci_views(&views, 9, 16);
    assert_fails(
        &estimate(&views, &["--max-view-pixels", "255"]),
        &["input_Cam000.png", "16x16", "--max-view-pixels"],
    );
    assert_fails(
        &estimate(&views, &["--max-pixels", "2000"]),
        &["9 views of 16x16", "--max-pixels"],
    );
    let ok = estimate(
        &views,
        &[
            "--max-pixels",
            "2304",
            "--max-view-pixels",
            "256",
            "--stage",
            "epi",
        ],
    );
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    assert_usage_error(
        &estimate(&views, &["--max-pixels", "lots"]),
        &["--max-pixels", "64Mi"],
    );
}

#[test]
fn the_odd_view_is_named_not_the_good_one() {
    let dir = common::temp();
    let views = dir.path().join("views");
    std::fs::create_dir(&views).unwrap();
    common::hci_views(&views, 9, 16);
    lfdepth_cli::io::png::write(&views.join("input_Cam000.png"), &common::view(20, 16, 1, 0))
        .unwrap();
    let msg = assert_fails(
        &estimate(&views, &[]),
        &["input_Cam000.png", "20x16", "16x16"],
    );
    assert!(
        msg.starts_with(&format!("error: {}", arg(&views.join("input_Cam000.png")))),
        "{msg}"
    );
    // A view with another sample format is named the same way.
    common::hci_views(&views, 9, 16);
    lfdepth_cli::io::png::write(&views.join("input_Cam000.png"), &common::view(16, 16, 3, 0))
        .unwrap();
    let msg = assert_fails(&estimate(&views, &[]), &["input_Cam000.png", "3 channel"]);
    assert!(
        msg.starts_with(&format!("error: {}", arg(&views.join("input_Cam000.png")))),
        "{msg}"
    );
}

#[test]
fn typed_sizes_are_checked_before_allocating() {
    let dir = common::temp();
    let out = dir.path().join("big");
    for args in [
        vec![
            "synth",
            "--scene",
            "planes",
            "--size",
            "100000",
            "--out",
            arg(&out),
        ],
        vec![
            "synth",
            "--scene",
            "planes",
            "--size",
            "100000x1000",
            "--out",
            arg(&out),
        ],
        vec!["demo", "--size", "100000", "--out", arg(&out)],
    ] {
        let start = Instant::now();
        assert_fails(&lfdepth(&args), &["--size", "100000", "--max-view-pixels"]);
        assert!(start.elapsed() < Duration::from_secs(10));
        assert!(!out.exists(), "{args:?} created its folder");
    }
    let synth = |flags: &[&str]| common::synth_command(&out, "planes", flags);
    // Within the per-view cap but not the light-field cap.
    assert_fails(
        &lfdepth(&["demo", "--size", "4096", "--out", arg(&out)]),
        &["--size", "81 views of 4096x4096", "--max-pixels"],
    );
    assert_fails(
        &synth(&["--grid", "17x17", "--size", "2048"]),
        &["289 views", "--max-pixels"],
    );
    // Grids are checked against the supported 3x3 … 17x17 before anything is rendered.
    for grid in ["100x100", "99999999x3"] {
        assert_fails(&synth(&["--grid", grid]), &["view grid", "17x17"]);
    }
    assert!(!out.exists());
}

#[test]
fn thread_counts_are_capped_and_negative_numbers_reach_the_range_checks() {
    let dir = common::temp();
    let views = dir.path().join("views");
    std::fs::create_dir(&views).unwrap();
    common::hci_views(&views, 9, 16);
    for n in ["10000", "257", "0", "-1"] {
        let start = Instant::now();
        assert_usage_error(
            &estimate(&views, &["--threads", n]),
            &["--threads", "1 to 256"],
        );
        assert!(start.elapsed() < Duration::from_secs(10));
    }
    assert_usage_error(
        &lfdepth(&["demo", "--threads", "10000"]),
        &["--threads", "1 to 256"],
    );
    assert_usage_error(
        &lfdepth(&["eval", "--dataset", arg(dir.path()), "--threads", "-1"]),
        &["--threads", "1 to 256"],
    );
    let ok = estimate(&views, &["--threads", "256", "--stage", "epi"]);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    // A negative value is the option's value, answered by its range check.
    let msg = assert_fails(&estimate(&views, &["--tv-tolerance", "-1"]), &["tolerance"]);
    assert!(!msg.contains("unexpected argument"), "{msg}");
    let help = lfdepth(&["estimate", "--help"]);
    assert!(String::from_utf8_lossy(&help.stdout).contains("1 to 256"));
}
