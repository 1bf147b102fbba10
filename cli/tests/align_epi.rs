//! End-to-end effect of alignment on the EPI disparity: synthetic 9×9 arrays
//! (`lfdepth::synth`) rendered rectified and misaligned (2°, 3 px, 1 %, perspective);
//! the misaligned array, aligned and warped as the pipeline does (its default
//! interpolation, into `f32`), is scored against the perfectly aligned array (goal: BadPix0.07 within 10 %
//! relative; measured numbers in docs/bench-align.md) and against a warp with the true
//! homographies. The disparity plane that no image can observe (see `align::gauge_fit`)
//! is removed before scoring and reported.
//! Run with `cargo test --release` (skipped in debug builds: too slow there).

use lfdepth::align::{
    self, gauge_fit_where, warp_rows_with, AlignMode, AlignModel, AlignParams, AlignedViews,
    Interpolation, Reference,
};
use lfdepth::metrics::{self, EvalOptions, BORDER};
use lfdepth::synth::{self, Misalignment, SceneKind, SynthSpec};
use lfdepth::{Grid, Homography, LightField, Params, Sample};
use lfdepth_cli::engine::{self, EstimateOptions, StageSelect};

const SIZE: usize = 384;

fn epi<S: Sample + Sync>(data: &[S], spec: &SynthSpec) -> Vec<f32> {
    let lf = LightField::new(data, spec.layout()).unwrap();
    let options = EstimateOptions {
        params: Params::default(),
        stage: StageSelect::Epi,
        threads: None,
    };
    engine::estimate(&lf, &options, &mut |_, _, _| {})
        .unwrap()
        .disparity
}

fn badpix(est: &[f32], gt: &[f32], n: usize) -> f64 {
    badpix_border(est, gt, n, BORDER)
}

fn badpix_border(est: &[f32], gt: &[f32], n: usize, border: usize) -> f64 {
    let mut scratch = vec![0.0f32; metrics::scratch_len(n, n)];
    let options = EvalOptions { border, mask: None };
    metrics::evaluate(est, gt, n, n, &options, &mut scratch)
        .unwrap()
        .badpix_007
}

/// Every view of `lf` warped by `hs` into `f32` (the pipeline warps only the views the
/// stages read; the EPI stage reads only those).
fn warp_all(lf: &LightField<'_, u8>, hs: &[Homography], how: Interpolation) -> Vec<f32> {
    let l = lf.layout();
    let view = l.width * l.height * l.channels;
    let mut out = vec![0.0f32; l.validate().unwrap()];
    for (v, chunk) in out.chunks_exact_mut(view).enumerate() {
        warp_rows_with(lf, hs, v, 0..l.height, how, chunk).unwrap();
    }
    out
}

/// The scene rendered rectified and misaligned: (rectified views, misaligned views,
/// ground truth, true homographies).
fn scenes(scene: SceneKind, n: usize) -> (SynthSpec, Vec<u8>, Vec<u8>, Vec<f32>, Vec<Homography>) {
    let mut spec = SynthSpec::new(scene, Grid::new(9, 9), n, n);
    spec.seed = 11;
    let views = spec.grid.len();
    let mut ideal = vec![0u8; spec.layout().validate().unwrap()];
    let mut gt = vec![0.0f32; n * n];
    let mut hs = vec![Homography::IDENTITY; views];
    synth::render(&spec, &mut ideal, &mut gt, &mut hs).unwrap();
    spec.misalign = Some(Misalignment {
        max_rotation_deg: 2.0,
        max_translation_px: 3.0,
        max_scale: 0.01,
        max_perspective: 0.002,
    });
    let mut misaligned = vec![0u8; ideal.len()];
    let mut truth = vec![Homography::IDENTITY; views];
    synth::render(&spec, &mut misaligned, &mut gt, &mut truth).unwrap();
    (spec, ideal, misaligned, gt, truth)
}

