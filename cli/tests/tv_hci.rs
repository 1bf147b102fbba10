//! TV refinement on the shared HCI scenes: the engine's EPI estimate refined by TV alone
//! must improve on both scenes, with a residual history that falls.

#[path = "tv_support.rs"]
mod tv_support;

use lfdepth::tv::TvParams;
use lfdepth::Params;
use tv_support::*;

/// The engine's EPI stage on an HCI scene: (disparity, confidence).
fn engine_epi(dir: &std::path::Path) -> (usize, usize, Vec<f32>, Vec<f32>) {
    use lfdepth_cli::engine::{estimate, EstimateOptions, Stages};
    let (views, layout) = load_hci(dir);
    let lf = lfdepth::LightField::new(&views, layout).unwrap();
    let options = EstimateOptions {
        params: Params {
            sweep: lfdepth::planesweep::PlaneSweepParams::off(),
            ..Params::default()
        },
        stage: Stages::Epi,
        threads: None,
    };
    let e = estimate(&lf, &options, &mut |_, _, _| {}).unwrap();
    (e.width, e.height, e.disparity, e.confidence)
}

#[test]
#[cfg_attr(debug_assertions, ignore)]
fn tv_improves_the_engine_epi_estimate_on_both_hci_scenes() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: the HCI TV accuracy test runs only with --release");
        return;
    }
    let Some(data) = shared_data("the HCI TV accuracy test") else {
        return;
    };
    for scene in ["stratified/backgammon", "training/cotton"] {
        let dir = data.join("hci").join(scene);
        let (w, h, d, c) = engine_epi(&dir);
        let (_, _, gt) = read_pfm(&dir.join("gt_disp_lowres.pfm"));
        let params = TvParams::default();
        let (out, history, report, secs) = refine_guided::<f32>(&dir, &d, &c, params);
        let before = scores(&d, &gt, w, h);
        let after = scores(&out, &gt, w, h);
        eprintln!(
            "{scene}: EPI {:.2} % / {:.3} → EPI+TV {:.2} % / {:.3} (BadPix0.07 / MSE×100); \
             {report:?}, {:.0} ms",
            before.0,
            before.1,
            after.0,
            after.1,
            secs * 1e3
        );
        assert!(after.1 < before.1, "{scene}: TV raised MSE×100");
        assert!(after.0 <= before.0, "{scene}: TV raised BadPix0.07");
        // The residual history falls by at least an order of magnitude.
        let last = history[report.max_iterations - 1];
        assert!(
            last < 0.1 * history[0],
            "{scene}: residuals {:?}",
            &history[..5]
        );
    }
}
