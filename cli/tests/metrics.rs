//! The metrics agree with the reference evaluator (`shared/tools/hci_metrics.py`) on
//! every published peer map, whose expected scores are in `peers/metrics.json`.

mod common;

use std::path::{Path, PathBuf};

use common::lfdepth;
use lfdepth_cli::commands::eval::score;
use lfdepth_cli::io::pfm;

/// The ground truth of a scene name (`hci/<category>/<scene>/gt_disp_lowres.pfm`).
fn ground_truth(data: &Path, scene: &str) -> PathBuf {
    ["training", "stratified", "test", "additional"]
        .iter()
        .map(|c| {
            data.join("hci")
                .join(c)
                .join(scene)
                .join("gt_disp_lowres.pfm")
        })
        .find(|p| p.is_file())
        .unwrap_or_else(|| panic!("no ground truth for {scene}"))
}

#[test]
fn every_peer_map_matches_the_reference_to_1e_3() {
    let Some(data) = common::shared_data("every_peer_map_matches_the_reference_to_1e_3") else {
        return;
    };
    let text = std::fs::read_to_string(data.join("peers/metrics.json")).unwrap();
    let expected: serde_json::Value = serde_json::from_str(&text).unwrap();
    let mut checked = 0;
    for (method, scenes) in expected.as_object().unwrap() {
        for (scene, want) in scenes.as_object().unwrap() {
            let est_path = data.join("peers").join(method).join(format!("{scene}.pfm"));
            let gt_path = ground_truth(&data, scene);
            let est = pfm::read(&est_path).unwrap();
            let gt = pfm::read(&gt_path).unwrap();
            let got = score(&est, &gt, None, &est_path, &gt_path).unwrap();
            for (key, value) in [
                ("badpix007", got.badpix_007),
                ("badpix003", got.badpix_003),
                ("badpix001", got.badpix_001),
                ("mse100", got.mse100),
                ("q25", got.q25),
                ("invalid_pct", got.invalid_pct),
            ] {
                let want = want[key].as_f64().unwrap();
                assert!(
                    (value - want).abs() <= 1e-3,
                    "{method}/{scene} {key}: got {value}, reference {want}"
                );
            }
            checked += 1;
        }
    }
    // Six methods, two scenes each except EPINET (cotton only, 490x490 → embedded).
    assert_eq!(checked, 11);
}

#[test]
fn spo_cotton_through_the_binary() {
    let Some(data) = common::shared_data("spo_cotton_through_the_binary") else {
        return;
    };
    let est = data.join("peers/SPO/cotton.pfm");
    let gt = data.join("hci/training/cotton/gt_disp_lowres.pfm");
    let out = lfdepth(&["eval", est.to_str().unwrap(), "--gt", gt.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.lines().any(|l| l.starts_with("BadPix0.07 2.59")),
        "{stdout}"
    );
    assert!(stdout.lines().any(|l| l == "MSE×100 1.313"), "{stdout}");
    let v = common::lfdepth_json(&[
        "eval",
        est.to_str().unwrap(),
        "--gt",
        gt.to_str().unwrap(),
        "--json",
    ]);
    assert!((v["badpix007"].as_f64().unwrap() - 2.594222).abs() < 1e-3);
    // With a mask the score covers fewer pixels and changes.
    let mask = data.join("hci/training/cotton/mask_planes_lowres.png");
    if mask.is_file() {
        let m = common::lfdepth_json(&[
            "eval",
            est.to_str().unwrap(),
            "--gt",
            gt.to_str().unwrap(),
            "--mask",
            mask.to_str().unwrap(),
            "--json",
        ]);
        // Independent count: pixels inside the 15-px border and the mask.
        let (e, g) = (pfm::read(&est).unwrap(), pfm::read(&gt).unwrap());
        let lfdepth_cli::io::png::Samples::Eight(mask) =
            lfdepth_cli::io::png::read(&mask).unwrap().samples
        else {
            panic!("8-bit mask expected")
        };
        let (mut bad, mut all) = (0usize, 0usize);
        for y in 15..g.height - 15 {
            for x in 15..g.width - 15 {
                let i = y * g.width + x;
                if mask[i] != 0 {
                    all += 1;
                    bad += usize::from((e.data[i] - g.data[i]).abs() > 0.07);
                }
            }
        }
        let want = 100.0 * bad as f64 / all as f64;
        let got = m["badpix007"].as_f64().unwrap();
        assert!(
            (got - want).abs() < 1e-6,
            "masked BadPix0.07 {got}, counted {want}"
        );
        assert_ne!(m["badpix007"], v["badpix007"]);
    }
}
