//! Comparing two sets of rectifying homographies modulo what no image can observe.

use nalgebra::{Matrix6, Vector6};

use crate::geometry::Homography;
use crate::lightfield::Grid;

/// The best gauge transform between two sets of rectifying homographies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaugeFit {
    /// Uniform scale `s` (about the image centre).
    pub scale: f32,
    /// Translation `t` (pixels).
    pub translation: (f32, f32),
    /// Disparity offset `δ` at the image centre: a point of true disparity `d` at
    /// `(x, y)` has disparity `s·d − (δ + βx' + γy')` in the estimated rectified array
    /// (`x', y'` about the image centre), so `d = (d_est + δ + βx' + γy') / s`.
    pub disparity_offset: f32,
    /// Disparity slope `(β, γ)` per pixel: the disparity plane no image can tell from
    /// the scene's own (see [`GaugeFit::true_disparity`]).
    pub disparity_slope: (f32, f32),
    /// Image centre the slope is measured from.
    pub centre: (f32, f32),
    /// RMS distance left after the transform (pixels): the registration error.
    pub rms: f32,
}

impl GaugeFit {
    /// The true-array disparity of a disparity `estimated` at pixel `(x, y)` of the
    /// estimated rectified array: the gauge removed.
    pub fn true_disparity(&self, estimated: f32, x: f32, y: f32) -> f32 {
        let (dx, dy) = (x - self.centre.0, y - self.centre.1);
        let plane =
            self.disparity_offset + self.disparity_slope.0 * dx + self.disparity_slope.1 * dy;
        (estimated + plane) / self.scale
    }
}

/// RMS distance in pixels between the rectified frames of `estimate` and `truth`
/// (both rectified → view pixel coordinates, one per view, row-major grid order), after
/// removing the best gauge transform `x ↦ s·x + t + (δ + βx' + γy')·b_v` (uniform scale,
/// translation, and a disparity plane: to first order in the disparity, adding a plane
/// to every disparity is the same as moving each view by its baseline times that plane)
/// that no light field can determine. Measured on an 8 × 8 grid of
/// points per view inside `width` × `height`. `None` when a map is singular.
pub fn gauge_rms(
    estimate: &[Homography],
    truth: &[Homography],
    grid: Grid,
    width: usize,
    height: usize,
) -> Option<f32> {
    gauge_fit(estimate, truth, grid, width, height).map(|g| g.rms)
}

/// The gauge transform behind [`gauge_rms`] (coordinates about the image centre).
pub fn gauge_fit(
    estimate: &[Homography],
    truth: &[Homography],
    grid: Grid,
    width: usize,
    height: usize,
) -> Option<GaugeFit> {
    gauge_fit_where(estimate, truth, grid, width, height, &|_| true)
}

/// [`gauge_fit`] over the views `include` accepts (row-major grid index), e.g. the
/// cross when only those were estimated ([`super::AlignedViews::Cross`]).
pub fn gauge_fit_where(
    estimate: &[Homography],
    truth: &[Homography],
    grid: Grid,
    width: usize,
    height: usize,
    include: &dyn Fn(usize) -> bool,
) -> Option<GaugeFit> {
    if estimate.len() != grid.len() || truth.len() != grid.len() {
        return None;
    }
    let (r0, c0) = grid.center();
    // Each sample: true rectified x, estimated rectified e, baseline b.
    let samples = |v: usize| {
        let inv = estimate[v].inverse();
        let t = truth[v];
        let b = (
            (v % grid.cols) as f32 - c0 as f32,
            (v / grid.cols) as f32 - r0 as f32,
        );
        (0..64).map(move |k| {
            let x = (0.5 + (k % 8) as f32) * width as f32 / 8.0;
            let y = (0.5 + (k / 8) as f32) * height as f32 / 8.0;
            let q = t.apply(x, y)?;
            let e = inv.as_ref()?.apply(q.0, q.1)?;
            Some((x, y, e.0, e.1, b))
        })
    };
    let o = (width as f32 * 0.5, height as f32 * 0.5);
    // f64: the columns differ in scale by the image size times the baseline.
    let mut ata = Matrix6::<f64>::zeros();
    let mut atb = Vector6::<f64>::zeros();
    for v in (0..grid.len()).filter(|&v| include(v)) {
        for s in samples(v) {
            let (x, y, ex, ey, b) = s?;
            let (dx, dy) = (f64::from(x - o.0), f64::from(y - o.1));
            let (bx, by) = (f64::from(b.0), f64::from(b.1));
            let rx = Vector6::new(dx, 1.0, 0.0, bx, bx * dx, bx * dy);
            let ry = Vector6::new(dy, 0.0, 1.0, by, by * dx, by * dy);
            ata += rx * rx.transpose() + ry * ry.transpose();
            atb += rx * f64::from(ex - o.0) + ry * f64::from(ey - o.1);
        }
    }
    let g = ata.lu().solve(&atb)?.map(|v| v as f32);
    let (mut sum, mut count) = (0.0f32, 0usize);
    for v in (0..grid.len()).filter(|&v| include(v)) {
        for s in samples(v) {
            let (x, y, ex, ey, b) = s?;
            let (dx, dy) = (x - o.0, y - o.1);
            let plane = g[3] + g[4] * dx + g[5] * dy;
            let px = g[0] * dx + g[1] + plane * b.0 + o.0;
            let py = g[0] * dy + g[2] + plane * b.1 + o.1;
            sum += (ex - px) * (ex - px) + (ey - py) * (ey - py);
            count += 1;
        }
    }
    (count > 0).then(|| GaugeFit {
        scale: g[0],
        translation: (g[1], g[2]),
        // e = s·(X − d·b) + t + (g₃ + g₄x' + g₅y')·b: the estimated disparity is
        // s·d − (g₃ + g₄x' + g₅y').
        disparity_offset: g[3],
        disparity_slope: (g[4], g[5]),
        centre: o,
        rms: crate::float::sqrtf(sum / count as f32),
    })
}

