//! The commands end to end on small synthetic scenes: `demo`, `synth` → `estimate` →
//! `eval`, and `eval --dataset` over a folder of scenes.

mod common;

use common::lfdepth;
use lfdepth_cli::io::{pfm, png};

fn ok(out: &std::process::Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).to_string()
}

#[test]
fn demo_writes_maps_and_reports_accuracy_and_timings() {
    let dir = common::temp();
    let out = dir.path().join("demo");
    let stdout = ok(&lfdepth(&[
        "demo",
        "--size",
        "48",
        "--out",
        out.to_str().unwrap(),
        "--stage",
        "epi",
    ]));
    for needle in [
        "BadPix0.07 ",
        "BadPix0.03 ",
        "BadPix0.01 ",
        "MSE×100 ",
        "Q25 ",
        "total ",
    ] {
        assert!(stdout.contains(needle), "`{needle}` missing from {stdout}");
    }
    let map = pfm::read(&out.join("disparity.pfm")).unwrap();
    assert_eq!((map.width, map.height), (48, 48));
    assert!(map.data.iter().all(|d| d.is_finite()));
    let picture = png::read(&out.join("disparity.png")).unwrap();
    assert_eq!(picture.channels, 3);
    assert!(picture.width > 48, "the legend bar sits right of the map");
    assert!(out.join("ground_truth.png").is_file());
}

