//! Tests of the realistic suite's scenes: names and ranges, the exactness of their ground
//! truth (every view reprojects onto the centre), the sensor model and the region labels.

extern crate std;

use super::tests::{bilinear, small};
use super::*;
use std::vec;
use std::vec::Vec;

/// The realistic scenes, as the suite defines them, at `size`² on a `grid`, with an
/// ideal sensor when `ideal`.
fn realistic(kind: SceneKind, size: usize, grid: Grid, ideal: bool) -> SynthSpec {
    let entry = REALISTIC_SUITE.iter().find(|s| s.kind == kind).unwrap();
    let mut spec = entry.spec(size, size);
    spec.grid = grid;
    if ideal {
        spec.sensor = None;
    }
    spec
}

#[test]
fn realistic_scenes_are_named_and_their_ground_truth_spans_the_range() {
    for kind in SceneKind::REALISTIC {
        assert_eq!(SceneKind::from_name(kind.name()), Some(kind));
        assert!(!SceneKind::ALL.contains(&kind));
    }
    assert_eq!(REALISTIC_SUITE.len(), SceneKind::REALISTIC.len());
    for (entry, kind) in REALISTIC_SUITE.iter().zip(SceneKind::REALISTIC) {
        assert_eq!(entry.kind, kind);
        let spec = entry.spec(512, 512);
        spec.validate().unwrap();
        let mut gt = vec![0.0f32; 512 * 512];
        render_ground_truth(&spec, &mut gt).unwrap();
        let lo = gt.iter().cloned().fold(f32::INFINITY, f32::min);
        let hi = gt.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
        let (min, max) = (entry.disparity_min, entry.disparity_max);
        assert!(lo >= min && hi <= max, "{kind:?} {lo} {hi}");
        // Most of the range is on screen: the back wall at the far end, the floor near.
        assert_eq!(
            lo, min,
            "{kind:?}: the back wall is at the smallest disparity"
        );
        assert!(
            hi - lo >= 0.8 * (max - min),
            "{kind:?} spans only {lo}..{hi}"
        );
    }
    // Any range and grid: the scenes stay within the range and keep planes single-hit.
    for kind in SceneKind::REALISTIC {
        for (grid, min, max) in [
            (Grid::new(4, 6), -4.0f32, 4.0f32),
            (Grid::new(17, 3), 0.5, 0.75),
        ] {
            let mut spec = SynthSpec::new(kind, grid, 48, 40);
            spec.disparity_min = min;
            spec.disparity_max = max;
            let mut gt = vec![0.0f32; 48 * 40];
            render_ground_truth(&spec, &mut gt).unwrap();
            let lo = gt.iter().cloned().fold(f32::INFINITY, f32::min);
            let hi = gt.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
            assert!(lo >= min && hi <= max, "{kind:?} {lo} {hi}");
            assert!(hi - lo >= (max - min) / 3.0, "{kind:?} spans {lo}..{hi}");
            let mut out = vec![0u8; 48 * 40 * 3];
            render_view(&spec, grid.rows - 1, 0, &mut out).unwrap();
        }
    }
}

/// Centre pixels of one surface over their 5×5 neighbourhood (edge pixels are
/// supersampled, so their rendering is approximate), close to its tangent plane there,
/// textured (8-bit rounding hides displacements in faint texture), and not hidden by a
/// nearer surface in view `(row, col)`.
fn comparable_pixels(
    spec: &SynthSpec,
    centre: &[u8],
    gt: &[f32],
    regions: &[u8],
    (row, col): (usize, usize),
) -> Vec<usize> {
    let (r0, c0) = spec.grid.center();
    let (u, v) = (col as f64 - c0 as f64, row as f64 - r0 as f64);
    let w = spec.width;
    let mut out = Vec::new();
    for y in 2..spec.height - 2 {
        for x in 2..w - 2 {
            let index = y * w + x;
            let d = gt[index];
            let (gx, gy) = (
                (gt[index + 1] - gt[index - 1]) / 2.0,
                (gt[index + w] - gt[index - w]) / 2.0,
            );
            let smooth = (0..25).all(|k| {
                let (dx, dy) = (k % 5, k / 5);
                let other = (y + dy - 2) * w + x + dx - 2;
                let planar = d + gx * (dx as f32 - 2.0) + gy * (dy as f32 - 2.0);
                (gt[other] - planar).abs() < 0.05 && regions[other] == regions[index]
            });
            if !smooth {
                continue;
            }
            let at = |i: usize| centre[i * spec.channels] as f64;
            let (ix, iy) = (
                (at(index + 1) - at(index - 1)) / 2.0,
                (at(index + w) - at(index - w)) / 2.0,
            );
            if ix * ix + iy * iy < 16.0 {
                continue;
            }
            // An occluder seen at centre point q = p + t·(u, v) with disparity d + t
            // covers the view's ray.
            let reach = (u * u + v * v).sqrt().max(1.0);
            let hidden = (1..)
                .map(|k| k as f64 * 0.2 / reach)
                .take_while(|&t| t < 9.0)
                .any(|t| {
                    let (qx, qy) = (x as f64 + t * u, y as f64 + t * v);
                    if qx < 0.0 || qy < 0.0 || qx > (w - 1) as f64 || qy > (spec.height - 1) as f64
                    {
                        return false;
                    }
                    let q = gt[qy.round() as usize * w + qx.round() as usize] as f64;
                    q - d as f64 > 0.1 && q - d as f64 >= t - 0.3
                });
            if !hidden {
                out.push(index);
            }
        }
    }
    out
}

