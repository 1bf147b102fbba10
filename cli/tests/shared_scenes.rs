//! The whole tool on the shared 512×512 HCI scenes and the Lytro capture. Estimation
//! at this size is slow unoptimised, so these run in release builds only
//! (`cargo test --release`).

mod common;

use common::lfdepth;
use lfdepth_cli::io::pfm;

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "512x512 scenes: run with cargo test --release"
)]
fn dataset_table_over_the_shared_hci_scenes() {
    let Some(data) = common::shared_data("dataset_table_over_the_shared_hci_scenes") else {
        return;
    };
    let v = common::lfdepth_json(&[
        "eval",
        "--dataset",
        data.join("hci").to_str().unwrap(),
        "--json",
    ]);
    let scenes = v["scenes"].as_array().unwrap();
    let names: Vec<&str> = scenes
        .iter()
        .map(|s| s["scene"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["stratified/backgammon", "training/cotton"]);
    for s in scenes {
        // A loader that scrambled views or channels scores near 100 % here.
        let bad = s["badpix007"].as_f64().unwrap();
        assert!(bad < 40.0, "{}: BadPix0.07 {bad}", s["scene"]);
        assert!(s["mse100"].as_f64().unwrap().is_finite());
    }
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "552x383 views: run with cargo test --release"
)]
fn lytro_capture_estimates_a_full_map() {
    let Some(data) = common::shared_data("lytro_capture_estimates_a_full_map") else {
        return;
    };
    let dir = common::temp();
    let est = dir.path().join("lytro.pfm");
    let input = data.join("real/lytro-2067");
    let out = lfdepth(&[
        "estimate",
        input.to_str().unwrap(),
        "-o",
        est.to_str().unwrap(),
        "--pattern",
        "2067_{row:02}_{col:02}.png",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let map = pfm::read(&est).unwrap();
    assert_eq!((map.width, map.height), (552, 383));
    assert!(map.data.iter().all(|d| d.is_finite()));
}
