extern crate std;
use std::vec;
use std::vec::Vec;

use super::fixedpoint::{fixed, window_sum};
use super::rows::unit_row;
use super::*;
use crate::lightfield::{Grid, Layout};
use crate::setup::TestSetup;

/// Smooth band-limited texture (frequencies ≤ 1.1 rad/px), distinct per channel.
fn texture(x: f32, y: f32, channel: usize) -> f32 {
    let p = channel as f32 * 0.9;
    0.5 + 0.18 * libm::sinf(0.83 * x + 0.31 * y + p)
        + 0.12 * libm::sinf(0.29 * x - 0.67 * y + 2.0 * p)
        + 0.08 * libm::sinf(1.1 * x + 0.9 * y - p)
        + 0.07 * libm::sinf(0.17 * x + 1.05 * y + 0.5 * p)
}

/// A textured plane of disparity `a + b·x` (x of the centre view), rendered exactly on a
/// 9×9 grid: view `(u, v)` shows at `(x', y')` the centre's point `X` with
/// `x' = X − (a + b·X)·u`, `y' = Y − (a + b·X)·v`.
fn plane(width: usize, height: usize, a: f32, b: f32) -> (Vec<f32>, Layout, Vec<f32>) {
    let grid = Grid::new(9, 9);
    let layout = Layout::packed(grid, width, height, 3);
    let (r0, c0) = grid.center();
    let mut data = Vec::with_capacity(grid.len() * width * height * 3);
    for r in 0..grid.rows {
        for c in 0..grid.cols {
            let (v, u) = (r as f32 - r0 as f32, c as f32 - c0 as f32);
            for y in 0..height {
                for x in 0..width {
                    let big_x = (x as f32 + a * u) / (1.0 - b * u);
                    let big_y = y as f32 + (a + b * big_x) * v;
                    for ch in 0..3 {
                        data.push(texture(big_x, big_y, ch));
                    }
                }
            }
        }
    }
    let gt = (0..height)
        .flat_map(|_| (0..width).map(move |x| a + b * x as f32))
        .collect();
    (data, layout, gt)
}

/// The whole map, band by band (`band` rows at a time).
fn estimate(
    setup: &TestSetup<PlaneSweepParams>,
    lf: &LightField<'_, f32>,
    range: (f32, f32),
    band: usize,
) -> (Vec<f32>, Vec<f32>) {
    estimate_with(setup, lf, range, band, true)
}

/// [`estimate`] of any sample type, the views' rows kept per band or converted per
/// hypothesis.
fn estimate_with<S: Sample>(
    setup: &TestSetup<PlaneSweepParams>,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    band: usize,
    keep_rows: bool,
) -> (Vec<f32>, Vec<f32>) {
    let (width, height) = (setup.layout().width, setup.layout().height);
    let mut d = vec![f32::NAN; width * height];
    let mut c = vec![f32::NAN; width * height];
    let mut scratch = vec![f32::NAN; scratch_len(setup.setup())];
    for_each_band(height, band, |rows| {
        let span = rows.start * width..rows.end * width;
        estimate_band(
            setup.setup(),
            range,
            lf,
            rows,
            SweepOut {
                map: DisparityOut {
                    disparity: &mut d[span.clone()],
                    confidence: &mut c[span],
                },
                candidate: None,
            },
            &mut scratch,
            keep_rows,
        )
        .unwrap();
    });
    (d, c)
}

/// Calls `band_rows` on each run of `band` rows of a `height`-row map, top to bottom
/// (the last one shorter).
fn for_each_band(height: usize, band: usize, mut band_rows: impl FnMut(core::ops::Range<usize>)) {
    let mut start = 0;
    while start < height {
        let end = (start + band).min(height);
        band_rows(start..end);
        start = end;
    }
}

