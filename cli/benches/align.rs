//! Criterion benchmarks of the align stage on a 9×9×512×512 RGB synthetic array
//! (`lfdepth::synth`, scene `mixed`) with per-view misalignment (2°, 3 px, 1 %,
//! perspective 0.002), single thread: `estimate` (auto on the rectified array, on with
//! each model and corner count), the CLI's parallel estimate (wall time, 1 and 2
//! threads) and the warp of the views the stages read.
//!
//! The times are the thread's on-CPU time (Linux `schedstat`), not wall time: the
//! development machine is shared and overloaded, and wall time there says little about
//! the code. Elsewhere (no schedstat) they fall back to wall time.
//! `cargo bench -p lfdepth-cli --bench align -- --warm-up-time 1 --measurement-time 4`

use std::ops::ControlFlow;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use lfdepth::align::{self, AlignMode, AlignModel, AlignParams, AlignedViews, Interpolation};
use lfdepth::pipeline::{self, Stages};
use lfdepth::synth::{self, Misalignment, SceneKind, SynthSpec};
use lfdepth::{Grid, Homography, LightField, Params, Plan};
use lfdepth_cli::engine::ParallelViews;

/// Time this thread has spent on a CPU (`None` without Linux `schedstat`).
fn thread_cpu() -> Option<Duration> {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse().ok())
        .map(Duration::from_nanos)
}

/// Runs `work` `iters` times and returns its on-CPU time (wall time without schedstat).
fn on_cpu(iters: u64, mut work: impl FnMut()) -> Duration {
    let (wall, cpu) = (Instant::now(), thread_cpu());
    for _ in 0..iters {
        work();
    }
    match (cpu, thread_cpu()) {
        (Some(a), Some(b)) => b - a,
        _ => wall.elapsed(),
    }
}

fn render(misalign: bool) -> (Vec<u8>, SynthSpec, Vec<Homography>) {
    let mut spec = SynthSpec::new(SceneKind::Mixed, Grid::new(9, 9), 512, 512);
    spec.supersample = 1;
    if misalign {
        spec.misalign = Some(Misalignment {
            max_rotation_deg: 2.0,
            max_translation_px: 3.0,
            max_scale: 0.01,
            max_perspective: 0.002,
        });
    }
    let mut views = vec![0u8; spec.layout().validate().unwrap()];
    let mut gt = vec![0.0f32; 512 * 512];
    let mut hs = vec![Homography::IDENTITY; 81];
    synth::render(&spec, &mut views, &mut gt, &mut hs).unwrap();
    (views, spec, hs)
}

fn bench(c: &mut Criterion) {
    let (misaligned, spec, truth) = render(true);
    let (rectified, _, _) = render(false);
    let layout = spec.layout();
    let mut group = c.benchmark_group("align");
    group.sample_size(10);
    let on = AlignParams {
        mode: AlignMode::On,
        ..AlignParams::default()
    };
    let cases = [
        (
            "estimate_auto_rectified_9x9x512",
            &rectified,
            AlignParams::default(),
        ),
        ("estimate_on_per_view_9x9x512", &misaligned, on),
        (
            "estimate_on_per_view_128_corners_9x9x512",
            &misaligned,
            AlignParams {
                features: 128,
                ..on
            },
        ),
        (
            "estimate_on_per_view_cross_only_9x9x512",
            &misaligned,
            AlignParams {
                views: AlignedViews::Cross,
                ..on
            },
        ),
        (
            "estimate_on_per_view_cross_only_128_corners_9x9x512",
            &misaligned,
            AlignParams {
                views: AlignedViews::Cross,
                features: 128,
                ..on
            },
        ),
        (
            "estimate_on_plane_patches_9x9x512",
            &misaligned,
            AlignParams {
                model: AlignModel::PlanePatches,
                ..on
            },
        ),
    ];
    for (name, data, params) in cases {
        let lf = LightField::new(&data[..], layout).unwrap();
        let mut hs = vec![Homography::IDENTITY; 81];
        let mut scratch = vec![0.0f32; align::scratch_len(&layout, &params).unwrap()];
        group.bench_function(name, |b| {
            b.iter_custom(|iters| {
                on_cpu(iters, || {
                    align::estimate(&lf, &params, &mut hs, &mut scratch).unwrap();
                })
            })
        });
    }
    // The CLI's estimate: per-view tracking over a rayon pool (wall time: the work is
    // spread over threads; on a shared machine it shows the scaling only roughly).
    let lf = LightField::new(&misaligned[..], layout).unwrap();
    for (views, label) in [(AlignedViews::All, "all"), (AlignedViews::Cross, "cross")] {
        for threads in [1, 2] {
            let params = AlignParams { views, ..on };
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut hs = vec![Homography::IDENTITY; 81];
            let mut scratch = vec![0.0f32; align::scratch_len(&layout, &params).unwrap()];
            let name =
                format!("estimate_on_per_view_{label}_parallel_views_{threads}_threads_wall");
            group.bench_function(&name, |b| {
                b.iter(|| {
                    pool.install(|| {
                        align::estimate_with(
                            &lf,
                            &params,
                            &mut hs,
                            &mut scratch,
                            &mut ParallelViews,
                        )
                        .unwrap()
                    })
                })
            });
        }
    }
    for (name, interpolation) in [
        (
            "warp_cross_17_views_f32_catmull_rom",
            Interpolation::CatmullRom,
        ),
        ("warp_cross_17_views_f32_bilinear", Interpolation::Bilinear),
        (
            "warp_cross_17_views_f32_sharpened_bilinear",
            Interpolation::SharpenedBilinear,
        ),
    ] {
        let mut params = Params::default();
        params.align.interpolation = interpolation;
        let plan = Plan::new(layout, params).unwrap();
        let mut out = vec![0.0f32; pipeline::aligned_len(&plan).unwrap()];
        group.bench_function(name, |b| {
            b.iter_custom(|iters| {
                on_cpu(iters, || {
                    pipeline::warp_views(&plan, &lf, Stages::Epi, &truth, &mut out, &mut |_| {
                        ControlFlow::Continue(())
                    })
                    .unwrap();
                })
            })
        });
    }
    let mut band = vec![0u8; 81 * 32 * 512 * 3];
    group.bench_function("warp_all_81_views_u8_bilinear_32_row_bands", |b| {
        b.iter_custom(|iters| {
            on_cpu(iters, || {
                for y in (0..512).step_by(32) {
                    align::warp_band(&lf, &truth, y..y + 32, &mut band).unwrap();
                }
            })
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
