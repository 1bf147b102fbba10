//! Criterion benchmark of the edge-snapping weighted median (`median/…`): the default
//! stage (four passes, radius 7, planar votes) on one thread over the disparity it really
//! filters, the default pipeline's (plane sweep, photometric refinement, geodesic refill:
//! `support/stage_inputs.rs`), of HCI cotton when `../shared/data` is
//! present, else of a synthetic 9×9×512×512 Mixed scene; passes after the first as the
//! engine runs them (`filter_pass`, remembering settled pixels) and in full (`filter`).
//! The reported times are the benchmark thread's CPU time (`/proc/thread-self/schedstat`),
//! not wall time: the machine is shared, and waiting for a core is no cost of the median.

#[path = "support/stage_inputs.rs"]
mod stage_inputs;
#[path = "../tests/tv_support.rs"]
mod tv_support;

use std::time::{Duration, Instant};

use criterion::measurement::WallTime;
use criterion::{criterion_group, criterion_main, BenchmarkGroup, Criterion};
use lfdepth::median::{self, MedianParams};
use lfdepth::{LightField, Params, Plan};

/// Every pass as the engine runs them: each pass after the first knows the one before's
/// input (`a`) and which pixels it settled (`settled`), its own input (`b`) is that
/// pass's output, its output goes to `next`. `maps` are three maps of the input's size,
/// overwritten.
fn engine_passes(
    plan: &Plan,
    lf: &LightField<'_, u8>,
    input: &[f32],
    maps: &mut [Vec<f32>; 3],
    settled: &mut [u8],
    scratch: &mut [f32],
) {
    let guide = lf.center_view();
    let height = plan.layout().height;
    let [a, b, next] = maps;
    median::filter_pass(
        plan.median(),
        median::PassInput {
            guide: &guide,
            input,
            previous: None,
        },
        0..height,
        b,
        settled,
        scratch,
    )
    .unwrap();
    a.copy_from_slice(input);
    for _ in 1..plan.params().median.passes {
        median::filter_pass(
            plan.median(),
            median::PassInput {
                guide: &guide,
                input: b,
                previous: Some(a),
            },
            0..height,
            next,
            settled,
            scratch,
        )
        .unwrap();
        std::mem::swap(a, b);
        std::mem::swap(b, next);
    }
}

/// The bench group both scenes report into.
fn median_group(c: &mut Criterion) -> BenchmarkGroup<'_, WallTime> {
    let mut group = c.benchmark_group("median");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(10))
        .warm_up_time(Duration::from_secs(1));
    group
}

/// `{scene}_{passes}passes_1t`: the engine's passes on `input`, thread CPU time.
fn bench_engine_passes(
    group: &mut BenchmarkGroup<'_, WallTime>,
    scene: &str,
    plan: &Plan,
    lf: &LightField<'_, u8>,
    input: &[f32],
) {
    let passes = plan.params().median.passes;
    let mut scratch = vec![0.0f32; median::scratch_len(plan.median())];
    let mut maps = [input.to_vec(), input.to_vec(), input.to_vec()];
    let mut settled = vec![0u8; plan.pixels()];
    stage_inputs::bench_thread_cpu(group, format!("{scene}_{passes}passes_1t"), || {
        engine_passes(plan, lf, input, &mut maps, &mut settled, &mut scratch);
    });
}

fn median_stage(c: &mut Criterion) {
    let (views, layout, name) = tv_support::bench_scene();
    let lf = LightField::new(&views, layout).unwrap();
    let plan = Plan::new(layout, Params::default()).unwrap();
    let start = Instant::now();
    let input = stage_inputs::before_median(&lf, &plan).median_input;
    eprintln!(
        "median input (plane sweep, refinement, refill) in {:.1?}",
        start.elapsed()
    );
    let passes = MedianParams::default().passes;
    let guide = lf.center_view();
    let mut scratch = vec![0.0f32; median::scratch_len(plan.median())];
    let (mut a, mut b) = (input.clone(), input.clone());
    let mut group = median_group(c);
    bench_engine_passes(&mut group, name, &plan, &lf, &input);
    // As the serial core pipeline and the page's workers run it: every pass in full.
    stage_inputs::bench_thread_cpu(&mut group, format!("{name}_{passes}passes_full_1t"), || {
        a.copy_from_slice(&input);
        for _ in 0..passes {
            median::filter(plan.median(), &guide, &a, &mut b, &mut scratch).unwrap();
            std::mem::swap(&mut a, &mut b);
        }
    });
    group.finish();
}

/// The engine's passes on HCI backgammon (many strong colour edges: most votes across
/// them weigh zero), when `../shared/data` is present.
fn median_backgammon(c: &mut Criterion) {
    let dir = std::path::PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/data/hci/stratified/backgammon"
    ));
    if !dir.is_dir() {
        eprintln!("SKIPPED: ../shared/data not found: no median/backgammon bench");
        return;
    }
    let (views, layout) = tv_support::load_hci(&dir);
    let lf = LightField::new(&views, layout).unwrap();
    let plan = Plan::new(layout, Params::default()).unwrap();
    let input = stage_inputs::before_median(&lf, &plan).median_input;
    let mut group = median_group(c);
    bench_engine_passes(&mut group, "backgammon", &plan, &lf, &input);
    group.finish();
}

criterion_group!(benches, median_stage, median_backgammon);
criterion_main!(benches);
