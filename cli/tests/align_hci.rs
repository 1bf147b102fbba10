//! Alignment on the shared real data (`../shared/data`): the rectified HCI scenes and
//! the Lytro capture must be recognised as rectified (auto leaves them alone, the
//! pipeline output bit-identical to alignment off), and HCI scenes misaligned with the
//! homographies `lfdepth synth --misalign` uses (at 2°, 3 px, 1 %, perspective 0.002)
//! must be realigned to within 0.1 px reprojection error; their EPI accuracy before and
//! after is printed (docs/stages/align.md). Heavy: run with `cargo test --release`.

use lfdepth::align::{
    self, gauge_fit, reprojection_rms, warp_rows_with, AlignMode, AlignParams, Interpolation,
};
use lfdepth::metrics::{self, EvalOptions, Scores, BORDER};
use lfdepth::synth::{self, Misalignment, SceneKind, SynthSpec};
use lfdepth::{Homography, Layout, LightField, Params, Sample};
use lfdepth_cli::engine::{self, EstimateOptions, Stages};
use lfdepth_cli::io::pfm;

mod align_support;
use align_support::{align_views, data_dir, load};

fn epi<S: Sample + Sync>(data: &[S], layout: Layout, align: AlignMode) -> Vec<f32> {
    let lf = LightField::new(data, layout).unwrap();
    let mut params = Params::default();
    params.align.mode = align;
    let options = EstimateOptions {
        params,
        stage: Stages::Epi,
        threads: None,
    };
    engine::estimate(&lf, &options, &mut |_, _, _| {})
        .unwrap()
        .disparity
}

fn scores(est: &[f32], gt: &[f32], layout: Layout) -> Scores {
    let (w, h) = (layout.width, layout.height);
    let mut scratch = vec![0.0f32; metrics::scratch_len(w, h)];
    let eval = EvalOptions {
        border: BORDER,
        mask: None,
    };
    metrics::evaluate(est, gt, w, h, &eval, &mut scratch).unwrap()
}

/// Every view of `lf` warped by `hs` into `O` (the pipeline's default interpolation).
fn warp_all<O: align::WarpSample + lfdepth::Sample>(
    lf: &LightField<'_, u8>,
    hs: &[Homography],
) -> Vec<O> {
    let l = lf.layout();
    let view = l.width * l.height * l.channels;
    let mut out = vec![O::default(); l.validate().unwrap()];
    let how = Interpolation::default();
    for (v, chunk) in out.chunks_exact_mut(view).enumerate() {
        warp_rows_with(lf, hs, v, 0..l.height, how, chunk).unwrap();
        align::finish_view(l, hs, v, how, chunk).unwrap();
    }
    out
}

#[test]
fn rectified_real_arrays_are_left_alone() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: heavy 512x512 test, run it with `cargo test --release`");
        return;
    }
    for name in [
        "hci/stratified/backgammon",
        "hci/training/cotton",
        "real/lytro-2067",
    ] {
        let Some((data, layout)) = load(name) else {
            continue;
        };
        let (report, hs) = align_views(&data, layout, &AlignParams::default());
        eprintln!(
            "{name}: skipped {} identity RMS {:.4} px, warning {:?}",
            report.skipped, report.identity_rms, report.warning
        );
        assert!(
            report.skipped && report.warning.is_none(),
            "{name}: {report:?}"
        );
        assert!(hs.iter().all(|h| *h == Homography::IDENTITY));
        // The pipeline with auto alignment gives exactly the output of alignment off.
        let auto = epi(&data, layout, AlignMode::Auto);
        let off = epi(&data, layout, AlignMode::Off);
        assert!(
            auto.iter()
                .zip(&off)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{name}: auto changed the disparity"
        );
        // Forced alignment agrees that there is (almost) nothing to undo.
        let on = AlignParams {
            mode: AlignMode::On,
            ..AlignParams::default()
        };
        let (report, hs) = align_views(&data, layout, &on);
        let (w, h) = (layout.width, layout.height);
        let identity = vec![Homography::IDENTITY; layout.grid.len()];
        let change =
            reprojection_rms(&identity, &hs, layout.grid, w, h, &[-1.5, 0.0, 1.5]).unwrap();
        eprintln!(
            "{name}: forced alignment moves the array by {change:.4} px (reprojection), track RMS {:.4} -> {:.4}",
            report.identity_rms, report.rms
        );
    }
}

