//! `lfdepth synth` writes the HCI layout; reading it back gives the exact renderer
//! output, and `lfdepth eval` of the written ground truth against itself scores zero.

mod common;

use common::{assert_fails, lfdepth};
use lfdepth::synth::{self, SceneKind, SynthSpec};
use lfdepth::{Grid, Homography};
use lfdepth_cli::io::scene::{self, LoadOptions, Views};
use lfdepth_cli::io::{cfg, pfm};

fn spec(size: usize) -> SynthSpec {
    let mut s = SynthSpec::new(SceneKind::Mixed, Grid::new(3, 3), size, size);
    s.seed = 7;
    s
}

#[test]
fn synth_then_eval_round_trips_exactly() {
    let dir = common::temp();
    let out = dir.path().join("scene");
    common::synth_scene(&out, "mixed", 48, &["--grid", "3x3", "--seed", "7"]);
    let spec = spec(48);

    // Ground truth: bit-exact through the PFM.
    let mut gt = vec![0f32; 48 * 48];
    synth::render_ground_truth(&spec, &mut gt).unwrap();
    let written = pfm::read(&out.join("gt_disp_lowres.pfm")).unwrap();
    assert_eq!((written.width, written.height), (48, 48));
    assert!(written
        .data
        .iter()
        .zip(&gt)
        .all(|(a, b)| a.to_bits() == b.to_bits()));

    // parameters.cfg carries the grid, size and disparity range.
    let c = cfg::read(&out.join("parameters.cfg")).unwrap();
    assert_eq!(c.grid(), Some((3, 3)));
    assert_eq!(c.image_resolution_x_px, Some(48));
    assert_eq!(
        c.disparity_range(),
        Some((f64::from(spec.disparity_min), f64::from(spec.disparity_max)))
    );
    assert!(!out.join("homographies.txt").exists());

    // Views: the loader returns exactly what the renderer produced.
    let loaded = scene::load(&out, &LoadOptions::default()).unwrap();
    assert_eq!(loaded.layout, spec.layout());
    let Views::U8(views) = &loaded.views else {
        panic!("8-bit views expected")
    };
    let stride = spec.layout().view_stride;
    for i in 0..9 {
        let mut view = vec![0u8; stride];
        synth::render_view(&spec, i / 3, i % 3, &mut view).unwrap();
        assert_eq!(&views[i * stride..(i + 1) * stride], &view[..], "view {i}");
    }

    // The ground truth scored against itself: zero error everywhere.
    let gt_path = out.join("gt_disp_lowres.pfm");
    let run = lfdepth(&[
        "eval",
        gt_path.to_str().unwrap(),
        "--gt",
        gt_path.to_str().unwrap(),
        "--json",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    for key in [
        "badpix007",
        "badpix003",
        "badpix001",
        "mse100",
        "q25",
        "invalid_pct",
    ] {
        assert_eq!(v[key].as_f64(), Some(0.0), "{key}: {v}");
    }
}

#[test]
fn misaligned_synth_writes_the_true_homographies() {
    let dir = common::temp();
    let out = dir.path().join("mis");
    common::synth_scene(
        &out,
        "planes",
        32,
        &["--grid", "3x3", "--misalign", "--gray", "--seed", "3"],
    );
    let mut spec = SynthSpec::new(SceneKind::Planes, Grid::new(3, 3), 32, 32);
    spec.channels = 1;
    spec.seed = 3;
    spec.misalign = Some(lfdepth_cli::commands::synth::default_misalignment());
    let layout = spec.layout();
    let mut views = vec![0u8; layout.validate().unwrap()];
    let mut gt = vec![0f32; 32 * 32];
    let mut homographies = vec![Homography::IDENTITY; 9];
    synth::render(&spec, &mut views, &mut gt, &mut homographies).unwrap();
    let text = std::fs::read_to_string(out.join("homographies.txt")).unwrap();
    let rows: Vec<Vec<f32>> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split_whitespace().map(|t| t.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 9);
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row[..2], [(i / 3) as f32, (i % 3) as f32]);
        assert_eq!(row[2..], homographies[i].m[..], "view {i}");
    }
    assert!(homographies.iter().any(|h| *h != Homography::IDENTITY));
    let loaded = scene::load(&out, &LoadOptions::default()).unwrap();
    assert_eq!(loaded.layout.channels, 1);
    assert_eq!(loaded.views, Views::U8(views));
}

#[test]
fn bad_synth_arguments() {
    let dir = common::temp();
    let out = dir.path().join("x");
    let run = common::synth_command(&out, "nosuch", &[]);
    assert_eq!(run.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&run.stderr).contains("mixed"));
    let run = common::synth_command(
        &out,
        "mixed",
        &["--disparity-range", "-9..9", "--size", "32"],
    );
    assert_fails(&run, &["disparity"]);
    let run = common::synth_command(&out, "mixed", &["--grid", "1x2", "--size", "32"]);
    assert_fails(&run, &["1x2", "1x3"]);
}