/// Share of the pixels (8 px from the border) within `tolerance` of the truth.
fn within(d: &[f32], gt: &[f32], width: usize, tolerance: f32) -> f32 {
    let height = d.len() / width;
    let (mut good, mut all) = (0, 0);
    for y in 8..height - 8 {
        for x in 8..width - 8 {
            all += 1;
            if (d[y * width + x] - gt[y * width + x]).abs() <= tolerance {
                good += 1;
            }
        }
    }
    good as f32 / all as f32
}

fn enabled() -> PlaneSweepParams {
    PlaneSweepParams {
        enabled: true,
        ..PlaneSweepParams::default()
    }
}

/// Fronto-parallel planes at −1.3, 0, 0.8 and 2.6 px, swept with `params` over ±3 px:
/// ≥ 99 % of the pixels within 0.05 px, confidences in [0, 1], disparities in the range.
fn assert_fronto_parallel_planes_recovered(params: PlaneSweepParams) {
    for a in [-1.3f32, 0.0, 0.8, 2.6] {
        let (data, layout, gt) = plane(64, 48, a, 0.0);
        let lf = LightField::new(&data[..], layout).unwrap();
        let setup = TestSetup::new(layout, params);
        let (d, c) = estimate(&setup, &lf, (-3.0, 3.0), BAND_ROWS);
        let share = within(&d, &gt, 64, 0.05);
        assert!(share >= 0.99, "disparity {a}: {share} within 0.05 px");
        assert!(c.iter().all(|c| (0.0..=1.0).contains(c)));
        assert!(d.iter().all(|d| (-3.0..=3.0).contains(d)));
    }
}

#[test]
fn fronto_parallel_planes_are_recovered() {
    assert_fronto_parallel_planes_recovered(enabled());
}

#[test]
fn a_slanted_plane_is_recovered() {
    // −1.2 px at the left edge to +0.06 px at the right: 0.02 px per pixel.
    let (data, layout, gt) = plane(64, 48, -1.2, 0.02);
    let lf = LightField::new(&data[..], layout).unwrap();
    let setup = TestSetup::new(layout, enabled());
    let (d, _) = estimate(&setup, &lf, (-2.0, 1.0), BAND_ROWS);
    let share = within(&d, &gt, 64, 0.07);
    assert!(share >= 0.95, "{share} within 0.07 px");
}

#[test]
fn any_banding_gives_the_same_bits() {
    let (data, layout, _) = plane(40, 70, -0.4, 0.015);
    let lf = LightField::new(&data[..], layout).unwrap();
    let setup = TestSetup::new(layout, enabled());
    let (d, c) = estimate(&setup, &lf, (-1.5, 1.5), BAND_ROWS);
    for band in [1, 7, 13] {
        let (bd, bc) = estimate(&setup, &lf, (-1.5, 1.5), band);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&bd), bits(&d), "bands of {band} rows");
        assert_eq!(bits(&bc), bits(&c), "bands of {band} rows");
    }
}

/// Sweeps a slanted plane of 24×200 pixels with `params` over ±1.5 and ±9 px from
/// `f32` and from 8-bit views, with the views' rows kept per band (where
/// [`keeps_rows`]) and converted per hypothesis, and asserts that both give the same
/// bits; returns each range's `f32` and 8-bit disparity bits. 200 rows: at ±9 px the
/// outer column views reach beyond the rows the scratch keeps for them (sized for ±8
/// px), so those views are read from the light field.
fn assert_kept_rows_give_the_bits_of_conversion(params: PlaneSweepParams) -> Vec<[Vec<u32>; 2]> {
    let (data, layout, _) = plane(24, 200, -0.4, 0.015);
    let levels: Vec<u8> = data
        .iter()
        .map(|&v| libm::roundf(v * 255.0).clamp(0.0, 255.0) as u8)
        .collect();
    let lf = LightField::new(&data[..], layout).unwrap();
    let lf8 = LightField::new(&levels[..], layout).unwrap();
    let setup = TestSetup::new(layout, params);
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let mut maps = Vec::new();
    for range in [(-1.5, 1.5), (-9.0, 9.0)] {
        let kept = estimate_with(&setup, &lf, range, BAND_ROWS, true);
        let converted = estimate_with(&setup, &lf, range, BAND_ROWS, false);
        assert_eq!(bits(&kept.0), bits(&converted.0), "f32, {range:?}");
        assert_eq!(bits(&kept.1), bits(&converted.1), "f32, {range:?}");
        let kept8 = estimate_with(&setup, &lf8, range, BAND_ROWS, true);
        let converted8 = estimate_with(&setup, &lf8, range, BAND_ROWS, false);
        assert_eq!(bits(&kept8.0), bits(&converted8.0), "u8, {range:?}");
        assert_eq!(bits(&kept8.1), bits(&converted8.1), "u8, {range:?}");
        maps.push([bits(&kept.0), bits(&kept8.0)]);
    }
    maps
}