#[test]
fn misaligned_hci_scenes_are_realigned() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: heavy 512x512 test, run it with `cargo test --release`");
        return;
    }
    for scene in ["stratified/backgammon", "training/cotton"] {
        let Some((data, layout)) = load(&format!("hci/{scene}")) else {
            continue;
        };
        let (w, h) = (layout.width, layout.height);
        // The homographies of a misaligned synthetic array of this size (the scene kind
        // does not matter for them; the centre view stays put).
        let mut spec = SynthSpec::new(SceneKind::Planes, layout.grid, w, h);
        spec.seed = 5;
        spec.misalign = Some(Misalignment {
            max_rotation_deg: 2.0,
            max_translation_px: 3.0,
            max_scale: 0.01,
            max_perspective: 0.002,
        });
        let cols = layout.grid.cols;
        let truth: Vec<Homography> = (0..layout.grid.len())
            .map(|v| synth::view_homography(&spec, v / cols, v % cols).unwrap())
            .collect();
        // Observed view = ideal view resampled at H⁻¹: warp with the inverses.
        let inverses: Vec<Homography> = truth.iter().map(|t| t.inverse().unwrap()).collect();
        let lf = LightField::new(&data[..], layout).unwrap();
        let misaligned: Vec<u8> = warp_all(&lf, &inverses);

        let on = AlignParams {
            mode: AlignMode::On,
            ..AlignParams::default()
        };
        let (report, hs) = align_views(&misaligned, layout, &on);
        let disparities = [-1.5, 0.0, 1.5];
        let identity = vec![Homography::IDENTITY; layout.grid.len()];
        let before = reprojection_rms(&identity, &truth, layout.grid, w, h, &disparities).unwrap();
        let after = reprojection_rms(&hs, &truth, layout.grid, w, h, &disparities).unwrap();
        eprintln!(
            "hci/{scene}: reprojection {before:.3} -> {after:.4} px, track RMS {:.4}, {} corners, disparity shift {:+.4} px (coherence {:.3})",
            report.rms, report.features, report.disparity_shift, report.disparity_coherence
        );
        assert!(after < 0.1, "{scene}: {after}");
        let (auto, _) = align_views(&misaligned, layout, &AlignParams::default());
        assert!(
            !auto.skipped,
            "{scene}: auto missed the misalignment: {auto:?}"
        );
        // Disparity accuracy of the EPI stage: original, misaligned, realigned (the
        // unobservable disparity plane and scale removed, see `align::gauge_fit`).
        let gt_path = data_dir()
            .join("hci")
            .join(scene)
            .join("gt_disp_lowres.pfm");
        let Ok(gt) = pfm::read(&gt_path) else {
            eprintln!(
                "SKIPPED: {} is missing: no accuracy table",
                gt_path.display()
            );
            continue;
        };
        let gauge = gauge_fit(&hs, &truth, layout.grid, w, h).unwrap();
        let mis_lf = LightField::new(&misaligned[..], layout).unwrap();
        let aligned: Vec<f32> = warp_all(&mis_lf, &hs);
        let oracle: Vec<f32> = warp_all(&mis_lf, &truth);
        let corrected: Vec<f32> = epi(&aligned, layout, AlignMode::Off)
            .iter()
            .enumerate()
            .map(|(i, &d)| gauge.true_disparity(d, (i % w) as f32, (i / w) as f32))
            .collect();
        for (label, est) in [
            ("original (rectified)", epi(&data, layout, AlignMode::Off)),
            (
                "misaligned, not aligned",
                epi(&misaligned, layout, AlignMode::Off),
            ),
            (
                "misaligned, warped with the true H",
                epi(&oracle, layout, AlignMode::Off),
            ),
            (
                "misaligned, aligned (raw)",
                epi(&aligned, layout, AlignMode::Off),
            ),
            ("misaligned, aligned (gauge plane removed)", corrected),
            (
                "misaligned, --align on through the engine (raw)",
                epi(&misaligned, layout, AlignMode::On),
            ),
        ] {
            let s = scores(&est, &gt.data, layout);
            eprintln!(
                "| {scene} | {label} | {:.2} | {:.2} | {:.2} |",
                s.badpix_007, s.mse100, s.q25
            );
        }
        eprintln!(
            "{scene}: gauge plane {:.4} px + ({:.2e}, {:.2e}) px/px, scale {:.5}",
            gauge.disparity_offset, gauge.disparity_slope.0, gauge.disparity_slope.1, gauge.scale
        );
    }
}
