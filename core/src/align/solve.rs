//! Tracking the centre view's corners into every view and the alternating estimate of
//! the rectifying homographies.
//!
//! Unknowns: per view `v` the map `M_v` from view pixels to rectified pixels (the inverse
//! of the output homography), per tracked corner `i` its rectified centre position `X_i`
//! and disparity `d_i`. An observation `q_iv` should satisfy `M_v(q_iv) = X_i − d_i·b_v`.
//! The two blocks are solved in turn, each exactly by linear least squares:
//! - points (paper Eq. 4–5 when [`AlignModel::PlanePatches`]): with every `M_v` fixed,
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

use heapless::Vec as FixedVec;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::corners::{self, Corner};
use super::model::{self, Mat, Rng};
use super::pyramid::Pyramid;
use super::track::{self, Pair};
use super::{
    AlignModel, AlignParams, AlignReport, Reference, ViewMap, ViewReport, ViewTask, MAX_FEATURES,
    MAX_VIEWS,
};
use crate::error::{checked_product, Error, Result};
use crate::geometry::Homography;
use crate::lightfield::{Grid, LightField, Sample};

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

/// Scratch of the track table: per view and corner, the observation `(x, y)` and an
/// inlier weight.
pub struct Tracks;

/// Per-corner tables in scratch (a point's `x`, `y`, `d`; the first pass's disparity
/// sums `d_num`, `d_den` and the prediction from them): on the stack they made
/// `align::solve::run` the whole-frame firmware's deepest frame (≈ 12 KB of its 27 KB).
const CORNER_TABLES: usize = 6;

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

/// Views handed to the `ViewMap` at once. The task table lives on the stack: one for a
/// whole 17×17 grid took ≈ 20–30 KB of frame (docs/EMBEDDED.md); 16 views still keep 16
/// threads busy. The views of a batch are independent, so the result does not depend
/// on it.
const TASK_BATCH: usize = 16;

/// The views `0..len` for which `wanted` holds, in index order (the order in which
/// their tasks are checked, so that errors name the same view however they are batched).
fn views_where(len: usize, wanted: impl Fn(usize) -> bool) -> FixedVec<usize, MAX_VIEWS> {
    let mut out = FixedVec::new();
    for v in (0..len.min(MAX_VIEWS)).filter(|&v| wanted(v)) {
        // At most `MAX_VIEWS` candidates: the push never fails (`collect` would panic).
        let _ = out.push(v);
    }
    out
}

/// Corners the auto mode's probe ([`ViewSet::Probe`]) tracks (at most
/// `align.features`, at least `align.min_inliers`).
const PROBE_FEATURES: usize = 64;

/// Shortest mean phase vector of the points' disparities (0 … 1) for which
/// [`snap_disparity_offset`] moves the gauge offset. Measured: 0.46–0.51 on the
/// synthetic `planes` arrays (fronto-parallel planes, +6…12 % BadPix0.07 off the
/// shears), 0.18–0.19 on `mixed` (no measurable preference); 256 random phases give
/// about 0.06.
const MIN_DISPARITY_COHERENCE: f32 = 0.3;

/// RANSAC threshold of the first round (pixels): misalignment is still in the points.
const FIRST_THRESHOLD: f32 = 3.0;
const RANSAC_ROUNDS: usize = 24;
/// Sigma clipping of the inlier set once the threshold has settled.
const CLIP_SIGMAS: f32 = 3.0;
/// The clipping threshold never goes below this (pixels): tracking noise.
const MIN_CLIP: f32 = 0.05;
/// Corners keep this far (full-resolution pixels) from the border.
const MARGIN: usize = 12;
/// Side of the plane-patch grid of [`AlignModel::PlanePatches`].
const PATCHES: usize = 4;

/// Baseline of a view: `(c − c0, r − r0)`.
fn baseline(grid: Grid, v: usize) -> (f32, f32) {
    let (r0, c0) = grid.center();
    let (r, c) = row_col(grid, v);
    (c as f32 - c0 as f32, r as f32 - r0 as f32)
}

/// Row and column of view `v` (`(0, 0)` for an empty grid, which has no views).
fn row_col(grid: Grid, v: usize) -> (usize, usize) {
    (
        v.checked_div(grid.cols).unwrap_or(0),
        v.checked_rem(grid.cols).unwrap_or(0),
    )
}

