//! Criterion benchmarks of the TV stage on a 512×512 synthetic scene (single thread):
//! the default refinement (stopping rule on), a fixed number of iterations (the
//! per-iteration cost), and the Q16.16 instantiation.

use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use lfdepth::synth::{self, SceneKind, SynthSpec};
use lfdepth::tv::{self, Guide, Maps, TvParams};
use lfdepth::{Grid, Layout, LightField, Params, Plan, Scalar, Q16};

struct Inputs {
    views: Vec<u8>,
    plan_layout: Layout,
    disparity: Vec<f32>,
    confidence: Vec<f32>,
}

/// A 512×512 Mixed scene: ground truth with noise and 3 % low-confidence outliers as the
/// EPI input, the rendered centre view as the guide (in a 3×3 grid of copies).
fn inputs() -> Inputs {
    let (w, h) = (512, 512);
    let spec = SynthSpec::new(SceneKind::Mixed, Grid::new(3, 3), w, h);
    let mut image = vec![0u8; w * h * 3];
    synth::render_view(&spec, 1, 1, &mut image).unwrap();
    let mut gt = vec![0.0f32; w * h];
    synth::render_ground_truth(&spec, &mut gt).unwrap();
    let mut s = 0x2545_F491_4F6C_DD1Du64;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    let (mut disparity, mut confidence) = (Vec::new(), Vec::new());
    for &g in &gt {
        if next() < 0.03 {
            disparity.push(g + (next() - 0.5) * 2.0);
            confidence.push(0.2 * next());
        } else {
            disparity.push(g + (next() - 0.5) * 0.1);
            confidence.push(0.7 + 0.3 * next());
        }
    }
    let views: Vec<u8> = (0..9).flat_map(|_| image.iter().copied()).collect();
    Inputs {
        views,
        plan_layout: Layout::packed(Grid::new(3, 3), w, h, 3),
        disparity,
        confidence,
    }
}

fn run<S: Scalar>(inputs: &Inputs, params: TvParams, scratch: &mut [S]) -> tv::RefineReport {
    let plan = Plan::new(
        inputs.plan_layout,
        Params {
            tv: params,
            ..Params::default()
        },
    )
    .unwrap();
    let lf = LightField::new(&inputs.views, *plan.layout()).unwrap();
    let (w, h) = (plan.layout().width, plan.layout().height);
    let maps = Maps::new(w, h, &inputs.disparity, &inputs.confidence).unwrap();
    let guide = Guide::View(lf.center_view());
    let mut out = vec![0.0f32; w * h];
    let mut history = vec![0.0f32; params.max_iterations];
    tv::refine(
        plan.tv(),
        &maps,
        &guide,
        &mut out,
        &mut history,
        tv::TvScratch {
            kernel: scratch,
            duals: &mut vec![0.0; tv::dual_len(plan.tv())],
        },
    )
    .unwrap()
}

fn scratch_for<S: Scalar>(inputs: &Inputs, params: TvParams) -> Vec<S> {
    let plan = Plan::new(
        inputs.plan_layout,
        Params {
            tv: params,
            ..Params::default()
        },
    )
    .unwrap();
    vec![S::ZERO; tv::scratch_len(plan.tv())]
}

fn bench(c: &mut Criterion) {
    let inputs = inputs();
    let mut group = c.benchmark_group("tv");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(20));

    let default = TvParams::default();
    let mut scratch = scratch_for::<f32>(&inputs, default);
    let report = run(&inputs, default, &mut scratch);
    eprintln!(
        "tv/refine_512_default: {} tile-iterations over {} tiles of {} + {}",
        report.total_iterations, report.tiles, default.tile, default.halo
    );
    group.bench_function("refine_512_default_f32", |b| {
        b.iter(|| run(&inputs, default, &mut scratch))
    });

    let fixed = TvParams {
        max_iterations: 50,
        tolerance: 0.0,
        ..default
    };
    group.bench_function("refine_512_50_iterations_f32", |b| {
        b.iter(|| run(&inputs, fixed, &mut scratch))
    });

    let mut scratch_q = scratch_for::<Q16>(&inputs, fixed);
    group.bench_function("refine_512_50_iterations_q16", |b| {
        b.iter(|| run(&inputs, fixed, &mut scratch_q))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
