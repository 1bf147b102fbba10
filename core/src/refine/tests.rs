extern crate std;
use std::vec;
use std::vec::Vec;

use super::*;
use crate::epi::test_scenes::{noise, slanted, strips, Scene};
use crate::lightfield::Grid;
use crate::setup::TestSetup;

fn stage_for(scene: &Scene, refine: RefineParams) -> TestSetup<RefineParams> {
    TestSetup::new(scene.layout, refine)
}

fn run(scene: &Scene, refine: RefineParams, input: &[f32]) -> (Vec<f32>, Vec<f32>) {
    run_in::<f32>(scene, refine, input)
}

/// [`run`] computing in `T`.
fn run_in<T: Scalar>(scene: &Scene, refine: RefineParams, input: &[f32]) -> (Vec<f32>, Vec<f32>) {
    let stage = stage_for(scene, refine);
    let lf = LightField::new(&scene.data, scene.layout).unwrap();
    let mut d = vec![0.0; stage.pixels()];
    let mut c = vec![0.0; stage.pixels()];
    let mut scratch = vec![T::ZERO; scratch_len(stage.setup())];
    super::refine(
        stage.setup(),
        &lf,
        (-4.0, 4.0),
        input,
        DisparityOut {
            disparity: &mut d,
            confidence: &mut c,
        },
        &mut scratch,
    )
    .unwrap();
    (d, c)
}

/// RMS error over pixels `margin` from every border.
fn rms(scene: &Scene, d: &[f32], margin: usize) -> f32 {
    let (w, h) = (scene.layout.width, scene.layout.height);
    let (mut se, mut n) = (0.0f32, 0);
    for y in margin..h - margin {
        for x in margin..w - margin {
            let e = d[y * w + x] - scene.gt[y * w + x];
            se += e * e;
            n += 1;
        }
    }
    (se / n as f32).sqrt()
}

/// The truth with uniform noise of ±`amplitude`.
fn perturbed(scene: &Scene, amplitude: f32, seed: u64) -> Vec<f32> {
    let n = noise(scene.gt.len(), seed);
    scene
        .gt
        .iter()
        .zip(&n)
        .map(|(g, u)| g + (2.0 * u - 1.0) * amplitude)
        .collect()
}

#[test]
fn a_noisy_plane_is_pulled_to_the_truth() {
    for disparity in [-1.3f32, 0.4, 2.1] {
        let scene = strips(Grid::new(9, 9), 48, 40, 3, disparity, &[]);
        let input = perturbed(&scene, 0.3, 7);
        let before = rms(&scene, &input, 10);
        let (d, c) = run(&scene, RefineParams::default(), &input);
        let after = rms(&scene, &d, 10);
        assert!(after < 0.01, "d {disparity}: rms {before} -> {after}");
        let w = scene.layout.width;
        let mid = c[20 * w + 24];
        assert!(mid > 0.9, "confidence {mid} on an exact plane");
    }
}

#[test]
fn many_views_and_oblique_views_pull_a_noisy_plane_to_the_truth() {
    // A 17×17 grid has 32 views in its centre row and column: two chunks of the
    // vectorised sampling; the diagonals take the bilinear path of oblique views.
    for (grid, views) in [
        (Grid::new(17, 17), ViewSet::Cross),
        (Grid::new(9, 9), ViewSet::CrossDiagonals),
        (Grid::new(5, 5), ViewSet::All),
    ] {
        let scene = strips(grid, 40, 36, 3, 0.35, &[]);
        let input = perturbed(&scene, 0.3, 11);
        let before = rms(&scene, &input, 10);
        let refine = RefineParams {
            views,
            ..RefineParams::default()
        };
        let (d, _) = run(&scene, refine, &input);
        let after = rms(&scene, &d, 10);
        assert!(after < 0.01, "{grid:?} {views:?}: rms {before} -> {after}");
    }
}

