//! Criterion benchmarks of the align stage on a 9×9×512×512 gray synthetic array with
//! per-view misalignment (2°, 3 px, 1 %, perspective), single thread:
//! `estimate` (auto on a rectified array, on with each model) and the banded warp.

#[path = "../tests/align_scene/mod.rs"]
mod align_scene;

use criterion::{criterion_group, criterion_main, Criterion};
use lfdepth::align::{self, AlignMode, AlignModel, AlignParams};
use lfdepth::{Grid, Homography, LightField};

fn bench(c: &mut Criterion) {
    let (grid, n) = (Grid::new(9, 9), 512);
    let (misaligned, layout, truth) =
        align_scene::render(grid, n, n, Some((2.0, 3.0, 0.01, 1e-5)), 1);
    let (rectified, _, _) = align_scene::render(grid, n, n, None, 1);
    let mut group = c.benchmark_group("align");
    group.sample_size(10);
    let cases = [
        (
            "estimate_auto_rectified_9x9x512",
            &rectified,
            AlignMode::Auto,
            AlignModel::PerView,
        ),
        (
            "estimate_on_per_view_9x9x512",
            &misaligned,
            AlignMode::On,
            AlignModel::PerView,
        ),
        (
            "estimate_on_plane_patches_9x9x512",
            &misaligned,
            AlignMode::On,
            AlignModel::PlanePatches,
        ),
    ];
    for (name, data, mode, model) in cases {
        let lf = LightField::new(&data[..], layout).unwrap();
        let params = AlignParams {
            mode,
            model,
            ..AlignParams::default()
        };
        let mut hs = vec![Homography::IDENTITY; 81];
        let mut scratch = vec![0.0f32; align::scratch_len(&layout, &params).unwrap()];
        group.bench_function(name, |b| {
            b.iter(|| align::estimate(&lf, &params, &mut hs, &mut scratch).unwrap())
        });
    }
    let lf = LightField::new(&misaligned[..], layout).unwrap();
    let mut band = vec![0u8; 81 * 32 * n];
    group.bench_function("warp_all_views_9x9x512_u8_in_32_row_bands", |b| {
        b.iter(|| {
            for y in (0..n).step_by(32) {
                align::warp_band(&lf, &truth, y..y + 32, &mut band).unwrap();
            }
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
