//! The EPI stage on analytic scenes from `lfdepth::synth` with exact ground truth:
//! accuracy over the whole −4…+4 px range, the automatic range, and fixed point vs f32.
//! Rendering and estimating 9×9 views is heavy in debug: these run in release only.

use std::ops::ControlFlow;

use lfdepth::epi::{self, DisparityRange, EpiParams};
use lfdepth::metrics::{evaluate, scratch_len, EvalOptions};
use lfdepth::synth::{render, SceneKind, SynthSpec};
use lfdepth::Scalar;
use lfdepth::{Grid, Homography, LightField, Params, Plan, Q16};
use lfdepth_cli::engine::{estimate, EstimateOptions, Stages};

fn scene(kind: SceneKind, min: f32, max: f32, size: usize) -> (SynthSpec, Vec<u8>, Vec<f32>) {
    let mut spec = SynthSpec::new(kind, Grid::new(9, 9), size, size);
    spec.disparity_min = min;
    spec.disparity_max = max;
    spec.seed = 7;
    let mut views = vec![0u8; spec.layout().validate().unwrap()];
    let mut gt = vec![0.0f32; size * size];
    let mut h = vec![Homography::IDENTITY; 81];
    render(&spec, &mut views, &mut gt, &mut h).unwrap();
    (spec, views, gt)
}

/// Share of pixels within 0.07 px by the core's HCI metrics (15 px border excluded).
fn share_within_007(est: &[f32], gt: &[f32], size: usize) -> f64 {
    let mut scratch = vec![0.0; scratch_len(size, size)];
    let s = evaluate(est, gt, size, size, &EvalOptions::default(), &mut scratch).unwrap();
    1.0 - s.badpix_007 / 100.0
}

/// Share of pixels (15 px border excluded) within `tol` of the truth.
fn within(est: &[f32], gt: &[f32], size: usize, tol: f32) -> f64 {
    let (mut good, mut all) = (0, 0);
    for y in 15..size - 15 {
        for x in 15..size - 15 {
            all += 1;
            good += ((est[y * size + x] - gt[y * size + x]).abs() <= tol) as usize;
        }
    }
    good as f64 / all as f64
}

fn release_only() -> bool {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: synthetic EPI accuracy runs only with --release");
        return false;
    }
    true
}

fn run_default(spec: &SynthSpec, views: &[u8]) -> Vec<f32> {
    let lf = LightField::new(views, spec.layout()).unwrap();
    let options = EstimateOptions {
        params: Params {
            sweep: lfdepth::planesweep::PlaneSweepParams::off(),
            ..Params::default()
        },
        stage: Stages::Epi,
        threads: None,
    };
    estimate(&lf, &options, &mut |_, _, _| {})
        .unwrap()
        .disparity
}

/// Textured planes at one slope each (the scene's rectangles within ±0.01 px of it, so no
/// occlusion), every slope of −4…+4 px, automatic range.
#[test]
#[cfg_attr(debug_assertions, ignore)]
fn textured_planes_at_every_slope_are_within_two_hundredths() {
    if !release_only() {
        return;
    }
    let size = 128;
    for slope in [
        -4.0f32, -3.3, -2.5, -1.75, -0.6, 0.0, 0.45, 1.2, 2.0, 2.85, 3.6, 4.0,
    ] {
        let (min, max) = ((slope - 0.01).max(-4.0), (slope + 0.01).min(4.0));
        let (spec, views, gt) = scene(SceneKind::Planes, min, max, size);
        let d = run_default(&spec, &views);
        let share = within(&d, &gt, size, 0.02);
        eprintln!(
            "plane at {slope:+.2} px: {:.2} % within 0.02 px",
            100.0 * share
        );
        assert!(share >= 0.95, "slope {slope}: {share}");
    }
}

/// The `Planes` scene proper: five rectangles over a background spread over the range, so
/// occlusion boundaries with jumps up to the whole range. Reported, with a floor that
/// guards against regressions (the local tensor has no occlusion model).
#[test]
#[cfg_attr(debug_assertions, ignore)]
fn occluding_planes_over_wide_ranges() {
    if !release_only() {
        return;
    }
    let size = 192;
    for (min, max, floor) in [
        (-4.0f32, 4.0f32, 0.80),
        (-4.0, -2.0, 0.90),
        (-1.0, 1.0, 0.90),
        (2.0, 4.0, 0.90),
    ] {
        let (spec, views, gt) = scene(SceneKind::Planes, min, max, size);
        let d = run_default(&spec, &views);
        let share = within(&d, &gt, size, 0.02);
        let share7 = share_within_007(&d, &gt, size);
        eprintln!(
            "planes scene [{min}, {max}]: {:.2} % within 0.02 px, {:.2} % within 0.07 px",
            100.0 * share,
            100.0 * share7
        );
        assert!(share >= floor, "[{min}, {max}]: {share}");
    }
}

