//! What the alignment tests and examples share: synthetic arrays rendered rectified and
//! misaligned, the HCI scenes' views, and what is measured on them (the EPI stage,
//! BadPix0.07, every view warped, the alignment estimate, the engine on aligned views).
#![allow(dead_code)]

use std::path::PathBuf;

use lfdepth::align::{self, warp_rows_with, AlignParams, Interpolation};
use lfdepth::metrics::{self, EvalOptions, BORDER};
use lfdepth::synth::{self, Misalignment, SceneKind, SynthSpec};
use lfdepth::{Grid, Homography, Layout, LightField, Params, Sample};
use lfdepth_cli::engine::{self, EstimateOptions, Stages};
use lfdepth_cli::io::scene::{self, LoadOptions, Views};

pub fn epi<S: Sample + Sync>(data: &[S], spec: &SynthSpec) -> Vec<f32> {
    let lf = LightField::new(data, spec.layout()).unwrap();
    let options = EstimateOptions {
        params: Params {
            sweep: lfdepth::planesweep::PlaneSweepParams::off(),
            ..Params::default()
        },
        stage: Stages::Epi,
        threads: None,
    };
    engine::estimate(&lf, &options, &mut |_, _, _| {})
        .unwrap()
        .disparity
}

/// BadPix0.07 (%) of `est` against `gt`, both `n`×`n`, with the benchmark's border.
pub fn badpix(est: &[f32], gt: &[f32], n: usize) -> f64 {
    let mut scratch = vec![0.0f32; metrics::scratch_len(n, n)];
    let options = EvalOptions {
        border: BORDER,
        mask: None,
    };
    metrics::evaluate(est, gt, n, n, &options, &mut scratch)
        .unwrap()
        .badpix_007
}

/// Every view of `lf` warped by `hs` into `f32` (the pipeline warps only the views the
/// stages read; the EPI stage reads only those).
pub fn warp_all(lf: &LightField<'_, u8>, hs: &[Homography], how: Interpolation) -> Vec<f32> {
    let l = lf.layout();
    let view = l.width * l.height * l.channels;
    let mut out = vec![0.0f32; l.validate().unwrap()];
    for (v, chunk) in out.chunks_exact_mut(view).enumerate() {
        warp_rows_with(lf, hs, v, 0..l.height, how, chunk).unwrap();
        align::finish_view(l, hs, v, how, chunk).unwrap();
    }
    out
}

/// The scene rendered rectified and misaligned: (rectified views, misaligned views,
/// ground truth, true homographies).
pub fn scenes(
    scene: SceneKind,
    n: usize,
) -> (SynthSpec, Vec<u8>, Vec<u8>, Vec<f32>, Vec<Homography>) {
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

pub fn estimate(lf: &LightField<'_, u8>, params: AlignParams) -> (Vec<Homography>, f32) {
    let mut est = vec![Homography::IDENTITY; lf.grid().len()];
    let mut scratch = vec![0.0f32; align::scratch_len(lf.layout(), &params).unwrap()];
    let report = align::estimate(lf, &params, &mut est, &mut scratch).unwrap();
    eprintln!(
        "  estimate {:?}/{:?}: disparity shift {:+.4} px, coherence {:.3}",
        params.views, params.disparity_step, report.disparity_shift, report.disparity_coherence
    );
    (est, report.rms)
}

/// The disparity map `engine::estimate` gives for the views `data` of `spec` with
/// `params`, run as far as `stage`.
pub fn engine_map<S: Sample + Sync>(
    data: &[S],
    spec: &SynthSpec,
    params: Params,
    stage: Stages,
) -> Vec<f32> {
    let lf = LightField::new(data, spec.layout()).unwrap();
    let options = EstimateOptions {
        params,
        stage,
        threads: None,
    };
    engine::estimate(&lf, &options, &mut |_, _, _| {})
        .unwrap()
        .disparity
}

/// `../shared/data` beside the repository.
pub fn data_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data"))
}

/// The 8-bit views of `../shared/data/<path>` and their layout, or `None` (with a loud
/// SKIPPED line) when they are missing.
pub fn load(path: &str) -> Option<(Vec<u8>, Layout)> {
    let loaded = scene::load(&data_dir().join(path), &LoadOptions::default());
    match loaded {
        Ok(scene::Scene {
            views: Views::U8(data),
            layout,
            ..
        }) => Some((data, layout)),
        Ok(_) => {
            eprintln!("SKIPPED: {path} has 16-bit views; this test reads 8-bit ones");
            None
        }
        Err(e) => {
            eprintln!("SKIPPED: ../shared/data not found: {path}: {e}");
            None
        }
    }
}

/// The alignment estimate of the views `data` with `params`: its report and homographies.
pub fn align_views(
    data: &[u8],
    layout: Layout,
    params: &AlignParams,
) -> (align::AlignReport, Vec<Homography>) {
    let lf = LightField::new(data, layout).unwrap();
    let mut hs = vec![Homography::IDENTITY; layout.grid.len()];
    let mut scratch = vec![0.0f32; align::scratch_len(&layout, params).unwrap()];
    let report = align::estimate(&lf, params, &mut hs, &mut scratch)
        .unwrap_or_else(|e| panic!("{params:?}: {e}"));
    (report, hs)
}
