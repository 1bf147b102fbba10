//! Tests of the refill.

use super::band::within_band;
use super::*;
use crate::lightfield::{Grid, Layout, LightField};
use crate::setup::TestSetup;

const W: usize = 48;
const H: usize = 24;

fn stage() -> TestSetup<GeoFillParams> {
    let params = GeoFillParams {
        enabled: true,
        ..GeoFillParams::default()
    };
    TestSetup::new(Layout::packed(Grid::new(3, 3), W, H, 3), params)
}

/// A 3×3 grid whose every view is the centre image (only the centre is read).
fn light_field(image: &[u8]) -> Vec<u8> {
    image.repeat(9)
}

#[test]
fn band_distance_is_the_city_block_distance_up_to_the_band() {
    let (w, h, band) = (23usize, 17usize, 4usize);
    let steps = [(0usize, 0usize), (11, 8), (22, 3), (5, 16), (6, 16)];
    let mut dist = vec![f32::INFINITY; w * h];
    for &(x, y) in &steps {
        dist[y * w + x] = 0.0;
    }
    let mut row = vec![0.0; w];
    within_band(&mut dist, w, band, &mut row);
    for y in 0..h {
        for x in 0..w {
            let exact = steps
                .iter()
                .map(|&(sx, sy)| (sx.abs_diff(x) + sy.abs_diff(y)) as f32)
                .fold(f32::INFINITY, f32::min);
            let got = dist[y * w + x];
            if exact <= band as f32 {
                assert_eq!(got, exact, "({x}, {y})");
            } else {
                assert!(got > band as f32, "({x}, {y}): {got}");
            }
        }
    }
}

#[test]
fn fattened_step_moves_to_the_colour_edge() {
    let stage = stage();
    // Bright foreground x < 20, dark background beyond; the disparity's step sits
    // 5 px into the background.
    let mut image = vec![0u8; W * H * 3];
    for y in 0..H {
        for x in 0..W {
            let level = if x < 20 { 200 } else { 30 };
            image[(y * W + x) * 3..(y * W + x) * 3 + 3].fill(level);
        }
    }
    let data = light_field(&image);
    let lf = LightField::new(&data, *stage.layout()).unwrap();
    let input: Vec<f32> = (0..W * H)
        .map(|i| if i % W < 25 { 2.0 } else { 0.5 })
        .collect();
    let mut out = vec![0.0f32; W * H];
    let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
    fill(
        stage.setup(),
        &lf.center_view(),
        &input,
        &mut out,
        &mut scratch,
    )
    .unwrap();
    for y in 0..H {
        for x in 0..W {
            let want = if x < 20 { 2.0 } else { 0.5 };
            assert_eq!(out[y * W + x], want, "({x}, {y})");
        }
    }
}

#[test]
fn slanted_band_is_extrapolated_along_the_seed_slope() {
    let mut params = *stage().params();
    params.planar = true;
    params.band = 8;
    let stage = TestSetup::new(*stage().layout(), params);
    let mut image = vec![0u8; W * H * 3];
    for (i, px) in image.chunks_exact_mut(3).enumerate() {
        px.fill(if i % W < 20 { 200 } else { 30 });
    }
    let data = light_field(&image);
    let lf = LightField::new(&data, *stage.layout()).unwrap();
    // Background slants by 0.01 px per column; the foreground (2.0) is fattened to
    // x < 24.
    let bg = |x: usize| 0.5 + 0.01 * x as f32;
    let input: Vec<f32> = (0..W * H)
        .map(|i| if i % W < 24 { 2.0 } else { bg(i % W) })
        .collect();
    let mut out = vec![0.0f32; W * H];
    let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
    fill(
        stage.setup(),
        &lf.center_view(),
        &input,
        &mut out,
        &mut scratch,
    )
    .unwrap();
    for x in 20..W {
        assert!(
            (out[5 * W + x] - bg(x)).abs() < 1e-4,
            "x {x}: {}",
            out[5 * W + x]
        );
    }
}

