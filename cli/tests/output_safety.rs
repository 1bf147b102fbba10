//! Nothing is lost, through the binary: outputs onto inputs or onto each other are
//! refused before any work, missing output folders and folders that take no files are
//! refused before loading, outputs replace old files whole, and `synth`/`demo` never
//! remove or overwrite files they did not write.

mod common;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use common::{arg, assert_fails, lfdepth};

/// A 3x3 synthetic scene of 32x32 views (views, ground truth, parameters.cfg).
fn scene(dir: &Path) -> PathBuf {
    common::synth_scene(&dir.join("scene"), "planes", 32, &["--grid", "3x3"])
}

/// Every file of `dir` with its bytes, sorted by name.
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .filter(|e| e.path().is_file())
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    files.sort();
    files
}

fn names(dir: &Path) -> Vec<String> {
    snapshot(dir).into_iter().map(|(n, _)| n).collect()
}

#[test]
fn outputs_onto_the_inputs_are_refused_and_the_scene_is_untouched() {
    let dir = common::temp();
    let scene = scene(dir.path());
    let before = snapshot(&scene);
    let view = scene.join("input_Cam004.png");
    let gt = scene.join("gt_disp_lowres.pfm");
    let cfg = scene.join("parameters.cfg");
    let elsewhere = dir.path().join("est.pfm");
    let view0 = scene.join("input_Cam000.png");
    let tenth = scene.join("input_Cam009.png");
    let respelled = scene.join("../scene/./input_Cam004.png");
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec!["-o", arg(&view)],
            vec!["-o", "input_Cam004.png", "a view of"],
        ),
        (
            vec!["-o", arg(&gt)],
            vec!["-o", "gt_disp_lowres.pfm", "ground truth"],
        ),
        (
            vec!["-o", arg(&cfg)],
            vec!["-o", "parameters.cfg", "camera parameters"],
        ),
        (
            vec!["-o", arg(&elsewhere), "--png", arg(&view0)],
            vec!["--png", "input_Cam000.png", "a view of"],
        ),
        (
            vec!["-o", arg(&elsewhere), "--png16", arg(&view)],
            vec!["--png16", "input_Cam004.png"],
        ),
        (
            vec!["-o", arg(&elsewhere), "--confidence", arg(&cfg)],
            vec!["--confidence", "parameters.cfg"],
        ),
        // The folder itself, and a name that would be read as a tenth view.
        (vec!["-o", arg(&scene)], vec!["-o", "input folder"]),
        (
            vec!["-o", arg(&tenth)],
            vec!["input_Cam009.png", "named like a view"],
        ),
        // The same view by another spelling of its path.
        (vec!["-o", arg(&respelled)], vec!["-o", "a view of"]),
    ];
    for (extra, needles) in cases {
        let mut args = vec!["estimate", arg(&scene)];
        args.extend(extra.iter().copied());
        args.push("--quiet");
        assert_fails(&lfdepth(&args), &needles);
        assert_eq!(snapshot(&scene), before, "lfdepth {}", args.join(" "));
    }
    assert!(!elsewhere.exists(), "a refused run wrote an output");
}

#[cfg(unix)]
#[test]
fn links_to_inputs_are_inputs() {
    let dir = common::temp();
    let scene = scene(dir.path());
    let before = snapshot(&scene);
    let link = dir.path().join("link.png");
    std::os::unix::fs::symlink(scene.join("input_Cam004.png"), &link).unwrap();
    let hard = dir.path().join("hard.pfm");
    std::fs::hard_link(scene.join("gt_disp_lowres.pfm"), &hard).unwrap();
    for out in [&link, &hard] {
        assert_fails(
            &lfdepth(&["estimate", arg(&scene), "-o", arg(out), "--quiet"]),
            &["-o", "would overwrite"],
        );
    }
    assert_eq!(snapshot(&scene), before);
}