/// Share of pixels `margin` from every border within `tol` of the truth.
fn share_within(scene: &Scene, d: &[f32], tol: f32, margin: usize) -> f32 {
    let (w, h) = (scene.layout.width, scene.layout.height);
    let (mut good, mut n) = (0, 0);
    for y in margin..h - margin {
        for x in margin..w - margin {
            good += usize::from((d[y * w + x] - scene.gt[y * w + x]).abs() <= tol);
            n += 1;
        }
    }
    good as f32 / n as f32
}

#[test]
fn occluding_strips_are_mostly_pulled_to_the_truth() {
    let scene = strips(Grid::new(9, 9), 60, 40, 3, -0.5, &[0.0, 1.2, 0.0]);
    let input = perturbed(&scene, 0.2, 3);
    let (d, _) = run(&scene, RefineParams::default(), &input);
    let (before, after) = (
        share_within(&scene, &input, 0.07, 10),
        share_within(&scene, &d, 0.07, 10),
    );
    // Uniform ±0.2 noise: 35 % within 0.07 px; the refinement fixes all but the
    // occlusion zones (up to 4 · 1.7 px wide at each edge).
    assert!(after > 0.7 && after > before + 0.3, "{before} -> {after}");
    assert!(d.iter().all(|v| v.is_finite() && (-4.0..=4.0).contains(v)));
}

#[test]
fn bands_and_halos_give_bit_identical_maps() {
    let scene = strips(Grid::new(5, 7), 40, 37, 3, 0.3, &[0.0, 1.0]);
    let input = perturbed(&scene, 0.3, 11);
    let reference = run(&scene, RefineParams::default(), &input);
    for band_rows in [1, 5, 16, 100] {
        let params = RefineParams {
            band_rows,
            iterations: 3,
            radius: 2,
            ..RefineParams::default()
        };
        let wide = RefineParams {
            band_rows: 100,
            ..params
        };
        let (d, c) = run(&scene, params, &input);
        let (dw, cw) = run(&scene, wide, &input);
        assert!(d.iter().zip(&dw).all(|(a, b)| a.to_bits() == b.to_bits()));
        assert!(c.iter().zip(&cw).all(|(a, b)| a.to_bits() == b.to_bits()));
    }
    assert!(reference.0.iter().all(|v| v.is_finite()));
}

#[test]
fn outputs_stay_finite_in_range_on_flat_and_extreme_inputs() {
    let mut scene = strips(Grid::new(3, 3), 20, 18, 1, 0.0, &[]);
    scene.data.iter_mut().for_each(|v| *v = 0.5);
    let stage = stage_for(&scene, RefineParams::default());
    let lf = LightField::new(&scene.data, scene.layout).unwrap();
    let input: Vec<f32> = (0..stage.pixels()).map(|i| (i % 7) as f32 - 3.0).collect();
    let mut d = vec![0.0; stage.pixels()];
    let mut c = vec![0.0; stage.pixels()];
    let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
    super::refine(
        stage.setup(),
        &lf,
        (-1.0, 2.0),
        &input,
        DisparityOut {
            disparity: &mut d,
            confidence: &mut c,
        },
        &mut scratch,
    )
    .unwrap();
    assert!(d.iter().all(|v| (-1.0..=2.0).contains(v)));
    assert!(c.iter().all(|v| (0.0..=1.0).contains(v)));
}

