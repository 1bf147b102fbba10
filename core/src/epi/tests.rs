extern crate std;
use std::vec;
use std::vec::Vec;

use core::ops::ControlFlow;

use super::load::{load_levels, Levels};
use super::serial::estimate_with_progress;
use super::test_scenes::{noise, strips, Scene};
use super::*;
use crate::lightfield::{Grid, Layout};
use crate::scalar::Q16;
use crate::setup::{DisparityOut, TestSetup};

fn stage_for(layout: Layout, epi: EpiParams) -> TestSetup<EpiParams> {
    TestSetup::new(layout, epi)
}

fn fixed(min: f32, max: f32) -> EpiParams {
    EpiParams {
        range: DisparityRange::Fixed { min, max },
        ..EpiParams::default()
    }
}

fn run<T: Scalar>(scene: &Scene, epi: EpiParams) -> (Vec<f32>, Vec<f32>) {
    let stage = stage_for(scene.layout, epi);
    let lf = LightField::new(&scene.data, scene.layout).unwrap();
    let mut d = vec![0.0; stage.pixels()];
    let mut c = vec![0.0; stage.pixels()];
    let mut scratch = vec![T::ZERO; scratch_len(stage.setup())];
    estimate(stage.setup(), &lf, &mut d, &mut c, &mut scratch).unwrap();
    (d, c)
}

/// Share of interior pixels (`margin` from every border) within `tol` of the truth.
fn share_within(scene: &Scene, d: &[f32], tol: f32, margin: usize) -> f32 {
    let (w, h) = (scene.layout.width, scene.layout.height);
    let (mut good, mut all) = (0, 0);
    for y in margin..h - margin {
        for x in margin..w - margin {
            all += 1;
            if (d[y * w + x] - scene.gt[y * w + x]).abs() <= tol {
                good += 1;
            }
        }
    }
    good as f32 / all as f32
}

#[test]
fn planes_across_the_range_are_measured_accurately() {
    for disparity in [-3.6f32, -2.3, -0.45, 0.0, 0.7, 1.5, 3.2] {
        // Outer views move up to 4 · 3.6 px: keep the clamped borders out of the count.
        let scene = strips(Grid::new(9, 9), 60, 52, 1, disparity, &[]);
        let (d, c) = run::<f32>(&scene, fixed(-4.0, 4.0));
        let share = share_within(&scene, &d, 0.02, 18);
        assert!(share > 0.95, "d = {disparity}: {share}");
        assert!(c.iter().all(|&v| (0.0..=1.0).contains(&v)));
    }
}

#[test]
fn samples_away_from_the_line_end_do_not_depend_on_the_line_length() {
    // The same texture (no strips) at widths below one 32-sample register block (24), with
    // a last block that overlaps its predecessor (40, 63) and a long reference (100):
    // everything is local along the line, so samples farther than the filters' reach
    // (shift 2·1.5 + inner 3 + outer 6 px < 20) from the right end are bit-identical.
    let epi = fixed(-1.0, 1.5);
    let reference = strips(Grid::new(5, 5), 100, 40, 1, 0.7, &[]);
    let (d_ref, c_ref) = run::<f32>(&reference, epi);
    for width in [24usize, 40, 63] {
        let scene = strips(Grid::new(5, 5), width, 40, 1, 0.7, &[]);
        let (d, c) = run::<f32>(&scene, epi);
        for y in 0..40 {
            for x in 0..width - 20 {
                let (i, j) = (y * width + x, y * 100 + x);
                assert_eq!(
                    d[i].to_bits(),
                    d_ref[j].to_bits(),
                    "width {width} ({x}, {y})"
                );
                assert_eq!(
                    c[i].to_bits(),
                    c_ref[j].to_bits(),
                    "width {width} ({x}, {y})"
                );
            }
        }
        assert!(share_within(&scene, &d, 0.02, 6) > 0.95, "width {width}");
    }
}

