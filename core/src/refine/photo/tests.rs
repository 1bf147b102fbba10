//! The regular cross against tap by tap, stored taps, and the sampling slack.

extern crate std;
use std::vec::Vec;

use super::*;
use crate::epi::test_scenes::{noise, strips};
use crate::lightfield::Grid;
use crate::scalar::Q16;

/// The 9×9 cross's taps in one pass (`fill_regular`, the group sums side by side)
/// against tap by tap (`fill`): the same bits for every pixel, disparity and bar,
/// borders (where the one pass masks the taps that do not see the pixel and clamps
/// the last samples) included.
fn regular_matches_tap_by_tap<T: Scalar>(slack: f32) {
    let scene = strips(Grid::new(9, 9), 40, 36, 3, 0.6, &[1.8]);
    let regular = Views::<T>::new(&scene.layout, ViewSet::Cross).with_slack(slack);
    assert!(regular.regular, "the 9×9 cross is regular");
    let mut by_tap = Views::<T>::new(&scene.layout, ViewSet::Cross).with_slack(slack);
    by_tap.regular = false;
    let robust = 0.01f32 * 0.01 * 3.0 * INTENSITY_SCALE * INTENSITY_SCALE;
    let stat_robust = (T::from_f32(robust), T::from_f32(4.0 * robust));
    let cost_robust = (T::from_f32(robust), T::from_f32(4096.0 * robust));
    let (w, h) = (scene.layout.width, scene.layout.height);
    let shifts = noise(w * h, 11);
    let mut costs = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let d = T::from_f32(6.0 * shifts[y * w + x] - 3.0);
            let (mut a, mut b) = ([T::ZERO; STATS], [T::ZERO; STATS]);
            regular.pixel(&scene.data, x, y, d, stat_robust, &mut a);
            by_tap.pixel(&scene.data, x, y, d, stat_robust, &mut b);
            assert!(a == b, "statistics differ at ({x}, {y}): {a:?} vs {b:?}");
            let full = regular.cost(&scene.data, x, y, d, cost_robust, None);
            assert_eq!(full, by_tap.cost(&scene.data, x, y, d, cost_robust, None));
            let full = full.unwrap_or(T::ZERO);
            costs.push(full);
            for bar in [full, full + T::from_f32(1.0e-3), full * T::from_f32(0.5)] {
                assert_eq!(
                    regular.cost(&scene.data, x, y, d, cost_robust, Some(bar)),
                    by_tap.cost(&scene.data, x, y, d, cost_robust, Some(bar)),
                    "cost below {bar:?} at ({x}, {y})"
                );
            }
        }
    }
    // The comparison saw real costs, not only empty ones.
    assert!(costs.iter().filter(|&&c| c > T::ZERO).count() > w * h / 2);
}

/// The compact stored oblique taps expand to the values a full tap held: offsets,
/// `h = ½ / reach`, `1 / (2h)` and the groups, in grid order (every view of the
/// largest grid, and a small one).
fn stored_taps_expand_to_full_taps<T: Scalar>() {
    for grid in [Grid::new(GRID_MAX, GRID_MAX), Grid::new(5, 7)] {
        let layout = crate::lightfield::Layout::packed(grid, 8, 6, 3);
        let views = Views::<T>::new(&layout, ViewSet::All);
        let (r0, c0) = grid.center();
        let mut expected = Vec::new();
        for r in 0..grid.rows {
            for c in 0..grid.cols {
                let (dr, dc) = (r as isize - r0 as isize, c as isize - c0 as isize);
                if dr == 0 || dc == 0 {
                    continue;
                }
                let h = 0.5 / (dr.unsigned_abs().max(dc.unsigned_abs()) as f32);
                let vertical = 2 + usize::from(dr > 0);
                expected.push((
                    grid.index(r, c) * layout.view_stride,
                    [dc as f32, dr as f32, h, 0.5 / h].map(T::from_f32),
                    usize::from(dc > 0),
                    Some(vertical),
                ));
            }
        }
        let taps: Vec<_> = views
            .oblique_taps()
            .map(|t| (t.start, [t.du, t.dv, t.h, t.inv], t.group, t.second_group))
            .collect();
        assert_eq!(taps.len(), grid.len() - grid.rows - grid.cols + 1);
        assert!(taps == expected, "{grid:?}: {taps:?} vs {expected:?}");
    }
}

#[test]
fn stored_f32_taps_expand_to_full_taps() {
    stored_taps_expand_to_full_taps::<f32>();
}

#[test]
fn stored_q16_taps_expand_to_full_taps() {
    stored_taps_expand_to_full_taps::<Q16>();
}