#[test]
fn bad_inputs_are_errors() {
    let scene = strips(Grid::new(3, 3), 20, 18, 1, 0.0, &[]);
    let stage = stage_for(&scene, RefineParams::default());
    let lf = LightField::new(&scene.data, scene.layout).unwrap();
    let mut input = vec![0.0; stage.pixels()];
    let mut d = vec![0.0; stage.pixels()];
    let mut c = vec![0.0; stage.pixels()];
    let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
    let short = scratch.len() - 1;
    assert!(matches!(
        super::refine(
            stage.setup(),
            &lf,
            (-1.0, 1.0),
            &input,
            DisparityOut {
                disparity: &mut d,
                confidence: &mut c
            },
            &mut scratch[..short]
        ),
        Err(Error::ScratchTooSmall { .. })
    ));
    assert!(super::refine(
        stage.setup(),
        &lf,
        (1.0, -1.0),
        &input,
        DisparityOut {
            disparity: &mut d,
            confidence: &mut c
        },
        &mut scratch
    )
    .is_err());
    assert!(super::refine(
        stage.setup(),
        &lf,
        (-1.0, 1.0),
        &input[1..],
        DisparityOut {
            disparity: &mut d,
            confidence: &mut c
        },
        &mut scratch
    )
    .is_err());
    input[5] = f32::NAN;
    assert!(matches!(
        super::refine(
            stage.setup(),
            &lf,
            (-1.0, 1.0),
            &input,
            DisparityOut {
                disparity: &mut d,
                confidence: &mut c
            },
            &mut scratch
        ),
        Err(Error::NonFinite { .. })
    ));
    let mut cancel = |_| ControlFlow::Break(());
    input[5] = 0.0;
    assert_eq!(
        refine_with_progress(
            stage.setup(),
            &lf,
            (-1.0, 1.0),
            &input,
            DisparityOut {
                disparity: &mut d,
                confidence: &mut c
            },
            &mut scratch,
            &mut cancel
        ),
        Err(Error::Cancelled)
    );
    assert!(band_rows(stage.setup(), band_count(stage.setup())).is_err());
}

#[test]
fn propagation_pulls_a_wrong_block_to_its_surroundings() {
    let scene = strips(Grid::new(9, 9), 48, 40, 3, 0.6, &[]);
    let w = scene.layout.width;
    let mut input = scene.gt.clone();
    for y in 14..24 {
        for x in 18..28 {
            input[y * w + x] += 1.3;
        }
    }
    let plain = RefineParams {
        propagation: 0,
        ..RefineParams::default()
    };
    let (without, _) = run(&scene, plain, &input);
    let (with, _) = run(&scene, RefineParams::default(), &input);
    let (a, b) = (
        share_within(&scene, &without, 0.07, 10),
        share_within(&scene, &with, 0.07, 10),
    );
    assert!(a < 0.95, "without propagation {a}");
    assert!(b > 0.99, "with propagation {b}");
}

/// [`refine_band_mapped`] over every band.
fn run_mapped<T: Scalar>(
    scene: &Scene,
    maps: &[Homography],
    how: Interpolation,
    input: &[f32],
) -> Result<Vec<f32>> {
    let stage = stage_for(scene, RefineParams::default());
    let lf = LightField::new(&scene.data, scene.layout).unwrap();
    let w = scene.layout.width;
    let mut d = vec![0.0; stage.pixels()];
    let mut c = vec![0.0; stage.pixels()];
    let mut scratch = vec![T::ZERO; scratch_len(stage.setup())];
    for band in 0..band_count(stage.setup()) {
        let rows = band_rows(stage.setup(), band)?;
        let span = rows.start * w..rows.end * w;
        refine_band_mapped(
            stage.setup(),
            MappedViews {
                lf: &lf,
                homographies: maps,
                interpolation: how,
            },
            (-4.0, 4.0),
            input,
            rows,
            DisparityOut {
                disparity: &mut d[span.clone()],
                confidence: &mut c[span],
            },
            &mut scratch,
        )?;
    }
    Ok(d)
}

#[test]
fn views_read_through_identities_pull_a_noisy_plane_to_the_truth() {
    let scene = strips(Grid::new(9, 9), 48, 40, 3, 0.4, &[]);
    let input = perturbed(&scene, 0.3, 7);
    let identities = vec![Homography::IDENTITY; 81];
    let (plain, _) = run(&scene, RefineParams::default(), &input);
    for how in [Interpolation::Bilinear, Interpolation::CatmullRom] {
        let d = run_mapped::<f32>(&scene, &identities, how, &input).unwrap();
        let (after, rectified) = (rms(&scene, &d, 10), rms(&scene, &plain, 10));
        assert!(
            after < 0.01,
            "{how:?}: rms {after} (rectified path {rectified})"
        );
        let q = run_mapped::<crate::Q16>(&scene, &identities, how, &input).unwrap();
        let after = rms(&scene, &q, 10);
        assert!(after < 0.02, "{how:?}, Q16: rms {after}");
    }
}