#[test]
fn bad_parameters_are_named() {
    let bad = [
        (
            "sweep.step",
            PlaneSweepParams {
                step: 0.0,
                ..enabled()
            },
        ),
        (
            "sweep.step",
            PlaneSweepParams {
                step: f32::NAN,
                ..enabled()
            },
        ),
        (
            "sweep.radius",
            PlaneSweepParams {
                radius: MAX_RADIUS + 1,
                ..enabled()
            },
        ),
        (
            "sweep.truncate",
            PlaneSweepParams {
                truncate: 0.0,
                ..enabled()
            },
        ),
        (
            "sweep.select",
            PlaneSweepParams {
                select: 0.9,
                ..enabled()
            },
        ),
        (
            "sweep.line",
            PlaneSweepParams {
                line: 0,
                ..enabled()
            },
        ),
        (
            "sweep.line",
            PlaneSweepParams {
                line: MAX_LINE + 1,
                ..enabled()
            },
        ),
        (
            "sweep.trust",
            PlaneSweepParams {
                trust: 1.5,
                ..enabled()
            },
        ),
        (
            "sweep.trust",
            PlaneSweepParams {
                trust: f32::NAN,
                ..enabled()
            },
        ),
        (
            "sweep.candidate",
            PlaneSweepParams {
                candidate: 2,
                ..enabled()
            },
        ),
        (
            "sweep.candidate",
            PlaneSweepParams {
                candidate: MAX_CANDIDATE + 2,
                ..enabled()
            },
        ),
    ];
    for (name, params) in bad {
        match params.validate() {
            Err(Error::InvalidParameter { name: got, .. }) => assert_eq!(got, name),
            other => panic!("{name}: {other:?}"),
        }
    }
    enabled().validate().unwrap();
}

#[test]
fn bad_calls_are_errors() {
    let (data, layout, _) = plane(32, 40, 0.5, 0.0);
    let lf = LightField::new(&data[..], layout).unwrap();
    let setup = TestSetup::new(layout, enabled());
    let mut d = vec![0.0; 32 * 8];
    let mut c = vec![0.0; 32 * 8];
    let mut scratch = vec![0.0; scratch_len(setup.setup())];
    let mut call = |rows: Range<usize>, range: (f32, f32), d: &mut [f32], scratch: &mut [f32]| {
        estimate_rows(
            setup.setup(),
            range,
            &lf,
            rows,
            DisparityOut {
                disparity: d,
                confidence: &mut c,
            },
            scratch,
        )
    };
    call(0..8, (-1.0, 1.0), &mut d, &mut scratch).unwrap();
    assert!(matches!(
        call(36..44, (-1.0, 1.0), &mut d, &mut scratch),
        Err(Error::InvalidParameter { name: "rows", .. })
    ));
    assert!(matches!(
        call(0..8, (1.0, -1.0), &mut d, &mut scratch),
        Err(Error::InvalidParameter { name: "range", .. })
    ));
    assert!(matches!(
        call(0..8, (-1.0, 1.0), &mut d[..10], &mut scratch),
        Err(Error::OutputSize { .. })
    ));
    let short = scratch.len() - 1;
    assert!(matches!(
        call(0..8, (-1.0, 1.0), &mut d, &mut scratch[..short]),
        Err(Error::ScratchTooSmall { .. })
    ));
    let other = Layout::packed(Grid::new(9, 9), 32, 40, 1);
    let wrong = TestSetup::new(other, enabled());
    let result = estimate_rows(
        wrong.setup(),
        (-1.0, 1.0),
        &lf,
        0..8,
        DisparityOut {
            disparity: &mut vec![0.0; 32 * 8],
            confidence: &mut vec![0.0; 32 * 8],
        },
        &mut vec![0.0; scratch_len(wrong.setup())],
    );
    assert!(matches!(
        result,
        Err(Error::InvalidParameter { name: "plan", .. })
    ));
}

