//! The alternating estimate: view steps (one homography per view from its inlier tracks)
//! and point steps in turn, the inlier threshold tightened each round, until the
//! reprojection error settles.

use heapless::Vec as FixedVec;

use super::frame::{correct_common_distortion, fix_gauge, snap_disparity_offset};
use super::observations::{reprojection_error, root_mean, State};
use super::views::{baseline, views_where, TASK_BATCH};
use crate::align::model::{self, Rng};
use crate::align::{
    AlignModel, AlignParams, AlignReport, Reference, ViewMap, ViewReport, ViewTask, MAX_FEATURES,
    MAX_VIEWS,
};
use crate::error::{Error, Result};
use crate::geometry::Homography;

/// RANSAC threshold of the first round (pixels): misalignment is still in the points.
const FIRST_THRESHOLD: f32 = 3.0;
const RANSAC_ROUNDS: usize = 24;
/// Sigma clipping of the inlier set once the threshold has settled.
const CLIP_SIGMAS: f32 = 3.0;
/// The clipping threshold never goes below this (pixels): tracking noise.
const MIN_CLIP: f32 = 0.05;

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

/// Estimates the homographies of the tracked views by alternating view and point steps
/// (see the module documentation of `solve`) and reports the result: maps rectified → view.
pub(super) fn alternate<M: ViewMap>(
    state: &mut State<'_>,
    params: &AlignParams,
    maps: &mut [Homography],
    width: usize,
    height: usize,
    map: &mut M,
    report: &mut AlignReport,
) -> Result<()> {
    let grid = state.grid;
    let n = state.corners.len();
    report.start(n);
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
    Ok(())
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