#[test]
#[cfg_attr(debug_assertions, ignore)]
fn automatic_range_brackets_synthetic_scenes() {
    if !release_only() {
        return;
    }
    let size = 160;
    for kind in [SceneKind::Planes, SceneKind::Spheres, SceneKind::Mixed] {
        for (min, max) in [(-4.0f32, 4.0f32), (-3.5, -1.0), (-0.5, 0.5), (1.0, 3.8)] {
            let (spec, views, gt) = scene(kind, min, max, size);
            let plan = Plan::new(spec.layout(), Params::default()).unwrap();
            let lf = LightField::new(&views, spec.layout()).unwrap();
            let mut scratch = vec![0.0f32; epi::scratch_len(plan.epi())];
            let (lo, hi) = epi::estimate_range(plan.epi(), &lf, &mut scratch).unwrap();
            let gmin = gt.iter().copied().fold(f32::MAX, f32::min);
            let gmax = gt.iter().copied().fold(f32::MIN, f32::max);
            // Surfaces covering under 1 % of the view may fall outside (they are clamped).
            let mut sorted = gt.clone();
            sorted.sort_by(f32::total_cmp);
            let (q01, q99) = (sorted[sorted.len() / 100], sorted[sorted.len() * 99 / 100]);
            eprintln!(
                "{}: truth [{gmin:.2}, {gmax:.2}] (1–99 %: [{q01:.2}, {q99:.2}]) estimated [{lo:.2}, {hi:.2}]",
                kind.name()
            );
            assert!(lo <= q01 + 0.05 && hi >= q99 - 0.05);
            assert!(lo >= gmin - 1.0 && hi <= gmax + 1.0);
        }
    }
}

/// The `thin` demo scene (`lfdepth demo --scene thin`): bars a few pixels across in front
/// of a plane and a far background. Their probe samples are too few and too scattered
/// for the surfaces' 0.3 px windows (the range ended at 0.10 px, leaving 2.5 % of the
/// truth above it); the thin-structure rule reaches them (docs/stages/epi.md).
#[test]
#[cfg_attr(debug_assertions, ignore)]
fn automatic_range_reaches_the_thin_scenes_bars() {
    if !release_only() {
        return;
    }
    let spec = SynthSpec::new(SceneKind::Thin, Grid::new(9, 9), 256, 256);
    let mut views = vec![0u8; spec.layout().validate().unwrap()];
    let mut gt = vec![0.0f32; 256 * 256];
    let mut h = vec![Homography::IDENTITY; 81];
    render(&spec, &mut views, &mut gt, &mut h).unwrap();
    let plan = Plan::new(spec.layout(), Params::default()).unwrap();
    let lf = LightField::new(&views, spec.layout()).unwrap();
    let mut scratch = vec![0.0f32; epi::scratch_len(plan.epi())];
    let (lo, hi) = epi::estimate_range(plan.epi(), &lf, &mut scratch).unwrap();
    let outside = gt.iter().filter(|&&g| g < lo || g > hi).count() as f64 / gt.len() as f64;
    eprintln!(
        "thin: estimated [{lo:.2}, {hi:.2}], {:.3} % of the truth outside",
        100.0 * outside
    );
    assert!(hi >= 1.3, "[{lo}, {hi}]");
    assert!(outside < 0.01, "{:.3} % outside", 100.0 * outside);
    // The far background (−1.5 px) stays covered, and nothing beyond the bars is added.
    assert!(lo <= -1.5 && hi <= 2.0, "[{lo}, {hi}]");
}

#[test]
#[cfg_attr(debug_assertions, ignore)]
fn fixed_point_is_within_a_hundredth_of_f32_on_99_percent() {
    if !release_only() {
        return;
    }
    let size = 128;
    for kind in [SceneKind::Planes, SceneKind::Slanted, SceneKind::Mixed] {
        let (spec, views, _) = scene(kind, -3.0, 3.0, size);
        let epi = EpiParams {
            range: DisparityRange::Fixed {
                min: -3.0,
                max: 3.0,
            },
            ..EpiParams::default()
        };
        let plan = Plan::new(
            spec.layout(),
            Params {
                epi,
                sweep: lfdepth::planesweep::PlaneSweepParams::off(),
                ..Params::default()
            },
        )
        .unwrap();
        let lf = LightField::new(&views, spec.layout()).unwrap();
        let run = |fixed: bool| {
            let mut d = vec![0.0; plan.pixels()];
            let mut c = vec![0.0; plan.pixels()];
            let mut go = |_| ControlFlow::Continue(());
            let mut maps =
                vec![
                    0.0f32;
                    lfdepth::pipeline::stage_map_scratch_len(&plan, lfdepth::pipeline::Stages::Epi)
                ];
            if fixed {
                let mut s = vec![Q16::ZERO; lfdepth::pipeline::scratch_len(&plan)];
                lfdepth::pipeline::estimate(
                    &plan,
                    &lf,
                    lfdepth::setup::DisparityOut {
                        disparity: &mut d,
                        confidence: &mut c,
                    },
                    lfdepth::pipeline::RunScratch {
                        kernel: &mut s,
                        maps: &mut maps,
                    },
                    &mut go,
                )
                .unwrap();
            } else {
                let mut s = vec![0.0f32; lfdepth::pipeline::scratch_len(&plan)];
                lfdepth::pipeline::estimate(
                    &plan,
                    &lf,
                    lfdepth::setup::DisparityOut {
                        disparity: &mut d,
                        confidence: &mut c,
                    },
                    lfdepth::pipeline::RunScratch {
                        kernel: &mut s,
                        maps: &mut maps,
                    },
                    &mut go,
                )
                .unwrap();
            }
            d
        };
        let (f, q) = (run(false), run(true));
        let close = f
            .iter()
            .zip(&q)
            .filter(|(a, b)| (*a - *b).abs() <= 0.01)
            .count();
        let share = close as f64 / f.len() as f64;
        eprintln!(
            "{}: Q16.16 within 0.01 px of f32 on {:.2} %",
            kind.name(),
            100.0 * share
        );
        assert!(share >= 0.99, "{}: {share}", kind.name());
    }
}
