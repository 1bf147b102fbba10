//! The maps each stage of the default pipeline reads, computed serially on one thread by
//! the core's stage functions in the pipeline's order (range → plane sweep → refinement
//! → refill), and benchmarks timed by the calling thread's CPU time: shared by the
//! per-stage benches
//! (included with `#[path]`).
#![allow(dead_code)]

use std::ops::ControlFlow;
use std::time::Duration;

use criterion::measurement::WallTime;
use criterion::BenchmarkGroup;

use lfdepth::setup::DisparityOut;
use lfdepth::{geofill, planesweep, refine, schedule, LightField, Plan};

/// CPU time of the calling thread (`/proc/thread-self/schedstat`): the machines the
/// benches run on are shared, and waiting for a core is no cost of a stage.
fn thread_cpu() -> Duration {
    let stat = std::fs::read_to_string("/proc/thread-self/schedstat").unwrap_or_default();
    let ns = stat
        .split_whitespace()
        .next()
        .and_then(|v| v.parse::<u64>().ok())
        .unwrap_or(0);
    Duration::from_nanos(ns)
}

/// Benchmark `id` of `group`, timed by the calling thread's CPU time ([`thread_cpu`]):
/// `run` once per iteration.
pub fn bench_thread_cpu(
    group: &mut BenchmarkGroup<'_, WallTime>,
    id: String,
    mut run: impl FnMut(),
) {
    group.bench_function(id, |bench| {
        bench.iter_custom(|iters| {
            let start = thread_cpu();
            for _ in 0..iters {
                run();
            }
            thread_cpu() - start
        })
    });
}

/// The disparity range the plan's hypotheses span (the schedule's first step).
pub fn range(lf: &LightField<'_, u8>, plan: &Plan) -> (f32, f32) {
    let mut scratch = vec![0.0f32; schedule::range_scratch_len(plan)];
    schedule::range(plan, lf, &mut scratch).unwrap()
}

/// The plane sweep's disparity and confidence over `range`, band by band into
/// `disparity` and `confidence` (one value per pixel each), with `scratch`
/// ([`planesweep::scratch_len`]).
pub fn sweep_into(
    lf: &LightField<'_, u8>,
    plan: &Plan,
    range: (f32, f32),
    (disparity, confidence): (&mut [f32], &mut [f32]),
    scratch: &mut [f32],
) {
    let width = plan.layout().width;
    let height = plan.layout().height;
    let rows = planesweep::BAND_ROWS;
    for band in 0..planesweep::band_count(plan.sweep()) {
        let (start, end) = (band * rows, ((band + 1) * rows).min(height));
        let span = start * width..end * width;
        planesweep::estimate_rows(
            plan.sweep(),
            range,
            lf,
            start..end,
            DisparityOut {
                disparity: &mut disparity[span.clone()],
                confidence: &mut confidence[span],
            },
            scratch,
        )
        .unwrap();
    }
}

/// The refinement of `start` over `range` into `disparity` and `confidence`, with
/// `scratch` ([`refine::scratch_len`]).
pub fn refine_into(
    lf: &LightField<'_, u8>,
    plan: &Plan,
    range: (f32, f32),
    start: &[f32],
    (disparity, confidence): (&mut [f32], &mut [f32]),
    scratch: &mut [f32],
) {
    refine::refine_with_progress(
        plan.refine(),
        lf,
        range,
        start,
        DisparityOut {
            disparity,
            confidence,
        },
        scratch,
        &mut |_| ControlFlow::Continue(()),
    )
    .unwrap();
}

/// The refill of `input` into `out`, with `scratch` ([`geofill::scratch_len`]).
pub fn refill_into(
    lf: &LightField<'_, u8>,
    plan: &Plan,
    input: &[f32],
    out: &mut [f32],
    scratch: &mut [f32],
) {
    geofill::fill(plan.geofill(), &lf.center_view(), input, out, scratch).unwrap();
}

/// Every map the default pipeline computes before its median: the range, the plane
/// sweep's disparity, the refinement's, and the median's input (the refill's output
/// when the plan enables it, else the refinement's).
pub struct BeforeMedian {
    pub range: (f32, f32),
    pub sweep: Vec<f32>,
    pub refined: Vec<f32>,
    pub median_input: Vec<f32>,
}

/// [`BeforeMedian`] of `lf` under `plan` (which must start from the plane sweep).
pub fn before_median(lf: &LightField<'_, u8>, plan: &Plan) -> BeforeMedian {
    assert!(
        plan.params().sweep.enabled,
        "the stage inputs follow the default pipeline, which starts from the plane sweep"
    );
    let n = plan.pixels();
    let range = range(lf, plan);
    let (mut sweep, mut sweep_confidence) = (vec![0.0f32; n], vec![0.0f32; n]);
    let mut scratch = vec![0.0f32; planesweep::scratch_len(plan.sweep())];
    sweep_into(
        lf,
        plan,
        range,
        (&mut sweep, &mut sweep_confidence),
        &mut scratch,
    );
    let (mut refined, mut confidence) = (vec![0.0f32; n], vec![0.0f32; n]);
    let mut scratch = vec![0.0f32; refine::scratch_len(plan.refine())];
    refine_into(
        lf,
        plan,
        range,
        &sweep,
        (&mut refined, &mut confidence),
        &mut scratch,
    );
    let median_input = if plan.params().geofill.enabled {
        let mut filled = vec![0.0f32; n];
        let mut scratch = vec![0.0f32; geofill::scratch_len(plan.geofill())];
        refill_into(lf, plan, &refined, &mut filled, &mut scratch);
        filled
    } else {
        refined.clone()
    };
    BeforeMedian {
        range,
        sweep,
        refined,
        median_input,
    }
}