#[test]
fn one_hypothesis_is_its_value() {
    let (data, layout, _) = plane(32, 32, 0.5, 0.0);
    let lf = LightField::new(&data[..], layout).unwrap();
    let setup = TestSetup::new(layout, enabled());
    let (d, c) = estimate(&setup, &lf, (0.5, 0.5), BAND_ROWS);
    assert!(d.iter().all(|&d| d == 0.5));
    assert!(c.iter().all(|c| c.is_finite()));
}

#[test]
fn window_sums_by_doubling_are_the_sums_of_their_taps() {
    let a: Vec<i32> = (0..120).map(|i| i * 7919 % 1013).collect();
    for n in [1usize, 2, 3, 5, 9, 16, 17, 33, 65] {
        let width = a.len() + 1 - n;
        let mut out = vec![-1; width];
        let (mut p0, mut p1) = (vec![-1; a.len()], vec![-1; a.len()]);
        window_sum(&a, n, &mut out, &mut p0, &mut p1);
        for (x, &o) in out.iter().enumerate() {
            assert_eq!(o, a[x..x + n].iter().sum::<i32>(), "{n} taps at {x}");
        }
    }
}

#[test]
fn the_largest_windows_of_the_largest_costs_fit_in_i32() {
    // Every view of the largest grid, three channels, each difference at the truncation:
    // the largest pixel cost, summed over the largest window the parameters allow.
    let views = 2 * (crate::lightfield::GRID_MAX - 1);
    for tau in [0.001f32, 0.1, 1.0] {
        for (radius, line) in [
            (MAX_RADIUS, MAX_LINE),
            (MAX_RADIUS, 1),
            (1, MAX_LINE),
            (0, 1),
        ] {
            let (rx, ry) = (radius, radius);
            let taps = ((2 * rx + 1) * (2 * ry + 1)).max(2 * line * radius + 1);
            let terms = views * 3;
            let scale = fixed_scale(taps, terms, tau);
            // The f32 sum of the terms may round up a little.
            let pixel = fixed(terms as f32 * tau * (1.0 + 1.0e-5), scale) as i64;
            let window = pixel * taps as i64;
            assert!(
                window < i32::MAX as i64,
                "τ {tau}, r {radius}, line {line}: {window}"
            );
            // And the unit stays far below the cost of one difference.
            assert!(
                scale * tau > 1.0e3,
                "τ {tau}, r {radius}, line {line}: {scale}"
            );
        }
    }
}

#[test]
fn fixed_point_costs_round_to_the_nearest_unit() {
    for (cost, units) in [
        (0.0f32, 0),
        (0.4, 0),
        (0.6, 1),
        (1.5, 2),
        (2.5, 2),
        (1234.49, 1234),
        (4_194_303.0, 4_194_303),
        (8_388_607.0, 8_388_607),
    ] {
        assert_eq!(fixed(cost, 1.0), units, "{cost}");
    }
    // The scale keeps the largest pixel cost below 2²², where the rounding is exact.
    let scale = fixed_scale(1, 48, 0.1);
    assert!(fixed(4.8, scale) <= 1 << 22);
    assert_eq!(fixed(2.4, scale), 1 << 21);
}