#[test]
fn estimates_stay_in_range_and_finite_on_any_input() {
    let layout = Layout::packed(Grid::new(5, 7), 24, 20, 3);
    let pattern = noise(layout.validate().unwrap(), 7);
    let flat = vec![0.5f32; layout.validate().unwrap()];
    let mut broken = pattern.clone();
    for (i, v) in broken.iter_mut().enumerate() {
        if i % 7 == 0 {
            *v = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30][i % 4];
        }
    }
    for data in [&pattern, &flat, &broken] {
        for epi in [fixed(-1.3, 2.2), EpiParams::paper(), EpiParams::default()] {
            let scene = Scene {
                data: data.clone(),
                layout,
                gt: vec![],
            };
            for (d, c) in [run::<f32>(&scene, epi), run::<Q16>(&scene, epi)] {
                let (lo, hi) = match epi.range {
                    DisparityRange::Fixed { min, max } => (min, max),
                    DisparityRange::Auto => (-MAX_DISPARITY, MAX_DISPARITY),
                };
                let bad = d
                    .iter()
                    .find(|v| !(v.is_finite() && (lo..=hi).contains(*v)));
                assert!(bad.is_none(), "{bad:?} outside [{lo}, {hi}] with {epi:?}");
                assert!(c.iter().all(|v| (0.0..=1.0).contains(v)));
            }
        }
    }
}

#[test]
fn bands_of_any_size_give_the_serial_result_bit_for_bit() {
    let scene = strips(Grid::new(7, 9), 37, 29, 3, -1.2, &[0.0, 1.6, -1.2, 2.4]);
    let epi = fixed(-1.5, 2.6);
    let stage = stage_for(scene.layout, epi);
    let lf = LightField::new(&scene.data, scene.layout).unwrap();
    let (serial_d, serial_c) = run::<f32>(&scene, epi);
    let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
    let hyps = hypotheses(stage.setup(), &lf, &mut scratch).unwrap();
    for band in [1usize, 5, 13, 64] {
        let mut maps = Vec::new();
        for direction in [Direction::Horizontal, Direction::Vertical] {
            let (lines, n) = (
                direction.lines(stage.layout()),
                direction.line_len(stage.layout()),
            );
            let mut d = vec![0.0; lines * n];
            let mut c = vec![0.0; lines * n];
            let mut start = 0;
            while start < lines {
                let end = (start + band).min(lines);
                let mut s = vec![0.0f32; band_scratch_len(stage.setup(), direction)];
                estimate_band(
                    stage.setup(),
                    &hyps,
                    &lf,
                    direction,
                    start..end,
                    DisparityOut {
                        disparity: &mut d[start * n..end * n],
                        confidence: &mut c[start * n..end * n],
                    },
                    &mut s,
                )
                .unwrap();
                start = end;
            }
            maps.push((d, c));
        }
        let (w, h) = (scene.layout.width, scene.layout.height);
        for y in 0..h {
            for x in 0..w {
                let (dh, ch) = (maps[0].0[y * w + x], maps[0].1[y * w + x]);
                let (dv, cv) = (maps[1].0[x * h + y], maps[1].1[x * h + y]);
                let (d, c) = fuse(epi.fusion, dh, ch, dv, cv);
                assert_eq!(d.to_bits(), serial_d[y * w + x].to_bits(), "band {band}");
                assert_eq!(c.to_bits(), serial_c[y * w + x].to_bits(), "band {band}");
            }
        }
    }
}

#[test]
fn fixed_point_tracks_f32() {
    let scene = strips(Grid::new(9, 9), 40, 32, 3, -0.8, &[1.3, 0.0, 2.1]);
    let epi = fixed(-1.0, 2.5);
    let (df, _) = run::<f32>(&scene, epi);
    let (dq, _) = run::<Q16>(&scene, epi);
    let close = df
        .iter()
        .zip(&dq)
        .filter(|(a, b)| (*a - *b).abs() <= 0.01)
        .count();
    assert!(
        close as f32 >= 0.99 * df.len() as f32,
        "{close} of {}",
        df.len()
    );
}

