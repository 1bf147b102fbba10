//! Q16.16 against `f32`: the refinement alone and the whole default pipeline
//! (EPI → refinement → TV) on small synthetic scenes.

extern crate std;
use std::vec;
use std::vec::Vec;

use core::ops::ControlFlow;

use crate::lightfield::{Grid, LightField};
use crate::pipeline::{self, Stages};
use crate::plan::{Params, Plan};
use crate::refine::{refine, scratch_len, RefineParams};
use crate::scalar::{Scalar, Q16};
use crate::setup::DisparityOut;
use crate::synth::{self, SceneKind, SynthSpec};
use crate::Homography;

struct Rendered {
    spec: SynthSpec,
    views: Vec<u8>,
}

fn render(scene: SceneKind, size: usize, seed: u64) -> Rendered {
    let mut spec = SynthSpec::new(scene, Grid::new(9, 9), size, size);
    spec.seed = seed;
    spec.supersample = 2;
    let layout = spec.layout();
    let mut views = vec![0u8; layout.validate().unwrap()];
    let mut gt = vec![0.0f32; size * size];
    let mut homographies = vec![Homography::IDENTITY; 81];
    synth::render(&spec, &mut views, &mut gt, &mut homographies).unwrap();
    Rendered { spec, views }
}

/// The full pipeline computing in `T`.
fn full<T: Scalar>(scene: &Rendered, params: Params) -> Vec<f32> {
    let plan = Plan::new(scene.spec.layout(), params).unwrap();
    let lf = LightField::new(&scene.views, scene.spec.layout()).unwrap();
    let mut d = vec![0.0f32; plan.pixels()];
    let mut c = vec![0.0f32; plan.pixels()];
    let mut scratch = vec![T::ZERO; pipeline::scratch_len(&plan)];
    let mut maps = vec![0.0f32; pipeline::map_scratch_len(&plan)];
    pipeline::run(
        &plan,
        &lf,
        Stages::Full,
        pipeline::RunOutput {
            disparity: &mut d,
            confidence: &mut c,
            history: &mut [],
        },
        pipeline::RunScratch {
            kernel: &mut scratch,
            maps: &mut maps,
        },
        &mut |_| ControlFlow::Continue(()),
    )
    .unwrap();
    d
}

/// Share of pixels within `tol` px of each other, and the largest difference.
fn agreement(a: &[f32], b: &[f32], tol: f32) -> (f32, f32) {
    let within = a
        .iter()
        .zip(b)
        .filter(|(x, y)| (*x - *y).abs() <= tol)
        .count();
    let max = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    (within as f32 / a.len() as f32, max)
}

#[test]
fn q16_pipeline_stays_within_two_hundredths_of_f32_on_synthetic_scenes() {
    // Low-texture at 64²: at 32² its one textured patch and the borders leave too few
    // pixels where the views carry information (measured 98.2 % at 32², 99.2 % at 64²,
    // 99.5 % at 256²; see docs/stages/fixed-point.md).
    for (scene, size, seed) in [
        (SceneKind::Planes, 32, 1),
        (SceneKind::Slanted, 32, 2),
        (SceneKind::Spheres, 32, 3),
        (SceneKind::Occlusion, 32, 4),
        (SceneKind::Thin, 32, 5),
        (SceneKind::Mixed, 32, 6),
        (SceneKind::LowTexture, 64, 7),
    ] {
        let rendered = render(scene, size, seed);
        // EPI → refine → TV against the 99 % goal, and the default pipeline with the
        // (f32) weighted median, which spreads the few differing pixels over its windows.
        // Measured (docs/stages/refine.md): without the median 99.93–100 %, with it
        // 99.56–100 % (97.97–100 % without scaling the propagation costs and the
        // statistics up in Q16).
        let no_median = Params {
            median: crate::median::MedianParams::off(),
            ..Params::default()
        };
        for (params, bound) in [(no_median, 0.995), (Params::default(), 0.99)] {
            let reference = full::<f32>(&rendered, params);
            let fixed = full::<Q16>(&rendered, params);
            let (share, max) = agreement(&reference, &fixed, 0.02);
            std::eprintln!(
                "{} (median {}): {:.2} % within 0.02 px, max {max:.4} px",
                scene.name(),
                params.median.enabled,
                100.0 * share
            );
            assert!(
                share >= bound,
                "{} (median {}): {share} within 0.02 px (max {max})",
                scene.name(),
                params.median.enabled
            );
        }
    }
}

#[test]
fn q16_refinement_stays_within_two_hundredths_of_f32_from_the_same_input() {
    for (i, scene) in SceneKind::ALL.into_iter().enumerate() {
        let rendered = render(scene, 32, 10 + i as u64);
        let plan = Plan::new(rendered.spec.layout(), Params::default()).unwrap();
        let lf = LightField::new(&rendered.views, rendered.spec.layout()).unwrap();
        let pixels = plan.pixels();
        let (mut d, mut c) = (vec![0.0f32; pixels], vec![0.0f32; pixels]);
        let mut scratch = vec![0.0f32; pipeline::scratch_len(&plan)];
        let hyps = crate::epi::estimate(plan.epi(), &lf, &mut d, &mut c, &mut scratch).unwrap();
        let range = (hyps.min(), hyps.max());
        let (mut df, mut cf) = (vec![0.0f32; pixels], vec![0.0f32; pixels]);
        refine(
            plan.refine(),
            &lf,
            range,
            &d,
            DisparityOut {
                disparity: &mut df,
                confidence: &mut cf,
            },
            &mut scratch,
        )
        .unwrap();
        let mut fixed_scratch = vec![Q16::ZERO; scratch_len(plan.refine())];
        let (mut dq, mut cq) = (vec![0.0f32; pixels], vec![0.0f32; pixels]);
        refine(
            plan.refine(),
            &lf,
            range,
            &d,
            DisparityOut {
                disparity: &mut dq,
                confidence: &mut cq,
            },
            &mut fixed_scratch,
        )
        .unwrap();
        let (share, max) = agreement(&df, &dq, 0.02);
        let (confidence_share, _) = agreement(&cf, &cq, 0.02);
        std::eprintln!(
            "{}: refinement {:.2} % within 0.02 px (max {max:.4}), confidence {:.2} %",
            scene.name(),
            100.0 * share,
            100.0 * confidence_share
        );
        // Measured 100 % on every scene (docs/stages/refine.md).
        assert!(share >= 0.995, "{}: {share} (max {max})", scene.name());
        assert!(
            confidence_share >= 0.99,
            "{}: confidence {confidence_share}",
            scene.name()
        );
        assert!(dq.iter().all(|v| (range.0..=range.1).contains(v)));
    }
}

#[test]
fn q16_refinement_is_bit_identical_for_any_banding() {
    let rendered = render(SceneKind::Occlusion, 32, 3);
    let run = |band_rows: usize| {
        let params = Params {
            refine: RefineParams {
                band_rows,
                ..RefineParams::default()
            },
            ..Params::default()
        };
        full::<Q16>(&rendered, params)
    };
    let reference = run(128);
    for band_rows in [1, 7, 16] {
        assert_eq!(run(band_rows), reference, "band_rows {band_rows}");
    }
}
