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
/// 27.573 / 10.743, 9.024 / 3.959, 2.246 / 0.287, 3.798 / 0.594 and 1.694 / 1.230 plus
/// 0.3 points and 5 % (maps are identical for any thread count and CPU, so the margin
/// only absorbs floating-point reassociation by a future compiler). At 256² the
/// floors are twice as steep per pixel as at the suite's 512²: hall and corridor fail
/// there.
const FLOORS: [(&str, f64, f64); 5] = [
    ("hall", 27.87, 11.28),
    ("corridor", 9.32, 4.16),
    ("tabletop", 2.55, 0.302),
    ("dusk", 4.1, 0.624),
    ("relief", 1.99, 1.292),
];

#[test]
fn default_pipeline_holds_its_accuracy_on_the_realistic_suite() {
    let size = 256;
    let mut failures = Vec::new();
    for (entry, (name, max_badpix, max_mse)) in REALISTIC_SUITE.iter().zip(FLOORS) {
        assert_eq!(entry.kind.name(), name);
        let spec = entry.spec(size, size);
        let rendered = render(&spec).unwrap();
        let lf = LightField::new(&rendered.views, spec.layout()).unwrap();
        let options = EstimateOptions {
            params: Params::default(),
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
    assert!(failures.is_empty(), "{failures:#?}");
}