#[test]
fn synth_estimate_eval_pipeline() {
    let dir = common::temp();
    let scene = dir.path().join("data/planes");
    common::synth_scene(&scene, "planes", 40, &["--grid", "5x5"]);
    let est = dir.path().join("est.pfm");
    let conf = dir.path().join("conf.pfm");
    let colour = dir.path().join("est.png");
    let gray16 = dir.path().join("est16.png");
    let stdout = ok(&lfdepth(&[
        "estimate",
        scene.to_str().unwrap(),
        "-o",
        est.to_str().unwrap(),
        "--confidence",
        conf.to_str().unwrap(),
        "--png",
        colour.to_str().unwrap(),
        "--png16",
        gray16.to_str().unwrap(),
        "--stage",
        "epi",
        "--threads",
        "2",
        "--disparity-range",
        "cfg",
        "--png-range",
        "-2..2",
    ]));
    assert!(
        stdout.contains("load") && stdout.contains("total"),
        "{stdout}"
    );
    let map = pfm::read(&est).unwrap();
    assert_eq!((map.width, map.height), (40, 40));
    let c = pfm::read(&conf).unwrap();
    assert!(c.data.iter().all(|v| (0.0..=1.0).contains(v)));
    assert_eq!(png::read(&gray16).unwrap().bit_depth(), 16);
    let raw = String::from_utf8_lossy(&std::fs::read(&gray16).unwrap()).to_string();
    assert!(
        raw.contains("disparity_min\x00-2") && raw.contains("disparity_max\x002"),
        "range chunks"
    );
    assert!(png::read(&colour).unwrap().width > 40);
    let gt = scene.join("gt_disp_lowres.pfm");
    let stdout = ok(&lfdepth(&[
        "eval",
        est.to_str().unwrap(),
        "--gt",
        gt.to_str().unwrap(),
    ]));
    assert!(stdout.starts_with("BadPix0.07 "), "{stdout}");

    // Two scenes under one root: one Markdown table with a mean row, or JSON.
    common::synth_scene(
        &dir.path().join("data/deeper/slanted"),
        "slanted",
        40,
        &["--grid", "5x5"],
    );
    let root = dir.path().join("data");
    let table = ok(&lfdepth(&[
        "eval",
        "--dataset",
        root.to_str().unwrap(),
        "--stage",
        "epi",
    ]));
    let lines: Vec<&str> = table.lines().collect();
    assert_eq!(lines.len(), 5, "{table}");
    assert!(lines[0].starts_with("| scene | BadPix0.07"), "{table}");
    assert!(
        lines[2].starts_with("| deeper/slanted |") && lines[3].starts_with("| planes |"),
        "{table}"
    );
    assert!(lines[4].starts_with("| **mean** |"), "{table}");
    let json = ok(&lfdepth(&[
        "eval",
        "--dataset",
        root.to_str().unwrap(),
        "--stage",
        "epi",
        "--json",
    ]));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let scenes = v["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 2);
    let mean =
        (scenes[0]["badpix007"].as_f64().unwrap() + scenes[1]["badpix007"].as_f64().unwrap()) / 2.0;
    assert!((v["mean"]["badpix007"].as_f64().unwrap() - mean).abs() < 1e-9);
}

#[test]
fn synth_suite_writes_every_scene_with_masks_and_eval_scores_them_in_one_table() {
    let dir = common::temp();
    let root = dir.path().join("suite");
    let stdout = ok(&lfdepth(&[
        "synth",
        "--suite",
        "realistic",
        "--size",
        "48",
        "--out",
        root.to_str().unwrap(),
    ]));
    let names = ["hall", "corridor", "tabletop", "dusk", "relief"];
    for name in names {
        let scene = root.join(name);
        assert!(scene.join("input_Cam080.png").is_file(), "{name}");
        let cfg = std::fs::read_to_string(scene.join("parameters.cfg")).unwrap();
        assert!(cfg.contains("sensor = read noise"), "{cfg}");
        for mask in ["floor", "dim", "relief", "thin", "slope"] {
            let m = png::read(&scene.join(format!("mask_{mask}.png"))).unwrap();
            assert_eq!((m.width, m.height, m.channels), (48, 48, 1));
        }
        assert!(
            stdout.contains(&format!("| {name} | ")),
            "{name} missing from {stdout}"
        );
        assert!(
            stdout.contains(&format!("{name} 9x9 views of 48x48, disparity ")),
            "{stdout}"
        );
    }
    assert!(
        stdout.contains("| scene | disparity | <0.005 |"),
        "{stdout}"
    );
    let table = ok(&lfdepth(&[
        "eval",
        "--dataset",
        root.to_str().unwrap(),
        "--stage",
        "epi",
    ]));
    let lines: Vec<&str> = table.lines().collect();
    assert_eq!(lines.len(), 8, "{table}");
    assert!(lines[7].starts_with("| **mean** |"), "{table}");
    // The suite defines its own ranges, seeds and sensor: those flags are refused.
    for extra in [
        &["--noise", "2"][..],
        &["--scene", "hall"],
        &["--seed", "3"],
    ] {
        let mut args = vec!["synth", "--suite", "realistic", "--out"];
        let other = dir.path().join("other");
        args.push(other.to_str().unwrap());
        args.extend_from_slice(extra);
        let out = lfdepth(&args);
        assert!(!out.status.success(), "{extra:?} accepted");
    }
    // A folder that is not empty is refused without --force.
    let out = lfdepth(&[
        "synth",
        "--suite",
        "realistic",
        "--size",
        "32",
        "--out",
        root.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("not empty"));
}

#[test]
fn help_lists_every_command() {
    let stdout = ok(&lfdepth(&["--help"]));
    for command in ["demo", "estimate", "eval", "synth"] {
        assert!(stdout.contains(command), "{stdout}");
    }
    let out = lfdepth(&["eval", "--dataset", "/nonexistent/lfdepth"]);
    common::assert_fails(&out, &["/nonexistent/lfdepth", "does not exist"]);
}

#[test]
fn sixteen_bit_views_estimate_like_their_8_bit_originals() {
    let dir = common::temp();
    let eight = dir.path().join("eight");
    common::synth_scene(&eight, "spheres", 40, &["--grid", "5x5"]);
    let sixteen = dir.path().join("sixteen");
    std::fs::create_dir(&sixteen).unwrap();
    for i in 0..25 {
        let name = format!("input_Cam{i:03}.png");
        let image = png::read(&eight.join(&name)).unwrap();
        let png::Samples::Eight(s) = image.samples else {
            panic!("8-bit views expected")
        };
        let wide = png::Image {
            samples: png::Samples::Sixteen(s.iter().map(|&v| u16::from(v) * 257).collect()),
            ..image
        };
        png::write(&sixteen.join(&name), &wide).unwrap();
    }
    let estimate = |input: &std::path::Path, out: &str| {
        let path = dir.path().join(out);
        ok(&lfdepth(&[
            "estimate",
            input.to_str().unwrap(),
            "-o",
            path.to_str().unwrap(),
            "--stage",
            "epi",
            "--disparity-range",
            "-1.5..1.5",
        ]));
        pfm::read(&path).unwrap()
    };
    let (a, b) = (estimate(&eight, "a.pfm"), estimate(&sixteen, "b.pfm"));
    let close = a
        .data
        .iter()
        .zip(&b.data)
        .filter(|(x, y)| (*x - *y).abs() < 0.01)
        .count();
    assert!(
        close as f64 >= 0.99 * a.data.len() as f64,
        "{close} of {} agree",
        a.data.len()
    );
}