/// A textured bar `width` px wide (across it) running diagonally at disparity `bar` in
/// front of a textured plane at `background`, rendered exactly on a 9×9 grid of
/// `size`² views: view `(u, v)` shows at `(x', y')` the bar's point `(x' + bar·u,
/// y' + bar·v)` where that lies on the bar, else the background's. Returns the views and
/// the centre view's true disparity.
pub(crate) fn diagonal_bar(
    size: usize,
    width: f32,
    bar: f32,
    background: f32,
) -> (Vec<f32>, Layout, Vec<f32>) {
    let grid = Grid::new(9, 9);
    let layout = Layout::packed(grid, size, size, 3);
    let (r0, c0) = grid.center();
    // Across the bar: the distance from the diagonal through the view's centre.
    let middle = size as f32 / 2.0;
    let on_bar = move |x: f32, y: f32| {
        ((x - middle) - (y - middle)).abs() * core::f32::consts::FRAC_1_SQRT_2 <= width / 2.0
    };
    let mut data = Vec::with_capacity(grid.len() * size * size * 3);
    for r in 0..grid.rows {
        for c in 0..grid.cols {
            let (v, u) = (r as f32 - r0 as f32, c as f32 - c0 as f32);
            for y in 0..size {
                for x in 0..size {
                    let (fx, fy) = (x as f32 + bar * u, y as f32 + bar * v);
                    for ch in 0..3 {
                        data.push(if on_bar(fx, fy) {
                            // Its own texture, darker than the background.
                            0.6 * texture(fx + 37.0, fy - 11.0, 2 - ch)
                        } else {
                            texture(x as f32 + background * u, y as f32 + background * v, ch)
                        });
                    }
                }
            }
        }
    }
    let gt = (0..size)
        .flat_map(|y| {
            (0..size).map(move |x| {
                if on_bar(x as f32, y as f32) {
                    bar
                } else {
                    background
                }
            })
        })
        .collect();
    (data, layout, gt)
}

/// The sweep's map and per-pixel candidate of the whole view, band by band.
fn estimate_candidate(
    setup: &TestSetup<PlaneSweepParams>,
    lf: &LightField<'_, f32>,
    range: (f32, f32),
    band: usize,
) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let (width, height) = (setup.layout().width, setup.layout().height);
    let mut d = vec![f32::NAN; width * height];
    let mut c = vec![f32::NAN; width * height];
    let mut k = vec![f32::NAN; width * height];
    let mut scratch = vec![f32::NAN; scratch_len(setup.setup())];
    for_each_band(height, band, |rows| {
        let span = rows.start * width..rows.end * width;
        estimate_rows_with_candidate(
            setup.setup(),
            range,
            lf,
            rows,
            SweepOut {
                map: DisparityOut {
                    disparity: &mut d[span.clone()],
                    confidence: &mut c[span.clone()],
                },
                candidate: Some(&mut k[span]),
            },
            &mut scratch,
        )
        .unwrap();
    });
    (d, c, k)
}

/// Share of the bar's pixels (8 px from the border) within `tolerance` of the truth.
fn on_bar_within(d: &[f32], gt: &[f32], size: usize, bar: f32, tolerance: f32) -> f32 {
    let (mut good, mut all) = (0, 0);
    for y in 8..size - 8 {
        for x in 8..size - 8 {
            let i = y * size + x;
            if gt[i] == bar {
                all += 1;
                if (d[i] - bar).abs() <= tolerance {
                    good += 1;
                }
            }
        }
    }
    assert!(all > 0);
    good as f32 / all as f32
}