/// RMS reprojection error in pixels of `estimate` against `truth` (both rectified →
/// view, one per view): scene points on an 8 × 8 grid with each disparity of
/// `disparities` are projected into every view by `truth`, taken back to rectified
/// coordinates by `estimate`, and the best rectified-array fit (one position and one
/// disparity per point) is subtracted. This is what the EPI stage sees; it is blind to
/// the gauge by construction. `None` when a map is singular or no point projects.
pub fn reprojection_rms(
    estimate: &[Homography],
    truth: &[Homography],
    grid: Grid,
    width: usize,
    height: usize,
    disparities: &[f32],
) -> Option<f32> {
    if estimate.len() != grid.len() || truth.len() != grid.len() {
        return None;
    }
    let (r0, c0) = grid.center();
    let baseline = |v: usize| {
        (
            (v % grid.cols) as f32 - c0 as f32,
            (v / grid.cols) as f32 - r0 as f32,
        )
    };
    let (mut sum, mut count) = (0.0f32, 0usize);
    for &d in disparities {
        for k in 0..64 {
            let x = (0.5 + (k % 8) as f32) * width as f32 / 8.0;
            let y = (0.5 + (k / 8) as f32) * height as f32 / 8.0;
            // Rectified positions according to the estimate, and their least-squares
            // rectified-array fit: d' = −cov(b, e)/var(b), X' = mean(e) + d'·mean(b).
            let project = |v: usize| -> Option<(f32, f32)> {
                let b = baseline(v);
                let q = truth[v].apply(x - d * b.0, y - d * b.1)?;
                estimate[v].inverse()?.apply(q.0, q.1)
            };
            let mut fit = super::model::ParallaxFit::default();
            for v in 0..grid.len() {
                fit.add(baseline(v), project(v)?);
            }
            let (xx, yy, dd) = fit.solution();
            for v in 0..grid.len() {
                let e = project(v)?;
                let b = baseline(v);
                let (ex, ey) = (e.0 - (xx - dd * b.0), e.1 - (yy - dd * b.1));
                sum += ex * ex + ey * ey;
                count += 1;
            }
        }
    }
    (count > 0).then(|| crate::float::sqrtf(sum / count as f32))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauge_transforms_cost_nothing_and_real_errors_show() {
        let grid = Grid::new(3, 3);
        let truth = [Homography {
            m: [1.01, 0.02, 1.0, -0.02, 0.99, 2.0, 1e-5, 0.0, 1.0],
        }; 9];
        // estimate_v = truth_v ∘ G_v⁻¹ with G_v(x) = 1.02·x + (3, −1) + 0.4·b_v.
        let mut est = truth;
        for (v, e) in est.iter_mut().enumerate() {
            let b = ((v % 3) as f32 - 1.0, (v / 3) as f32 - 1.0);
            let g = Homography {
                m: [
                    1.02,
                    0.0,
                    3.0 + 0.4 * b.0,
                    0.0,
                    1.02,
                    -1.0 + 0.4 * b.1,
                    0.0,
                    0.0,
                    1.0,
                ],
            };
            *e = truth[v].compose(&g.inverse().unwrap());
        }
        assert!(gauge_rms(&est, &truth, grid, 64, 48).unwrap() < 2e-3);
        assert!(reprojection_rms(&est, &truth, grid, 64, 48, &[-1.0, 2.0]).unwrap() < 2e-3);
        // A rotation of one view is not a gauge transform.
        let rot = Homography {
            m: [1.0, -0.01, 0.0, 0.01, 1.0, 0.0, 0.0, 0.0, 1.0],
        };
        est[2] = est[2].compose(&rot);
        assert!(gauge_rms(&est, &truth, grid, 64, 48).unwrap() > 0.05);
        assert!(reprojection_rms(&est, &truth, grid, 64, 48, &[-1.0, 2.0]).unwrap() > 0.05);
    }
}