#[test]
fn the_benchmarks_other_ground_truths_are_kept_and_devices_take_any_output() {
    let dir = common::temp();
    let scene = scene(dir.path());
    std::fs::write(scene.join("gt_depth_lowres.pfm"), b"depth ground truth").unwrap();
    let before = snapshot(&scene);
    assert_fails(
        &lfdepth(&[
            "estimate",
            arg(&scene),
            "-o",
            arg(&scene.join("gt_depth_lowres.pfm")),
            "--quiet",
        ]),
        &["-o", "gt_depth_lowres.pfm", "ground truth"],
    );
    assert_eq!(snapshot(&scene), before);
    // An estimate beside the views is fine, and may be written again.
    let est = scene.join("disparity.pfm");
    for _ in 0..2 {
        let out = lfdepth(&[
            "estimate",
            arg(&scene),
            "-o",
            arg(&est),
            "--stage",
            "epi",
            "--quiet",
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let out = lfdepth(&[
            "estimate",
            arg(&scene),
            "-o",
            "/dev/null",
            "--png",
            "/dev/null",
            "--stage",
            "epi",
            "--quiet",
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(std::fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device());
    }
}

#[test]
fn several_outputs_on_one_file_are_refused() {
    let dir = common::temp();
    let scene = scene(dir.path());
    let x = dir.path().join("x.out");
    let msg = assert_fails(
        &lfdepth(&[
            "estimate",
            arg(&scene),
            "-o",
            arg(&x),
            "--confidence",
            arg(&x),
            "--png16",
            arg(&x),
            "--quiet",
        ]),
        &["-o", "--confidence", "--png16", "same file"],
    );
    assert!(msg.contains("x.out"), "{msg}");
    assert!(!x.exists());
    // Two spellings of one path are one file.
    let other = dir.path().join("scene/../x.out");
    assert_fails(
        &lfdepth(&[
            "estimate",
            arg(&scene),
            "-o",
            arg(&x),
            "--png",
            arg(&other),
            "--quiet",
        ]),
        &["-o", "--png", "same file"],
    );
}

#[test]
fn a_missing_output_folder_is_refused_before_the_views_are_read() {
    let dir = common::temp();
    let scene = scene(dir.path());
    // A corrupt view: had the views been decoded first, the error would be about it.
    std::fs::write(scene.join("input_Cam008.png"), b"not a png").unwrap();
    for flag in ["-o", "--png", "--png16", "--confidence", "--depth"] {
        let missing = dir.path().join("no/such/folder/out.file");
        let ok_out = dir.path().join("est.pfm");
        let mut args = vec!["estimate", arg(&scene)];
        if flag == "-o" {
            args.extend(["-o", arg(&missing)]);
        } else {
            args.extend(["-o", arg(&ok_out), flag, arg(&missing)]);
        }
        args.push("--quiet");
        let start = Instant::now();
        let msg = assert_fails(&lfdepth(&args), &[flag, "does not exist"]);
        assert!(!msg.contains("input_Cam008"), "{msg}");
        assert!(start.elapsed() < Duration::from_secs(10));
        assert!(!ok_out.exists());
    }
    // An output path that is a folder is refused the same way.
    assert_fails(
        &lfdepth(&["estimate", arg(&scene), "-o", arg(dir.path()), "--quiet"]),
        &["-o", "is a folder"],
    );
}

/// A folder that exists but takes no files is refused like a missing one, before the
/// views are read. Permission bits do not stop root, so the folder is one of the
/// process's own entries in `/proc`, where nobody can create a file.
#[test]
fn an_output_folder_that_takes_no_files_is_refused_before_the_views_are_read() {
    let unwritable = Path::new("/proc/self");
    if !cfg!(target_os = "linux") || !unwritable.is_dir() {
        eprintln!("SKIPPED: /proc/self is not a folder here (Linux only)");
        return;
    }
    let dir = common::temp();
    let scene = scene(dir.path());
    // A corrupt view: had the views been decoded first, the error would be about it.
    std::fs::write(scene.join("input_Cam008.png"), b"not a png").unwrap();
    for flag in ["-o", "--png", "--png16", "--confidence", "--depth"] {
        let bad = unwritable.join("out.pfm");
        let ok_out = dir.path().join("est.pfm");
        let mut args = vec!["estimate", arg(&scene)];
        if flag == "-o" {
            args.extend(["-o", arg(&bad)]);
        } else {
            args.extend(["-o", arg(&ok_out), flag, arg(&bad)]);
        }
        args.push("--quiet");
        let msg = assert_fails(
            &lfdepth(&args),
            &[flag, "out.pfm", "cannot write in the folder"],
        );
        assert!(!msg.contains("input_Cam008"), "{msg}");
        assert!(!ok_out.exists());
    }
}

#[test]
fn outputs_replace_old_files_whole_and_refused_runs_keep_them() {
    let dir = common::temp();
    let scene = scene(dir.path());
    let est = dir.path().join("est.pfm");
    let png = dir.path().join("est.png");
    std::fs::write(&est, b"an earlier estimate").unwrap();
    // Held open, the earlier file stays whole: the output is a new file renamed onto
    // its name, not the old one truncated and rewritten.
    let earlier = std::fs::File::open(&est).unwrap();
    let out = lfdepth(&[
        "estimate",
        arg(&scene),
        "-o",
        arg(&est),
        "--png",
        arg(&png),
        "--stage",
        "epi",
        "--quiet",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let map = lfdepth_cli::io::pfm::read(&est).unwrap();
    assert_eq!((map.width, map.height), (32, 32));
    if cfg!(unix) {
        assert_eq!(
            std::io::read_to_string(earlier).unwrap(),
            "an earlier estimate"
        );
    }
    // No temporary file is left beside the outputs.
    let leftovers: Vec<String> = names(dir.path())
        .into_iter()
        .filter(|n| n.ends_with(lfdepth_cli::io::output::TEMP_SUFFIX))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    // A refused run leaves the earlier outputs as they were.
    let before = (std::fs::read(&est).unwrap(), std::fs::read(&png).unwrap());
    assert_fails(
        &lfdepth(&[
            "estimate",
            arg(&scene),
            "-o",
            arg(&est),
            "--png",
            arg(&scene.join("parameters.cfg")),
            "--quiet",
        ]),
        &["--png", "parameters.cfg"],
    );
    assert_eq!(
        (std::fs::read(&est).unwrap(), std::fs::read(&png).unwrap()),
        before
    );
}

#[test]
fn synth_refuses_a_used_folder_and_force_removes_only_its_own_files() {
    let dir = common::temp();
    let out = dir.path().join("lf");
    let synth = |extra: &[&str]| {
        let mut flags = vec!["--size", "24"];
        flags.extend_from_slice(extra);
        common::synth_command(&out, "planes", &flags)
    };
    assert!(synth(&["--misalign"]).status.success());
    assert!(out.join("input_Cam080.png").is_file() && out.join("homographies.txt").is_file());
    std::fs::write(out.join("gt_depth_lowres.pfm"), b"someone's depth map").unwrap();
    std::fs::write(out.join("notes.txt"), b"keep me").unwrap();
    let before = snapshot(&out);
    assert_fails(
        &synth(&["--grid", "3x3"]),
        &["--out", "not empty", "--force"],
    );
    assert_eq!(snapshot(&out), before, "a refused synth changed the folder");
    // --force: a 3x3 scene without misalignment replaces the views, removes the
    // earlier scene's other views and homographies, and keeps the unrelated files.
    let forced = synth(&["--grid", "3x3", "--force"]);
    assert!(
        forced.status.success(),
        "{}",
        String::from_utf8_lossy(&forced.stderr)
    );
    assert!(String::from_utf8_lossy(&forced.stderr).contains("gt_depth_lowres.pfm"));
    let mut expected: Vec<String> = (0..9).map(|i| format!("input_Cam{i:03}.png")).collect();
    expected.extend(
        [
            "gt_depth_lowres.pfm",
            "gt_disp_lowres.pfm",
            "notes.txt",
            "parameters.cfg",
        ]
        .map(String::from),
    );
    expected.sort();
    assert_eq!(names(&out), expected);
    assert_eq!(
        std::fs::read(out.join("gt_depth_lowres.pfm")).unwrap(),
        b"someone's depth map"
    );
    assert_eq!(std::fs::read(out.join("notes.txt")).unwrap(), b"keep me");
    // The folder now holds a consistent 3x3 light field.
    let loaded = lfdepth_cli::io::scene::load(&out, &Default::default()).unwrap();
    assert_eq!(loaded.layout.grid, lfdepth::Grid::new(3, 3));
    // A file where the folder should be is refused.
    let file = dir.path().join("plain-file");
    std::fs::write(&file, b"x").unwrap();
    assert_fails(
        &common::synth_command(&file, "planes", &[]),
        &["--out", "not a folder"],
    );
    assert_eq!(std::fs::read(&file).unwrap(), b"x");
}

#[test]
fn demo_never_writes_into_a_folder_of_other_files_unless_forced() {
    let dir = common::temp();
    let out = dir.path().join("demo");
    let demo = |extra: &[&str]| {
        let mut args = vec![
            "demo",
            "--size",
            "32",
            "--stage",
            "epi",
            "--quiet",
            "--out",
            arg(&out),
        ];
        args.extend_from_slice(extra);
        lfdepth(&args)
    };
    // Its own folder can be written again.
    assert!(demo(&[]).status.success());
    assert!(demo(&[]).status.success());
    std::fs::write(out.join("disparity.pfm"), b"x").unwrap();
    std::fs::write(out.join("paper.tex"), b"my paper").unwrap();
    let before = snapshot(&out);
    assert_fails(&demo(&[]), &["--out", "paper.tex", "--force"]);
    assert_eq!(snapshot(&out), before);
    assert!(demo(&["--force"]).status.success());
    assert_eq!(std::fs::read(out.join("paper.tex")).unwrap(), b"my paper");
    assert_ne!(std::fs::read(out.join("disparity.pfm")).unwrap(), b"x");
}
