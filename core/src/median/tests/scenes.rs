//! The median's behaviour on small scenes: colour edges, thin structures, smooth ramps,
//! bad parameters and non-finite values.

use super::*;
use crate::lightfield::LightField;

/// A vertical colour edge at x = 16 (dark left, bright right) and a disparity edge
/// fattened 3 px into the dark side: the median moves the depth edge onto the colour
/// edge and leaves everything else alone.
#[test]
fn fattened_depth_edge_snaps_to_colour_edge() {
    let (w, h) = (32usize, 24usize);
    let stage = stage_for(w, h, MedianParams::default());
    let mut views = [0u8; 9 * 32 * 24];
    let centre = 4 * w * h;
    for y in 0..h {
        for x in 0..w {
            views[centre + y * w + x] = if x < 16 { 40 } else { 200 };
        }
    }
    let lf = LightField::new(&views, *stage.layout()).unwrap();
    let mut input = [0.0f32; 32 * 24];
    for y in 0..h {
        for x in 0..w {
            input[y * w + x] = if x >= 13 { 1.5 } else { -0.5 };
        }
    }
    let mut out = [0.0f32; 32 * 24];
    filter(
        stage.setup(),
        &lf.center_view(),
        &input,
        &mut out,
        &mut vec![0.0; scratch_len(stage.setup())],
    )
    .unwrap();
    for y in 0..h {
        for x in 0..w {
            let want = if x >= 16 { 1.5 } else { -0.5 };
            assert_eq!(out[y * w + x], want, "({x}, {y})");
        }
    }
}

/// A two-pixel pole 16 levels brighter than the background (colour weight ≈ 0.29: the
/// background's 195 pixels of a window outweigh the pole's 30) and a short blotch of
/// the same colour and disparity: without the thin-structure test the median erases
/// both; with it the pole, long and narrow and of its own colour, keeps its disparity
/// and the blotch (4 rows, shorter than r + 1) is still erased.
#[test]
fn thin_structures_keep_their_value_and_short_blotches_do_not() {
    let (w, h) = (32usize, 24usize);
    let mut views = [0u8; 9 * 32 * 24];
    let centre = 4 * w * h;
    let mut input = [-1.0f32; 32 * 24];
    let pole = |x: usize| x == 10 || x == 11;
    let blotch = |x: usize, y: usize| (23..25).contains(&x) && (10..14).contains(&y);
    for y in 0..h {
        for x in 0..w {
            let on = pole(x) || blotch(x, y);
            views[centre + y * w + x] = if on { 76 } else { 60 } + (x * 7 + y * 3) as u8 % 3;
            if on {
                input[y * w + x] = 1.0;
            }
        }
    }
    let run = |params: MedianParams| {
        let stage = stage_for(w, h, params);
        let lf = LightField::new(&views, *stage.layout()).unwrap();
        let mut out = [0.0f32; 32 * 24];
        filter(
            stage.setup(),
            &lf.center_view(),
            &input,
            &mut out,
            &mut vec![0.0; scratch_len(stage.setup())],
        )
        .unwrap();
        out
    };
    let without = run(MedianParams {
        thin: 0.0,
        ..MedianParams::default()
    });
    let with = run(MedianParams::default());
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            assert_eq!(without[i], -1.0, "without the test ({x}, {y})");
            let want = if pole(x) { 1.0 } else { -1.0 };
            assert_eq!(with[i], want, "with the test ({x}, {y})");
        }
    }
}

