//! The track table and the per-corner unknowns: observations and their inlier flags per
//! view and corner, and the points step that solves each corner's position and disparity.

use nalgebra::{Matrix3, Vector3};

use super::views::baseline;
use crate::align::corners::Corner;
use crate::align::model::{self, Mat};
use crate::align::{MAX_FEATURES, MAX_VIEWS};
use crate::geometry::Homography;
use crate::lightfield::Grid;

/// Side of the plane-patch grid of [`AlignModel::PlanePatches`](crate::align::AlignModel::PlanePatches).
pub(super) const PATCHES: usize = 4;

/// The centre view's corners, as three per-corner tables in the alignment scratch (a
/// fixed-capacity list of them made `align::solve::run`'s frame 6 KB larger).
pub(super) struct Corners<'s> {
    x: &'s mut [f32; MAX_FEATURES],
    y: &'s mut [f32; MAX_FEATURES],
    strength: &'s mut [f32; MAX_FEATURES],
    len: usize,
}

impl<'s> Corners<'s> {
    /// An empty list over three tables.
    pub(super) fn new(
        x: &'s mut [f32; MAX_FEATURES],
        y: &'s mut [f32; MAX_FEATURES],
        strength: &'s mut [f32; MAX_FEATURES],
    ) -> Self {
        Corners {
            x,
            y,
            strength,
            len: 0,
        }
    }
    /// Appends `c`; `false` when the list is full.
    pub(super) fn push(&mut self, c: Corner) -> bool {
        let i = self.len;
        match (
            self.x.get_mut(i),
            self.y.get_mut(i),
            self.strength.get_mut(i),
        ) {
            (Some(x), Some(y), Some(s)) => {
                (*x, *y, *s) = (c.x, c.y, c.strength);
                self.len += 1;
                true
            }
            _ => false,
        }
    }
    pub(super) fn len(&self) -> usize {
        self.len
    }
    pub(super) fn get(&self, i: usize) -> Option<Corner> {
        if i >= self.len {
            return None;
        }
        Some(Corner {
            x: *self.x.get(i)?,
            y: *self.y.get(i)?,
            strength: *self.strength.get(i)?,
        })
    }
    /// The corners in detection order.
    pub(super) fn iter(&self) -> impl Iterator<Item = Corner> + '_ {
        (0..self.len).map_while(|i| self.get(i))
    }
}

/// The track table and per-corner unknowns, over borrowed scratch.
pub(super) struct State<'s> {
    pub(super) grid: Grid,
    pub(super) corners: Corners<'s>,
    /// `(x, y)` per view and corner; NaN when not tracked.
    pub(super) obs: &'s mut [f32],
    /// 1 for an inlier observation, 0 otherwise.
    pub(super) weight: &'s mut [f32],
    pub(super) x: &'s mut [f32; MAX_FEATURES],
    pub(super) y: &'s mut [f32; MAX_FEATURES],
    pub(super) d: &'s mut [f32; MAX_FEATURES],
    /// Whether corner `i` has enough inlier observations to be solved.
    pub(super) solved: [bool; MAX_FEATURES],
    /// Views tracked (centre included), a bitmap over the grid.
    pub(super) tracked: [bool; MAX_VIEWS],
}

impl State<'_> {
    pub(super) fn ob(&self, v: usize, i: usize) -> Option<(f32, f32)> {
        let k = (v * MAX_FEATURES + i) * 2;
        let (x, y) = (*self.obs.get(k)?, *self.obs.get(k + 1)?);
        x.is_finite().then_some((x, y))
    }
    pub(super) fn set_ob(&mut self, v: usize, i: usize, q: Option<(f32, f32)>) {
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
    pub(super) fn set_inlier(&mut self, v: usize, i: usize, inlier: bool) {
        if let Some(w) = self.weight.get_mut(v * MAX_FEATURES + i) {
            *w = if inlier { 1.0 } else { 0.0 };
        }
    }
    pub(super) fn inlier(&self, v: usize, i: usize) -> bool {
        self.weight
            .get(v * MAX_FEATURES + i)
            .is_some_and(|&w| w > 0.5)
    }
    pub(super) fn is_tracked(&self, v: usize) -> bool {
        self.tracked.get(v) == Some(&true)
    }
    pub(super) fn is_solved(&self, i: usize) -> bool {
        self.solved.get(i) == Some(&true)
    }

    /// Points step: `(X_i, d_i)` for every corner from its inlier observations mapped by
    /// `maps` (view → rectified).
    pub(super) fn solve_points(&mut self, maps: &[Homography]) {
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
    pub(super) fn solve_point(
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
    pub(super) fn fit_planes(&mut self, maps: &[Homography], width: usize, height: usize) {
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
                if self.solved[i] && self.corners.get(i).is_some_and(|c| in_patch(&c)) {
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
                if !(self.solved[i] && self.corners.get(i).is_some_and(|c| in_patch(&c))) {
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
    pub(super) fn residual(&self, m: &Mat, v: usize, i: usize) -> Option<f32> {
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
pub(super) fn reprojection_error(u: (f32, f32), (x, y, d): (f32, f32, f32), b: (f32, f32)) -> f32 {
    let (ex, ey) = (u.0 - (x - d * b.0), u.1 - (y - d * b.1));
    crate::float::sqrtf(ex * ex + ey * ey)
}

/// `sqrt(total / count)`, infinite without observations.
pub(super) fn root_mean(total: f32, count: usize) -> f32 {
    if count == 0 {
        f32::INFINITY
    } else {
        crate::float::sqrtf(total / count as f32)
    }
}