#[test]
fn a_thin_diagonal_bar_is_lost_by_the_windows_and_kept_by_the_candidate() {
    let size = 48;
    let (data, layout, gt) = diagonal_bar(size, 2.0, 1.2, -0.6);
    let lf = LightField::new(&data[..], layout).unwrap();
    // The 1×1 candidate keeps the bar; a 3×3 window straddles it and the background
    // (a flatter cost curve), whose confident winners keep less of it.
    for (side, kept) in [(1, 0.8), (3, 0.2)] {
        let setup = TestSetup::new(
            layout,
            PlaneSweepParams {
                candidate: side,
                ..enabled()
            },
        );
        let (d, _, k) = estimate_candidate(&setup, &lf, (-1.5, 1.5), BAND_ROWS);
        let map = on_bar_within(&d, &gt, size, 1.2, 0.25);
        let candidate = on_bar_within(&k, &gt, size, 1.2, 0.25);
        assert!(map < 0.5, "{side}: the map keeps {map} of the bar");
        assert!(candidate > kept, "{side}: the candidate keeps {candidate}");
        assert!(
            candidate > map + 0.15,
            "{side}: {candidate} against the map's {map}"
        );
        // The map is the one without the candidate, bit for bit.
        let plain = TestSetup::new(layout, enabled());
        let (pd, _) = estimate(&plain, &lf, (-1.5, 1.5), BAND_ROWS);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&pd), bits(&d), "{side}");
    }
}

#[test]
fn the_candidate_is_the_same_bits_for_any_banding() {
    let (data, layout, _) = diagonal_bar(40, 2.0, 0.9, -0.4);
    let lf = LightField::new(&data[..], layout).unwrap();
    let setup = TestSetup::new(
        layout,
        PlaneSweepParams {
            candidate: 3,
            ..enabled()
        },
    );
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let (d, c, k) = estimate_candidate(&setup, &lf, (-1.5, 1.5), BAND_ROWS);
    assert!(k.iter().all(|v| (-1.5..=1.5).contains(v)));
    for band in [1, 7, 13] {
        let (bd, bc, bk) = estimate_candidate(&setup, &lf, (-1.5, 1.5), band);
        assert_eq!(bits(&bd), bits(&d), "bands of {band} rows");
        assert_eq!(bits(&bc), bits(&c), "bands of {band} rows");
        assert_eq!(bits(&bk), bits(&k), "bands of {band} rows");
    }
}

#[test]
fn a_candidate_needs_its_window_and_its_output() {
    let (data, layout, _) = plane(32, 16, 0.5, 0.0);
    let lf = LightField::new(&data[..], layout).unwrap();
    let mut d = vec![0.0; 32 * 16];
    let mut c = vec![0.0; 32 * 16];
    let mut k = vec![0.0; 32 * 16];
    for (side, with_output) in [(0, true), (3, false)] {
        let setup = TestSetup::new(
            layout,
            PlaneSweepParams {
                candidate: side,
                ..enabled()
            },
        );
        let out = SweepOut {
            map: DisparityOut {
                disparity: &mut d,
                confidence: &mut c,
            },
            candidate: with_output.then_some(&mut k[..]),
        };
        let result = estimate_rows_with_candidate(
            setup.setup(),
            (-1.0, 1.0),
            &lf,
            0..16,
            out,
            &mut vec![0.0; scratch_len(setup.setup())],
        );
        assert!(
            matches!(
                result,
                Err(Error::InvalidParameter {
                    name: "sweep.candidate",
                    ..
                })
            ),
            "{side}, {with_output}: {result:?}"
        );
    }
    // A candidate row of the wrong length.
    let setup = TestSetup::new(
        layout,
        PlaneSweepParams {
            candidate: 1,
            ..enabled()
        },
    );
    let result = estimate_rows_with_candidate(
        setup.setup(),
        (-1.0, 1.0),
        &lf,
        0..16,
        SweepOut {
            map: DisparityOut {
                disparity: &mut d,
                confidence: &mut c,
            },
            candidate: Some(&mut k[..10]),
        },
        &mut vec![0.0; scratch_len(setup.setup())],
    );
    assert!(
        matches!(result, Err(Error::OutputSize { .. })),
        "{result:?}"
    );
}

fn gray() -> PlaneSweepParams {
    PlaneSweepParams {
        color: SweepColor::Gray,
        ..enabled()
    }
}

#[test]
fn gray_matching_recovers_fronto_parallel_planes() {
    assert_fronto_parallel_planes_recovered(gray());
}

