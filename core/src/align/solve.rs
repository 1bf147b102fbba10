//! Tracking the centre view's corners into every view and the alternating estimate of
//! the rectifying homographies.
//!
//! Unknowns: per view `v` the map `M_v` from view pixels to rectified pixels (the inverse
//! of the output homography), per tracked corner `i` its rectified centre position `X_i`
//! and disparity `d_i`. An observation `q_iv` should satisfy `M_v(q_iv) = X_i − d_i·b_v`.
//! The two blocks are solved in turn, each exactly by linear least squares:
//! - points (paper Eq. 4–5 when [`AlignModel::PlanePatches`](super::AlignModel::PlanePatches)): with every `M_v` fixed,
//!   `(X_i, d_i)` from the 2 × (views) equations of corner `i` — in the plane-patch model
//!   `d` is then replaced by the plane fitted to its patch, `ΔN_t`;
//! - views (paper Eq. 6–7): with the points fixed, `M_v` from the normalised DLT over the
//!   view's inlier tracks (seeded RANSAC in the first round);
//!
//! until the RMS reprojection error reaches `target_rms` or stops improving. After each
//! view step the gauge (see the module documentation of `align`) is fixed again.

// Views and corners index several parallel tables (observations, weights, maps); index
// loops say that more plainly than zipped iterators.
#![allow(clippy::needless_range_loop)]
mod alternate;
mod frame;
mod observations;
mod tracking;
mod views;

use super::corners;
use super::model;
use super::pyramid::Pyramid;
use super::{AlignParams, AlignReport, ViewMap, ViewTask, MAX_FEATURES, MAX_VIEWS};
use crate::error::{checked_product, Error, Result};
use crate::geometry::Homography;
use crate::lightfield::{LightField, Sample};
use alternate::alternate;
use observations::{Corners, State};
use tracking::{track_batches, track_first, track_second, Centre, Points};
pub(super) use views::view_order;
use views::{baseline, views_where, PROBE_FEATURES};

pub use views::ViewSet;

/// Scratch of the track table: per view and corner, the observation `(x, y)` and an
/// inlier weight.
pub struct Tracks;

/// Per-corner tables in scratch (a point's `x`, `y`, `d`; the first pass's disparity
/// sums `d_num`, `d_den` and the prediction from them; the detected corners' `x`, `y`
/// and strength): on the stack they made `align::solve::run` the whole-frame firmware's
/// deepest frame (≈ 18 KB of its 27 KB).
const CORNER_TABLES: usize = 9;

impl Tracks {
    /// Scratch for `views` views: each (view, corner)'s observation and inlier weight,
    /// then the per-corner tables.
    pub fn len_for(views: usize) -> Result<usize> {
        checked_product(&[views, MAX_FEATURES, 3], "the alignment track table")?
            .checked_add(CORNER_TABLES * MAX_FEATURES)
            .ok_or(Error::SizeOverflow {
                what: "the alignment track table",
            })
    }
}

/// Splits one zeroed `MAX_FEATURES`-entry table off the front of `scratch`.
fn corner_table(scratch: &mut [f32]) -> Option<(&mut [f32; MAX_FEATURES], &mut [f32])> {
    let (table, rest) = scratch.split_first_chunk_mut::<MAX_FEATURES>()?;
    table.fill(0.0);
    Some((table, rest))
}

/// Corners keep this far (full-resolution pixels) from the border.
const MARGIN: usize = 12;

/// The views an estimate tracks: those of `set` for which `present` holds (row-major
/// grid index); the others stay identities and are never read.
#[derive(Clone, Copy)]
pub struct Tracked<'a> {
    pub set: ViewSet,
    pub present: &'a dyn Fn(usize) -> bool,
}