/// Mean |centre(x, y) − view(x − d'·u, y − d'·v)| (channel 0) over `pixels`, with
/// `d' = gt + offset`, for view `(row, col)`.
fn reprojection_error(
    spec: &SynthSpec,
    centre: &[u8],
    other: &[u8],
    gt: &[f32],
    pixels: &[usize],
    (row, col): (usize, usize),
    offset: f64,
) -> f64 {
    let (r0, c0) = spec.grid.center();
    let (u, v) = (col as f64 - c0 as f64, row as f64 - r0 as f64);
    let (mut sum, mut n) = (0.0, 0usize);
    for &index in pixels {
        let (x, y) = ((index % spec.width) as f64, (index / spec.width) as f64);
        let d = gt[index] as f64 + offset;
        if let Some(value) = bilinear(other, spec, 0, x - d * u, y - d * v) {
            sum += (value - centre[index * spec.channels] as f64).abs();
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

#[test]
fn realistic_ground_truth_reprojects_every_view_onto_the_centre() {
    // An ideal sensor (no noise, no vignetting) but the scene's uneven lighting. Each
    // view is warped to the centre with the ground truth plus a constant offset; on the
    // floor, the walls, the objects and the relief the offset that agrees best is within
    // 0.02 px of 0 (searched in steps of 0.01 px; 8-bit rounding and bilinear
    // interpolation flatten the minimum) and ±0.06 px agree clearly worse.
    let grid = Grid::new(5, 5);
    let offsets: Vec<f64> = (-6..=6).map(|k| k as f64 * 0.01).collect();
    for kind in SceneKind::REALISTIC {
        let spec = realistic(kind, 128, grid, true);
        let mut gt = vec![0.0f32; 128 * 128];
        render_ground_truth(&spec, &mut gt).unwrap();
        let mut regions = vec![0u8; 128 * 128];
        render_regions(&spec, &mut regions).unwrap();
        let len = 128 * 128 * 3;
        let mut centre = vec![0u8; len];
        render_view(&spec, 2, 2, &mut centre).unwrap();
        let (mut tested, mut floor_tested) = (0, false);
        for view in [(2, 4), (4, 0)] {
            let mut other = vec![0u8; len];
            render_view(&spec, view.0, view.1, &mut other).unwrap();
            let comparable = comparable_pixels(&spec, &centre, &gt, &regions, view);
            for flag in [
                0,
                region::FLOOR,
                region::WALL,
                region::OBJECT,
                region::RELIEF,
            ] {
                let pixels: Vec<usize> = comparable
                    .iter()
                    .copied()
                    .filter(|&i| flag == 0 || regions[i] & flag != 0)
                    .collect();
                if pixels.len() < 600 {
                    continue;
                }
                let errors: Vec<f64> = offsets
                    .iter()
                    .map(|&o| reprojection_error(&spec, &centre, &other, &gt, &pixels, view, o))
                    .collect();
                let best = (0..errors.len())
                    .min_by(|&a, &b| errors[a].total_cmp(&errors[b]))
                    .unwrap();
                std::eprintln!(
                    "{kind:?} view {view:?} region {flag}: {} pixels, mean |diff| {:.3} levels \
                     with the gt, best offset {:+.2} px ({:.3})",
                    pixels.len(),
                    errors[6],
                    offsets[best],
                    errors[best]
                );
                assert!(
                    offsets[best].abs() < 0.025
                        && errors[0] > errors[6] * 1.05
                        && errors[12] > errors[6] * 1.05,
                    "{kind:?} {view:?} region {flag}: {errors:?}"
                );
                assert!(errors[6] < 1.5, "{kind:?} {view:?}: {}", errors[6]);
                tested += 1;
                floor_tested |= flag == region::FLOOR;
            }
        }
        assert!(
            tested >= 4 && floor_tested,
            "{kind:?}: {tested} regions tested"
        );
    }
}

#[test]
fn sensor_noise_grows_with_brightness_and_vignetting_darkens_the_corners() {
    let ideal = realistic(SceneKind::Corridor, 96, Grid::new(3, 3), true);
    let real = realistic(SceneKind::Corridor, 96, Grid::new(3, 3), false);
    let len = 96 * 96 * 3;
    let (mut a, mut b) = (vec![0u8; len], vec![0u8; len]);
    render_view(&ideal, 0, 1, &mut a).unwrap();
    render_view(&real, 0, 1, &mut b).unwrap();
    // Undo the vignetting (known) and compare the residual's spread by brightness.
    let sensor = real.sensor.unwrap();
    let (mut dark, mut bright) = (Vec::new(), Vec::new());
    let (mut centre_ratio, mut corner_ratio) = ((0.0, 0.0), (0.0, 0.0));
    for (k, (&x, &y)) in a.iter().zip(&b).enumerate() {
        let p = k / 3;
        let (i, j) = ((p % 96) as f64, (p / 96) as f64);
        let g = sensor.vignette(i, j, 96, 96);
        let residual = y as f64 - g * x as f64;
        if x < 60 {
            dark.push(residual);
        } else if x > 100 && x < 250 {
            bright.push(residual);
        }
        let r2 = (i - 47.5).powi(2) + (j - 47.5).powi(2);
        if r2 < 100.0 {
            centre_ratio = (centre_ratio.0 + y as f64, centre_ratio.1 + x as f64);
        } else if r2 > 3500.0 {
            corner_ratio = (corner_ratio.0 + y as f64, corner_ratio.1 + x as f64);
        }
    }
    let std = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|d| (d - m) * (d - m)).sum::<f64>() / v.len() as f64).sqrt()
    };
    let (sd, sb) = (std(&dark), std(&bright));
    std::eprintln!(
        "noise σ {sd:.2} levels below 60, {sb:.2} in 100..250 ({} / {} samples)",
        dark.len(),
        bright.len()
    );
    assert!(dark.len() > 500 && bright.len() > 200);
    assert!(sd > 0.7 && sd < 1.6 && sb > 1.8 && sb < 3.0, "{sd} {sb}");
    let (c, e) = (
        centre_ratio.0 / centre_ratio.1,
        corner_ratio.0 / corner_ratio.1,
    );
    assert!(c > 0.97 && e < 0.85, "centre {c}, corners {e}");
}

