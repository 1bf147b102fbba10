//! Alignment of synthetic 9×9 arrays with known per-view misalignment (up to 2°
//! rotation, 3 px translation, 1 % scale and a little perspective): the recovered
//! homographies must reproject within 0.1 px of a perfect rectified array, and the warp
//! with the true homographies must reproduce the ideal views.
//! Full 512×512 size in release (`cargo test --release`), smaller in debug.

mod align_scene;

use std::time::Instant;

use lfdepth::align::{
    self, gauge_rms, reprojection_rms, AlignMode, AlignModel, AlignParams, AlignReport,
};
use lfdepth::{Grid, Homography, Layout, LightField};

const MISALIGN: (f32, f32, f32, f32) = (2.0, 3.0, 0.01, 1e-5);

fn size() -> usize {
    if cfg!(debug_assertions) {
        128
    } else {
        512
    }
}

fn estimate(data: &[u8], layout: Layout, params: &AlignParams) -> (AlignReport, Vec<Homography>) {
    let lf = LightField::new(data, layout).unwrap();
    let mut hs = vec![Homography::IDENTITY; layout.grid.len()];
    let mut scratch = vec![0.0f32; align::scratch_len(&layout, params).unwrap()];
    let (t, cpu) = (Instant::now(), align_scene::thread_cpu_ns());
    let report = align::estimate(&lf, params, &mut hs, &mut scratch).unwrap();
    eprintln!(
        "{:?}/{:?}: {:.1} ms wall, {:.1} ms on-CPU (this thread), scratch {} bytes",
        params.mode,
        params.model,
        t.elapsed().as_secs_f64() * 1e3,
        (align_scene::thread_cpu_ns() - cpu) as f64 * 1e-6,
        scratch.len() * 4
    );
    (report, hs)
}

#[test]
fn misaligned_9x9_arrays_reproject_within_a_tenth_of_a_pixel() {
    let (grid, n) = (Grid::new(9, 9), size());
    let seeds: &[u32] = if cfg!(debug_assertions) {
        &[1]
    } else {
        &[1, 2]
    };
    for &seed in seeds {
        let (data, layout, truth) = align_scene::render(grid, n, n, Some(MISALIGN), seed);
        let disparities = [-0.8, 0.0, 1.5];
        let identity = vec![Homography::IDENTITY; 81];
        let before = reprojection_rms(&identity, &truth, grid, n, n, &disparities).unwrap();
        for model in [AlignModel::PerView, AlignModel::PlanePatches] {
            let params = AlignParams {
                mode: AlignMode::On,
                model,
                ..AlignParams::default()
            };
            let (report, hs) = estimate(&data, layout, &params);
            let after = reprojection_rms(&hs, &truth, grid, n, n, &disparities).unwrap();
            let registration = gauge_rms(&hs, &truth, grid, n, n).unwrap();
            let min_inliers = report.views.iter().map(|v| v.inliers).min().unwrap();
            eprintln!(
                "seed {seed} {model:?}: reprojection {before:.3} -> {after:.4} px, registration (mod gauge) {registration:.3} px, track RMS {:.4}, {} corners, min inliers {min_inliers}, {} rounds",
                report.rms, report.features, report.iterations
            );
            assert!(before > 1.0, "the scene is not misaligned: {before}");
            assert!(after < 0.1, "seed {seed} {model:?}: {after} px");
            assert!(!report.skipped && report.warning.is_none());
        }
        // Auto detects the misalignment and aligns.
        let (report, hs) = estimate(&data, layout, &AlignParams::default());
        assert!(!report.skipped, "{report:?}");
        assert!(reprojection_rms(&hs, &truth, grid, n, n, &disparities).unwrap() < 0.1);
    }
}

#[test]
fn auto_skips_a_rectified_array() {
    let (grid, n) = (Grid::new(9, 9), size());
    let (data, layout, _) = align_scene::render(grid, n, n, None, 3);
    let (report, hs) = estimate(&data, layout, &AlignParams::default());
    eprintln!("rectified: identity RMS {:.4} px", report.identity_rms);
    assert!(report.skipped && report.warning.is_none(), "{report:?}");
    assert!(hs.iter().all(|h| *h == Homography::IDENTITY));
}

#[test]
fn warping_with_the_true_homographies_restores_the_ideal_views() {
    let (grid, n) = (Grid::new(9, 9), size());
    let (ideal, layout, _) = align_scene::render(grid, n, n, None, 4);
    let (data, _, truth) = align_scene::render(grid, n, n, Some(MISALIGN), 4);
    let lf = LightField::new(&data[..], layout).unwrap();
    // Warp in bands of 37 rows (deliberately not a divisor of the height).
    let mut warped = vec![0u8; data.len()];
    let mut band = vec![0u8; 81 * 37 * n];
    let mut y = 0;
    let (t, cpu) = (Instant::now(), align_scene::thread_cpu_ns());
    while y < n {
        let rows = y..(y + 37).min(n);
        let len = 81 * rows.len() * n;
        align::warp_band(&lf, &truth, rows.clone(), &mut band[..len]).unwrap();
        for v in 0..81 {
            let src = &band[v * rows.len() * n..(v + 1) * rows.len() * n];
            warped[v * n * n + y * n..v * n * n + rows.end * n].copy_from_slice(src);
        }
        y = rows.end;
    }
    eprintln!(
        "warp of 81 {n}x{n} gray views in 37-row bands: {:.1} ms wall, {:.1} ms on-CPU",
        t.elapsed().as_secs_f64() * 1e3,
        (align_scene::thread_cpu_ns() - cpu) as f64 * 1e-6
    );
    // Mean absolute difference inside a border the misalignment may have pushed out.
    let mad = |a: &[u8]| {
        let (mut sum, mut count) = (0u64, 0u64);
        for v in 0..81 {
            for y in 16..n - 16 {
                for x in 16..n - 16 {
                    let i = v * n * n + y * n + x;
                    sum += (a[i] as i32 - ideal[i] as i32).unsigned_abs() as u64;
                    count += 1;
                }
            }
        }
        sum as f64 / count as f64
    };
    let (before, after) = (mad(&data), mad(&warped));
    eprintln!("mean |misaligned - ideal| {before:.2}, |warped - ideal| {after:.2} (8-bit levels)");
    assert!(before > 4.0 && after < 1.0, "{before} {after}");
}