#[test]
fn the_regular_cross_gives_the_same_f32_statistics_and_costs_as_tap_by_tap() {
    regular_matches_tap_by_tap::<f32>(0.0);
    regular_matches_tap_by_tap::<f32>(0.5);
}

#[test]
fn the_regular_cross_gives_the_same_q16_statistics_and_costs_as_tap_by_tap() {
    regular_matches_tap_by_tap::<Q16>(0.0);
    regular_matches_tap_by_tap::<Q16>(0.5);
}

/// The sampling slack only forgives: the cost and every group's residual energy
/// with it are at most the plain ones, for the cross and every view; it forgives something on a textured scene; and a view that is the centre
/// view shifted by less than the slack costs nothing at the true disparity (0) where
/// the plain residual does not.
fn slack_only_forgives<T: Scalar>() {
    let scene = strips(Grid::new(5, 5), 32, 28, 3, 0.6, &[1.2]);
    let robust = 0.01f32 * 0.01 * 3.0 * INTENSITY_SCALE * INTENSITY_SCALE;
    let stat_robust = (T::from_f32(robust), T::from_f32(4.0 * robust));
    let cost_robust = (T::from_f32(robust), T::from_f32(4096.0 * robust));
    let (w, h) = (scene.layout.width, scene.layout.height);
    let shifts = noise(w * h, 5);
    for set in [ViewSet::Cross, ViewSet::All] {
        let plain = Views::<T>::new(&scene.layout, set);
        let slack = Views::<T>::new(&scene.layout, set).with_slack(0.5);
        let mut forgiven = 0;
        for y in 0..h {
            for x in 0..w {
                let d = T::from_f32(4.0 * shifts[y * w + x] - 2.0);
                let (mut a, mut b) = ([T::ZERO; STATS], [T::ZERO; STATS]);
                plain.pixel(&scene.data, x, y, d, stat_robust, &mut a);
                slack.pixel(&scene.data, x, y, d, stat_robust, &mut b);
                // Within the rounding of Q16.16's weights (the weight of a large
                // residual is a few LSB, times that residual's energy).
                for g in 0..GROUPS {
                    let (e0, e1) = (a[3 * g + 2], b[3 * g + 2]);
                    let tolerance = T::from_f32(1.0e-3) + e0 * T::from_f32(0.02);
                    assert!(
                        e1 <= e0 + tolerance,
                        "{set:?} energy at ({x}, {y}): {e1:?} > {e0:?}"
                    );
                }
                let c0 = plain.cost(&scene.data, x, y, d, cost_robust, None);
                let c1 = slack.cost(&scene.data, x, y, d, cost_robust, None);
                let (c0, c1) = (c0.unwrap_or(T::ZERO), c1.unwrap_or(T::ZERO));
                let tolerance = T::from_f32(0.05);
                assert!(
                    c1 <= c0 + tolerance,
                    "{set:?} cost at ({x}, {y}): {c1:?} > {c0:?}"
                );
                forgiven += usize::from(c1 + tolerance < c0);
            }
        }
        assert!(forgiven > w * h / 4, "{set:?}: {forgiven} pixels forgiven");
    }
    // Every view is the centre view moved by 0.2 px per grid step along x (linear interpolation
    // of a smooth ramp image): at disparity 0 each row view's sample lies within
    // the centre's values over ±0.5 px.
    let grid = Grid::new(3, 5);
    let layout = Layout::packed(grid, 24, 16, 1);
    let mut data = std::vec![0.0f32; layout.validate().unwrap()];
    for v in 0..grid.len() {
        for y in 0..16 {
            for x in 0..24 {
                let p = x as f32 + 0.2 * ((v % 5) as f32 - 2.0);
                data[v * layout.view_stride + y * 24 + x] = 0.2 + 0.02 * p;
            }
        }
    }
    let plain = Views::<T>::new(&layout, ViewSet::Cross);
    let slack = Views::<T>::new(&layout, ViewSet::Cross).with_slack(0.5);
    let c0 = plain
        .cost(&data, 12, 8, T::ZERO, cost_robust, None)
        .unwrap();
    let c1 = slack
        .cost(&data, 12, 8, T::ZERO, cost_robust, None)
        .unwrap();
    assert!(c0 > T::ZERO && c1 == T::ZERO, "{c0:?} {c1:?}");
}

#[test]
fn the_f32_sampling_slack_only_forgives() {
    slack_only_forgives::<f32>();
}

#[test]
fn the_q16_sampling_slack_only_forgives() {
    slack_only_forgives::<Q16>();
}