#[test]
fn automatic_range_brackets_the_scene() {
    for (background, fronts) in [
        (-2.5f32, [0.5f32, -3.0, 1.0]),
        (0.2, [2.9, 0.0, 3.5]),
        (-0.3, [0.1, 0.0, 0.4]),
        (-3.8, [-3.8, -1.0, -3.8]),
    ] {
        let scene = strips(Grid::new(9, 9), 64, 64, 1, background, &fronts);
        let stage = stage_for(scene.layout, EpiParams::default());
        let lf = LightField::new(&scene.data, scene.layout).unwrap();
        let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
        let (lo, hi) = estimate_range(stage.setup(), &lf, &mut scratch).unwrap();
        let gmin = scene.gt.iter().copied().fold(f32::MAX, f32::min);
        let gmax = scene.gt.iter().copied().fold(f32::MIN, f32::max);
        assert!(lo <= gmin && hi >= gmax, "[{lo}, {hi}] vs [{gmin}, {gmax}]");
        assert!(
            lo >= gmin - 1.0 && hi <= gmax + 1.0,
            "[{lo}, {hi}] vs [{gmin}, {gmax}]"
        );
    }
}

#[test]
fn bad_buffers_and_cancellation_are_errors() {
    let scene = strips(Grid::new(3, 3), 16, 16, 1, 0.3, &[]);
    let stage = stage_for(scene.layout, fixed(-1.0, 1.0));
    let lf = LightField::new(&scene.data, scene.layout).unwrap();
    let mut d = vec![0.0; stage.pixels()];
    let mut c = vec![0.0; stage.pixels()];
    let mut small = vec![0.0f32; scratch_len(stage.setup()) - 1];
    assert!(matches!(
        estimate(stage.setup(), &lf, &mut d, &mut c, &mut small),
        Err(Error::ScratchTooSmall { .. })
    ));
    let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
    assert!(matches!(
        estimate(stage.setup(), &lf, &mut d[1..], &mut c, &mut scratch),
        Err(Error::OutputSize { .. })
    ));
    let hyps = hypotheses(stage.setup(), &lf, &mut scratch).unwrap();
    assert!(estimate_band(
        stage.setup(),
        &hyps,
        &lf,
        Direction::Horizontal,
        3..17,
        DisparityOut {
            disparity: &mut d[..14 * 16],
            confidence: &mut c[..14 * 16]
        },
        &mut scratch
    )
    .is_err());
    let mut calls = 0;
    let r = estimate_with_progress(stage.setup(), &lf, &mut d, &mut c, &mut scratch, &mut |p| {
        calls += 1;
        assert!(p.done <= p.total);
        if p.stage == STAGE_VERTICAL {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    assert_eq!(r, Err(Error::Cancelled));
    assert!(calls >= 3);
    let other = Layout::packed(Grid::new(3, 3), 17, 16, 1);
    let stage2 = stage_for(other, fixed(-1.0, 1.0));
    assert!(estimate(stage2.setup(), &lf, &mut d, &mut c, &mut scratch).is_err());
}

#[test]
fn invalid_parameters_are_rejected() {
    for p in [
        EpiParams {
            inner_sigma: -1.0,
            ..EpiParams::default()
        },
        EpiParams {
            outer_sigma: f32::NAN,
            ..EpiParams::default()
        },
        EpiParams {
            shear_step: 0.0,
            ..EpiParams::default()
        },
        fixed(3.0, -3.0),
        fixed(-9.0, 0.0),
        EpiParams {
            search: Search::CoarseToFine { margin: -0.5 },
            ..EpiParams::default()
        },
        EpiParams {
            search: Search::CoarseToFine {
                margin: f32::INFINITY,
            },
            ..EpiParams::default()
        },
    ] {
        assert!(p.validate().is_err(), "{p:?}");
    }
    assert!(EpiParams::default().validate().is_ok());
    assert!(EpiParams::paper().validate().is_ok());
}

#[test]
fn coarse_to_fine_search_finds_the_exhaustive_estimate() {
    // Occluding strips over a range of disparities (several brackets per line), in colour:
    // where the gray pass places a sample, the two hypotheses that bracket it are the ones
    // the exhaustive search picks, so most estimates agree (within 0.01 px: a coherent
    // sample whose residual puts it near the lower shear keeps that shear's estimate
    // instead of the zero crossing, see `FINE_NEAR`); near occlusions the pruned search may
    // pick another bracket, never a worse one overall.
    let scene = strips(Grid::new(9, 9), 64, 40, 3, -2.2, &[-0.3, 1.7, 0.6, 2.9]);
    let exhaustive = EpiParams {
        search: Search::Exhaustive,
        ..fixed(-3.0, 3.2)
    };
    let (d_all, _) = run::<f32>(&scene, exhaustive);
    for margin in [0.0f32, 0.5] {
        let epi = EpiParams {
            search: Search::CoarseToFine { margin },
            ..fixed(-3.0, 3.2)
        };
        let (d, _) = run::<f32>(&scene, epi);
        let same = d
            .iter()
            .zip(&d_all)
            .filter(|(a, b)| (*a - *b).abs() <= 0.01)
            .count();
        let share = same as f32 / d.len() as f32;
        std::eprintln!("margin {margin}: {share} within 0.01 px of the exhaustive estimate");
        assert!(share > 0.85, "margin {margin}: {share} within 0.01 px");
        for (tol, margin_px) in [(0.02, 14), (0.07, 4)] {
            let good = share_within(&scene, &d, tol, margin_px);
            let good_all = share_within(&scene, &d_all, tol, margin_px);
            assert!(
                good >= good_all - 0.005,
                "margin {margin}, within {tol}: {good} vs exhaustive {good_all}"
            );
        }
    }
}

#[test]
fn the_scratch_bound_covers_every_estimator_the_parameters_make() {
    let searches = [
        Search::Exhaustive,
        Search::CoarseToFine { margin: 0.0 },
        Search::CoarseToFine { margin: 1.0 },
    ];
    let ranges = [
        (-8.0f32, 8.0f32),
        (-4.0, 4.0),
        (-1.5, 1.5),
        (-0.3, 2.7),
        (2.25, 3.75),
        (-7.9, -6.1),
        (0.0, 0.0),
    ];
    for step in [0.1f32, 0.25, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0] {
        for shear in [true, false] {
            for search in searches {
                let params = EpiParams {
                    shear_step: step,
                    shear,
                    search,
                    ..EpiParams::default()
                };
                for (views, centre) in [(9, 4), (7, 3), (5, 2), (3, 1), (4, 2), (17, 8)] {
                    let n = 100;
                    let bound = LineEstimator::<f32>::work_len(&params, views, centre, 3, n);
                    // The range probe's integer shears, and every range the step allows.
                    let probe = Hypotheses::sheared(-4.0, 4.0, 1.0, 1.0).unwrap();
                    let hyps = ranges
                        .iter()
                        .filter_map(|&(min, max)| Hypotheses::new(&params, min, max).ok())
                        .chain([probe]);
                    for h in hyps {
                        let e = LineEstimator::<f32>::new(&params, h, views, centre, 3);
                        assert!(
                            e.line_work_len(n) <= bound,
                            "step {step} shear {shear} {search:?} views {views}: {h:?} needs {} > {bound}",
                            e.line_work_len(n)
                        );
                    }
                }
            }
        }
    }
    // Half-sample steps need neither fallback planes nor half-shifted planes of the views
    // at even distances from the centre: a third less than a step of 0.3.
    let layout = Layout::packed(Grid::new(9, 9), 512, 512, 3);
    let default = scratch_len(stage_for(layout, EpiParams::default()).setup());
    let any_step = stage_for(
        layout,
        EpiParams {
            shear_step: 0.3,
            ..EpiParams::default()
        },
    );
    let any_step = scratch_len(any_step.setup());
    let large = stage_for(
        Layout::packed(Grid::new(9, 9), 4096, 4096, 3),
        EpiParams::default(),
    );
    let large = scratch_len(large.setup());
    std::eprintln!(
        "EPI scratch, 9x9 RGB: 512x512 {} B (step 0.3: {} B), 4096x4096 {} B",
        4 * default,
        4 * any_step,
        4 * large
    );
    assert!(3 * default < 2 * any_step, "{default} vs {any_step}");
}

/// The level table gives the values `load_line` converts, bit for bit, along rows
/// (contiguous pixels) and columns (strided), for 3 and 4 channels, in f32 and Q16.
fn levels_match_the_conversion<T: Scalar>() {
    assert!(
        Levels::<T>::new::<f32>().is_none(),
        "only u8 samples have a table"
    );
    let levels = Levels::<T>::new::<u8>().unwrap();
    for channels in [3usize, 4] {
        let (width, height) = (11usize, 7usize);
        let data: Vec<u8> = (0..width * height * channels)
            .map(|i| (i * 97 % 256) as u8)
            .collect();
        let row_stride = width * channels;
        // (start, step, n): a row, and a column.
        for (start, step, n) in [
            (2 * row_stride, channels, width),
            (3 * channels, row_stride, height),
        ] {
            let mut want = vec![T::ZERO; 3 * n];
            let mut got = vec![T::ONE; 3 * n];
            load_line(
                &data,
                "test",
                LineSpan {
                    start,
                    step,
                    channels,
                    n,
                },
                ColorMode::Tensor,
                &mut want,
            )
            .unwrap();
            load_levels(
                &data,
                "test",
                LineSpan {
                    start,
                    step,
                    channels,
                    n,
                },
                &levels,
                &mut got,
            )
            .unwrap();
            assert_eq!(got, want, "channels {channels}, step {step}");
        }
        // A line past the buffer's end is an error, as for `load_line`.
        let mut out = vec![T::ZERO; 3 * height];
        assert!(load_levels(
            &data,
            "t",
            LineSpan {
                start: 4 * channels,
                step: row_stride,
                channels,
                n: height + 1
            },
            &levels,
            &mut out
        )
        .is_err());
    }
}

#[test]
fn the_level_table_loads_u8_samples_bit_for_bit() {
    levels_match_the_conversion::<f32>();
    levels_match_the_conversion::<Q16>();
}

#[test]
fn the_vector_square_root_is_within_two_ulps_of_the_exact_one() {
    use super::line::lane_sqrt;
    // Every magnitude the coherence takes (a² + b² ≤ 2, down to the smallest normal).
    let mut x = f32::MIN_POSITIVE;
    while x < 4.0 {
        for v in [x, x * 1.37, x * 1.9] {
            let exact = crate::float::sqrtf(v);
            let got = lane_sqrt(v);
            let ulps = (got.to_bits() as i64 - exact.to_bits() as i64).abs();
            assert!(ulps <= 2, "√{v}: {got} vs {exact} ({ulps} ulps)");
        }
        x *= 2.0;
    }
    for v in [1.0f32, 0.25, 0.5, 0.81, 0.999_999] {
        assert!((lane_sqrt(v) - crate::float::sqrtf(v)).abs() <= 2.0 * f32::EPSILON);
    }
    for v in [0.0f32, -0.0, -1.0, f32::NAN, f32::MIN_POSITIVE / 2.0] {
        assert_eq!(lane_sqrt(v), 0.0, "√{v}");
    }
}

/// One pixel per plane triple: (r, g, b) in the kernels' units.
fn mixed<T: Scalar>(pixels: &[[f32; 3]], keep: f32, knee: f32, color: ColorMode) -> Vec<[f32; 3]> {
    let n = pixels.len();
    let mut line = vec![T::ZERO; 3 * n];
    for (t, px) in pixels.iter().enumerate() {
        for (c, &v) in px.iter().enumerate() {
            line[c * n + t] = T::from_f32(v);
        }
    }
    let params = EpiParams {
        chroma: keep,
        chroma_knee: knee,
        ..EpiParams::default()
    };
    mix_chroma(color, 3, Chroma::of(&params), n, &mut line);
    (0..n)
        .map(|t| [0, 1, 2].map(|c| line[c * n + t].to_f32()))
        .collect()
}

/// The chroma weight keeps each pixel's channel mean (the gray plane of the coarse
/// search), scales the channels' differences from it by `chroma` without a knee, and
/// with a knee keeps strong colour nearly whole while weak colour takes `chroma`.
fn chroma_weights<T: Scalar>(tolerance: f32) {
    let s = INTENSITY_SCALE;
    // Weak colour (0.01 of unit intensity), strong colour (0.4), a gray pixel.
    let pixels = [
        [0.30 * s, 0.31 * s, 0.29 * s],
        [0.60 * s, 0.20 * s, 0.20 * s],
        [0.50 * s, 0.50 * s, 0.50 * s],
    ];
    let mean = |p: &[f32; 3]| (p[0] + p[1] + p[2]) / 3.0;
    let close = |a: f32, b: f32| (a - b).abs() <= tolerance * s;
    // chroma 1 and the gray mode leave the line bit for bit as loaded.
    for (keep, color) in [(1.0, ColorMode::Tensor), (0.0, ColorMode::Gray)] {
        let got = mixed::<T>(&pixels, keep, 0.0, color);
        for (g, p) in got.iter().zip(&pixels) {
            assert_eq!(g.map(T::from_f32), p.map(T::from_f32));
        }
    }
    for keep in [0.0f32, 0.5] {
        let got = mixed::<T>(&pixels, keep, 0.0, ColorMode::Tensor);
        for (g, p) in got.iter().zip(&pixels) {
            let m = mean(p);
            assert!(close(mean(g), m), "mean {g:?} vs {p:?}");
            for c in 0..3 {
                assert!(
                    close(g[c], m + keep * (p[c] - m)),
                    "keep {keep}: {g:?} vs {p:?}"
                );
            }
        }
    }
    // Knee 0.3 (saturation): the saturated colour's weight ≥ 0.9, the pale one's ≤ 0.03
    // (keep 0); the same at a tenth of the brightness, where only the ratio counts.
    let weight = |g: &[f32; 3], p: &[f32; 3]| (g[1] - mean(g)) / (p[1] - mean(p));
    for dim in [1.0f32, 0.1] {
        let pixels = pixels.map(|p| p.map(|v| v * dim));
        let got = mixed::<T>(&pixels, 0.0, 0.3, ColorMode::Tensor);
        assert!(weight(&got[1], &pixels[1]) >= 0.9, "{dim}: {:?}", got[1]);
        assert!(
            weight(&got[0], &pixels[0]).abs() <= 0.03,
            "{dim}: {:?}",
            got[0]
        );
    }
    let got = mixed::<T>(&pixels, 0.0, 0.3, ColorMode::Tensor);
    assert!(close(mean(&got[0]), mean(&pixels[0])));
    assert!(close(mean(&got[1]), mean(&pixels[1])));
    for c in 0..3 {
        assert!(
            close(got[2][c], pixels[2][c]),
            "gray stays gray: {:?}",
            got[2]
        );
    }
}

#[test]
fn the_chroma_weight_keeps_the_mean_and_scales_weak_colour() {
    chroma_weights::<f32>(1e-6);
    chroma_weights::<Q16>(1e-3);
}

/// A dim gray texture with independent noise in each channel: all its colour is noise.
/// Scaling weak colour out of the tensor (chroma 0, knee 0.3) estimates the plane more
/// closely than the plain R, G, B tensor, and stays within the range.
#[test]
fn weak_colour_out_of_the_tensor_steadies_a_dim_noisy_plane() {
    let mut scene = strips(Grid::new(9, 9), 48, 40, 3, 0.7, &[]);
    let grain = noise(scene.data.len(), 7);
    for (px, g) in scene.data.chunks_mut(3).zip(grain.chunks(3)) {
        let gray = px[0];
        for (v, n) in px.iter_mut().zip(g) {
            *v = 0.1 + 0.1 * gray + 0.03 * (n - 0.5);
        }
    }
    let error = |d: &[f32]| {
        d.iter()
            .zip(&scene.gt)
            .map(|(a, b)| (a - b).abs())
            .sum::<f32>()
            / d.len() as f32
    };
    let plain = run::<f32>(&scene, fixed(-2.0, 2.0)).0;
    let weighted = run::<f32>(
        &scene,
        EpiParams {
            chroma: 0.0,
            chroma_knee: 0.3,
            ..fixed(-2.0, 2.0)
        },
    )
    .0;
    assert!(weighted.iter().all(|v| (-2.0..=2.0).contains(v)));
    assert!(
        error(&weighted) < 0.93 * error(&plain),
        "mean error {} (weak colour out) vs {} (plain tensor)",
        error(&weighted),
        error(&plain)
    );
}
