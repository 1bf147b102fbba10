//! Every answer clear, through the binary: each bad input below gets an error (or a
//! warning) that names the right thing and says what to change.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::{arg, assert_fails, lfdepth};
use lfdepth::options::{Flag, Kind, TUNABLES};
use lfdepth_cli::io::pfm::{self, Pfm};

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn estimate(scene: &Path, extra: &[&str]) -> Output {
    let out = scene.parent().unwrap().join("out.pfm");
    let mut args = vec!["estimate", arg(scene), "-o", arg(&out)];
    args.extend_from_slice(extra);
    lfdepth(&args)
}

/// Runs the binary, killing it (and failing the test) after `limit`.
fn lfdepth_within(args: &[&str], limit: Duration) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lfdepth"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            child.kill().unwrap();
            panic!("lfdepth {args:?} still ran after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

#[test]
fn a_size_mismatch_blames_the_view_unlike_the_majority() {
    // The rule: the size most views share is the right one (the first view's on a tie);
    // every other view is named.
    for odd in ["input_Cam005.png", "input_Cam000.png"] {
        let dir = common::temp();
        common::hci_views(dir.path(), 9, 16);
        lfdepth_cli::io::png::write(&dir.path().join(odd), &common::view(20, 16, 1, 5)).unwrap();
        let line = assert_fails(
            &estimate(dir.path(), &[]),
            &[odd, "is 20x16 pixels but the other 8 views", "are 16x16"],
        );
        // The example of a good view is another view.
        assert!(!line.contains(&format!("(e.g. {odd})")), "{line}");
    }
}

#[cfg(unix)]
#[test]
fn unreadable_views_are_named_for_what_they_are_not_missing() {
    use std::os::unix::fs::symlink;
    /// What stands in for the view, how to make it, and what the error must say.
    type Case = (&'static str, fn(&Path), &'static str);
    let cases: [Case; 3] = [
        (
            "a FIFO",
            |p| {
                let status = Command::new("mkfifo").arg(p).status().unwrap();
                assert!(status.success());
            },
            "FIFO",
        ),
        ("a folder", |p| std::fs::create_dir(p).unwrap(), "a folder"),
        (
            "a looping link",
            |p| symlink(p.file_name().unwrap(), p).unwrap(),
            "cannot read it",
        ),
    ];
    for (what, make, needle) in cases {
        let dir = common::temp();
        common::hci_views(dir.path(), 9, 16);
        let view = dir.path().join("input_Cam007.png");
        std::fs::remove_file(&view).unwrap();
        make(&view);
        let out = lfdepth_within(
            &[
                "estimate",
                arg(dir.path()),
                "-o",
                arg(&dir.path().join("o.pfm")),
            ],
            Duration::from_secs(60),
        );
        let line = assert_fails(&out, &["input_Cam007.png", needle]);
        assert!(!line.contains("missing"), "{what}: {line}");
    }
}

#[test]
fn a_nonexistent_input_is_not_called_not_a_folder() {
    let dir = common::temp();
    let nowhere = dir.path().join("nowhere");
    let line = assert_fails(&estimate(&nowhere, &[]), &["nowhere", "does not exist"]);
    assert!(!line.contains("not a folder"), "{line}");
    let file = dir.path().join("file.txt");
    std::fs::write(&file, "x").unwrap();
    assert_fails(
        &estimate(&file, &[]),
        &["file.txt", "is a file, not a folder"],
    );
    assert_fails(
        &lfdepth(&["eval", "--dataset", arg(&nowhere)]),
        &["nowhere", "does not exist", "scenes"],
    );
}

#[test]
fn a_folder_that_cannot_be_made_is_named_in_plain_words() {
    let dir = common::temp();
    let file = dir.path().join("file.txt");
    std::fs::write(&file, "x").unwrap();
    let inside = file.join("scene");
    for run in [
        common::synth_command(&inside, "planes", &["--size", "16"]),
        lfdepth(&["demo", "--size", "32", "--out", arg(&inside)]),
    ] {
        let line = assert_fails(&run, &["scene: cannot create it:"]);
        assert!(!line.contains("the folder it"), "{line}");
    }
}

/// A dataset: `real` and `broken` scenes under the root, `linked` a symbolic link to a
/// scene outside it, and a link back to the root (a cycle).
#[cfg(unix)]
fn dataset(root: &Path, outside: &Path) {
    use std::os::unix::fs::symlink;
    common::synth_scene(&root.join("real"), "planes", 32, &[]);
    common::synth_scene(&outside.join("elsewhere"), "planes", 32, &[]);
    symlink(outside.join("elsewhere"), root.join("linked")).unwrap();
    symlink(root, root.join("cycle")).unwrap();
    common::synth_scene(&root.join("broken"), "planes", 32, &[]);
    // The centre view: every stage reads it.
    std::fs::write(root.join("broken/input_Cam040.png"), b"not a png").unwrap();
}

#[cfg(unix)]
#[test]
fn eval_dataset_follows_links_and_reports_a_broken_scene_after_the_others() {
    let (root, outside) = (common::temp(), common::temp());
    dataset(root.path(), outside.path());
    let args = [
        "eval",
        "--dataset",
        arg(root.path()),
        "--stage",
        "epi",
        "--align",
        "off",
    ];
    let out = lfdepth(&args);
    let line = assert_fails(&out, &["1 of the 3 scenes could not be scored"]);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(table.contains("| linked | "), "{table}");
    assert!(table.contains("| real | "), "{table}");
    assert!(table.contains("| broken | failed |"), "{table}");
    assert!(table.contains("| **mean** of 2 scored |"), "{table}");
    assert!(
        table.contains("error: broken: ") && table.contains("input_Cam040.png"),
        "{table}"
    );
    assert!(!table.contains("cycle"), "{table}\n{line}");
    // JSON: the same, machine-readable.
    let mut json_args = args.to_vec();
    json_args.push("--json");
    let out = lfdepth(&json_args);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["failed"], serde_json::json!(1));
    let scenes = v["scenes"].as_array().unwrap();
    let names: Vec<&str> = scenes
        .iter()
        .map(|s| s["scene"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["broken", "linked", "real"]);
    assert!(scenes[0]["error"]
        .as_str()
        .unwrap()
        .contains("input_Cam040.png"));
    assert!(scenes[1]["badpix007"].is_number());
}

#[test]
fn negative_numbers_get_a_range_error_not_unexpected_argument() {
    let dir = common::temp();
    common::synth_scene(dir.path(), "planes", 16, &[]);
    for (flag, needle) in [
        ("--tv-tolerance", "--tv-tolerance"),
        ("--threads", "1 to 256"),
        ("--lambda", "--lambda"),
        ("--median", "--median"),
    ] {
        let out = estimate(dir.path(), &[flag, "-1"]);
        let err = stderr(&out);
        assert!(!out.status.success(), "{flag} -1 was accepted");
        assert!(!err.contains("unexpected argument"), "{flag}: {err}");
        assert!(err.contains(needle), "{flag}: {err}");
    }
}

/// Adds what `--depth` needs to a synthetic scene's parameters.cfg and sets its image
/// resolution.
fn cfg_with_resolution(scene: &Path, x: usize, y: usize) {
    let path = scene.join("parameters.cfg");
    let text = std::fs::read_to_string(&path).unwrap();
    let text = text
        .replace(
            "image_resolution_x_px = 32",
            &format!("image_resolution_x_px = {x}\nfocal_length_mm = 100\nsensor_size_mm = 35"),
        )
        .replace(
            "image_resolution_y_px = 32",
            &format!("image_resolution_y_px = {y}"),
        )
        .replace(
            "num_cams_y = 9",
            "num_cams_y = 9\nbaseline_mm = 90\nfocus_distance_m = 4",
        );
    std::fs::write(&path, text).unwrap();
}

#[test]
fn a_cfg_resolution_unlike_the_views_warns_and_blocks_metric_depth() {
    let dir = common::temp();
    let scene = dir.path().join("scene");
    common::synth_scene(&scene, "planes", 32, &[]);
    cfg_with_resolution(&scene, 32, 32);
    let depth = dir.path().join("depth.pfm");
    let epi = ["--stage", "epi", "--align", "off"];
    let ok = estimate(&scene, &[&epi[..], &["--depth", arg(&depth)]].concat());
    assert!(ok.status.success(), "{}", stderr(&ok));
    assert!(!stderr(&ok).contains("warning: "), "{}", stderr(&ok));
    std::fs::write(
        scene.join("parameters.cfg"),
        std::fs::read_to_string(scene.join("parameters.cfg"))
            .unwrap()
            .replace("image_resolution_x_px = 32", "image_resolution_x_px = 40")
            .replace("image_resolution_y_px = 32", "image_resolution_y_px = 40"),
    )
    .unwrap();
    let warned = estimate(&scene, &epi);
    assert!(warned.status.success(), "{}", stderr(&warned));
    let err = stderr(&warned);
    assert!(
        err.contains("warning: ") && err.contains("40x40") && err.contains("32x32"),
        "{err}"
    );
    std::fs::remove_file(&depth).unwrap();
    assert_fails(
        &estimate(&scene, &[&epi[..], &["--depth", arg(&depth)]].concat()),
        &["parameters.cfg", "40x40", "32x32", "--depth", "25.0 %"],
    );
    assert!(!depth.exists());
}

#[test]
fn cfg_disparity_bounds_out_of_range_name_the_cfg() {
    for (min, max) in [("3", "-2"), ("-50", "50"), ("nan", "1")] {
        let dir = common::temp();
        common::synth_scene(dir.path(), "planes", 16, &[]);
        let path = dir.path().join("parameters.cfg");
        let text = std::fs::read_to_string(&path)
            .unwrap()
            .replace("disp_min = -1.5", &format!("disp_min = {min}"))
            .replace("disp_max = 1.5", &format!("disp_max = {max}"));
        std::fs::write(&path, text).unwrap();
        let out = estimate(dir.path(), &["--disparity-range", "cfg"]);
        let err = stderr(&out);
        if min == "nan" && !out.status.success() && err.contains("line ") {
            // The cfg reader itself refuses a non-number, naming the key and line.
            assert!(err.contains("disp_min"), "{err}");
            continue;
        }
        let line = assert_fails(&out, &["parameters.cfg", "disp_min", "disp_max"]);
        assert!(!line.contains("parameter `--disparity-range`"), "{line}");
    }
}

/// A value `kind` refuses, as text.
fn out_of_range(kind: Kind) -> String {
    match kind {
        Kind::Float { max, .. } if max.is_finite() => format!("{}", max * 2.0 + 1.0),
        Kind::Float { min, .. } => format!("{}", min - 1.0),
        Kind::Int { min, .. } if min > 0 => "0".into(),
        Kind::Int { max, .. } => max
            .checked_add(1)
            .map_or_else(|| "-1".into(), |v| v.to_string()),
        Kind::Bool => "2".into(),
        Kind::Choice(_) => "bogus".into(),
        Kind::Range => "20..30".into(),
    }
}

#[test]
fn every_option_error_names_the_flag_as_typed() {
    let dir = common::temp();
    common::synth_scene(dir.path(), "planes", 16, &[]);
    let mut checked = 0;
    for t in TUNABLES {
        let Some(Flag::Value(flag)) = t.flag else {
            continue;
        };
        let bad = out_of_range(t.kind);
        let out = estimate(dir.path(), &[flag, &bad]);
        let err = stderr(&out);
        assert!(!out.status.success(), "{flag} {bad} was accepted");
        assert!(!err.contains("panicked"), "{err}");
        let line = err
            .lines()
            .find(|l| l.starts_with("error: "))
            .unwrap_or_else(|| panic!("{flag} {bad}: no error line in {err}"));
        assert!(line.contains(flag), "{flag} {bad}: {line}");
        if !t.path.starts_with("--") && t.path != flag.trim_start_matches("--") {
            assert!(
                !line.contains(&format!("`{}`", t.path)),
                "{flag} {bad}: the internal name in {line}"
            );
        }
        checked += 1;
    }
    assert!(checked >= 35, "only {checked} flags take a value");
}

#[test]
fn a_corrupt_png_is_described_in_words() {
    let dir = common::temp();
    common::hci_views(dir.path(), 9, 16);
    let path = dir.path().join("input_Cam004.png");
    let mut bytes = std::fs::read(&path).unwrap();
    // The IHDR chunk's CRC (bytes 29..33).
    bytes[30] ^= 0xff;
    std::fs::write(&path, &bytes).unwrap();
    let line = assert_fails(
        &estimate(dir.path(), &[]),
        &["input_Cam004.png", "checksum", "IHDR", "damaged"],
    );
    assert!(!line.contains("ChunkType") && !line.contains('{'), "{line}");
    // Damaged pixel data.
    let mut bytes = std::fs::read(dir.path().join("input_Cam005.png")).unwrap();
    let idat = bytes.windows(4).position(|w| w == b"IDAT").unwrap();
    bytes[idat + 4] ^= 0x55;
    bytes[idat + 5] ^= 0xaa;
    std::fs::write(&path, &bytes).unwrap();
    let line = assert_fails(&estimate(dir.path(), &[]), &["input_Cam004.png", "damaged"]);
    assert!(!line.contains("ChunkType") && !line.contains('{'), "{line}");
}

#[test]
fn views_too_small_to_score_are_refused_up_front_with_the_minimum() {
    let dir = common::temp();
    let scene = dir.path().join("s16");
    common::synth_scene(&scene, "planes", 16, &[]);
    // Estimating small views works…
    let est = dir.path().join("est.pfm");
    let out = lfdepth(&["estimate", arg(&scene), "-o", arg(&est), "--stage", "epi"]);
    assert!(out.status.success(), "{}", stderr(&out));
    // …scoring them cannot: the benchmark ignores a 15-pixel border.
    let line = assert_fails(
        &lfdepth(&[
            "eval",
            arg(&est),
            "--gt",
            arg(&scene.join("gt_disp_lowres.pfm")),
        ]),
        &["gt_disp_lowres.pfm", "16x16", "at least 31x31"],
    );
    assert!(!line.contains("border` leaves"), "{line}");
    let demo = dir.path().join("demo");
    let line = assert_fails(
        &lfdepth(&["demo", "--size", "16", "--out", arg(&demo)]),
        &["--size 16", "31"],
    );
    assert!(!line.contains("parameter"), "{line}");
    assert!(!demo.exists(), "the demo computed before refusing");
    let out = lfdepth(&[
        "demo",
        "--size",
        "31",
        "--out",
        arg(&demo),
        "--stage",
        "epi",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    // In a dataset, the small scene is reported and not estimated.
    let out = lfdepth(&["eval", "--dataset", arg(dir.path()), "--stage", "epi"]);
    assert_fails(&out, &["1 of the 1 scenes"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("at least 31x31"));
}

fn write_pfm(path: &Path, map: &Pfm) -> PathBuf {
    pfm::write(path, map).unwrap();
    path.to_path_buf()
}

#[test]
fn an_estimate_with_nan_pixels_keeps_the_protocol_but_warns() {
    let dir = common::temp();
    let (w, h) = (40, 40);
    let gt = write_pfm(
        &dir.path().join("gt.pfm"),
        &Pfm::new(w, h, vec![0.5; w * h]).unwrap(),
    );
    let mut data = vec![0.5f32; w * h];
    for v in data.iter_mut().take(w * h / 2) {
        *v = f32::NAN;
    }
    let est = write_pfm(&dir.path().join("est.pfm"), &Pfm::new(w, h, data).unwrap());
    let out = lfdepth(&["eval", arg(&est), "--gt", arg(&gt), "--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // The protocol: a NaN pixel is not a bad pixel.
    assert_eq!(v["badpix007"], serde_json::json!(0.0));
    assert!(v["invalid_pct"].as_f64().unwrap() > 0.0);
    assert!(
        v["warning"].as_str().unwrap().contains("NaN or infinite"),
        "{v}"
    );
    assert!(stderr(&out).contains("warning: "), "{}", stderr(&out));
    let out = lfdepth(&["eval", arg(&est), "--gt", arg(&gt)]);
    assert!(out.status.success());
    assert!(stderr(&out).contains("NaN or infinite"), "{}", stderr(&out));
    // A complete estimate: no warning.
    let out = lfdepth(&["eval", arg(&gt), "--gt", arg(&gt), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v.get("warning").is_none(), "{v}");
    assert!(!stderr(&out).contains("warning"), "{}", stderr(&out));
}

#[test]
fn colour_pfm_and_trailing_bytes_are_refused_with_the_reason() {
    let dir = common::temp();
    let (w, h) = (32, 32);
    let gt = write_pfm(
        &dir.path().join("gt.pfm"),
        &Pfm::new(w, h, vec![0.5; w * h]).unwrap(),
    );
    // Colour: red, green and blue differ.
    let colour = dir.path().join("colour.pfm");
    let mut bytes = format!("PF\n{w} {h}\n-1\n").into_bytes();
    for i in 0..w * h {
        for c in 0..3 {
            bytes.extend_from_slice(&((i + c) as f32).to_le_bytes());
        }
    }
    std::fs::write(&colour, &bytes).unwrap();
    assert_fails(
        &lfdepth(&["eval", arg(&colour), "--gt", arg(&gt)]),
        &["colour.pfm", "PF", "channels differ", "`Pf`"],
    );
    // Trailing bytes after the map.
    let trailing = dir.path().join("trailing.pfm");
    let mut bytes = pfm::encode(&Pfm::new(w, h, vec![0.5; w * h]).unwrap());
    bytes.extend_from_slice(&[0; 8]);
    std::fs::write(&trailing, &bytes).unwrap();
    assert_fails(
        &lfdepth(&["eval", arg(&trailing), "--gt", arg(&gt)]),
        &["trailing.pfm", "8 byte(s) more than the 32x32 map"],
    );
}
