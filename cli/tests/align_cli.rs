//! `--align off|on|auto` through the binary: a misaligned array written by
//! `lfdepth synth --misalign` is aligned and scores close to the same scene rendered
//! rectified; a rectified array is left alone; bad values and textureless views give
//! clear messages.

mod common;

use std::path::Path;

use common::{assert_fails, lfdepth};
use lfdepth_cli::io::png::{self, Image, Samples};

fn ok(out: &std::process::Output) -> (String, String) {
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{stderr}");
    (String::from_utf8_lossy(&out.stdout).to_string(), stderr)
}

/// The `mixed` scene on a 5×5 grid of 128² views in `dir`, misaligned or rectified.
fn synth(dir: &Path, misalign: bool) {
    let mut flags = vec!["--grid", "5x5", "--seed", "4"];
    if misalign {
        flags.push("--misalign");
    }
    common::synth_scene(dir, "mixed", 128, &flags);
}

/// EPI disparity of `scene` with `--align mode`, scored against its ground truth:
/// (MSE×100, what the command printed on stderr).
fn mse_with(scene: &Path, mode: &str) -> (f64, String) {
    mse_with_args(scene, mode, &[]).0
}

/// [`mse_with`] with `extra` flags: ((MSE×100, stderr), the estimate's PFM bytes).
fn mse_with_args(scene: &Path, mode: &str, extra: &[&str]) -> ((f64, String), Vec<u8>) {
    let est = scene.with_extension(format!("{mode}{}.pfm", extra.join("").replace('-', "")));
    let mut args = vec![
        "estimate",
        scene.to_str().unwrap(),
        "-o",
        est.to_str().unwrap(),
        "--stage",
        "epi",
        // The EPI stage alone: its error on unaligned views is what the bounds were set on.
        "--initial",
        "epi",
        "--align",
        mode,
        "--quiet",
    ];
    args.extend_from_slice(extra);
    let (_, stderr) = ok(&lfdepth(&args));
    let gt = scene.join("gt_disp_lowres.pfm");
    let (json, _) = ok(&lfdepth(&[
        "eval",
        est.to_str().unwrap(),
        "--gt",
        gt.to_str().unwrap(),
        "--json",
    ]));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    (
        (v["mse100"].as_f64().unwrap(), stderr),
        std::fs::read(&est).unwrap(),
    )
}

#[test]
fn a_misaligned_synthetic_array_aligns_and_scores_like_the_rectified_one() {
    let dir = common::temp();
    let (bent, ideal) = (dir.path().join("bent"), dir.path().join("ideal"));
    synth(&bent, true);
    synth(&ideal, false);
    assert!(bent.join("homographies.txt").is_file());

    let (unaligned, _) = mse_with(&bent, "off");
    let (aligned, stderr) = mse_with(&bent, "on");
    // The EPI stage reads the centre row and column: 9 of the 25 views.
    assert!(stderr.contains("alignment: 9 views aligned"), "{stderr}");
    let (rectified, stderr) = mse_with(&ideal, "auto");
    assert!(stderr.contains("alignment: skipped"), "{stderr}");
    eprintln!("MSE×100: unaligned {unaligned:.2}, aligned {aligned:.2}, rectified {rectified:.2}");
    // Stated bound: alignment removes almost all of the misalignment's error. What is
    // left includes the disparity offset no image can observe (the random translations'
    // projection onto the baselines, about 0.1–0.2 px on a 5×5 grid).
    assert!(unaligned > 200.0, "{unaligned}");
    assert!(
        aligned < 2.0 * rectified + 5.0 && aligned < 0.05 * unaligned,
        "aligned {aligned}, rectified {rectified}, unaligned {unaligned}"
    );
    // Auto finds the misaligned array not rectified and aligns it the same way.
    let (auto, stderr) = mse_with(&bent, "auto");
    assert!(stderr.contains("views aligned"), "{stderr}");
    assert_eq!(auto, aligned);
}

#[test]
fn bad_align_values_are_usage_errors() {
    for command in [
        &["estimate", "in", "-o", "x.pfm", "--align", "sideways"][..],
        &["demo", "--align", "maybe"][..],
        &["eval", "--dataset", "d", "--align", "1"][..],
    ] {
        let out = lfdepth(command);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.contains("--align") && stderr.contains("off, on, auto"),
            "{stderr}"
        );
    }
}

#[test]
fn textureless_views_fail_when_on_and_warn_when_auto() {
    let dir = common::temp();
    for i in 0..9 {
        let flat = Image {
            width: 48,
            height: 48,
            channels: 1,
            samples: Samples::Eight(vec![128; 48 * 48]),
        };
        png::write(&dir.path().join(format!("input_Cam{i:03}.png")), &flat).unwrap();
    }
    let est = dir.path().join("est.pfm");
    let (input, output) = (dir.path().to_str().unwrap(), est.to_str().unwrap());
    let args = |mode| {
        [
            "estimate", input, "-o", output, "--stage", "epi", "--quiet", "--align", mode,
        ]
    };
    assert_fails(
        &lfdepth(&args("on")),
        &["alignment of view 4 failed", "turn alignment off"],
    );
    let (_, stderr) = ok(&lfdepth(&args("auto")));
    assert!(
        stderr.contains("warning: the views were not aligned") && stderr.contains("view 4"),
        "{stderr}"
    );
    assert!(est.is_file());
}

#[test]
fn align_views_interp_and_threads_flags() {
    let dir = common::temp();
    let bent = dir.path().join("bent");
    synth(&bent, true);
    let ((cross, stderr), cross_pfm) = mse_with_args(&bent, "on", &["--threads", "1"]);
    assert!(stderr.contains("alignment: 9 views aligned"), "{stderr}");
    // The estimate maps its per-view tracking over the threads: same bytes for any count.
    let ((_, _), threaded) = mse_with_args(&bent, "on", &["--threads", "3"]);
    assert!(threaded == cross_pfm, "--threads 3 changed the disparity");
    let ((explicit, _), explicit_pfm) = mse_with_args(&bent, "on", &["--align-views", "cross"]);
    assert!(
        explicit_pfm == cross_pfm,
        "--align-views cross is the EPI stage's default"
    );
    // Every view estimated: 25 homographies, the cross still the only views warped.
    let ((all, stderr), all_pfm) = mse_with_args(&bent, "on", &["--align-views", "all"]);
    assert!(stderr.contains("alignment: 25 views aligned"), "{stderr}");
    assert!(all_pfm != cross_pfm);
    // Catmull–Rom resamples differently, and no worse than within noise.
    let ((cubic, _), cubic_pfm) = mse_with_args(&bent, "on", &["--align-interp", "catmull-rom"]);
    assert!(cubic_pfm != cross_pfm, "--align-interp had no effect");
    eprintln!(
        "MSE×100: cross {cross:.2} (explicit {explicit:.2}), all views {all:.2}, Catmull–Rom {cubic:.2}"
    );
    for mse in [all, cubic] {
        assert!(mse < 1.5 * cross + 2.0, "{mse} vs {cross}");
    }
    // Bad values are usage errors that list the choices.
    for (flag, value, choices) in [
        ("--align-interp", "cubic", "bilinear, catmull-rom"),
        ("--align-views", "some", "read, cross, all"),
    ] {
        for command in [
            &["estimate", "in", "-o", "x.pfm", flag, value][..],
            &["demo", flag, value][..],
            &["eval", "--dataset", "d", flag, value][..],
        ] {
            let out = lfdepth(command);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{stderr}");
            assert!(
                stderr.contains(flag) && stderr.contains(choices),
                "{stderr}"
            );
        }
    }
}
