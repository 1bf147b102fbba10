//! Accuracy floors of the default pipeline on the realistic synthetic suite
//! (`lfdepth synth --suite realistic`), rendered at 256² to keep the test short: each
//! scene's BadPix0.07 and MSE×100 (HCI metrics, 15-pixel border) must stay at or below
//! the level measured when the floors were set plus a small margin. Generated, so
//! nothing is skipped.

use lfdepth::metrics::{self, EvalOptions};
use lfdepth::synth::REALISTIC_SUITE;
use lfdepth::{LightField, Params};
use lfdepth_cli::commands::synth::render;
use lfdepth_cli::engine::{estimate, EstimateOptions, Stages};

/// Scene, highest BadPix0.07 (%) and MSE×100 allowed at 256²: the default pipeline's
/// (plane-sweep start) 21.744 / 8.745, 8.458 / 4.101, 1.607 / 0.320, 4.556 / 0.531 and
/// 1.441 / 1.766 plus 0.3 points and 5 % (maps are identical for any thread count and
/// CPU, so the margin only absorbs floating-point reassociation by a future compiler).
/// At 256² the floors are twice as steep per pixel as at the suite's 512²: hall and
/// corridor fail there. Dusk is worse than from the EPI start (3.798 / 0.594 at 256²;
/// not at 512², docs/stages/sweep.md): the sweep leaves a blob in its low-texture patch.
const FLOORS: [(&str, f64, f64); 5] = [
    ("hall", 22.04, 9.18),
    ("corridor", 8.76, 4.31),
    ("tabletop", 1.91, 0.336),
    ("dusk", 4.86, 0.558),
    ("relief", 1.74, 1.854),
];

/// The slanted refinement window at radius 2 (`--refine-slant 1 --refine-radius 2`, an
/// option) on the suite's two steepest scenes at 256²: 21.262 / 8.639 and 6.375 / 4.247,
/// with the same margins; the default's floors above are 22.04 and 8.76.
const SLANTED_FLOORS: [(&str, f64, f64); 2] = [("hall", 21.56, 9.07), ("corridor", 6.68, 4.46)];

/// The fused start (`--initial fused`, an option) on every scene at 256²: 17.674 /
/// 8.584, 7.463 / 4.014, 1.466 / 0.306, 4.149 / 0.542 and 1.302 / 1.665, with the same
/// margins. Dusk is the one scene where it stays above the EPI start's floor
/// (docs/stages/fused.md).
const FUSED_FLOORS: [(&str, f64, f64); 5] = [
    ("hall", 17.98, 9.02),
    ("corridor", 7.77, 4.22),
    ("tabletop", 1.77, 0.322),
    ("dusk", 4.45, 0.57),
    ("relief", 1.61, 1.749),
];

/// Each of `floors`' scenes of the suite at 256², estimated with `params` and scored:
/// the scenes over their floor, described.
fn over_floors(params: Params, floors: &[(&str, f64, f64)]) -> Vec<String> {
    let size = 256;
    let mut failures = Vec::new();
    for &(name, max_badpix, max_mse) in floors {
        let entry = REALISTIC_SUITE
            .iter()
            .find(|entry| entry.kind.name() == name)
            .unwrap();
        let spec = entry.spec(size, size);
        let rendered = render(&spec).unwrap();
        let lf = LightField::new(&rendered.views, spec.layout()).unwrap();
        let options = EstimateOptions {
            params,
            stage: Stages::Full,
            threads: None,
        };
        let est = estimate(&lf, &options, &mut |_, _, _| {}).unwrap();
        let mut scratch = vec![0f32; metrics::scratch_len(size, size)];
        let scores = metrics::evaluate(
            &est.disparity,
            &rendered.gt,
            size,
            size,
            &EvalOptions {
                border: metrics::BORDER,
                mask: None,
            },
            &mut scratch,
        )
        .unwrap();
        eprintln!(
            "{name}: BadPix0.07 {:.3} % (floor {max_badpix}), MSE×100 {:.3} (floor {max_mse})",
            scores.badpix_007, scores.mse100
        );
        if scores.badpix_007 > max_badpix || scores.mse100 > max_mse {
            failures.push(format!(
                "{name}: BadPix0.07 {:.3} > {max_badpix} or MSE×100 {:.3} > {max_mse}",
                scores.badpix_007, scores.mse100
            ));
        }
    }
    failures
}

#[test]
fn default_pipeline_holds_its_accuracy_on_the_realistic_suite() {
    let names: Vec<_> = REALISTIC_SUITE.iter().map(|e| e.kind.name()).collect();
    let floors: Vec<_> = FLOORS.iter().map(|f| f.0).collect();
    assert_eq!(names, floors);
    let failures = over_floors(Params::default(), &FLOORS);
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn the_slanted_refinement_window_holds_its_accuracy_on_the_steep_scenes() {
    let mut params = Params::default();
    params.refine.slanted = true;
    params.refine.radius = 2;
    let failures = over_floors(params, &SLANTED_FLOORS);
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn the_fused_start_holds_its_accuracy_on_the_realistic_suite() {
    let params = Params {
        fused: true,
        ..Params::default()
    };
    let failures = over_floors(params, &FUSED_FLOORS);
    assert!(failures.is_empty(), "{failures:#?}");
}
