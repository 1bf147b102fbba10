//! Accuracy floors of the default pipeline on the realistic synthetic suite
//! (`lfdepth synth --suite realistic`): at the suite's 512², each scene's BadPix0.07 and
//! MSE×100 (HCI metrics, 15-pixel border) must stay at or below the level measured when
//! the floors were set plus a small margin, and the default must keep issue #22's goals
//! against the EPI start (mean BadPix0.07 at least 40 % lower, no scene worse); at 256²
//! (quicker) the same floors for the default and two options. Generated, so nothing is
//! skipped.

use lfdepth::metrics::{self, EvalOptions, Scores};
use lfdepth::options::{self, Value};
use lfdepth::synth::{SynthSpec, REALISTIC_SUITE};
use lfdepth::{LightField, Params};
use lfdepth_cli::commands::synth::{render, Rendered};
use lfdepth_cli::engine::{estimate, EstimateOptions, Stages};

/// Scene, highest BadPix0.07 (%) and MSE×100 allowed at 512²: the default pipeline's
/// (plane-sweep start) 3.540 / 1.679, 1.061 / 1.094, 1.193 / 0.398, 2.807 / 0.298 and
/// 0.613 / 0.771 plus 0.3 points and 5 % (rounded up), as at 256² below. From
/// the EPI start the scenes score 8.350, 1.193, 1.848, 3.904 and 0.613 (mean 3.182
/// against the default's 1.843, 42.1 % lower; relief ties).
const FLOORS_512: [(&str, f64, f64); 5] = [
    ("hall", 3.84, 1.763),
    ("corridor", 1.36, 1.149),
    ("tabletop", 1.50, 0.418),
    ("dusk", 3.11, 0.313),
    ("relief", 0.91, 0.810),
];

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

/// The suite's scene `name` rendered at `size`²: its views and exact ground truth.
fn render_scene(name: &str, size: usize) -> (SynthSpec, Rendered) {
    let entry = REALISTIC_SUITE
        .iter()
        .find(|entry| entry.kind.name() == name)
        .unwrap();
    let spec = entry.spec(size, size);
    let rendered = render(&spec).unwrap();
    (spec, rendered)
}

/// The scores of the scene `rendered` estimated with `params` (on every core).
fn score(spec: &SynthSpec, rendered: &Rendered, params: Params) -> Scores {
    let lf = LightField::new(&rendered.views, spec.layout()).unwrap();
    let options = EstimateOptions {
        params,
        stage: Stages::Full,
        threads: None,
    };
    let est = estimate(&lf, &options, &mut |_, _, _| {}).unwrap();
    let (width, height) = (spec.width, spec.height);
    let mut scratch = vec![0f32; metrics::scratch_len(width, height)];
    metrics::evaluate(
        &est.disparity,
        &rendered.gt,
        width,
        height,
        &EvalOptions {
            border: metrics::BORDER,
            mask: None,
        },
        &mut scratch,
    )
    .unwrap()
}

/// `scores` of the scene `name` against its floor: a description when it is over.
fn over_floor(name: &str, scores: &Scores, (max_badpix, max_mse): (f64, f64)) -> Option<String> {
    eprintln!(
        "{name}: BadPix0.07 {:.3} % (floor {max_badpix}), MSE×100 {:.3} (floor {max_mse})",
        scores.badpix_007, scores.mse100
    );
    (scores.badpix_007 > max_badpix || scores.mse100 > max_mse).then(|| {
        format!(
            "{name}: BadPix0.07 {:.3} > {max_badpix} or MSE×100 {:.3} > {max_mse}",
            scores.badpix_007, scores.mse100
        )
    })
}

/// Each of `floors`' scenes of the suite at 256², estimated with `params` and scored:
/// the scenes over their floor, described.
fn over_floors(params: Params, floors: &[(&str, f64, f64)]) -> Vec<String> {
    floors
        .iter()
        .filter_map(|&(name, max_badpix, max_mse)| {
            let (spec, rendered) = render_scene(name, 256);
            over_floor(
                name,
                &score(&spec, &rendered, params),
                (max_badpix, max_mse),
            )
        })
        .collect()
}

/// The parameters of `--initial epi`, through the parameter table as the CLI sets them.
fn epi_start() -> Params {
    let mut params = Params::default();
    options::by_flag("--initial")
        .unwrap()
        .apply(&mut params, Value::Choice("epi"))
        .unwrap();
    assert!(!params.sweep.enabled && !params.fused);
    params
}

#[test]
fn default_pipeline_holds_its_accuracy_and_beats_the_epi_start_on_the_512_suite() {
    let names: Vec<_> = REALISTIC_SUITE.iter().map(|e| e.kind.name()).collect();
    let floors: Vec<_> = FLOORS_512.iter().map(|f| f.0).collect();
    assert_eq!(names, floors);
    let mut failures = Vec::new();
    let (mut default_sum, mut epi_sum) = (0.0, 0.0);
    for &(name, max_badpix, max_mse) in &FLOORS_512 {
        let (spec, rendered) = render_scene(name, 512);
        let default = score(&spec, &rendered, Params::default());
        let epi = score(&spec, &rendered, epi_start());
        eprintln!(
            "{name} from the EPI start: BadPix0.07 {:.3} %, MSE×100 {:.3}",
            epi.badpix_007, epi.mse100
        );
        failures.extend(over_floor(name, &default, (max_badpix, max_mse)));
        if default.badpix_007 > epi.badpix_007 {
            failures.push(format!(
                "{name}: BadPix0.07 {:.3} is worse than the EPI start's {:.3}",
                default.badpix_007, epi.badpix_007
            ));
        }
        default_sum += default.badpix_007;
        epi_sum += epi.badpix_007;
    }
    let scenes = FLOORS_512.len() as f64;
    let (default_mean, epi_mean) = (default_sum / scenes, epi_sum / scenes);
    eprintln!(
        "mean BadPix0.07 {default_mean:.3} % against the EPI start's {epi_mean:.3} % ({:.1} % lower)",
        100.0 * (1.0 - default_mean / epi_mean)
    );
    if default_mean > 0.6 * epi_mean {
        failures.push(format!(
            "mean BadPix0.07 {default_mean:.3} is not 40 % below the EPI start's {epi_mean:.3}"
        ));
    }
    assert!(failures.is_empty(), "{failures:#?}");
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