#[test]
fn regions_mark_the_floor_and_dim_surfaces() {
    for kind in SceneKind::REALISTIC {
        let spec = realistic(kind, 96, Grid::new(9, 9), false);
        let mut regions = vec![0u8; 96 * 96];
        render_regions(&spec, &mut regions).unwrap();
        let mut gt = vec![0.0f32; 96 * 96];
        render_ground_truth(&spec, &mut gt).unwrap();
        let share = |flag: u8| regions.iter().filter(|&&r| r & flag != 0).count() as f64 / 9216.0;
        assert!(
            share(region::FLOOR) > 0.2,
            "{kind:?} floor {}",
            share(region::FLOOR)
        );
        assert!(
            share(region::DIM) > 0.05,
            "{kind:?} dim {}",
            share(region::DIM)
        );
        // The floor's disparity grows downwards wherever two floor pixels are stacked.
        for y in 0..95 {
            for x in 0..96 {
                let (a, b) = (y * 96 + x, (y + 1) * 96 + x);
                if regions[a] & region::FLOOR != 0 && regions[b] & region::FLOOR != 0 {
                    assert!(gt[b] > gt[a], "{kind:?} ({x}, {y})");
                }
            }
        }
    }
    // The basic scenes mark nothing.
    let spec = small(SceneKind::Mixed);
    let mut regions = vec![0u8; 64 * 64];
    render_regions(&spec, &mut regions).unwrap();
    assert!(regions.iter().all(|&r| r == 0));
    assert!(render_regions(&spec, &mut [0u8; 10]).is_err());
}