fn estimate(lf: &LightField<'_, u8>, params: AlignParams) -> (Vec<Homography>, f32) {
    let mut est = vec![Homography::IDENTITY; lf.grid().len()];
    let mut scratch = vec![0.0f32; align::scratch_len(lf.layout(), &params).unwrap()];
    let report = align::estimate(lf, &params, &mut est, &mut scratch).unwrap();
    (est, report.rms)
}

#[test]
fn aligned_arrays_score_like_rectified_ones() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: heavy 384x384 test, run it with `cargo test --release`");
        return;
    }
    let n = SIZE;
    for scene in [SceneKind::Planes, SceneKind::Mixed] {
        let (spec, ideal, misaligned, gt, truth) = scenes(scene, n);
        let name = scene.name();
        let reference = badpix(&epi(&ideal, &spec), &gt, n);
        let unaligned = badpix(&epi(&misaligned, &spec), &gt, n);
        let lf = LightField::new(&misaligned[..], spec.layout()).unwrap();
        // The best any estimate can do with this warp: the true homographies.
        let oracle = badpix(
            &epi(&warp_all(&lf, &truth, Interpolation::default()), &spec),
            &gt,
            n,
        );
        eprintln!("{name} {n}x{n}: BadPix0.07 rectified {reference:.2}, misaligned {unaligned:.2}, warped with the true homographies {oracle:.2}");
        // The pipeline estimates the cross only (all its stages read by default).
        let variants = [
            (
                AlignModel::PerView,
                Reference::Estimated,
                AlignedViews::Cross,
            ),
            (AlignModel::PerView, Reference::Estimated, AlignedViews::All),
            (
                AlignModel::PerView,
                Reference::CentreView,
                AlignedViews::All,
            ),
            (
                AlignModel::PlanePatches,
                Reference::Estimated,
                AlignedViews::All,
            ),
        ];
        let (r0, c0) = spec.grid.center();
        let cols = spec.grid.cols;
        for (model, frame, views) in variants {
            let params = AlignParams {
                mode: AlignMode::On,
                model,
                reference: frame,
                views,
                ..AlignParams::default()
            };
            let (est, rms) = estimate(&lf, params);
            let raw = epi(&warp_all(&lf, &est, params.interpolation), &spec);
            let include = |v: usize| views == AlignedViews::All || v / cols == r0 || v % cols == c0;
            let gauge = gauge_fit_where(&est, &truth, spec.grid, n, n, &include).unwrap();
            let corrected: Vec<f32> = raw
                .iter()
                .enumerate()
                .map(|(i, &d)| gauge.true_disparity(d, (i % n) as f32, (i / n) as f32))
                .collect();
            let (raw_score, score) = (badpix(&raw, &gt, n), badpix(&corrected, &gt, n));
            eprintln!(
                "{name} {n}x{n} {model:?}/{frame:?}/{views:?}: BadPix0.07 aligned {raw_score:.2} raw, {score:.2} ({:+.0} % vs rectified) after the unobservable disparity plane {:.4} px + ({:.2e}, {:.2e}) px/px, scale {:.5} (track RMS {rms:.4})",
                100.0 * (score / reference - 1.0),
                gauge.disparity_offset,
                gauge.disparity_slope.0,
                gauge.disparity_slope.1,
                gauge.scale,
            );
            // The goal is 10 % relative; measured +7 … +19 % (see docs/bench-align.md).
            // Guard against regressions. The plane-patch model is reported, not asserted:
            // it is the worse of the two on these scenes (patches straddle surfaces).
            assert!(
                model == AlignModel::PlanePatches
                    || (score <= 1.3 * reference && score < 0.1 * unaligned),
                "{name} {model:?}/{frame:?}/{views:?}: {score} vs {reference}"
            );
        }
    }
}