/// The views to track, centre excluded, nearest baselines first.
fn view_order(grid: Grid, set: ViewSet) -> FixedVec<usize, MAX_VIEWS> {
    let (r0, c0) = grid.center();
    let centre = grid.index(r0, c0);
    let mut out: FixedVec<usize, MAX_VIEWS> = FixedVec::new();
    match set {
        ViewSet::All | ViewSet::Cross => {
            for v in 0..grid.len() {
                let (r, c) = row_col(grid, v);
                let wanted = set == ViewSet::All || r == r0 || c == c0;
                if v != centre && wanted {
                    let _ = out.push(v);
                }
            }
        }
        ViewSet::Probe => {
            let (last_r, last_c) = (grid.rows - 1, grid.cols - 1);
            let picks = [
                (r0, c0 - 1),
                (r0, c0 + 1),
                (r0 - 1, c0),
                (r0 + 1, c0),
                (r0, c0.saturating_sub(2)),
                (r0, (c0 + 2).min(grid.cols - 1)),
                (r0.saturating_sub(2), c0),
                ((r0 + 2).min(grid.rows - 1), c0),
                (0, 0),
                (0, last_c),
                (last_r, 0),
                (last_r, last_c),
            ];
            for (r, c) in picks {
                let v = grid.index(r, c);
                if v != centre && !out.contains(&v) {
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

/// The track table and per-corner unknowns, over borrowed scratch.
struct State<'s> {
    grid: Grid,
    corners: FixedVec<Corner, MAX_FEATURES>,
    /// `(x, y)` per view and corner; NaN when not tracked.
    obs: &'s mut [f32],
    /// 1 for an inlier observation, 0 otherwise.
    weight: &'s mut [f32],
    x: &'s mut [f32; MAX_FEATURES],
    y: &'s mut [f32; MAX_FEATURES],
    d: &'s mut [f32; MAX_FEATURES],
    /// Whether corner `i` has enough inlier observations to be solved.
    solved: [bool; MAX_FEATURES],
    /// Views tracked (centre included), a bitmap over the grid.
    tracked: [bool; MAX_VIEWS],
}

impl State<'_> {
    fn ob(&self, v: usize, i: usize) -> Option<(f32, f32)> {
        let k = (v * MAX_FEATURES + i) * 2;
        let (x, y) = (*self.obs.get(k)?, *self.obs.get(k + 1)?);
        x.is_finite().then_some((x, y))
    }
    fn set_ob(&mut self, v: usize, i: usize, q: Option<(f32, f32)>) {
        let k = (v * MAX_FEATURES + i) * 2;
        let (x, y) = q.unwrap_or((f32::NAN, f32::NAN));
        // The tables hold every (view, corner) of the grid (`run` sized them), so the
        // skips below never happen.
        if let Some([ox, oy]) = self.obs.get_mut(k..k + 2) {
            *ox = x;
            *oy = y;
        }
        self.set_inlier(v, i, q.is_some());
    }
    fn set_inlier(&mut self, v: usize, i: usize, inlier: bool) {
        if let Some(w) = self.weight.get_mut(v * MAX_FEATURES + i) {
            *w = if inlier { 1.0 } else { 0.0 };
        }
    }
    fn inlier(&self, v: usize, i: usize) -> bool {
        self.weight
            .get(v * MAX_FEATURES + i)
            .is_some_and(|&w| w > 0.5)
    }
    fn is_tracked(&self, v: usize) -> bool {
        self.tracked.get(v) == Some(&true)
    }
    fn is_solved(&self, i: usize) -> bool {
        self.solved.get(i) == Some(&true)
    }

    /// Points step: `(X_i, d_i)` for every corner from its inlier observations mapped by
    /// `maps` (view → rectified).
    fn solve_points(&mut self, maps: &[Homography]) {
        for i in 0..self.corners.len().min(MAX_FEATURES) {
            // An unsolved point's unknowns are never read (every reader checks
            // `solved`), so they keep whatever they held.
            let solution = self.solve_point(i, |v| maps.get(v).map(model::from_homography));
            if let Some((x, y, d)) = solution {
                self.x[i] = x;
                self.y[i] = y;
                self.d[i] = d;
            }
            self.solved[i] = solution.is_some();
        }
    }

    /// `(X_i, Y_i, d_i)` of corner `i` from its inlier observations mapped by `map_of(v)`
    /// (view → rectified); `None` when too few views (or baselines too short) see it, or
    /// the fit is not finite.
    fn solve_point(
        &self,
        i: usize,
        map_of: impl Fn(usize) -> Option<Mat>,
    ) -> Option<(f32, f32, f32)> {
        let mut fit = model::ParallaxFit::default();
        for v in 0..self.grid.len() {
            if !self.is_tracked(v) || !self.inlier(v, i) {
                continue;
            }
            let Some(q) = self.ob(v, i) else { continue };
            let Some(m) = map_of(v) else { continue };
            let Some(u) = model::apply(&m, q.0, q.1) else {
                continue;
            };
            fit.add(baseline(self.grid, v), u);
        }
        if fit.n < 3.0 || fit.spread() < 0.5 {
            return None;
        }
        let (x, y, d) = fit.solution();
        (x.is_finite() && y.is_finite() && d.is_finite()).then_some((x, y, d))
    }

    /// Plane-patch step (paper Eq. 4–5): the disparity of each patch of the centre view
    /// becomes the least-squares plane through its corners' disparities, and `X_i` follows.
    fn fit_planes(&mut self, maps: &[Homography], width: usize, height: usize) {
        for patch in 0..PATCHES * PATCHES {
            let (px, py) = (patch % PATCHES, patch / PATCHES);
            let in_patch = |c: &Corner| {
                (c.x as usize * PATCHES / width.max(1)).min(PATCHES - 1) == px
                    && (c.y as usize * PATCHES / height.max(1)).min(PATCHES - 1) == py
            };
            let mut ata = Matrix3::<f32>::zeros();
            let mut atb = Vector3::<f32>::zeros();
            let mut count = 0;
            let (cx, cy) = (width as f32 * 0.5, height as f32 * 0.5);
            for i in 0..self.corners.len().min(MAX_FEATURES) {
                if self.solved[i] && in_patch(&self.corners[i]) {
                    let a = Vector3::new(self.x[i] - cx, self.y[i] - cy, 1.0);
                    ata += a * a.transpose();
                    atb += a * self.d[i];
                    count += 1;
                }
            }
            if count < 6 {
                continue;
            }
            let Some(plane) = model::lu_solve(&ata, &atb) else {
                continue;
            };
            for i in 0..self.corners.len().min(MAX_FEATURES) {
                if !(self.solved[i] && self.corners.get(i).is_some_and(in_patch)) {
                    continue;
                }
                let d = plane[0] * (self.x[i] - cx) + plane[1] * (self.y[i] - cy) + plane[2];
                // X given d: mean of M_v(q) + d · b_v.
                let (mut n, mut sx, mut sy) = (0.0f32, 0.0f32, 0.0f32);
                for v in 0..self.grid.len() {
                    if !self.is_tracked(v) || !self.inlier(v, i) {
                        continue;
                    }
                    let Some(q) = self.ob(v, i) else { continue };
                    let Some(h) = maps.get(v) else { continue };
                    let Some(u) = model::apply(&model::from_homography(h), q.0, q.1) else {
                        continue;
                    };
                    let b = baseline(self.grid, v);
                    n += 1.0;
                    sx += u.0 + d * b.0;
                    sy += u.1 + d * b.1;
                }
                if n > 0.0 && d.is_finite() {
                    self.d[i] = d;
                    self.x[i] = sx / n;
                    self.y[i] = sy / n;
                }
            }
        }
    }

    /// Reprojection residual of observation `(v, i)` under `m`.
    fn residual(&self, m: &Mat, v: usize, i: usize) -> Option<f32> {
        if !self.is_solved(i) {
            return None;
        }
        let q = self.ob(v, i)?;
        let u = model::apply(m, q.0, q.1)?;
        let point = (self.x[i], self.y[i], self.d[i]);
        Some(reprojection_error(u, point, baseline(self.grid, v)))
    }
}

/// Distance between the rectified observation `u` of a view with baseline `b` and the
/// point `(X, Y, d)`'s position there, `X − d·b`.
fn reprojection_error(u: (f32, f32), (x, y, d): (f32, f32, f32), b: (f32, f32)) -> f32 {
    let (ex, ey) = (u.0 - (x - d * b.0), u.1 - (y - d * b.1));
    crate::float::sqrtf(ex * ex + ey * ey)
}

/// `sqrt(total / count)`, infinite without observations.
fn root_mean(total: f32, count: usize) -> f32 {
    if count == 0 {
        f32::INFINITY
    } else {
        crate::float::sqrtf(total / count as f32)
    }
}

/// Estimates the homographies of the views in `set` (others stay identities) and reports.
/// The tracking of each view (the bulk of the work) runs through `map`, a batch of
/// mutually independent views at a time; its result does not depend on how `map` runs
/// them.
pub fn run<S: Sample, M: ViewMap>(
    lf: &LightField<'_, S>,
    params: &AlignParams,
    set: ViewSet,
    homographies: &mut [Homography],
    scratch: &mut [f32],
    map: &mut M,
) -> Result<AlignReport> {
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
    let (predicted, _) = corner_table(rest).ok_or(too_small)?;

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
        corners: FixedVec::new(),
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
        &mut state.corners,
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
        let Some(&c) = state.corners.get(i) else {
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
    let order = view_order(grid, set);
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
        let corners = &state.corners;
        let ring_views = views_where(grid.len(), |v| ring(v) == k && order.contains(&v));
        let job = |task: &mut ViewTask<'_>, view_pyr: &mut [f32]| {
            task.outcome =
                track_first(lf, &pyramid, centre_pyr, view_pyr, corners, predicted, task);
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
    let first = alternate(&mut state, params, homographies, width, height, map)?;
    if first.identity_rms <= params.rectified_rms {
        // Nothing to undo: the second pass would only re-measure the same positions.
        return Ok(first);
    }

    // Second pass: predicted positions and template shapes from the first estimate, so
    // that rotation and scale between views no longer bias the matches. Every view is
    // independent of the others now.
    let Some(to_rect) = homographies
        .get(centre)
        .and_then(Homography::inverse)
        .map(|h| model::from_homography(&h))
    else {
        return alternate(&mut state, params, homographies, width, height, map);
    };
    {
        let points = Points {
            x: state.x,
            y: state.y,
            d: state.d,
            solved: &state.solved,
        };
        let corners = &state.corners;
        let hs = &*homographies;
        let job = |task: &mut ViewTask<'_>, view_pyr: &mut [f32]| {
            task.outcome = track_second(
                lf, &pyramid, centre_pyr, view_pyr, corners, &points, &to_rect, hs, task,
            );
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
    alternate(&mut state, params, homographies, width, height, map)
}

/// Runs the tracking `job` for `views` (in index order) through `map`, [`TASK_BATCH`]
/// at a time, each task writing its view's row of the observation table `obs`; `check`
/// sees every finished task in order and stops at the first error.
fn track_batches<M, J>(
    obs: &mut [f32],
    views: &[usize],
    view_pyr: &mut [f32],
    map: &mut M,
    job: &J,
    mut check: impl FnMut(&ViewTask<'_>) -> Result<()>,
) -> Result<()>
where
    M: ViewMap,
    J: Fn(&mut ViewTask<'_>, &mut [f32]) + Sync,
{
    for batch in views.chunks(TASK_BATCH) {
        let mut tasks: FixedVec<ViewTask<'_>, TASK_BATCH> = FixedVec::new();
        for (v, chunk) in obs.chunks_exact_mut(2 * MAX_FEATURES).enumerate() {
            if batch.contains(&v) {
                let _ = tasks.push(ViewTask::new(v, chunk));
            }
        }
        map.map(&mut tasks, view_pyr, job);
        for task in &tasks {
            check(task)?;
        }
    }
    Ok(())
}

/// The per-corner unknowns the second pass predicts from.
struct Points<'p> {
    x: &'p [f32; MAX_FEATURES],
    y: &'p [f32; MAX_FEATURES],
    d: &'p [f32; MAX_FEATURES],
    solved: &'p [bool; MAX_FEATURES],
}

/// Which pyramid levels of a view to build.
#[derive(Clone, Copy)]
enum Levels {
    All,
    /// Full resolution only.
    Base,
}

/// The pyramid of view `v`, built in `view_pyr`, paired with the centre view's.
fn view_pair<'p, S: Sample>(
    lf: &LightField<'_, S>,
    pyramid: &'p Pyramid,
    centre_pyr: &'p [f32],
    view_pyr: &'p mut [f32],
    v: usize,
    levels: Levels,
) -> Result<Pair<'p>> {
    let got = view_pyr.len();
    let view_pyr = view_pyr
        .get_mut(..pyramid.len)
        .ok_or(Error::ScratchTooSmall {
            needed: pyramid.len,
            got,
        })?;
    let (r, c) = row_col(lf.grid(), v);
    let view = lf.view(r, c)?;
    match levels {
        Levels::All => pyramid.build(&view, view_pyr),
        Levels::Base => pyramid.build_base(&view, view_pyr),
    }
    Ok(Pair {
        pyramid,
        center: centre_pyr,
        view: view_pyr,
    })
}

/// First-pass tracking of the corners into `task`'s view: the search starts where the
/// `predicted` disparity puts each corner. Returns the number of corners found.
fn track_first<S: Sample>(
    lf: &LightField<'_, S>,
    pyramid: &Pyramid,
    centre_pyr: &[f32],
    view_pyr: &mut [f32],
    corners: &[Corner],
    predicted: &[f32; MAX_FEATURES],
    task: &mut ViewTask<'_>,
) -> Result<usize> {
    let v = task.view;
    let pair = view_pair(lf, pyramid, centre_pyr, view_pyr, v, Levels::All)?;
    let b = baseline(lf.grid(), v);
    let mut found = 0;
    for ((i, c), &d) in corners.iter().enumerate().zip(predicted) {
        let guess = (c.x - d * b.0, c.y - d * b.1);
        let q = track::track(&pair, (c.x, c.y), guess, track::IDENTITY, usize::MAX);
        found += usize::from(q.is_some());
        task.set(i, q);
    }
    Ok(found)
}

/// Second-pass tracking into `task`'s view: positions and template shapes predicted by
/// the first estimate (`hs`, rectified → view; `to_rect`, centre view → rectified).
#[allow(clippy::too_many_arguments)]
fn track_second<S: Sample>(
    lf: &LightField<'_, S>,
    pyramid: &Pyramid,
    centre_pyr: &[f32],
    view_pyr: &mut [f32],
    corners: &[Corner],
    points: &Points<'_>,
    to_rect: &Mat,
    hs: &[Homography],
    task: &mut ViewTask<'_>,
) -> Result<usize> {
    let grid = lf.grid();
    let (width, height) = (lf.width(), lf.height());
    let o = ((width as f32 - 1.0) * 0.5, (height as f32 - 1.0) * 0.5);
    let v = task.view;
    let h_v = model::from_homography(hs.get(v).ok_or(Error::OutOfRange {
        what: "view",
        index: v,
        len: hs.len(),
    })?);
    let centre_to_view = h_v * to_rect;
    let shape = jacobian(&centre_to_view, o).unwrap_or(track::IDENTITY);
    // The second pass matches at full resolution only.
    let pair = view_pair(lf, pyramid, centre_pyr, view_pyr, v, Levels::Base)?;
    let b = baseline(grid, v);
    let mut found = 0;
    for (i, c) in corners.iter().enumerate() {
        let predicted = if points.solved.get(i) == Some(&true) {
            model::apply(
                &h_v,
                points.x[i] - points.d[i] * b.0,
                points.y[i] - points.d[i] * b.1,
            )
        } else {
            task.get(i)
        };
        let q = predicted.and_then(|g| track::track(&pair, (c.x, c.y), g, shape, 0));
        found += usize::from(q.is_some());
        task.set(i, q);
    }
    Ok(found)
}

/// Row-major 2 × 2 Jacobian of `m` at `p`.
fn jacobian(m: &Mat, p: (f32, f32)) -> Option<[f32; 4]> {
    let at = model::apply(m, p.0, p.1)?;
    let ax = model::apply(m, p.0 + 1.0, p.1)?;
    let ay = model::apply(m, p.0, p.1 + 1.0)?;
    Some([ax.0 - at.0, ay.0 - at.0, ax.1 - at.1, ay.1 - at.1])
}

/// Fixes the gauge: the centre view is the identity ([`Reference::CentreView`]) or keeps
/// its scale and the position of its image centre, and view translations have no mean
/// component along the baselines.
fn fix_gauge(
    state: &State<'_>,
    maps: &mut [Homography],
    width: usize,
    height: usize,
    reference: Reference,
) -> Option<()> {
    let grid = state.grid;
    let (r0, c0) = grid.center();
    let centre = grid.index(r0, c0);
    let o = ((width as f32 - 1.0) * 0.5, (height as f32 - 1.0) * 0.5);
    let mc = model::from_homography(maps.get(centre)?);
    let at = model::apply(&mc, o.0, o.1)?;
    let ax = model::apply(&mc, o.0 + 1.0, o.1)?;
    let ay = model::apply(&mc, o.0, o.1 + 1.0)?;
    let det = (ax.0 - at.0) * (ay.1 - at.1) - (ax.1 - at.1) * (ay.0 - at.0);
    if det.abs().partial_cmp(&1e-6) != Some(core::cmp::Ordering::Greater) {
        return None;
    }
    let g = match reference {
        // Express everything in the centre view's frame: its map becomes the identity.
        Reference::CentreView => mc.try_inverse()?,
        Reference::Estimated => {
            let s = 1.0 / crate::float::sqrtf(det.abs());
            Mat::new(
                s,
                0.0,
                o.0 - s * at.0,
                0.0,
                s,
                o.1 - s * at.1,
                0.0,
                0.0,
                1.0,
            )
        }
    };

    let (mut num, mut den) = (0.0f32, 0.0f32);
    for (v, map) in maps.iter_mut().enumerate().take(grid.len()) {
        if !state.is_tracked(v) {
            continue;
        }
        let m = g * model::from_homography(map);
        *map = model::to_homography(&m)?;
        let b = baseline(grid, v);
        let t = model::apply(&m, o.0, o.1)?;
        num += b.0 * (t.0 - o.0) + b.1 * (t.1 - o.1);
        den += b.0 * b.0 + b.1 * b.1;
    }
    let delta = if den > 0.0 { -num / den } else { 0.0 };
    for (v, map) in maps.iter_mut().enumerate().take(grid.len()) {
        if !state.is_tracked(v) {
            continue;
        }
        let b = baseline(grid, v);
        let shift = Mat::new(1.0, 0.0, delta * b.0, 0.0, 1.0, delta * b.1, 0.0, 0.0, 1.0);
        *map = model::to_homography(&(shift * model::from_homography(map)))?;
    }
    Some(())
}

/// The distortions common to every view that are not gauge: rotation and the two
/// shears, `x ↦ o + (I + A)(x − o)` (uniform scale is gauge). A common perspective is
/// not fitted: its effect on the parallax is second order, and fitting it was measured
/// to make the frame noisier (registration 0.08–0.36 px instead of 0.01–0.33 px) at the
/// same BadPix.
const COMMON_MODES: usize = 3;

/// Derivatives of the common distortion at `p = u − o` with respect to its parameters
/// (rotation, shear along the axes, symmetric shear).
fn common_mode_derivatives(px: f64, py: f64) -> [[f64; 2]; COMMON_MODES] {
    [[-py, px], [px, -py], [py, px]]
}

/// Solves for the distortion common to every view's map directly and removes it.
///
/// A distortion `C` applied to every map moves a point's observations by
/// `C(X − d·b) ≈ C(X) − d·A·b`: only the parallax `d·b` of each point sees the linear
/// part `A`, so the alternation between the view and the point blocks, each of which
/// re-absorbs what the other changed, creeps towards it by a fraction of the error per
/// round and stops when the improvement stalls (measured: the common rotation stayed
/// 0.2° off on the synthetic tests, 0.76 px at the image corners, costing 3–4 %
/// relative BadPix). Here the three non-gauge modes are fitted jointly by linear least
/// squares on the residuals, each point's own unknowns `(X, d)` projected out, and
/// every map is corrected. `None` (maps untouched) when the system is degenerate.
///
/// The projection is applied through inner products, `⟨Pz, Pw⟩ = ⟨z, w⟩ −
/// (Fᵀz)ᵀ(FᵀF)⁻¹(Fᵀw)` (`P` the projector onto the complement of the point's columns
/// `F`), so each observation is added to a few sums and no per-view table is kept:
/// the stack frame stays small enough for a microcontroller (it held ≈ 60 KB of
/// tables before, docs/EMBEDDED.md).
fn correct_common_distortion(
    state: &State<'_>,
    maps: &mut [Homography],
    width: usize,
    height: usize,
) -> Option<()> {
    let grid = state.grid;
    let o = ((width as f32 - 1.0) * 0.5, (height as f32 - 1.0) * 0.5);
    let mut ata = SMatrix::<f64, COMMON_MODES, COMMON_MODES>::zeros();
    let mut atb = SVector::<f64, COMMON_MODES>::zeros();
    // The stacked vectors of one point: the three mode derivatives and the residual.
    const STACKED: usize = COMMON_MODES + 1;
    for i in 0..state.corners.len().min(MAX_FEATURES) {
        if !state.is_solved(i) {
            continue;
        }
        // Per point: the Gram matrix of the stacked vectors, their products with the
        // point's columns `F` (per observation (1, 0), (0, 1), −b) and `FᵀF`.
        let mut gram = SMatrix::<f64, STACKED, STACKED>::zeros();
        let mut ftz = [Vector3::<f64>::zeros(); STACKED];
        let (mut n, mut sbx, mut sby, mut sbb) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for (v, map) in maps.iter().enumerate().take(grid.len()) {
            if !state.is_tracked(v) || !state.inlier(v, i) {
                continue;
            }
            let Some(q) = state.ob(v, i) else { continue };
            let Some(u) = model::apply(&model::from_homography(map), q.0, q.1) else {
                continue;
            };
            let b = baseline(grid, v);
            let (px, py) = (f64::from(u.0 - o.0), f64::from(u.1 - o.1));
            let a = common_mode_derivatives(px, py);
            let r = [
                f64::from(u.0 - (state.x[i] - state.d[i] * b.0)),
                f64::from(u.1 - (state.y[i] - state.d[i] * b.1)),
            ];
            let z = [a[0], a[1], a[2], r];
            let (bx, by) = (f64::from(b.0), f64::from(b.1));
            for p in 0..STACKED {
                ftz[p] += Vector3::new(z[p][0], z[p][1], -(bx * z[p][0] + by * z[p][1]));
                for q in 0..STACKED {
                    gram[(p, q)] += z[p][0] * z[q][0] + z[p][1] * z[q][1];
                }
            }
            n += 1.0;
            sbx += bx;
            sby += by;
            sbb += bx * bx + by * by;
        }
        if n < 3.0 {
            continue;
        }
        let ftf = Matrix3::new(n, 0.0, -sbx, 0.0, n, -sby, -sbx, -sby, sbb);
        let Some(ftf_inv) = ftf.try_inverse() else {
            continue;
        };
        let projected = |p: usize, q: usize| match (gram.get((p, q)), ftz.get(p), ftz.get(q)) {
            (Some(g), Some(zp), Some(zq)) => g - zp.dot(&(ftf_inv * zq)),
            // Indices below `STACKED`: never taken.
            _ => 0.0,
        };
        for k in 0..COMMON_MODES {
            atb[k] += projected(k, COMMON_MODES);
            for l in 0..COMMON_MODES {
                ata[(k, l)] += projected(k, l);
            }
        }
    }
    let phi = model::lu_solve(&ata, &(-atb))?;
    let (r, e, h) = (phi[0] as f32, phi[1] as f32, phi[2] as f32);
    // A small, finite correction or none.
    let largest = r.abs().max(e.abs()).max(h.abs());
    if !phi.iter().all(|p| p.is_finite())
        || largest.partial_cmp(&0.05) != Some(core::cmp::Ordering::Less)
    {
        return None;
    }
    let c = Mat::new(
        1.0 + e,
        h - r,
        o.0 - (1.0 + e) * o.0 - (h - r) * o.1,
        h + r,
        1.0 - e,
        o.1 - (h + r) * o.0 - (1.0 - e) * o.1,
        0.0,
        0.0,
        1.0,
    );
    let corrected = |v: usize, map: &Homography| {
        if state.is_tracked(v) {
            model::to_homography(&(c * model::from_homography(map)))
        } else {
            Some(*map)
        }
    };
    // Every map or none: check them all before writing any (no table of the results).
    if !maps
        .iter()
        .enumerate()
        .take(grid.len())
        .all(|(v, map)| corrected(v, map).is_some())
    {
        return None;
    }
    for (v, map) in maps.iter_mut().enumerate().take(grid.len()) {
        if let Some(h) = corrected(v, map) {
            *map = h;
        }
    }
    Some(())
}

/// RMS residual over inlier observations, per view into `per_view`.
fn rms(
    state: &State<'_>,
    maps: &[Homography],
    per_view: &mut FixedVec<ViewReport, MAX_VIEWS>,
) -> f32 {
    per_view.clear();
    let (mut total, mut count) = (0.0f32, 0usize);
    for v in 0..state.grid.len() {
        let mut rep = ViewReport::default();
        if let (true, Some(h)) = (state.is_tracked(v), maps.get(v)) {
            let m = model::from_homography(h);
            let (mut sum, mut k) = (0.0f32, 0usize);
            for i in 0..state.corners.len().min(MAX_FEATURES) {
                if state.inlier(v, i) {
                    if let Some(r) = state.residual(&m, v, i) {
                        sum += r * r;
                        k += 1;
                    }
                }
            }
            total += sum;
            count += k;
            rep.inliers = k as u16;
            rep.rms = if k > 0 {
                crate::float::sqrtf(sum / k as f32)
            } else {
                0.0
            };
        }
        let _ = per_view.push(rep);
    }
    root_mean(total, count)
}

/// Median residual of the current inliers, from a 256-bin histogram over `[0, cap]`.
fn median_residual(state: &State<'_>, maps: &[Homography], cap: f32) -> f32 {
    let mut bins = [0u32; 256];
    let mut total = 0u32;
    for (v, h) in maps.iter().enumerate().take(state.grid.len()) {
        if !state.is_tracked(v) {
            continue;
        }
        let m = model::from_homography(h);
        for i in 0..state.corners.len().min(MAX_FEATURES) {
            if !state.inlier(v, i) {
                continue;
            }
            if let Some(r) = state.residual(&m, v, i) {
                let k = ((r / cap * 256.0) as usize).min(255);
                if let Some(bin) = bins.get_mut(k) {
                    *bin += 1;
                }
                total += 1;
            }
        }
    }
    let mut seen = 0u32;
    for (k, &b) in bins.iter().enumerate() {
        seen += b;
        if 2 * seen >= total {
            return (k as f32 + 0.5) * cap / 256.0;
        }
    }
    cap
}

/// Marks observations within `threshold` of the model as inliers (tracked ones only).
fn classify(state: &mut State<'_>, maps: &[Homography], threshold: f32) {
    for (v, h) in maps.iter().enumerate().take(state.grid.len()) {
        if !state.is_tracked(v) {
            continue;
        }
        let m = model::from_homography(h);
        for i in 0..state.corners.len().min(MAX_FEATURES) {
            let ok = state.ob(v, i).is_some()
                && state.residual(&m, v, i).is_some_and(|r| r <= threshold);
            state.set_inlier(v, i, ok);
        }
    }
}

fn alternate<M: ViewMap>(
    state: &mut State<'_>,
    params: &AlignParams,
    maps: &mut [Homography],
    width: usize,
    height: usize,
    map: &mut M,
) -> Result<AlignReport> {
    let grid = state.grid;
    let n = state.corners.len();
    let mut report = AlignReport {
        features: n,
        ..AlignReport::default()
    };
    maps.fill(Homography::IDENTITY);
    state.solve_points(maps);
    let mut previous = f32::INFINITY;
    let mut threshold = FIRST_THRESHOLD;
    for round in 0..params.max_iterations {
        // Views step: one homography per view from its own tracks, independent of the
        // other views (RANSAC seeded per view), so `map` may spread it.
        {
            let st = &*state;
            let job = |task: &mut ViewTask<'_>, _: &mut [f32]| {
                let v = task.view();
                let b = baseline(grid, v);
                let pair = |i: usize| {
                    if !(st.is_solved(i) && st.inlier(v, i)) {
                        return None;
                    }
                    let q = st.ob(v, i)?;
                    Some((q.0, q.1, st.x[i] - st.d[i] * b.0, st.y[i] - st.d[i] * b.1))
                };
                let fitted = if round == 0 {
                    let mut rng = Rng::new(params.seed.wrapping_add(v as u64));
                    model::ransac(n, &pair, threshold, RANSAC_ROUNDS, &mut rng).map(|r| r.0)
                } else {
                    model::fit((0..n).filter_map(pair))
                };
                task.homography = fitted.and_then(|m| model::to_homography(&m));
            };
            for batch in views_where(grid.len(), |v| st.is_tracked(v)).chunks(TASK_BATCH) {
                let mut tasks: FixedVec<ViewTask<'_>, TASK_BATCH> = FixedVec::new();
                for &v in batch {
                    let _ = tasks.push(ViewTask::new(v, &mut []));
                }
                map.map(&mut tasks, &mut [], &job);
                for task in &tasks {
                    let v = task.view();
                    let len = maps.len();
                    let slot = maps.get_mut(v).ok_or(Error::OutOfRange {
                        what: "view",
                        index: v,
                        len,
                    })?;
                    *slot = task.homography.ok_or(Error::Alignment {
                        view: v,
                        reason: "no homography fits the matches of this view: it is too different from the centre view",
                    })?;
                }
            }
        }
        fix_gauge(state, maps, width, height, params.reference).ok_or(Error::Alignment {
            view: grid.index(grid.center().0, grid.center().1),
            reason: "the estimated homographies are degenerate: the views are too different",
        })?;
        // Points step, then the inlier set for the next round.
        state.solve_points(maps);
        // The plane-patch model constrains `d`, which the correction projects out as
        // free: on scenes whose planes straddle the patches it then drifts (measured:
        // registration 2.4 px, BadPix +54 % on `planes`), so it is left alone there.
        // Only once the inlier threshold is down to `inlier_threshold`: gross
        // mismatches of the first rounds would bend every view.
        if params.reference == Reference::Estimated
            && params.model == AlignModel::PerView
            && threshold <= params.inlier_threshold
            && correct_common_distortion(state, maps, width, height).is_some()
        {
            state.solve_points(maps);
        }
        if params.model == AlignModel::PlanePatches {
            state.fit_planes(maps, width, height);
        }
        // Halve the threshold down to `inlier_threshold`, then clip at three times the
        // RMS error: occlusion boundaries and repeated texture give matches a fraction of
        // a pixel off that a fixed threshold would keep.
        let next = if threshold > params.inlier_threshold {
            (threshold * 0.5).max(params.inlier_threshold)
        } else {
            let sigma = 1.4826 * median_residual(state, maps, params.inlier_threshold);
            crate::float::clamp_f32(CLIP_SIGMAS * sigma, MIN_CLIP, params.inlier_threshold)
        };
        let settled = (next - threshold).abs() <= 0.05 * threshold;
        threshold = next;
        classify(state, maps, threshold);
        state.solve_points(maps);
        if params.model == AlignModel::PlanePatches {
            state.fit_planes(maps, width, height);
        }
        let err = rms(state, maps, &mut report.views);
        report.iterations = round + 1;
        report.rms = err;
        if settled && (err <= params.target_rms || err > previous * (1.0 - 1e-4)) {
            break;
        }
        previous = if settled { err } else { f32::INFINITY };
    }
    if params.disparity_step > 0.0 {
        let (shift, coherence) = snap_disparity_offset(state, maps, params.disparity_step);
        report.disparity_shift = shift;
        report.disparity_coherence = coherence;
    }
    for v in 0..grid.len() {
        // `rms` reported every view (none when no round ran: 0 inliers).
        let inliers = report.views.get(v).map_or(0, |r| usize::from(r.inliers));
        if state.is_tracked(v) && inliers < params.min_inliers {
            return Err(Error::Alignment {
                view: v,
                reason: "too few matches agree with one homography: the view is textureless or too different from the centre view",
            });
        }
    }
    // The misalignment as measured: the same inliers, identity homographies.
    report.identity_rms = identity_rms(state);
    // Outputs: rectified → view.
    for (v, map) in maps.iter_mut().enumerate().take(grid.len()) {
        if state.is_tracked(v) {
            *map = map.inverse().ok_or(Error::Alignment {
                view: v,
                reason: "the estimated homography is singular: the view is too different from the centre view",
            })?;
        } else {
            *map = Homography::IDENTITY;
        }
    }
    Ok(report)
}

/// Moves the gauge's disparity offset by `δ ∈ (−step/2, step/2]` so that the solved
/// points' disparities lie as near as possible to multiples of `step`: `δ` maximises
/// `Σ cos(2π(d_i + δ)/step)` (the circular mean of the phases `d_i / step`). Adding `δ`
/// to every disparity is the gauge transform `M_v ↦ M_v − δ·b_v` (view → rectified), so
/// the reprojection error does not change. Why: the EPI stage shears at multiples of its
/// step and its estimates near occlusion edges are best for surfaces that lie on a
/// shear; the offset is unobservable, so the estimate may as well put the scene's
/// dominant disparities there (measured on the synthetic `planes` array: a rectified
/// scene shifted by 0.1 px off the shears scores +12 % BadPix0.07 in the EPI stage,
/// docs/stages/align.md). Points with too few views are left out. Only
/// when the phases cluster (their mean vector at least [`MIN_DISPARITY_COHERENCE`]
/// long): disparities spread over every phase gain nothing from the move (measured:
/// the rectified `mixed` array scores within ±2 % at any offset), and then the
/// zero-mean convention, which is nearer the true offset on average, stays. Returns the
/// shift and the coherence.
fn snap_disparity_offset(state: &mut State<'_>, maps: &mut [Homography], step: f32) -> (f32, f32) {
    let grid = state.grid;
    let n = state.corners.len().min(MAX_FEATURES);
    let turn = core::f32::consts::TAU / step;
    let (mut sin, mut cos, mut count) = (0.0f32, 0.0f32, 0.0f32);
    for i in (0..n).filter(|&i| state.is_solved(i)) {
        let phase = turn * state.d[i];
        sin += libm::sinf(phase);
        cos += libm::cosf(phase);
        count += 1.0;
    }
    let coherence = crate::float::sqrtf(sin * sin + cos * cos) / count.max(1.0);
    // NaN (no solved point) compares as not coherent.
    if coherence.partial_cmp(&MIN_DISPARITY_COHERENCE) == Some(core::cmp::Ordering::Less)
        || coherence.is_nan()
    {
        return (0.0, coherence);
    }
    let delta = -libm::atan2f(sin, cos) / turn;
    if !delta.is_finite() {
        return (0.0, coherence);
    }
    for (v, map) in maps.iter_mut().enumerate().take(grid.len()) {
        if !state.is_tracked(v) {
            continue;
        }
        let b = baseline(grid, v);
        let shift = Mat::new(
            1.0,
            0.0,
            -delta * b.0,
            0.0,
            1.0,
            -delta * b.1,
            0.0,
            0.0,
            1.0,
        );
        if let Some(h) = model::to_homography(&(shift * model::from_homography(map))) {
            *map = h;
        }
    }
    for d in state.d.iter_mut().take(n) {
        *d += delta;
    }
    (delta, coherence)
}

/// RMS of the inlier observations when every view is taken as already rectified.
fn identity_rms(state: &State<'_>) -> f32 {
    // As `solve_points` then `rms` with identity maps, without touching the state: the
    // points are solved one at a time and each view's sum is kept, added in the same
    // order (corners ascending within a view, then views ascending), so the figure is
    // the same to the bit; no table of maps or saved points (≈ 19 KB of stack before).
    let identity = model::from_homography(&Homography::IDENTITY);
    let mut sums = [0.0f32; MAX_VIEWS];
    let mut counts = [0u32; MAX_VIEWS];
    for i in 0..state.corners.len().min(MAX_FEATURES) {
        let Some(point) = state.solve_point(i, |_| Some(identity)) else {
            continue;
        };
        for (v, (sum, count)) in sums.iter_mut().zip(&mut counts).enumerate() {
            if v >= state.grid.len() || !state.is_tracked(v) || !state.inlier(v, i) {
                continue;
            }
            let Some(q) = state.ob(v, i) else { continue };
            let Some(u) = model::apply(&identity, q.0, q.1) else {
                continue;
            };
            let r = reprojection_error(u, point, baseline(state.grid, v));
            *sum += r * r;
            *count += 1;
        }
    }
    let (mut total, mut count) = (0.0f32, 0usize);
    for (&sum, &k) in sums.iter().zip(&counts).take(state.grid.len()) {
        total += sum;
        count += k as usize;
    }
    root_mean(total, count)
}