#[test]
fn gray_matching_recovers_a_slanted_plane_from_other_costs_than_rgb() {
    let (data, layout, gt) = plane(64, 48, -1.2, 0.02);
    let lf = LightField::new(&data[..], layout).unwrap();
    let (d, c) = estimate(&TestSetup::new(layout, gray()), &lf, (-2.0, 1.0), BAND_ROWS);
    let share = within(&d, &gt, 64, 0.07);
    assert!(share >= 0.95, "{share} within 0.07 px");
    // One channel's costs, not three: the confidences differ from RGB matching's.
    let rgb = estimate(
        &TestSetup::new(layout, enabled()),
        &lf,
        (-2.0, 1.0),
        BAND_ROWS,
    );
    assert_ne!(c, rgb.1);
}

#[test]
fn gray_matching_gives_the_same_bits_for_any_banding_and_row_conversion() {
    let (data, layout, _) = plane(40, 70, -0.4, 0.015);
    let lf = LightField::new(&data[..], layout).unwrap();
    let setup = TestSetup::new(layout, gray());
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let (d, c) = estimate(&setup, &lf, (-1.5, 1.5), BAND_ROWS);
    for band in [1, 7, 13] {
        let (bd, bc) = estimate(&setup, &lf, (-1.5, 1.5), band);
        assert_eq!(bits(&bd), bits(&d), "bands of {band} rows");
        assert_eq!(bits(&bc), bits(&c), "bands of {band} rows");
    }
    // Kept luminance rows against luminance converted per hypothesis (beyond ±8 px the
    // outer column views are converted per hypothesis in either case).
    for [f32_map, u8_map] in assert_kept_rows_give_the_bits_of_conversion(gray()) {
        // The 8-bit map differs from the f32 one (the kept rows are the samples' own
        // values, not one type's).
        assert_ne!(u8_map, f32_map);
    }
}

#[test]
fn only_luminance_matching_keeps_rows_in_the_scratch() {
    // Luminance rows (one value per pixel) are kept; per-channel matching reads the
    // views' own samples and needs no room for rows, and the estimates above ran in
    // exactly this scratch.
    let (_, layout, _) = plane(64, 48, 0.0, 0.0);
    let rgb_len = scratch_len(TestSetup::new(layout, enabled()).setup());
    let gray_len = scratch_len(TestSetup::new(layout, gray()).setup());
    let grid = layout.grid;
    let rows = cache_rows(grid, height_rows(48, 2 * 4), 48);
    assert!(rows > 0);
    assert_eq!(gray_len - rgb_len, rows * 64);
    // One channel: nothing to average, nothing kept.
    let single = Layout::packed(grid, 64, 48, 1);
    assert_eq!(
        scratch_len(TestSetup::new(single, enabled()).setup()),
        scratch_len(TestSetup::new(single, gray()).setup())
    );
}

#[test]
fn luminance_is_the_mean_of_the_colour_channels_for_any_channel_count() {
    let levels: [u8; 8] = [255, 0, 0, 9, 30, 60, 90, 200];
    let units = levels.map(|l| l as f32 / 255.0);
    // Two channels: both averaged; four: the fourth (alpha) left out; five (the
    // generic path): the first three of the one whole pixel.
    for (channels, want) in [
        (2, &[127.5, 4.5, 45.0, 145.0][..]),
        (3, &[85.0, 33.0][..]),
        (4, &[85.0, 60.0][..]),
        (5, &[85.0][..]),
    ] {
        let mut from_u8 = vec![f32::NAN; want.len()];
        let mut from_f32 = vec![f32::NAN; want.len()];
        let luma = Some(Luma { channels });
        unit_row(&levels[..], &mut from_u8, luma);
        unit_row(&units[..], &mut from_f32, luma);
        for ((&a, &b), &w) in from_u8.iter().zip(&from_f32).zip(want) {
            assert!((a - w / 255.0).abs() < 1e-6, "{channels}: {a} for {w}/255");
            assert!((b - w / 255.0).abs() < 1e-6, "{channels}: {b} for {w}/255");
        }
    }
}
