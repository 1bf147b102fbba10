//! The whole pipeline on synthetic scenes: the refinement stage lowers the EPI error, never
//! leaves the range or produces NaN, and the rayon engine is bit-identical for any thread
//! count and agrees with the serial core pipeline.

mod synth_support;

use std::ops::ControlFlow;

use lfdepth::median::MedianParams;
use lfdepth::pipeline::{self, Stages};
use lfdepth::refine::RefineParams;
use lfdepth::synth::SceneKind;
use lfdepth::tv::TvParams;
use lfdepth::{LightField, Params, Plan};
use synth_support::{errors, run, scene, Scene};

fn params() -> Params {
    Params {
        refine: RefineParams {
            band_rows: 8,
            ..RefineParams::on()
        },
        tv: TvParams {
            tile: 24,
            halo: 8,
            max_iterations: 60,
            ..TvParams::default()
        },
        ..Params::default()
    }
}

#[test]
fn refinement_lowers_the_epi_error_on_smooth_scenes() {
    for kind in [SceneKind::Slanted, SceneKind::Spheres] {
        let s = scene(kind, 64);
        let epi = run(&s, params(), Stages::Epi, 2);
        let no_tv = Params {
            tv: TvParams {
                max_iterations: 1,
                lambda: 1e-3,
                ..params().tv
            },
            median: MedianParams::off(),
            ..params()
        };
        let refined = run(&s, no_tv, Stages::Full, 2);
        let (before, after) = (errors(&s, &epi.disparity), errors(&s, &refined.disparity));
        eprintln!(
            "{}: EPI bad {:.3} rms {:.4} → refined bad {:.3} rms {:.4}",
            kind.name(),
            before.0,
            before.1,
            after.0,
            after.1
        );
        assert!(after.0 < before.0, "{}: BadPix0.07 rose", kind.name());
        assert!(after.1 < before.1, "{}: RMS rose", kind.name());
        // The EPI stage's hypothesis range bounds every output.
        let plan = Plan::new(s.spec.layout(), no_tv).unwrap();
        let lf = LightField::new(&s.views, s.spec.layout()).unwrap();
        let mut scratch = vec![0.0f32; lfdepth::epi::scratch_len(plan.epi())];
        let hyps = lfdepth::epi::hypotheses(plan.epi(), &lf, &mut scratch).unwrap();
        let (lo, hi) = (hyps.min(), hyps.max());
        assert!(refined
            .disparity
            .iter()
            .all(|v| v.is_finite() && (lo..=hi).contains(v)));
        assert!(refined.confidence.iter().all(|c| (0.0..=1.0).contains(c)));
    }
}

#[test]
fn engine_is_bit_identical_for_any_thread_count_and_matches_the_core_pipeline() {
    let s = scene(SceneKind::Mixed, 48);
    let without_sweeps = check_engine_against_core(&s, params());
    // Outer TV sweeps (tiles solved again from the stitched dual) keep the identity and
    // change the map.
    let mut swept = params();
    swept.tv.sweeps = 2;
    let with_sweeps = check_engine_against_core(&s, swept);
    assert!(without_sweeps
        .iter()
        .zip(&with_sweeps)
        .any(|(a, b)| a.to_bits() != b.to_bits()));
    // The occlusion scene, where the geodesic refill (on by default) moves edges.
    check_engine_against_core(&scene(SceneKind::Occlusion, 48), params());
    // The EPI start instead of the plane sweep.
    let epi_start = Params {
        sweep: lfdepth::planesweep::PlaneSweepParams::off(),
        ..params()
    };
    check_engine_against_core(&s, epi_start);
}

