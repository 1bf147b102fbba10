//! The AVX2 kernels the engine picks at run time give the same bits as the baseline
//! build's: every stage (EPI, refinement, refill, median, TV, and the warp of a
//! misaligned array), in `f32` and in Q16.16, with one and two threads.

use lfdepth::align::AlignMode;
use lfdepth::synth::{self, Misalignment, SceneKind, SynthSpec};
use lfdepth::{Grid, Homography, LightField, Params};
use lfdepth_cli::engine::{
    avx2_available, estimate_with, Active, Estimate, EstimateOptions, Kernels, Precision,
    StageSelect,
};

fn size() -> usize {
    if cfg!(debug_assertions) {
        48
    } else {
        128
    }
}

fn render(kind: SceneKind, misalign: bool) -> (Vec<u8>, SynthSpec) {
    let n = size();
    let spec = SynthSpec {
        noise_sigma: 1.0,
        seed: 3,
        misalign: misalign.then_some(Misalignment {
            max_rotation_deg: 1.0,
            max_translation_px: 2.0,
            max_scale: 0.005,
            max_perspective: 0.001,
        }),
        ..SynthSpec::new(kind, Grid::new(9, 9), n, n)
    };
    let mut views = vec![0u8; spec.layout().validate().unwrap()];
    let mut gt = vec![0.0f32; n * n];
    let mut homographies = vec![Homography::IDENTITY; 81];
    synth::render(&spec, &mut views, &mut gt, &mut homographies).unwrap();
    (views, spec)
}

fn run(
    views: &[u8],
    spec: &SynthSpec,
    params: Params,
    precision: Precision,
    threads: usize,
    kernels: Kernels,
) -> Estimate {
    let lf = LightField::new(views, spec.layout()).unwrap();
    let options = EstimateOptions {
        params,
        stage: StageSelect::Full,
        threads: Some(threads),
        kernels,
    };
    estimate_with(&lf, &options, precision, &mut |_, _, _| {}).unwrap()
}

fn bits(values: &[f32]) -> Vec<u32> {
    values.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn avx2_kernels_give_the_baseline_bits() {
    if !avx2_available() {
        eprintln!(
            "NOTE: this CPU lacks AVX2 (or BMI/LZCNT/POPCNT/FMA): both runs take the \
             baseline kernels, so this test only checks that they agree"
        );
    }
    let rectified = render(SceneKind::Mixed, false);
    let misaligned = render(SceneKind::Planes, true);
    let mut aligned = Params::default();
    aligned.align.mode = AlignMode::On;
    let cases = [
        ("mixed, f32", &rectified, Params::default(), Precision::F32),
        ("mixed, Q16", &rectified, Params::default(), Precision::Q16),
        (
            "misaligned planes, align on",
            &misaligned,
            aligned,
            Precision::F32,
        ),
    ];
    for (name, (views, spec), params, precision) in cases {
        let baseline = run(views, spec, params, precision, 1, Kernels::Baseline);
        assert_eq!(baseline.kernels, Some(Active::Baseline));
        for threads in [1, 2] {
            let auto = run(views, spec, params, precision, threads, Kernels::Auto);
            let expected = if avx2_available() {
                Active::Avx2
            } else {
                Active::Baseline
            };
            assert_eq!(auto.kernels, Some(expected), "{name}");
            assert_eq!(
                bits(&auto.disparity),
                bits(&baseline.disparity),
                "{name}, {threads} threads: the disparity differs between the kernels"
            );
            assert_eq!(
                bits(&auto.confidence),
                bits(&baseline.confidence),
                "{name}, {threads} threads: the confidence differs between the kernels"
            );
            assert_eq!(
                bits(&auto.residuals),
                bits(&baseline.residuals),
                "{name}, {threads} threads: TV's residual history differs"
            );
        }
    }
}
