//! TV refinement on the shared HCI scenes: the engine's EPI estimate refined by TV alone
//! must improve on both scenes, with a residual history that falls.

#[path = "tv_support.rs"]
mod tv_support;

use std::time::Instant;

use lfdepth::tv::{self, Guide, Maps, TvParams};
use lfdepth::Params;
use tv_support::*;

/// Refines `disparity` with confidence `confidence` guided by the scene's centre view.
fn run<S: lfdepth::Scalar>(
    scene: &std::path::Path,
    disparity: &[f32],
    confidence: &[f32],
    params: TvParams,
) -> (Vec<f32>, Vec<f32>, tv::RefineReport, f64) {
    let (w, h, rgb) = read_rgb_png(&scene.join("input_Cam040.png"));
    let (data, plan) = guide_light_field(
        w,
        h,
        &rgb,
        Params {
            tv: params,
            ..Params::default()
        },
    );
    let lf = light_field(&data, &plan);
    let maps = Maps::new(w, h, disparity, confidence).unwrap();
    let guide = Guide::View(lf.center_view());
    let mut out = vec![0.0f32; w * h];
    let mut history = vec![0.0f32; params.max_iterations];
    let mut scratch = vec![S::ZERO; tv::scratch_len(&plan)];
    let t = Instant::now();
    let report = tv::refine(
        &plan,
        &maps,
        &guide,
        &mut out,
        &mut history,
        &mut scratch,
        &mut vec![0.0; tv::dual_len(&plan)],
    )
    .unwrap();
    let secs = t.elapsed().as_secs_f64();
    (out, history, report, secs)
}

/// The engine's EPI stage on an HCI scene: (disparity, confidence).
fn engine_epi(dir: &std::path::Path) -> (usize, usize, Vec<f32>, Vec<f32>) {
    use lfdepth_cli::engine::{estimate, EstimateOptions, Stages};
    let (views, layout) = load_hci(dir);
    let lf = lfdepth::LightField::new(&views, layout).unwrap();
    let options = EstimateOptions {
        params: Params::default(),
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
        let (out, history, report, secs) = run::<f32>(&dir, &d, &c, params);
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