#[test]
fn views_read_through_translations_see_the_shifted_plane() {
    // Every view's samples moved by a whole pixel to the right (the homography maps the
    // rectified pixel to the view pixel one to the right): read through the
    // translation, the array is the rectified one again, with one column less.
    let scene = strips(Grid::new(9, 9), 48, 40, 3, -1.3, &[]);
    let layout = scene.layout;
    let mut shifted = scene.data.clone();
    let (w, ch) = (layout.width, layout.channels);
    for view in 0..layout.grid.len() {
        for y in 0..layout.height {
            let row = view * layout.view_stride + y * layout.row_stride;
            for x in (1..w).rev() {
                for c in 0..ch {
                    shifted[row + x * ch + c] = scene.data[row + (x - 1) * ch + c];
                }
            }
        }
    }
    let moved = Scene {
        data: shifted,
        layout,
        gt: scene.gt.clone(),
    };
    let mut right = Homography::IDENTITY;
    right.m[2] = 1.0;
    let maps = vec![right; 81];
    let input = perturbed(&scene, 0.3, 7);
    let d = run_mapped::<f32>(&moved, &maps, Interpolation::Bilinear, &input).unwrap();
    let after = rms(&scene, &d, 10);
    assert!(after < 0.01, "rms {after}");
}

#[test]
fn mapped_refinement_rejects_bad_homographies() {
    let scene = strips(Grid::new(9, 9), 48, 40, 3, 0.4, &[]);
    let input = perturbed(&scene, 0.3, 7);
    let too_few = vec![Homography::IDENTITY; 80];
    assert!(matches!(
        run_mapped::<f32>(&scene, &too_few, Interpolation::Bilinear, &input),
        Err(Error::OutputSize { .. })
    ));
    let mut broken = vec![Homography::IDENTITY; 81];
    broken[3].m[4] = f32::NAN;
    assert!(matches!(
        run_mapped::<f32>(&scene, &broken, Interpolation::Bilinear, &input),
        Err(Error::NonFinite { .. })
    ));
    // A homography that sends everything behind the camera: no view is read, no panic.
    let mut away = vec![Homography::IDENTITY; 81];
    for h in &mut away {
        h.m[8] = 0.0;
    }
    assert!(run_mapped::<f32>(&scene, &away, Interpolation::CatmullRom, &input).is_ok());
}

#[test]
fn settled_windows_give_bit_identical_maps_in_any_band_and_stay_close_to_every_update() {
    // Radius 1: the rows' interior pixels take `update_row`, the sides `window_sum`.
    let scene = strips(Grid::new(9, 9), 40, 37, 3, 0.3, &[0.0, 1.0]);
    let input = perturbed(&scene, 0.3, 5);
    let mut maps = Vec::new();
    for skip_settled in [SKIP_SETTLED, 0.01, 0.0] {
        let wide = RefineParams {
            band_rows: 100,
            skip_settled,
            ..RefineParams::default()
        };
        let (dw, cw) = run(&scene, wide, &input);
        for band_rows in [1, 5, 16] {
            let (d, c) = run(&scene, RefineParams { band_rows, ..wide }, &input);
            assert!(d.iter().zip(&dw).all(|(a, b)| a.to_bits() == b.to_bits()));
            assert!(c.iter().zip(&cw).all(|(a, b)| a.to_bits() == b.to_bits()));
        }
        maps.push((dw, cw));
    }
    let off = &maps[2];
    let most = |a: &[f32], b: &[f32], tol: f32| {
        a.iter()
            .zip(b)
            .filter(|(x, y)| (*x - *y).abs() <= tol)
            .count()
            * 100
            >= 99 * a.len()
    };
    for on in &maps[..2] {
        assert!(most(&on.0, &off.0, 0.01), "disparities");
        assert!(most(&on.1, &off.1, 0.05), "confidences");
    }
}

