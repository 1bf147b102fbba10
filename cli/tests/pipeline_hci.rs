//! The full pipeline (plane sweep → refine → refill → median → TV) on the shared HCI
//! scenes, release only: below SPO on both scenes and better than the paper's pipeline.

#[path = "tv_support.rs"]
mod tv_support;

use std::path::Path;

use lfdepth::{LightField, Params};
use lfdepth_cli::engine::{estimate, EstimateOptions, Stages};
use tv_support::*;

/// The engine's full pipeline with default parameters on one scene: (BadPix0.07 %,
/// MSE×100) of the default (plane sweep → refine → refill → median → TV) and of the
/// paper's pipeline (EPI → TV).
fn engine_scores(dir: &Path) -> ((f64, f64), (f64, f64)) {
    let (views, layout) = load_hci(dir);
    let (w, h, gt) = read_pfm(&dir.join("gt_disp_lowres.pfm"));
    let lf = LightField::new(&views, layout).unwrap();
    let run = |params: Params| {
        let options = EstimateOptions {
            params,
            stage: Stages::Full,
            threads: None,
        };
        let e = estimate(&lf, &options, &mut |_, _, _| {}).unwrap();
        assert!(e.disparity.iter().all(|v| v.is_finite()));
        scores(&e.disparity, &gt, w, h)
    };
    let full = run(Params::default());
    let paper = run(Params::paper());
    (full, paper)
}

#[test]
#[cfg_attr(debug_assertions, ignore)]
fn full_pipeline_accuracy_on_both_hci_scenes() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: the HCI pipeline accuracy test runs only with --release");
        return;
    }
    let Some(data) = shared_data("the HCI pipeline accuracy test") else {
        return;
    };
    // The goal: beat SPO (2.55 / 3.24 and 2.59 / 1.31) on both scenes. Measured
    // 2.447 / 2.877 and 2.130 / 0.996; the floors add a margin that stays below SPO.
    for (scene, bad_max, mse_max) in [
        ("stratified/backgammon", 2.52, 2.95),
        ("training/cotton", 2.2, 1.05),
    ] {
        let (full, paper) = engine_scores(&data.join("hci").join(scene));
        eprintln!(
            "{scene}: sweep→refine→refill→median→TV {:.2} % / {:.3}, paper EPI→TV {:.2} % / {:.3} \
             (BadPix0.07 / MSE×100)",
            full.0, full.1, paper.0, paper.1
        );
        assert!(full.0 < bad_max, "{scene}: BadPix0.07 {:.2} %", full.0);
        assert!(full.1 < mse_max, "{scene}: MSE×100 {:.3}", full.1);
        assert!(
            full.0 < paper.0,
            "{scene}: the pipeline did not beat the paper's on BadPix0.07"
        );
    }
}
