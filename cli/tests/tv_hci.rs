//! TV refinement on the shared HCI scenes: accuracy on a corrupted ground truth, and a
//! development harness (ignored) that refines any EPI map given by environment variables.

#[path = "tv_support.rs"]
mod tv_support;

use std::path::PathBuf;
use std::time::Instant;

use lfdepth::tv::{self, Guide, Maps, TvNorm, TvParams};
use lfdepth::Params;
use tv_support::*;

fn params_from_env() -> TvParams {
    let d = TvParams::default();
    TvParams {
        lambda: env_f32("TV_LAMBDA", d.lambda),
        tikhonov: env_f32("TV_TIKHONOV", d.tikhonov),
        confidence_threshold: env_f32("TV_THRESHOLD", d.confidence_threshold),
        confidence_power: env_f32("TV_POWER", d.confidence_power),
        edge_sigma: env_f32("TV_SIGMA", d.edge_sigma),
        edge_floor: env_f32("TV_FLOOR", d.edge_floor),
        norm: if std::env::var("TV_NORM").as_deref() == Ok("l1") {
            TvNorm::L1
        } else {
            d.norm
        },
        max_iterations: env_f32("TV_ITERS", d.max_iterations as f32) as usize,
        tolerance: env_f32("TV_TOL", d.tolerance),
        step: env_f32("TV_STEP", d.step),
        relaxation: env_f32("TV_RELAX", d.relaxation),
        tile: env_f32("TV_TILE", d.tile as f32) as usize,
        halo: env_f32("TV_HALO", d.halo as f32) as usize,
        sweeps: env_f32("TV_SWEEPS", d.sweeps as f32) as usize,
    }
}

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

#[test]
#[ignore = "development harness: TV_SCENE, TV_INPUT (PFM; confidence in *_conf.pfm)"]
fn tv_hci_dev_harness() {
    let (Ok(scene), Ok(input)) = (std::env::var("TV_SCENE"), std::env::var("TV_INPUT")) else {
        eprintln!("SKIPPED: set TV_SCENE and TV_INPUT");
        return;
    };
    let scene = PathBuf::from(scene);
    let (w, h, d) = read_pfm(input.as_ref());
    let (_, _, c) = read_pfm(input.replace(".pfm", "_conf.pfm").as_ref());
    let (_, _, gt) = read_pfm(&scene.join("gt_disp_lowres.pfm"));
    let params = params_from_env();
    let (out, history, report, secs) = run::<f32>(&scene, &d, &c, params);
    if std::env::var("TV_Q16").is_ok() {
        let (q, _, qreport, qsecs) = run::<lfdepth::Q16>(&scene, &d, &c, params);
        let diffs: Vec<f32> = q.iter().zip(&out).map(|(a, b)| (a - b).abs()).collect();
        let max = diffs.iter().cloned().fold(0.0, f32::max);
        let mean = diffs.iter().sum::<f32>() / diffs.len() as f32;
        let over = diffs.iter().filter(|&&d| d > 0.01).count();
        println!(
            "q16: max |q16 − f32| {max:.5} px, mean {mean:.6}, {over} px over 0.01; {qreport:?} in {:.1} ms",
            qsecs * 1e3
        );
    }
    let before = scores(&d, &gt, w, h);
    let after = scores(&out, &gt, w, h);
    println!(
        "params {params:?}\ninput  badpix {:.3} mse {:.4}\noutput badpix {:.3} mse {:.4}\n\
         {report:?} in {:.1} ms",
        before.0,
        before.1,
        after.0,
        after.1,
        secs * 1e3
    );
    if let Ok(path) = std::env::var("TV_HISTORY") {
        let text: Vec<String> = history.iter().map(|v| format!("{v:e}")).collect();
        std::fs::write(path, text.join("\n")).unwrap();
    }
    if let Ok(path) = std::env::var("TV_OUT") {
        write_pfm(path.as_ref(), w, h, &out);
    }
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
#[ignore = "development aid: writes the engine's EPI disparity and confidence of both HCI scenes to TV_DUMP_DIR"]
fn tv_dump_engine_epi_inputs() {
    let (Some(data), Ok(out)) = (shared_data("the EPI dump"), std::env::var("TV_DUMP_DIR")) else {
        eprintln!("SKIPPED: needs ../shared/data and TV_DUMP_DIR");
        return;
    };
    for (scene, name) in [
        ("stratified/backgammon", "backgammon"),
        ("training/cotton", "cotton"),
    ] {
        let (w, h, d, c) = engine_epi(&data.join("hci").join(scene));
        let out = PathBuf::from(&out);
        write_pfm(&out.join(format!("{name}_epi.pfm")), w, h, &d);
        write_pfm(&out.join(format!("{name}_epi_conf.pfm")), w, h, &c);
    }
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
