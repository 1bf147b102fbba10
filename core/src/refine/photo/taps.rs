//! The compared views as taps: axis taps in the centre row and column, oblique taps.

use crate::lightfield::GRID_MAX;
use crate::scalar::Scalar;

use super::statistics::Interval;
use super::{Views, GROUPS};

/// A compared view off the centre row and column (the diagonal and full view sets).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Tap<T> {
    /// Index of the view's first sample.
    pub(super) start: usize,
    /// Camera offset from the centre (columns, rows).
    pub(super) du: T,
    pub(super) dv: T,
    /// Half the disparity step of the central difference: one pixel of image motion.
    pub(super) h: T,
    /// `1 / (2h)`: the central difference's divisor (the view's reach, an integer).
    pub(super) inv: T,
    /// The groups the view belongs to: one or (off the centre row and column) two,
    /// each below [`GROUPS`].
    pub(super) group: usize,
    pub(super) second_group: Option<usize>,
}

impl<T: Scalar> Tap<T> {
    /// One view's Cauchy-weighted residual energy over the first `n` channels,
    /// `scaled · e / (robust + e)`.
    pub(super) fn weighted_cost<const L: usize>(
        &self,
        at: &[T; L],
        centre: &[T; L],
        n: usize,
        (robust, scaled): (T, T),
        slack: Option<&Interval<T, L>>,
    ) -> T {
        let mut e = T::ZERO;
        for c in 0..n.min(L) {
            let mut r = at[c] - centre[c];
            if let Some(s) = slack {
                r = s.outside(r, c);
            }
            e += r * r;
        }
        scaled / (robust + e) * e
    }

    /// Adds one view's normal-equation terms `(a, b, e)` to the sums of its groups
    /// (`out[3g..3g + 3]`), Cauchy-weighted by its residual energy `e`:
    /// `w = scaled / (robust + e)`.
    pub(super) fn add_weighted(
        &self,
        out: &mut [T],
        (a, b, e): (T, T, T),
        (robust, scaled): (T, T),
    ) {
        let w = scaled / (robust + e);
        let (a, b, e) = (w * a, w * b, w * e);
        let mut add = |g: usize| {
            if let Some(sums) = out.get_mut(3 * g..3 * g + 3) {
                sums[0] += a;
                sums[1] += b;
                sums[2] += e;
            }
        };
        add(self.group);
        if let Some(g) = self.second_group {
            add(g);
        }
    }
}

/// An oblique view as [`Views`] keeps it, expanded to a [`Tap`] where it is used: 16
/// bytes on 32-bit targets instead of the tap's 32 (a table of `MAX_VIEWS` full taps
/// was the largest part of the whole-frame firmware's deepest stack frame).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct StoredTap {
    /// Index of the view's first sample.
    pub(super) start: usize,
    /// Camera offset from the centre (columns, rows), at most `GRID_MAX / 2`.
    pub(super) du: i8,
    pub(super) dv: i8,
    /// Distance from the centre view (grid steps): the index of its `(h, 1 / (2h))`
    /// in [`Views::steps`].
    pub(super) reach: u8,
    /// The groups the view belongs to (below [`GROUPS`]; `GROUPS` for no second one).
    pub(super) group: u8,
    pub(super) second_group: u8,
}

impl StoredTap {
    /// No view (a table's unused entry).
    pub(super) const EMPTY: Self = StoredTap {
        start: 0,
        du: 0,
        dv: 0,
        reach: 0,
        group: 0,
        second_group: 0,
    };
}

/// Entries of [`Views::steps`]: reaches 0…`GRID_MAX / 2`.
pub(super) const STEPS: usize = GRID_MAX / 2 + 1;