/// The engine with 1, 2 and 3 threads and the serial core pipeline compute the same bits;
/// returns the disparity.
fn check_engine_against_core(s: &Scene, params: Params) -> Vec<f32> {
    let reference = run(s, params, Stages::Full, 1);
    let names: Vec<&str> = reference.timings.iter().map(|t| t.0).collect();
    let start: &[&str] = if params.sweep.enabled {
        &["sweep"]
    } else {
        &["epi horizontal", "epi vertical"]
    };
    let expected: Vec<&str> = [
        &["epi range"][..],
        start,
        &["refine", "geofill", "median", "tv"],
    ]
    .concat();
    assert_eq!(names, expected);
    assert!(!reference.residuals.is_empty());
    for threads in [2, 3] {
        let e = run(s, params, Stages::Full, threads);
        let same = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(
            same(&e.disparity, &reference.disparity),
            "{threads} threads"
        );
        assert!(
            same(&e.confidence, &reference.confidence),
            "{threads} threads"
        );
        assert!(
            same(&e.residuals, &reference.residuals),
            "{threads} threads"
        );
    }
    // The serial core pipeline computes the same map.
    let layout = s.spec.layout();
    let plan = Plan::new(layout, params).unwrap();
    let lf = LightField::new(&s.views, layout).unwrap();
    let mut d = vec![0.0f32; plan.pixels()];
    let mut c = vec![0.0f32; plan.pixels()];
    let mut scratch = vec![0.0f32; pipeline::scratch_len(&plan)];
    let mut maps = vec![0.0f32; pipeline::map_scratch_len(&plan)];
    let mut history = vec![0.0f32; params.tv.max_iterations];
    pipeline::run(
        &plan,
        &lf,
        Stages::Full,
        pipeline::RunOutput {
            disparity: &mut d,
            confidence: &mut c,
            history: &mut history,
        },
        pipeline::RunScratch {
            kernel: &mut scratch,
            maps: &mut maps,
        },
        &mut |_| ControlFlow::Continue(()),
    )
    .unwrap();
    assert!(d
        .iter()
        .zip(&reference.disparity)
        .all(|(a, b)| a.to_bits() == b.to_bits()));
    assert!(c
        .iter()
        .zip(&reference.confidence)
        .all(|(a, b)| a.to_bits() == b.to_bits()));
    let n = reference.residuals.len();
    assert!(history[..n]
        .iter()
        .zip(&reference.residuals)
        .all(|(a, b)| a.to_bits() == b.to_bits()));
    reference.disparity
}

#[test]
fn paper_pipeline_stays_selectable() {
    let s = scene(SceneKind::Planes, 40);
    let paper = Params {
        tv: params().tv,
        ..Params::paper()
    };
    let e = run(&s, paper, Stages::Full, 2);
    let names: Vec<&str> = e.timings.iter().map(|t| t.0).collect();
    assert_eq!(names, ["epi range", "epi horizontal", "epi vertical", "tv"]);
}

/// The edge-snapping median moves fattened depth edges back onto colour edges: on the
/// occlusion, thin-structure and planes scenes the full pipeline from the EPI start with
/// it beats the one without. (From the plane sweep, the default start, the median lowers
/// BadPix0.07 on occlusion, 6.80 → 5.73 %, and thin, 12.68 → 10.17 %, but raises it on
/// planes, 3.77 → 4.66 %, while lowering its RMS error, 0.290 → 0.269 px.)
#[test]
fn median_lowers_the_error_at_depth_edges() {
    let epi_start = Params {
        sweep: lfdepth::planesweep::PlaneSweepParams::off(),
        ..params()
    };
    for kind in [SceneKind::Occlusion, SceneKind::Thin, SceneKind::Planes] {
        let s = scene(kind, 64);
        let with = run(&s, epi_start, Stages::Full, 2);
        let without = Params {
            median: MedianParams::off(),
            ..epi_start
        };
        let without = run(&s, without, Stages::Full, 2);
        let (a, b) = (errors(&s, &with.disparity), errors(&s, &without.disparity));
        eprintln!(
            "{}: median bad {:.4} rms {:.4}, none bad {:.4} rms {:.4}",
            kind.name(),
            a.0,
            a.1,
            b.0,
            b.1
        );
        assert!(a.0 < b.0, "{}: BadPix0.07 not lower", kind.name());
    }
}
