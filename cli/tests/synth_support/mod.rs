//! Synthetic scenes for the whole-pipeline tests (`pipeline_synth.rs`, `geofill.rs`):
//! a noisy 9×9 render with its exact ground truth, the rayon engine on it, and its error.
#![allow(dead_code)]

use lfdepth::synth::{self, SceneKind, SynthSpec};
use lfdepth::{Grid, Homography, LightField, Params};
use lfdepth_cli::engine::{estimate, Estimate, EstimateOptions, Stages};

pub struct Scene {
    pub spec: SynthSpec,
    pub views: Vec<u8>,
    pub gt: Vec<f32>,
}

/// A 9×9 render of `kind`, `size`² pixels, 8-bit with noise σ 1 (seed 5).
pub fn scene(kind: SceneKind, size: usize) -> Scene {
    scene_seeded(kind, size, 5)
}

/// [`scene`] with the noise of `seed`.
pub fn scene_seeded(kind: SceneKind, size: usize, seed: u64) -> Scene {
    let spec = SynthSpec {
        noise_sigma: 1.0,
        seed,
        ..SynthSpec::new(kind, Grid::new(9, 9), size, size)
    };
    let layout = spec.layout();
    let mut views = vec![0u8; layout.validate().unwrap()];
    let mut gt = vec![0.0f32; size * size];
    let mut homographies = vec![Homography::IDENTITY; 81];
    synth::render(&spec, &mut views, &mut gt, &mut homographies).unwrap();
    Scene { spec, views, gt }
}

/// The rayon engine on `s`.
pub fn run(s: &Scene, params: Params, stage: Stages, threads: usize) -> Estimate {
    let lf = LightField::new(&s.views, s.spec.layout()).unwrap();
    let options = EstimateOptions {
        params,
        stage,
        threads: Some(threads),
    };
    estimate(&lf, &options, &mut |_, _, _| {}).unwrap()
}

/// (Share of pixels off by more than 0.07 px, RMS error) inside a 6-pixel border.
pub fn errors(s: &Scene, d: &[f32]) -> (f64, f64) {
    let n = s.spec.width;
    let (mut bad, mut se, mut count) = (0usize, 0.0f64, 0usize);
    for y in 6..n - 6 {
        for x in 6..n - 6 {
            let e = (d[y * n + x] - s.gt[y * n + x]) as f64;
            bad += usize::from(e.abs() > 0.07);
            se += e * e;
            count += 1;
        }
    }
    (bad as f64 / count as f64, (se / count as f64).sqrt())
}
