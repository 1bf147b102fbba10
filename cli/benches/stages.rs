//! Criterion benchmarks of the default pipeline's stages that have no bench of their own
//! (`stages/…`), each on one thread from the map the pipeline gives it: the automatic
//! range, the plane sweep (every band in turn), the photometric refinement of the
//! sweep's map, and the refill of the refinement's. HCI cotton when `../shared/data`
//! is present, else a synthetic 9×9×512×512 Mixed scene. The EPI stage, the median and
//! TV have their own benches (`epi`, `median`, `tv`), the whole pipeline `pipeline`.
//! The reported times are the benchmark thread's CPU time, not wall time (see
//! `stage_inputs::thread_cpu`).
//! `cargo bench -p lfdepth-cli --bench stages`

#[path = "support/stage_inputs.rs"]
mod stage_inputs;
#[path = "../tests/tv_support.rs"]
mod tv_support;

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use lfdepth::{geofill, planesweep, refine, LightField, Params, Plan};

fn stages(c: &mut Criterion) {
    let (views, layout, name) = tv_support::bench_scene();
    let lf = LightField::new(&views, layout).unwrap();
    let plan = Plan::new(layout, Params::default()).unwrap();
    let start = Instant::now();
    let inputs = stage_inputs::before_median(&lf, &plan);
    eprintln!(
        "stage inputs (range {:.3}…{:.3} px) in {:.1?}",
        inputs.range.0,
        inputs.range.1,
        start.elapsed()
    );
    let n = plan.pixels();
    let mut group = c.benchmark_group("stages");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(10))
        .warm_up_time(Duration::from_secs(1));

    stage_inputs::bench_thread_cpu(&mut group, format!("{name}_range_1t"), || {
        std::hint::black_box(stage_inputs::range(&lf, &plan));
    });

    let (mut disparity, mut confidence) = (vec![0.0f32; n], vec![0.0f32; n]);
    let mut scratch = vec![0.0f32; planesweep::scratch_len(plan.sweep())];
    stage_inputs::bench_thread_cpu(&mut group, format!("{name}_sweep_1t"), || {
        stage_inputs::sweep_into(
            &lf,
            &plan,
            inputs.range,
            (&mut disparity, &mut confidence),
            &mut scratch,
        );
    });
    assert_eq!(disparity, inputs.sweep, "the sweep is deterministic");

    let mut scratch = vec![0.0f32; refine::scratch_len(plan.refine())];
    stage_inputs::bench_thread_cpu(&mut group, format!("{name}_refine_1t"), || {
        stage_inputs::refine_into(
            &lf,
            &plan,
            inputs.range,
            &inputs.sweep,
            (&mut disparity, &mut confidence),
            &mut scratch,
        );
    });
    assert_eq!(disparity, inputs.refined, "the refinement is deterministic");

    if plan.params().geofill.enabled {
        let mut scratch = vec![0.0f32; geofill::scratch_len(plan.geofill())];
        stage_inputs::bench_thread_cpu(&mut group, format!("{name}_refill_1t"), || {
            stage_inputs::refill_into(&lf, &plan, &inputs.refined, &mut disparity, &mut scratch);
        });
        assert_eq!(
            disparity, inputs.median_input,
            "the refill is deterministic"
        );
    }
    group.finish();
}

criterion_group!(benches, stages);
criterion_main!(benches);