/// Largest error over pixels `margin` from every border.
fn max_error(scene: &Scene, d: &[f32], margin: usize) -> f32 {
    let (w, h) = (scene.layout.width, scene.layout.height);
    (margin..h - margin)
        .flat_map(|y| (margin..w - margin).map(move |x| y * w + x))
        .map(|i| (d[i] - scene.gt[i]).abs())
        .fold(0.0, f32::max)
}

#[test]
fn a_slanted_window_recovers_a_slanted_plane_that_the_fronto_parallel_window_pulls_off() {
    // 0.08 px per px down the view and 0.03 across: at radius 2 the fronto-parallel
    // window averages targets up to 0.16 px apart, weighted by their texture.
    let scene = slanted(Grid::new(9, 9), (48, 40, 3), 0.3, (0.03, 0.08));
    let input = perturbed(&scene, 0.03, 3);
    for radius in [1, 2] {
        let fronto = RefineParams {
            radius,
            ..RefineParams::default()
        };
        let slant = RefineParams {
            slanted: true,
            ..fronto
        };
        let (df, _) = run(&scene, fronto, &input);
        let (ds, cs) = run(&scene, slant, &input);
        let (ef, es) = (max_error(&scene, &df, 8), max_error(&scene, &ds, 8));
        let (rf, rs) = (rms(&scene, &df, 8), rms(&scene, &ds, 8));
        std::eprintln!("radius {radius}: max |error| {ef} -> {es}, rms {rf} -> {rs}");
        assert!(es < 0.02 && es < 0.5 * ef, "radius {radius}: {ef} -> {es}");
        assert!(rs < 0.5 * rf, "radius {radius}: rms {rf} -> {rs}");
        let w = scene.layout.width;
        assert!(cs[20 * w + 24] > 0.9, "confidence on an exact plane");
    }
}

#[test]
fn a_slanted_window_keeps_fronto_parallel_planes_and_their_edges() {
    let scene = strips(Grid::new(9, 9), 48, 40, 3, 0.4, &[0.0, 1.6, 0.0]);
    let input = perturbed(&scene, 0.3, 7);
    let slant = RefineParams {
        slanted: true,
        ..RefineParams::default()
    };
    let (d, _) = run(&scene, RefineParams::default(), &input);
    let (ds, _) = run(&scene, slant, &input);
    let (good, good_slanted) = (
        share_within(&scene, &d, 0.07, 6),
        share_within(&scene, &ds, 0.07, 6),
    );
    assert!(good_slanted >= good - 0.01, "{good} -> {good_slanted}");
}

#[test]
fn slanted_windows_give_bit_identical_maps_in_any_band_and_agree_in_q16() {
    let scene = slanted(Grid::new(9, 9), (40, 37, 3), -0.2, (-0.05, 0.07));
    let input = perturbed(&scene, 0.1, 9);
    for radius in [1, 2] {
        let wide = RefineParams {
            band_rows: 100,
            radius,
            slanted: true,
            ..RefineParams::default()
        };
        let (dw, cw) = run(&scene, wide, &input);
        for band_rows in [1, 5, 16] {
            let (d, c) = run(&scene, RefineParams { band_rows, ..wide }, &input);
            assert!(d.iter().zip(&dw).all(|(a, b)| a.to_bits() == b.to_bits()));
            assert!(c.iter().zip(&cw).all(|(a, b)| a.to_bits() == b.to_bits()));
        }
        let (dq, _) = run_in::<crate::Q16>(&scene, wide, &input);
        let close = dq
            .iter()
            .zip(&dw)
            .filter(|(q, f)| (*q - *f).abs() <= 0.02)
            .count();
        assert!(
            close * 100 >= 99 * dw.len(),
            "radius {radius}: {close} of {}",
            dw.len()
        );
    }
}

