//! The across-view parts of the gradients as bands of consecutive views: each view's
//! gradients read a fixed number of neighbouring views, so the tensor kernel's loops have
//! a compile-time length.

use crate::lightfield::GRID_MAX;
use crate::scalar::Scalar;

/// Mixing entries below this fraction of their row's largest are dropped: the inner
/// Gaussian's 3σ tails (≈ 3·10⁻⁴ of the centre at σ = 0.5) would otherwise widen every
/// row by two views for no measurable change (docs/stages/epi.md).
const PRUNE: f32 = 1e-3;

/// The across-view gradients of every view as bands of `taps` consecutive views: view `k`
/// reads views `start[k] + m` (`m < taps`, clamped to the last view) with weights `smooth[k]` (smoothing across views, for the
/// along-line gradient) and `derivative[k]` (derivative across views), both scaled by the
/// square root of view k's outer weight so that the tensor terms are plain products.
/// Entries below `PRUNE` of their row's largest are zero.
#[derive(Clone, Copy, Debug)]
pub(super) struct Band<T: Scalar> {
    /// First view of each view's band.
    pub(super) start: [usize; GRID_MAX],
    pub(super) smooth: [[T; GRID_MAX]; GRID_MAX],
    pub(super) derivative: [[T; GRID_MAX]; GRID_MAX],
    /// Views with a non-zero outer weight.
    pub(super) active: [bool; GRID_MAX],
    pub(super) taps: usize,
}

impl<T: Scalar> Band<T> {
    /// Bands of the mixing rows of `views` views: `rows(k)` gives row `k` of the
    /// smoothing and of the derivative matrix. It is called twice per row (the two
    /// 17×17 matrices are not held: on a firmware's stack they were 2.3 KB).
    pub(super) fn new(
        rows: impl Fn(usize) -> ([f32; GRID_MAX], [f32; GRID_MAX]),
        active: [bool; GRID_MAX],
        views: usize,
    ) -> Self {
        let views = views.min(GRID_MAX);
        let significant = |row: &[f32; GRID_MAX], j: usize| {
            let largest = row
                .iter()
                .take(views)
                .fold(0.0f32, |m, &v| m.max(libm::fabsf(v)));
            row.get(j)
                .is_some_and(|&v| v != 0.0 && libm::fabsf(v) >= PRUNE * largest)
        };
        let mut spans = [(0usize, 0usize); GRID_MAX];
        let mut taps = 1;
        for (k, span) in spans.iter_mut().enumerate().take(views) {
            let (smooth, derivative) = rows(k);
            let used = |j: &usize| significant(&smooth, *j) || significant(&derivative, *j);
            let first = (0..views).find(used).unwrap_or(k);
            let last = (0..views).rev().find(used).unwrap_or(k);
            *span = (first, last.max(first));
            taps = taps.max(last.max(first) - first + 1);
        }
        let mut band = Band {
            start: [0; GRID_MAX],
            smooth: [[T::ZERO; GRID_MAX]; GRID_MAX],
            derivative: [[T::ZERO; GRID_MAX]; GRID_MAX],
            active,
            taps,
        };
        let last_view = views.saturating_sub(1);
        for (k, &(first, last)) in spans.iter().enumerate().take(views) {
            let (smooth, derivative) = rows(k);
            // The window starts early enough to stay inside the views where it can.
            let start = first.min(views.saturating_sub(Self::width_for(taps)));
            band.start[k] = start;
            for m in 0..GRID_MAX {
                let j = (start + m).min(last_view);
                if start + m == j && (first..=last).contains(&j) {
                    if let (true, Some(&v)) = (significant(&smooth, j), smooth.get(j)) {
                        band.smooth[k][m] = T::from_f32(v);
                    }
                    if let (true, Some(&v)) = (significant(&derivative, j), derivative.get(j)) {
                        band.derivative[k][m] = T::from_f32(v);
                    }
                }
            }
        }
        band
    }

    /// The compiled band width used for `taps` significant views.
    pub(super) fn width_for(taps: usize) -> usize {
        match taps {
            0..=3 => 3,
            4..=5 => 5,
            6..=7 => 7,
            8..=9 => 9,
            _ => GRID_MAX,
        }
    }
}
