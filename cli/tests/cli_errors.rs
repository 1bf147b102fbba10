//! Bad input through the binary: each gives one clear `error: …` line naming the file
//! and what to change, a non-zero exit status, and no panic.

mod common;

use common::{assert_fails, lfdepth};

fn estimate(dir: &std::path::Path, extra: &[&str]) -> std::process::Output {
    let out = dir.join("out.pfm");
    let mut args = vec![
        "estimate",
        dir.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    lfdepth(&args)
}

#[test]
fn empty_folder() {
    let dir = common::temp();
    assert_fails(&estimate(dir.path(), &[]), &["no PNG views"]);
}

#[test]
fn missing_and_extra_views() {
    let dir = common::temp();
    common::hci_views(dir.path(), 9, 16);
    // Corners of a 3×3 grid: no stage reads them.
    std::fs::remove_file(dir.path().join("input_Cam002.png")).unwrap();
    std::fs::remove_file(dir.path().join("input_Cam006.png")).unwrap();
    std::fs::remove_file(dir.path().join("input_Cam003.png")).unwrap();
    assert_fails(
        &estimate(dir.path(), &[]),
        &["input_Cam003.png", "missing", "centre row and column"],
    );
    let dir = common::temp();
    common::row_col_views(dir.path(), "lf", 4, 3, 1, 16);
    assert_fails(
        &estimate(dir.path(), &["--grid", "3x3"]),
        &["do not fit the 3x3 grid", "lf_04_01.png", "--grid"],
    );
}

#[test]
fn views_of_different_sizes() {
    let dir = common::temp();
    common::hci_views(dir.path(), 9, 16);
    lfdepth_cli::io::png::write(
        &dir.path().join("input_Cam005.png"),
        &common::view(20, 16, 1, 5),
    )
    .unwrap();
    assert_fails(
        &estimate(dir.path(), &[]),
        &["input_Cam005.png", "20x16", "16x16"],
    );
}

#[test]
fn corrupt_and_zero_sized_pngs() {
    let dir = common::temp();
    common::hci_views(dir.path(), 9, 16);
    std::fs::write(dir.path().join("input_Cam003.png"), b"not a png at all").unwrap();
    assert_fails(&estimate(dir.path(), &[]), &["input_Cam003.png", "PNG"]);
    std::fs::write(
        dir.path().join("input_Cam003.png"),
        common::png_with_header(16, 0),
    )
    .unwrap();
    assert_fails(&estimate(dir.path(), &[]), &["input_Cam003.png"]);
}

#[test]
fn bad_cfg_value() {
    let dir = common::temp();
    common::hci_views(dir.path(), 9, 16);
    std::fs::write(
        dir.path().join("parameters.cfg"),
        "[intrinsics]\nfocal_length_mm = 100.0\n[extrinsics]\nnum_cams_y = -3\n",
    )
    .unwrap();
    assert_fails(
        &estimate(dir.path(), &[]),
        &["parameters.cfg", "line 4", "num_cams_y"],
    );
}

#[test]
fn a_strip_too_short_for_an_epi_and_bad_flags() {
    let dir = common::temp();
    // One row of two cameras: a linear array needs three.
    common::row_col_views(dir.path(), "strip", 1, 2, 0, 16);
    assert_fails(&estimate(dir.path(), &[]), &["1x2", "1x3", "3x3"]);
    assert_fails(
        &estimate(dir.path(), &["--pattern", "strip_{row}.png"]),
        &["pattern", "{row}"],
    );
    // clap's own usage errors exit with 2 and say what is wrong.
    let out = estimate(dir.path(), &["--grid", "seven"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("ROWSxCOLS"));
}

#[test]
fn corrupt_and_overflowing_pfms() {
    let dir = common::temp();
    let gt = dir.path().join("gt.pfm");
    let map = lfdepth_cli::io::pfm::Pfm::new(40, 40, vec![0.5; 1600]).unwrap();
    lfdepth_cli::io::pfm::write(&gt, &map).unwrap();
    let est = dir.path().join("est.pfm");
    let run = |bytes: &[u8]| {
        std::fs::write(&est, bytes).unwrap();
        lfdepth(&["eval", est.to_str().unwrap(), "--gt", gt.to_str().unwrap()])
    };
    assert_fails(
        &run(b"Pf\n18446744073709551615 2\n-1\n"),
        &["est.pfm", "too many"],
    );
    assert_fails(&run(b"Pf\n40 40\n-1\n\0\0\0\0"), &["est.pfm", "truncated"]);
    assert_fails(&run(b"P5\n40 40\n255\n"), &["est.pfm", "not a PFM"]);
    let mut small = lfdepth_cli::io::pfm::encode(
        &lfdepth_cli::io::pfm::Pfm::new(33, 40, vec![0.0; 1320]).unwrap(),
    );
    assert_fails(&run(&small), &["est.pfm", "33x40", "40x40"]);
    small.clear();
    let absent = dir.path().join("absent.pfm");
    assert_fails(
        &lfdepth(&[
            "eval",
            absent.to_str().unwrap(),
            "--gt",
            gt.to_str().unwrap(),
        ]),
        &["absent.pfm"],
    );
}

#[test]
fn out_of_range_parameters() {
    let dir = common::temp();
    common::hci_views(dir.path(), 9, 16);
    assert_fails(
        &estimate(dir.path(), &["--lambda", "-1"]),
        &["`--lambda`", "(0, 1000]"],
    );
    assert_fails(
        &estimate(dir.path(), &["--disparity-range", "-20..20"]),
        &["--disparity-range", "-8..8"],
    );
    assert_fails(
        &estimate(dir.path(), &["--disparity-range", "cfg"]),
        &["disp_min", "auto"],
    );
    let out = dir.path().join("no/such/folder/out.pfm");
    let input = dir.path().to_str().unwrap();
    assert_fails(
        &lfdepth(&[
            "estimate",
            input,
            "-o",
            out.to_str().unwrap(),
            "--stage",
            "epi",
        ]),
        &["out.pfm", "does not exist"],
    );
}