/// Share of pixels of columns `columns` (rows `margin` from the top and bottom) within
/// `tol` of the truth.
fn share_in_columns(scene: &Scene, d: &[f32], columns: Range<usize>, margin: usize) -> f32 {
    let (w, h) = (scene.layout.width, scene.layout.height);
    let (mut good, mut n) = (0, 0);
    for y in margin..h - margin {
        for x in columns.clone() {
            good += usize::from((d[y * w + x] - scene.gt[y * w + x]).abs() <= 0.07);
            n += 1;
        }
    }
    good as f32 / n as f32
}

#[test]
fn the_fused_choice_keeps_each_start_where_it_is_right() {
    // A strip at 1.2 px in front of a background at −0.5 px: the left half, then the
    // background on the right half. Start A is right on the left half and 1.9 px off on
    // the right, start B 1.5 px off on the left and right on the right. The refinement
    // mends neither wrong half (its propagation offers only the other surface's
    // disparity across the edge); the choice must take each half from the right start.
    let scene = strips(Grid::new(9, 9), 64, 40, 3, -0.5, &[1.2, -2.0]);
    let w = scene.layout.width;
    let half = |d: &[f32], left: f32, right: f32| -> Vec<f32> {
        d.iter()
            .enumerate()
            .map(|(i, v)| v + if i % w < w / 2 { left } else { right })
            .collect()
    };
    let a = half(&scene.gt, 0.0, 1.9);
    let b = half(&scene.gt, -1.5, 0.0);
    let (ad, ac) = run(&scene, RefineParams::default(), &a);
    let (bd, bc) = run(&scene, RefineParams::default(), &b);
    // Columns 8 px from the image's sides and from the strip's edge (its occlusion zone).
    let (left, right) = (8..w / 2 - 8, w / 2 + 8..w - 8);
    assert!(share_in_columns(&scene, &ad, right.clone(), 8) < 0.2);
    assert!(share_in_columns(&scene, &bd, left.clone(), 8) < 0.2);
    let stage = stage_for(&scene, RefineParams::default());
    let lf = LightField::new(&scene.data, scene.layout).unwrap();
    let (mut d, mut c) = (bd.clone(), bc.clone());
    let rows = 0..scene.layout.height;
    let out = DisparityOut {
        disparity: &mut d,
        confidence: &mut c,
    };
    choose::<f32, f32>(stage.setup(), &lf, rows.clone(), (&ad, &ac), out).unwrap();
    for (name, columns) in [("left", left), ("right", right)] {
        let share = share_in_columns(&scene, &d, columns, 8);
        assert!(share > 0.95, "{name} half: {share}");
    }
    // Each pixel carries its start's confidence.
    for i in 0..d.len() {
        let from_a = d[i].to_bits() == ad[i].to_bits() && c[i].to_bits() == ac[i].to_bits();
        let from_b = d[i].to_bits() == bd[i].to_bits() && c[i].to_bits() == bc[i].to_bits();
        assert!(from_a || from_b, "pixel {i}");
    }
    // Candidates of the wrong length are an error in words.
    let (mut d, mut c) = (bd.clone(), bc.clone());
    let out = DisparityOut {
        disparity: &mut d,
        confidence: &mut c,
    };
    assert!(matches!(
        choose::<f32, f32>(stage.setup(), &lf, rows, (&ad[1..], &ac), out),
        Err(Error::OutputSize { .. })
    ));
}

/// [`refine_band_from`] over every band of `band_rows` rows, from `start` with the
/// per-pixel `candidate`.
fn run_from(
    data: &[f32],
    layout: crate::lightfield::Layout,
    band_rows: usize,
    start: &[f32],
    candidate: Option<&[f32]>,
) -> Vec<f32> {
    let stage = TestSetup::new(
        layout,
        RefineParams {
            band_rows,
            ..RefineParams::default()
        },
    );
    let lf = LightField::new(data, layout).unwrap();
    let mut d = vec![f32::NAN; stage.pixels()];
    let mut c = vec![f32::NAN; stage.pixels()];
    let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
    let width = layout.width;
    for band in 0..band_count(stage.setup()) {
        let rows = band_rows_of(&stage, band);
        let span = rows.start * width..rows.end * width;
        refine_band_from(
            stage.setup(),
            &lf,
            (-1.5, 1.5),
            Start {
                disparity: start,
                candidate,
            },
            rows,
            DisparityOut {
                disparity: &mut d[span.clone()],
                confidence: &mut c[span],
            },
            &mut scratch,
        )
        .unwrap();
    }
    d
}

