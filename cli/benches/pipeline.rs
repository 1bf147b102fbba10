//! Criterion benchmarks of the whole pipeline (engine, `Stages::Full`) on a
//! 9×9×512×512 light field: HCI cotton when `../shared/data` is present, else a synthetic
//! Mixed scene; 1 and 2 threads; the default pipeline (plane sweep → refine → refill →
//! median → TV), the `fast` preset, the refinement without propagation, and the paper's
//! pipeline (EPI → TV). Group `scalar`: the default
//! pipeline computing in `f32` and in Q16.16 fixed point, one thread, on a smaller
//! synthetic scene (9×9×192×192 Mixed) so that the Q16.16 case stays under two minutes.

#[path = "../tests/tv_support.rs"]
mod tv_support;

use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use lfdepth::plan::Preset;
use lfdepth::refine::RefineParams;
use lfdepth::synth::{self, SceneKind, SynthSpec};
use lfdepth::{Grid, Homography, LightField, Params};
use lfdepth_cli::engine::{estimate, estimate_with, EstimateOptions, Precision, Stages};

fn pipeline(c: &mut Criterion) {
    let (views, layout, name) = tv_support::bench_scene();
    let lf = LightField::new(&views, layout).unwrap();
    let mut group = c.benchmark_group("pipeline");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(20))
        .warm_up_time(Duration::from_secs(2));
    let variants = [
        ("default", Params::default()),
        ("fast", Params::preset(Preset::Fast)),
        (
            "no_propagation",
            Params {
                refine: RefineParams {
                    propagation: 0,
                    ..RefineParams::default()
                },
                ..Params::default()
            },
        ),
        (
            "paper",
            Params {
                refine: RefineParams::off(),
                ..Params::default()
            },
        ),
    ];
    for threads in [1, 2] {
        for (variant, params) in variants {
            let options = EstimateOptions {
                params,
                stage: Stages::Full,
                threads: Some(threads),
            };
            group.bench_function(format!("{name}_{variant}_{threads}t"), |b| {
                b.iter(|| estimate(&lf, &options, &mut |_, _, _| {}).unwrap())
            });
        }
    }
    group.finish();
}

/// The default pipeline in `f32` and in Q16.16 (ids `scalar/mixed192_{f32,q16}_1t`).
fn scalar(c: &mut Criterion) {
    let size = 192;
    let spec = SynthSpec::new(SceneKind::Mixed, Grid::new(9, 9), size, size);
    let layout = spec.layout();
    let mut views = vec![0u8; layout.validate().unwrap()];
    let mut gt = vec![0.0f32; size * size];
    let mut homographies = vec![Homography::IDENTITY; 81];
    synth::render(&spec, &mut views, &mut gt, &mut homographies).unwrap();
    let lf = LightField::new(&views, layout).unwrap();
    let mut group = c.benchmark_group("scalar");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(15))
        .warm_up_time(Duration::from_secs(2));
    let options = EstimateOptions {
        params: Params::default(),
        stage: Stages::Full,
        threads: Some(1),
    };
    for (name, precision) in [("f32", Precision::F32), ("q16", Precision::Q16)] {
        group.bench_function(format!("mixed{size}_{name}_1t"), |b| {
            b.iter(|| estimate_with(&lf, &options, precision, &mut |_, _, _| {}).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, pipeline, scalar);
criterion_main!(benches);