#[test]
fn smooth_ramp_is_kept_and_bands_are_bit_identical() {
    let (w, h) = (24usize, 20usize);
    // No gate: every pixel goes through the median.
    let stage = stage_for(
        w,
        h,
        MedianParams {
            gate: 0.0,
            ..MedianParams::default()
        },
    );
    let mut views = [0u8; 9 * 24 * 20];
    for (i, v) in views.iter_mut().enumerate() {
        *v = (i * 7 % 13) as u8 + 100;
    }
    let lf = LightField::new(&views, *stage.layout()).unwrap();
    let mut input = [0.0f32; 24 * 20];
    for y in 0..h {
        for x in 0..w {
            input[y * w + x] = 0.01 * x as f32 + 0.02 * y as f32;
        }
    }
    let mut whole = [0.0f32; 24 * 20];
    filter(
        stage.setup(),
        &lf.center_view(),
        &input,
        &mut whole,
        &mut vec![0.0; scratch_len(stage.setup())],
    )
    .unwrap();
    // Interior pixels (full symmetric window) keep their value on a plane.
    let r = MedianParams::default().radius;
    for y in r..h - r {
        for x in r..w - r {
            assert!((whole[y * w + x] - input[y * w + x]).abs() < 1e-6);
        }
    }
    let mut banded = [0.0f32; 24 * 20];
    for start in (0..h).step_by(3) {
        let end = (start + 3).min(h);
        filter_rows(
            stage.setup(),
            &lf.center_view(),
            &input,
            start..end,
            &mut banded[start * w..end * w],
            &mut vec![0.0; scratch_len(stage.setup())],
        )
        .unwrap();
    }
    assert_eq!(whole, banded);
}

#[test]
fn bad_parameters_and_sizes_are_errors() {
    let layout = Layout::packed(Grid::new(3, 3), 16, 16, 1);
    for bad in [
        MedianParams {
            radius: 0,
            ..MedianParams::default()
        },
        MedianParams {
            radius: 8,
            ..MedianParams::default()
        },
        MedianParams {
            color_sigma: f32::NAN,
            ..MedianParams::default()
        },
        MedianParams {
            gate: -1.0,
            ..MedianParams::default()
        },
    ] {
        assert!(matches!(
            Setup::new(&layout, &bad),
            Err(Error::InvalidParameter { .. })
        ));
    }
    let stage = stage_for(16, 16, MedianParams::default());
    let views = [0u8; 9 * 256];
    let lf = LightField::new(&views, *stage.layout()).unwrap();
    let input = [0.0f32; 256];
    let mut out = [0.0f32; 255];
    assert!(filter(
        stage.setup(),
        &lf.center_view(),
        &input,
        &mut out,
        &mut vec![0.0; scratch_len(stage.setup())]
    )
    .is_err());
    let mut out = [0.0f32; 256];
    assert!(filter(
        stage.setup(),
        &lf.center_view(),
        &input[..10],
        &mut out,
        &mut vec![0.0; scratch_len(stage.setup())]
    )
    .is_err());
    assert!(matches!(
        filter(
            stage.setup(),
            &lf.center_view(),
            &input,
            &mut out,
            &mut vec![0.0; scratch_len(stage.setup()) - 1]
        ),
        Err(Error::ScratchTooSmall { .. })
    ));
    assert!(filter_rows(
        stage.setup(),
        &lf.center_view(),
        &input,
        10..17,
        &mut out[..112],
        &mut vec![0.0; scratch_len(stage.setup())]
    )
    .is_err());
}

#[test]
fn non_finite_values_pass_through_and_stay_out_of_neighbours() {
    let stage = stage_for(16, 16, MedianParams::default());
    let views = [128u8; 9 * 256];
    let lf = LightField::new(&views, *stage.layout()).unwrap();
    let mut input = [0.25f32; 256];
    input[17] = f32::NAN;
    input[40] = f32::INFINITY;
    let mut out = [0.0f32; 256];
    filter(
        stage.setup(),
        &lf.center_view(),
        &input,
        &mut out,
        &mut vec![0.0; scratch_len(stage.setup())],
    )
    .unwrap();
    assert!(out[17].is_nan());
    assert_eq!(out[40], f32::INFINITY);
    for (i, v) in out.iter().enumerate() {
        if i != 17 && i != 40 {
            assert_eq!(*v, 0.25);
        }
    }
}