fn band_rows_of(stage: &TestSetup<RefineParams>, band: usize) -> Range<usize> {
    super::band_rows(stage.setup(), band).unwrap()
}

/// A 2 px diagonal bar that the start lacks (the background's disparity everywhere) has
/// no neighbour to take its disparity from; its pixels' own candidates, a line of them,
/// bring it back in the first round. Isolated candidates (no neighbour's candidate
/// agrees) are not offered, whatever they cost.
#[test]
fn a_line_of_candidates_brings_back_a_bar_that_no_neighbour_holds() {
    let size = 48;
    let (bar, background) = (1.2, -0.6);
    let (data, layout, gt) = crate::planesweep::tests::diagonal_bar(size, 2.0, bar, background);
    let start = vec![background; size * size];
    let mut candidate = gt.clone();
    // Isolated candidates on the background, every 7th pixel of every 5th row.
    let mut isolated = Vec::new();
    for y in (3..size - 3).step_by(5) {
        for x in (3..size - 3).step_by(7) {
            let i = y * size + x;
            if gt[i] == background && gt[i - 1] == background && gt[i + 1] == background {
                candidate[i] = 1.0;
                isolated.push(i);
            }
        }
    }
    let share = |d: &[f32], pixels: &mut dyn Iterator<Item = usize>, value: f32| {
        let (mut good, mut all) = (0, 0);
        for i in pixels {
            all += 1;
            good += usize::from((d[i] - value).abs() <= 0.1);
        }
        good as f32 / all as f32
    };
    let bar_pixels = || {
        (8 * size..(size - 8) * size)
            .filter(|&i| gt[i] == bar && (8..size - 8).contains(&(i % size)))
    };
    let without = run_from(&data, layout, 128, &start, None);
    let with = run_from(&data, layout, 128, &start, Some(&candidate));
    let (a, b) = (
        share(&without, &mut bar_pixels(), bar),
        share(&with, &mut bar_pixels(), bar),
    );
    assert!(a < 0.3, "without the candidate {a} of the bar");
    assert!(b > 0.8, "with the candidate {b} of the bar");
    let kept = share(&with, &mut isolated.iter().copied(), background);
    assert!(kept > 0.95, "{kept} of the isolated candidates left alone");
    // Any banding: the same bits.
    for band_rows in [5, 16] {
        let banded = run_from(&data, layout, band_rows, &start, Some(&candidate));
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&banded), bits(&with), "bands of {band_rows} rows");
    }
}

#[test]
fn a_bad_candidate_map_is_an_error() {
    let scene = strips(Grid::new(3, 3), 20, 18, 1, 0.0, &[]);
    let stage = stage_for(&scene, RefineParams::default());
    let lf = LightField::new(&scene.data, scene.layout).unwrap();
    let input = vec![0.0; stage.pixels()];
    let mut d = vec![0.0; 20 * 18];
    let mut c = vec![0.0; 20 * 18];
    let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
    let short = vec![0.0; stage.pixels() - 1];
    let mut nan = vec![0.0; stage.pixels()];
    nan[5] = f32::NAN;
    for candidate in [&short, &nan] {
        let result = refine_band_from(
            stage.setup(),
            &lf,
            (-1.0, 1.0),
            Start {
                disparity: &input,
                candidate: Some(candidate),
            },
            0..18,
            DisparityOut {
                disparity: &mut d,
                confidence: &mut c,
            },
            &mut scratch,
        );
        assert!(
            matches!(
                result,
                Err(Error::OutputSize { .. } | Error::NonFinite { .. })
            ),
            "{result:?}"
        );
    }
}