/// A compared view in the centre row or column of the grid: its samples move along one
/// image axis, and it belongs to one group.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct AxisTap<T> {
    /// Index of the view's first sample.
    pub(super) start: usize,
    /// Camera offset along the axis of motion (columns in the centre row, rows in the
    /// centre column).
    pub(super) offset: T,
    /// In the centre row (motion along x), else in the centre column (along y).
    pub(super) in_row: bool,
    /// The group (left, right, up, down) the view belongs to.
    pub(super) group: usize,
    /// Distance from the centre view (grid steps).
    pub(super) reach: usize,
}

impl<T: Scalar> AxisTap<T> {
    /// No view (a table's unused entry).
    pub(super) const EMPTY: Self = AxisTap {
        start: 0,
        offset: T::ZERO,
        in_row: false,
        group: 0,
        reach: 0,
    };
}

impl<T: Scalar> Views<T> {
    /// The oblique taps.
    #[inline(always)]
    pub(super) fn oblique_taps(&self) -> impl Iterator<Item = Tap<T>> + '_ {
        // `len` ≤ MAX_VIEWS (`new` stops there): the default never happens.
        let stored = self.taps.get(..self.len).unwrap_or_default();
        stored.iter().map(|t| {
            // `reach` < STEPS (`new`): the default never happens.
            let (h, inv) = self
                .steps
                .get(usize::from(t.reach))
                .copied()
                .unwrap_or((T::ZERO, T::ZERO));
            let second = usize::from(t.second_group);
            Tap {
                start: t.start,
                // The same values as `T::from_f32` of the offsets (small integers).
                du: T::from_i32(i32::from(t.du)),
                dv: T::from_i32(i32::from(t.dv)),
                h,
                inv,
                group: usize::from(t.group),
                second_group: (second < GROUPS).then_some(second),
            }
        })
    }

    /// Where the samples of an axis tap lie for pixel `(x, y)`: the position along the
    /// axis, its largest value, the index of the last sample along it, the sample index
    /// of position 0 and the stride between positions (in samples).
    #[inline(always)]
    pub(super) fn axis_frame(
        &self,
        tap: &AxisTap<T>,
        (x, y): (usize, usize),
        (xf, yf): (T, T),
        d: T,
    ) -> (T, T, usize, usize, usize) {
        if tap.in_row {
            (
                xf - d * tap.offset,
                self.x_max,
                self.x_last + 1,
                tap.start + y * self.row_stride,
                self.channels,
            )
        } else {
            (
                yf - d * tap.offset,
                self.y_max,
                self.y_last + 1,
                tap.start + x * self.channels,
                self.row_stride,
            )
        }
    }

    /// Whether the derivative's samples of an oblique `tap` (at `d ± h`) lie inside the
    /// image. Both the statistics and the cost skip the views where they do not (for an
    /// axis tap: where the position at `d` is not half a pixel inside the image).
    #[inline(always)]
    pub(super) fn sees(&self, tap: &Tap<T>, xf: T, yf: T, d: T) -> bool {
        let (dp, dm) = (d + tap.h, d - tap.h);
        let inside = |dd: T| {
            let (px, py) = (xf - dd * tap.du, yf - dd * tap.dv);
            px >= T::ZERO && px <= self.x_max && py >= T::ZERO && py <= self.y_max
        };
        inside(dp) && inside(dm)
    }
}

/// Every compared view as an oblique tap (axis views included): the simple path of
/// [`Mapped`](super::Mapped), which samples each view through its homography.
impl<T: Scalar> Views<T> {
    pub(super) fn all_taps(&self) -> impl Iterator<Item = Tap<T>> + '_ {
        let axis = self.axis.get(..self.axis_len).unwrap_or_default();
        axis.iter()
            .map(|a| {
                let h = 0.5 / (a.reach.max(1) as f32);
                let (du, dv) = if a.in_row {
                    (a.offset, T::ZERO)
                } else {
                    (T::ZERO, a.offset)
                };
                Tap {
                    start: a.start,
                    du,
                    dv,
                    h: T::from_f32(h),
                    inv: T::from_f32(0.5 / h),
                    group: a.group,
                    second_group: None,
                }
            })
            .chain(self.oblique_taps())
    }
}
