//! Which views the alignment tracks, in what order, and where each sits in the grid.

use heapless::Vec as FixedVec;

use crate::align::MAX_VIEWS;
use crate::lightfield::Grid;

/// Which views to track.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewSet {
    /// Every view.
    All,
    /// The centre row and column of the grid.
    Cross,
    /// The views one and two steps from the centre along the axes and the four corner
    /// views: enough to tell a rectified array from a misaligned one, cheaply; the
    /// nearer views predict the parallax in the outer ones. (Adding the four edge
    /// middles, 16 views, with 256 corners instead of [`PROBE_FEATURES`] costs 24 ms per
    /// 9×9×512² array instead of 9.)
    Probe,
}

/// Corners the auto mode's probe ([`ViewSet::Probe`]) tracks (at most
/// `align.features`, at least `align.min_inliers`).
pub(super) const PROBE_FEATURES: usize = 64;

/// Views handed to the `ViewMap` at once. The task table lives on the stack: one for a
/// whole 17×17 grid took ≈ 20–30 KB of frame (docs/EMBEDDED.md); 16 views still keep 16
/// threads busy. The views of a batch are independent, so the result does not depend
/// on it.
pub(super) const TASK_BATCH: usize = 16;

/// The views `0..len` for which `wanted` holds, in index order (the order in which
/// their tasks are checked, so that errors name the same view however they are batched).
pub(super) fn views_where(
    len: usize,
    wanted: impl Fn(usize) -> bool,
) -> FixedVec<usize, MAX_VIEWS> {
    let mut out = FixedVec::new();
    for v in (0..len.min(MAX_VIEWS)).filter(|&v| wanted(v)) {
        // At most `MAX_VIEWS` candidates: the push never fails (`collect` would panic).
        let _ = out.push(v);
    }
    out
}

/// Baseline of a view: `(c − c0, r − r0)`.
pub(super) fn baseline(grid: Grid, v: usize) -> (f32, f32) {
    let (r0, c0) = grid.center();
    let (r, c) = row_col(grid, v);
    (c as f32 - c0 as f32, r as f32 - r0 as f32)
}

/// Row and column of view `v` (`(0, 0)` for an empty grid, which has no views).
pub(super) fn row_col(grid: Grid, v: usize) -> (usize, usize) {
    (
        v.checked_div(grid.cols).unwrap_or(0),
        v.checked_rem(grid.cols).unwrap_or(0),
    )
}

/// The views of `set` (centre excluded) for which `present` holds, nearest baselines
/// first.
pub(crate) fn view_order(
    grid: Grid,
    set: ViewSet,
    present: &dyn Fn(usize) -> bool,
) -> FixedVec<usize, MAX_VIEWS> {
    let (r0, c0) = grid.center();
    let centre = grid.index(r0, c0);
    let mut out: FixedVec<usize, MAX_VIEWS> = FixedVec::new();
    if grid.is_empty() {
        return out;
    }
    match set {
        ViewSet::All | ViewSet::Cross => {
            for v in 0..grid.len() {
                let (r, c) = row_col(grid, v);
                let wanted = set == ViewSet::All || r == r0 || c == c0;
                if v != centre && wanted && present(v) {
                    let _ = out.push(v);
                }
            }
        }
        ViewSet::Probe => {
            let (last_r, last_c) = (grid.rows - 1, grid.cols - 1);
            // A step that leaves the grid (the missing axis of a rail) picks nothing.
            let (before, after) = (|i: usize| i.checked_sub(1), |i: usize| i.checked_add(1));
            let picks = [
                (Some(r0), before(c0)),
                (Some(r0), after(c0)),
                (before(r0), Some(c0)),
                (after(r0), Some(c0)),
                (Some(r0), Some(c0.saturating_sub(2))),
                (Some(r0), Some((c0 + 2).min(last_c))),
                (Some(r0.saturating_sub(2)), Some(c0)),
                (Some((r0 + 2).min(last_r)), Some(c0)),
                (Some(0), Some(0)),
                (Some(0), Some(last_c)),
                (Some(last_r), Some(0)),
                (Some(last_r), Some(last_c)),
            ];
            for pick in picks {
                let (Some(r), Some(c)) = pick else { continue };
                if r > last_r || c > last_c {
                    continue;
                }
                let v = grid.index(r, c);
                if v != centre && !out.contains(&v) && present(v) {
                    let _ = out.push(v);
                }
            }
        }
    }
    let norm = |v: usize| {
        let (bx, by) = baseline(grid, v);
        bx * bx + by * by
    };
    // Insertion sort: stable, allocation-free, at most 288 entries.
    for i in 1..out.len() {
        let mut j = i;
        while j > 0 {
            let Some([a, b]) = out.get_mut(j - 1..=j) else {
                break;
            };
            if norm(*a) <= norm(*b) {
                break;
            }
            core::mem::swap(a, b);
            j -= 1;
        }
    }
    out
}