#[test]
fn thin_structure_inside_a_band_keeps_its_value() {
    let stage = stage();
    let bar = |x: usize, y: usize| (18..20).contains(&x) && (8..13).contains(&y);
    let mut image = vec![0u8; W * H * 3];
    for (i, px) in image.chunks_exact_mut(3).enumerate() {
        let (x, y) = (i % W, i / W);
        px.fill(if x < 10 || bar(x, y) { 200 } else { 30 });
    }
    let data = light_field(&image);
    let lf = LightField::new(&data, *stage.layout()).unwrap();
    // The foreground (x < 10) is fattened to x < 15, within a band's reach of a
    // short bright bar at disparity 3 whose own steps sit on colour edges.
    let input: Vec<f32> = (0..W * H)
        .map(|i| match (i % W, i / W) {
            (x, y) if bar(x, y) => 3.0,
            (x, _) if x < 15 => 2.0,
            _ => 0.5,
        })
        .collect();
    let mut out = vec![0.0f32; W * H];
    let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
    fill(
        stage.setup(),
        &lf.center_view(),
        &input,
        &mut out,
        &mut scratch,
    )
    .unwrap();
    for y in 0..H {
        for x in 0..W {
            let want = if bar(x, y) {
                3.0
            } else if x < 10 {
                2.0
            } else {
                0.5
            };
            assert_eq!(out[y * W + x], want, "({x}, {y})");
        }
    }
}

#[test]
fn step_on_a_colour_edge_is_left_alone() {
    let stage = stage();
    let mut image = vec![0u8; W * H * 3];
    for (i, px) in image.chunks_exact_mut(3).enumerate() {
        px.fill(if i % W < 20 { 200 } else { 30 });
    }
    let data = light_field(&image);
    let lf = LightField::new(&data, *stage.layout()).unwrap();
    // The step sits on the colour edge: nothing to move.
    let input: Vec<f32> = (0..W * H)
        .map(|i| if i % W < 20 { 2.0 } else { 0.5 })
        .collect();
    let mut out = vec![0.0f32; W * H];
    let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
    fill(
        stage.setup(),
        &lf.center_view(),
        &input,
        &mut out,
        &mut scratch,
    )
    .unwrap();
    assert_eq!(out, input);
}

#[test]
fn map_without_steps_is_unchanged() {
    let stage = stage();
    let image: Vec<u8> = (0..W * H * 3).map(|i| (i * 37 % 251) as u8).collect();
    let data = light_field(&image);
    let lf = LightField::new(&data, *stage.layout()).unwrap();
    // Smooth slant: every neighbour step is below 0.3 px.
    let mut input: Vec<f32> = (0..W * H)
        .map(|i| 0.1 * (i % W) as f32 + 0.05 * (i / W) as f32)
        .collect();
    input[7] = f32::NAN;
    let mut out = vec![0.0f32; W * H];
    let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
    fill(
        stage.setup(),
        &lf.center_view(),
        &input,
        &mut out,
        &mut scratch,
    )
    .unwrap();
    for (a, b) in out.iter().zip(&input) {
        assert_eq!(a.to_bits(), b.to_bits());
    }
}

#[test]
fn short_scratch_and_wrong_sizes_are_errors() {
    let stage = stage();
    let data = vec![0u8; W * H * 3 * 9];
    let lf = LightField::new(&data, *stage.layout()).unwrap();
    let input = vec![0.0f32; W * H];
    let mut out = vec![0.0f32; W * H];
    let mut scratch = vec![0.0f32; scratch_len(stage.setup()) - 1];
    assert!(matches!(
        fill(
            stage.setup(),
            &lf.center_view(),
            &input,
            &mut out,
            &mut scratch
        ),
        Err(Error::ScratchTooSmall { .. })
    ));
    let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
    assert!(matches!(
        fill(
            stage.setup(),
            &lf.center_view(),
            &input[1..],
            &mut out,
            &mut scratch
        ),
        Err(Error::OutputSize { .. })
    ));
}

#[test]
fn parameters_are_checked() {
    let ok = GeoFillParams::default();
    assert!(ok.validate().is_ok());
    for bad in [
        GeoFillParams { band: 0, ..ok },
        GeoFillParams { reach: 4, ..ok },
        GeoFillParams {
            step: f32::NAN,
            ..ok
        },
        GeoFillParams {
            spatial: -1.0,
            ..ok
        },
        GeoFillParams { sweeps: 0, ..ok },
        GeoFillParams {
            max_cost: 0.0,
            ..ok
        },
    ] {
        assert!(matches!(
            bad.validate(),
            Err(Error::InvalidParameter { .. })
        ));
    }
}
