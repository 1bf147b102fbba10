//! Criterion benchmarks of the EPI stage on a 9×9×512×512 RGB synthetic scene (`Mixed`,
//! disparities −1.5…1.5 px, automatic range): the engine with 1 and 2 threads (and 1 thread
//! with the exhaustive hypothesis search, for a same-run comparison), the automatic range
//! estimate alone, and the core's serial `pipeline::estimate` in Q16.16.
//! `cargo bench -p lfdepth-cli --bench epi`

use std::ops::ControlFlow;

use criterion::{criterion_group, criterion_main, Criterion};
use lfdepth::epi::{self, Direction, EpiParams, Search};
use lfdepth::synth::{render, SceneKind, SynthSpec};
use lfdepth::{Grid, Homography, Layout, LightField, Params, Plan, Scalar, Q16};
use lfdepth_cli::engine::{estimate, EstimateOptions, Stages};

fn scene() -> (SynthSpec, Vec<u8>) {
    let spec = SynthSpec::new(SceneKind::Mixed, Grid::new(9, 9), 512, 512);
    let mut views = vec![0u8; spec.layout().validate().unwrap()];
    let mut gt = vec![0.0f32; 512 * 512];
    let mut h = vec![Homography::IDENTITY; 81];
    render(&spec, &mut views, &mut gt, &mut h).unwrap();
    (spec, views)
}

/// Scratch bytes of the serial estimate and of one engine worker (f32), per frame size.
fn report_scratch() {
    for size in [512usize, 4096] {
        let plan = Plan::new(
            Layout::packed(Grid::new(9, 9), size, size, 3),
            Params::default(),
        )
        .unwrap();
        let f32_bytes = std::mem::size_of::<f32>();
        eprintln!(
            "scratch {size}x{size}: serial {} B; engine worker horizontal {} B, vertical {} B",
            epi::scratch_len(plan.epi()) * f32_bytes,
            epi::band_scratch_len(plan.epi(), Direction::Horizontal) * f32_bytes,
            epi::band_scratch_len(plan.epi(), Direction::Vertical) * f32_bytes,
        );
    }
}

/// The default parameters with the EPI start (the default starts from the plane sweep).
fn epi_start() -> Params {
    Params {
        sweep: lfdepth::planesweep::PlaneSweepParams::off(),
        ..Params::default()
    }
}

fn bench(c: &mut Criterion) {
    report_scratch();
    let (spec, views) = scene();
    let lf = LightField::new(&views, spec.layout()).unwrap();
    let mut group = c.benchmark_group("epi");
    group.sample_size(10);
    for threads in [1usize, 2] {
        let options = EstimateOptions {
            params: epi_start(),
            stage: Stages::Epi,
            threads: Some(threads),
        };
        group.bench_function(format!("engine_9x9x512x512_{threads}_thread"), |b| {
            b.iter(|| estimate(&lf, &options, &mut |_, _, _| {}).unwrap())
        });
    }
    let exhaustive = EstimateOptions {
        params: Params {
            epi: EpiParams {
                search: Search::Exhaustive,
                ..EpiParams::default()
            },
            ..epi_start()
        },
        stage: Stages::Epi,
        threads: Some(1),
    };
    group.bench_function("engine_9x9x512x512_1_thread_exhaustive", |b| {
        b.iter(|| estimate(&lf, &exhaustive, &mut |_, _, _| {}).unwrap())
    });
    let plan = Plan::new(spec.layout(), epi_start()).unwrap();
    // The automatic range alone (`lfdepth estimate` prints it as `epi range`), f32.
    let mut range_scratch = vec![0.0f32; epi::scratch_len(plan.epi())];
    group.bench_function("range_9x9x512x512", |b| {
        b.iter(|| epi::hypotheses(plan.epi(), &lf, &mut range_scratch).unwrap())
    });
    let mut d = vec![0.0; plan.pixels()];
    let mut conf = vec![0.0; plan.pixels()];
    let mut scratch = vec![Q16::ZERO; lfdepth::pipeline::scratch_len(&plan)];
    let mut maps =
        vec![
            0.0f32;
            lfdepth::pipeline::stage_map_scratch_len(&plan, lfdepth::pipeline::Stages::Epi)
        ];
    group.bench_function("core_serial_q16_9x9x512x512", |b| {
        b.iter(|| {
            lfdepth::pipeline::estimate(
                &plan,
                &lf,
                lfdepth::setup::DisparityOut {
                    disparity: &mut d,
                    confidence: &mut conf,
                },
                lfdepth::pipeline::RunScratch {
                    kernel: &mut scratch,
                    maps: &mut maps,
                },
                &mut |_| ControlFlow::Continue(()),
            )
            .unwrap()
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