/// Where the gap to the rectified array comes from (a measurement, run by hand):
/// resampling (true homographies, bilinear vs Catmull–Rom), the estimated homographies
/// (with the unobservable disparity plane removed), corner count and reference frame,
/// the border. An affine fit of the error map to the rectified estimate shows what is a
/// smooth bias and what is noise.
/// `cargo test --release -p lfdepth-cli --test align_epi gap -- --ignored --nocapture`
#[test]
#[ignore]
fn gap() {
    let n = SIZE;
    for scene in [SceneKind::Planes, SceneKind::Mixed] {
        let (spec, ideal, misaligned, gt, truth) = scenes(scene, n);
        let name = scene.name();
        let reference = epi(&ideal, &spec);
        for border in [BORDER, 30] {
            let score = badpix_border(&reference, &gt, n, border);
            eprintln!("{name} border {border}: rectified {score:.2}");
        }
        let lf = LightField::new(&misaligned[..], spec.layout()).unwrap();
        let on = AlignParams {
            mode: AlignMode::On,
            ..AlignParams::default()
        };
        let with = |params: AlignParams| estimate(&lf, params).0;
        let cross = AlignParams {
            views: AlignedViews::Cross,
            ..on
        };
        let variants = [
            ("true H", truth.clone(), false),
            ("estimated H", with(on), false),
            (
                "estimated H, 512 corners",
                with(AlignParams {
                    features: 512,
                    ..on
                }),
                false,
            ),
            (
                "estimated H, 128 corners",
                with(AlignParams {
                    features: 128,
                    ..on
                }),
                false,
            ),
            (
                "estimated H, centre reference",
                with(AlignParams {
                    reference: Reference::CentreView,
                    ..on
                }),
                false,
            ),
            ("estimated H, cross only", with(cross), true),
            (
                "estimated H, cross only, 128 corners",
                with(AlignParams {
                    features: 128,
                    ..cross
                }),
                true,
            ),
        ];
        let (r0, c0) = spec.grid.center();
        let cols = spec.grid.cols;
        let on_cross = |v: usize| v / cols == r0 || v % cols == c0;
        for (label, hs, cross_only) in &variants {
            let include = |v: usize| !cross_only || on_cross(v);
            let gauge = gauge_fit_where(hs, &truth, spec.grid, n, n, &include).unwrap();
            for how in [Interpolation::Bilinear, Interpolation::CatmullRom] {
                let d: Vec<f32> = epi(&warp_all(&lf, hs, how), &spec)
                    .iter()
                    .enumerate()
                    .map(|(i, &d)| gauge.true_disparity(d, (i % n) as f32, (i / n) as f32))
                    .collect();
                let (mut sums, mut count) = ([[0.0f64; 4]; 3], 0usize);
                for y in BORDER..n - BORDER {
                    for x in BORDER..n - BORDER {
                        let e = f64::from(d[y * n + x] - reference[y * n + x]);
                        if e.abs() > 0.2 {
                            continue;
                        }
                        let f = [1.0, x as f64 / n as f64, y as f64 / n as f64];
                        for i in 0..3 {
                            for j in 0..3 {
                                sums[i][j] += f[i] * f[j];
                            }
                            sums[i][3] += f[i] * e;
                        }
                        count += 1;
                    }
                }
                let c = solve3(&sums);
                eprintln!(
                    "{name} {label} {how:?}: BadPix0.07 {:.2} (border 30: {:.2}); error vs the rectified map: {:.4} + {:.4}x + {:.4}y (x, y in image widths) over {count} px; gauge plane {:.4} + ({:.2e}, {:.2e}) px/px",
                    badpix(&d, &gt, n),
                    badpix_border(&d, &gt, n, 30),
                    c[0],
                    c[1],
                    c[2],
                    gauge.disparity_offset,
                    gauge.disparity_slope.0,
                    gauge.disparity_slope.1,
                );
            }
        }
    }
}

/// Solves the 3 × 3 system `[A | b]` by Cramer's rule.
fn solve3(m: &[[f64; 4]; 3]) -> [f64; 3] {
    let det = |a: [[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let a = |col: Option<usize>| {
        let mut out = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                out[i][j] = if Some(j) == col { m[i][3] } else { m[i][j] };
            }
        }
        out
    };
    let d = det(a(None));
    [
        det(a(Some(0))) / d,
        det(a(Some(1))) / d,
        det(a(Some(2))) / d,
    ]
}