/// Estimates the homographies of the `tracked` views and reports.
/// The tracking of each view (the bulk of the work) runs through `map`, a batch of
/// mutually independent views at a time; its result does not depend on how `map` runs
/// them.
pub fn run<S: Sample, M: ViewMap>(
    lf: &LightField<'_, S>,
    params: &AlignParams,
    tracked: Tracked<'_>,
    homographies: &mut [Homography],
    scratch: &mut [f32],
    map: &mut M,
    report: &mut AlignReport,
) -> Result<()> {
    let Tracked { set, present } = tracked;
    let grid = lf.grid();
    let (width, height) = (lf.width(), lf.height());
    let (r0, c0) = grid.center();
    let centre = grid.index(r0, c0);
    let pyramid = Pyramid::new(width, height)?;
    let cells = grid.len() * MAX_FEATURES;
    // `align::scratch_len` covers these; a short slice is the caller's error.
    let too_small = Error::ScratchTooSmall {
        needed: 2 * pyramid.len + Tracks::len_for(grid.len())?,
        got: scratch.len(),
    };
    let (centre_pyr, rest) = scratch.split_at_mut_checked(pyramid.len).ok_or(too_small)?;
    let (view_pyr, rest) = rest.split_at_mut_checked(pyramid.len).ok_or(too_small)?;
    let (obs, rest) = rest.split_at_mut_checked(2 * cells).ok_or(too_small)?;
    let (weight, rest) = rest.split_at_mut_checked(cells).ok_or(too_small)?;
    let (x, rest) = corner_table(rest).ok_or(too_small)?;
    let (y, rest) = corner_table(rest).ok_or(too_small)?;
    let (d, rest) = corner_table(rest).ok_or(too_small)?;
    let (d_num, rest) = corner_table(rest).ok_or(too_small)?;
    let (d_den, rest) = corner_table(rest).ok_or(too_small)?;
    let (predicted, rest) = corner_table(rest).ok_or(too_small)?;
    let (corner_x, rest) = corner_table(rest).ok_or(too_small)?;
    let (corner_y, rest) = corner_table(rest).ok_or(too_small)?;
    let (corner_strength, _) = corner_table(rest).ok_or(too_small)?;

    pyramid.build(&lf.center_view(), centre_pyr);
    let centre_pyr = &*centre_pyr;
    // The probe only tells a rectified array from a misaligned one: fewer corners do.
    let features = if set == ViewSet::Probe {
        params.features.min(PROBE_FEATURES.max(params.min_inliers))
    } else {
        params.features
    };
    // Detect at the coarsest level that still gives each corner a cell of ≥ 4×4 pixels.
    let mut level = 0;
    while level + 1 < pyramid.levels.min(3)
        && pyramid.width[level + 1] * pyramid.height[level + 1] >= 16 * features
    {
        level += 1;
    }
    let mut state = State {
        grid,
        corners: Corners::new(corner_x, corner_y, corner_strength),
        obs,
        weight,
        x,
        y,
        d,
        solved: [false; MAX_FEATURES],
        tracked: [false; MAX_VIEWS],
    };
    corners::detect(
        &pyramid.level(centre_pyr, level),
        level,
        features,
        MARGIN,
        |c| state.corners.push(c),
    );
    let n = state.corners.len();
    if n < params.min_inliers {
        return Err(Error::Alignment {
            view: centre,
            reason: "the centre view has too little texture (fewer corners than align.min_inliers): align a textured scene or turn alignment off",
        });
    }
    state.obs.fill(f32::NAN);
    state.weight.fill(0.0);
    for i in 0..n {
        let Some(c) = state.corners.get(i) else {
            break;
        };
        state.set_ob(centre, i, Some((c.x, c.y)));
    }
    if let Some(t) = state.tracked.get_mut(centre) {
        *t = true;
    }

    // First pass, ring after ring of views around the centre (Chebyshev distance): the
    // disparity measured in the inner rings predicts each corner's position in the next
    // ring; the views of one ring are independent of each other.
    let order = view_order(grid, set, present);
    let ring = |v: usize| {
        let b = baseline(grid, v);
        libm::fabsf(b.0).max(libm::fabsf(b.1)) as usize
    };
    let rings = order.iter().map(|&v| ring(v)).max().unwrap_or(0);
    for k in 1..=rings {
        predicted.fill(0.0);
        for ((p, &num), &den) in predicted.iter_mut().zip(&*d_num).zip(&*d_den).take(n) {
            if den > 0.0 {
                *p = num / den;
            }
        }
        let centre_view = Centre {
            lf,
            pyramid: &pyramid,
            centre_pyr,
            corners: &state.corners,
        };
        let ring_views = views_where(grid.len(), |v| ring(v) == k && order.contains(&v));
        let job = |task: &mut ViewTask<'_>, view_pyr: &mut [f32]| {
            task.outcome = track_first(&centre_view, view_pyr, predicted, task);
        };
        track_batches(state.obs, &ring_views, view_pyr, map, &job, |task| {
            if task.outcome? < params.min_inliers {
                return Err(Error::Alignment {
                    view: task.view,
                    reason: "too few corners of the centre view were found in this view: it is textureless or too different from the centre view",
                });
            }
            Ok(())
        })?;
        for &v in &ring_views {
            let b = baseline(grid, v);
            for (i, (num, den)) in d_num.iter_mut().zip(d_den.iter_mut()).enumerate().take(n) {
                let q = state.ob(v, i);
                if let (Some(q), Some(c)) = (q, state.corners.get(i)) {
                    // q − p ≈ −d · b (misalignment is noise here).
                    *num -= b.0 * (q.0 - c.x) + b.1 * (q.1 - c.y);
                    *den += b.0 * b.0 + b.1 * b.1;
                }
                state.set_ob(v, i, q);
            }
            if let Some(t) = state.tracked.get_mut(v) {
                *t = true;
            }
        }
    }
    alternate(&mut state, params, homographies, width, height, map, report)?;
    if report.identity_rms <= params.rectified_rms {
        // Nothing to undo: the second pass would only re-measure the same positions.
        return Ok(());
    }

    // Second pass: predicted positions and template shapes from the first estimate, so
    // that rotation and scale between views no longer bias the matches. Every view is
    // independent of the others now.
    let Some(to_rect) = homographies
        .get(centre)
        .and_then(Homography::inverse)
        .map(|h| model::from_homography(&h))
    else {
        return alternate(&mut state, params, homographies, width, height, map, report);
    };
    {
        let points = Points {
            x: state.x,
            y: state.y,
            d: state.d,
            solved: &state.solved,
        };
        let centre_view = Centre {
            lf,
            pyramid: &pyramid,
            centre_pyr,
            corners: &state.corners,
        };
        let hs = &*homographies;
        let job = |task: &mut ViewTask<'_>, view_pyr: &mut [f32]| {
            task.outcome = track_second(&centre_view, view_pyr, &points, &to_rect, hs, task);
        };
        let views = views_where(grid.len(), |v| order.contains(&v));
        track_batches(state.obs, &views, view_pyr, map, &job, |task| {
            task.outcome.map(|_| ())
        })?;
    }
    for &v in &order {
        for i in 0..n {
            let q = state.ob(v, i);
            state.set_ob(v, i, q);
        }
    }
    alternate(&mut state, params, homographies, width, height, map, report)
}
