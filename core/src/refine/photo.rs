//! Photo-consistency of one centre-view pixel against the other views at a disparity:
//! per view the residual `r = I_v(x − d·u, y − d·v) − I_c(x, y)` and its derivative
//! `g = ∂r/∂d`, accumulated as Gauss–Newton normal equations in four half-plane groups
//! of views (left, right, up, down) so that occluded halves can be dropped.
//!
//! Everything is computed in the scalar type `T`; see [the module](super) for the scale
//! that keeps Q16.16 precise.

use core::any::Any;

use crate::lightfield::{Layout, Sample, GRID_MAX};
use crate::scalar::Scalar;

use super::params::ViewSet;

/// Half-plane groups of views: left (`c < c0`), right, up (`r < r0`), down.
pub(crate) const GROUPS: usize = 4;
/// Statistics per group: `A = Σ g²`, `B = Σ g·(g·d − r)`, `E = Σ r²`.
pub(crate) const STATS: usize = 3 * GROUPS;
const MAX_VIEWS: usize = GRID_MAX * GRID_MAX;

/// Intensities enter as `sample · INTENSITY_SCALE` (full scale 16, one 8-bit level
/// 0.063). Why: in Q16.16 the squared residual of one level, `(1/255)² ≈ 1.5e-5`, would
/// be a single LSB, so the Cauchy weights and the error `E` would be noise; scaled it is
/// 256 LSB. The largest per-view products, `g² ≤ (reach · 16)²` ≤ 4096 on a 9×9 grid
/// (16384 on 17×17), still fit below 32768. A power of two: `f32` results only scale
/// exactly, bit for bit.
pub(crate) const INTENSITY_SCALE: f32 = 16.0;

/// One compared view.
#[derive(Clone, Copy, Debug, Default)]
struct Tap<T> {
    /// Index of the view's first sample.
    start: usize,
    /// Camera offset from the centre (columns, rows).
    du: T,
    dv: T,
    /// In the centre row (`dv = 0`): samples lie on the pixel's own image row.
    in_row: bool,
    /// In the centre column (`du = 0`): samples lie on the pixel's own image column.
    in_column: bool,
    /// Half the disparity step of the central difference: one pixel of image motion.
    h: T,
    /// `1 / (2h)`: the central difference's divisor (the view's reach, an integer).
    inv: T,
    /// The groups the view belongs to: one or (off the centre row and column) two,
    /// each below [`GROUPS`].
    group: usize,
    second_group: Option<usize>,
}

/// The compared views of a light field.
pub(crate) struct Views<T> {
    taps: [Tap<T>; MAX_VIEWS],
    len: usize,
    /// Views per group times channels: the number of terms of each group per pixel.
    pub terms: [f32; GROUPS],
    centre: usize,
    channels: usize,
    row_stride: usize,
    /// Largest sample position along x and y.
    x_max: T,
    y_max: T,
    /// The last bilinear cell's origin along x and y, as an index and in `T`.
    x_last: usize,
    y_last: usize,
    x_cell: T,
    y_cell: T,
    /// The scaled intensity of each 8-bit level: `level · INTENSITY_SCALE / 255`,
    /// computed in `T` as `T::from_i32(level) · unit` (a table lookup costs less than
    /// the conversion and the product, with the same bits).
    levels: [T; 256],
}

/// The scaled intensity of a sample in `T`. 8-bit samples read the table of levels, so
/// fixed point does no `f32` arithmetic in the sampling loop; `f32` samples cross the
/// `f32 → T` boundary here. (For `T = f32` both equal `to_unit() · INTENSITY_SCALE` bit
/// for bit.)
#[inline(always)]
fn texel<T: Scalar, S: Sample>(sample: S, levels: &[T; 256]) -> T {
    // Resolved at compile time for each sample type.
    match (&sample as &dyn Any).downcast_ref::<u8>() {
        Some(&level) => levels[usize::from(level)],
        None => T::from_f32(sample.to_unit() * INTENSITY_SCALE),
    }
}

/// `(⌊p⌋, p − ⌊p⌋)` of a position `p ≥ 0` inside the image. For `f32` the truncating
/// conversion is the floor of a non-negative value (and the fraction is exact below
/// 2^24), without the out-of-line `floorf`; fixed point splits its bits.
#[inline(always)]
fn split<T: Scalar>(p: T) -> (usize, T) {
    // Resolved at compile time for each scalar type.
    match (&p as &dyn Any).downcast_ref::<f32>() {
        Some(&v) => {
            // `as` saturates (and maps NaN to 0); positions are below the image size.
            let whole = v as u32;
            (whole as usize, T::from_f32(v - whole as f32))
        }
        None => {
            let (whole, fraction) = p.floor_fract();
            (whole.max(0) as usize, fraction)
        }
    }
}

/// The bilinear cell (origin, fraction) of position `p` in `[0, last + 1]`, `last` the
/// last cell's origin (`last_t` in `T`).
#[inline(always)]
fn cell<T: Scalar>(p: T, last: usize, last_t: T) -> (usize, T) {
    let (whole, fraction) = split(p);
    if whole > last {
        // The last row or column itself: the last cell at fraction 1.
        (last, p - last_t)
    } else {
        (whole, fraction)
    }
}

/// `N` consecutive samples from `at` (`None` past the end of the data).
#[inline(always)]
fn samples<S: Sample, const N: usize>(data: &[S], at: usize) -> Option<&[S; N]> {
    // Indices stay far below `usize::MAX`; a wrapped end would only fail the lookup.
    data.get(at..at.wrapping_add(N))?.try_into().ok()
}

impl<T: Scalar> Views<T> {
    /// The views of `set`.
    pub(crate) fn new(layout: &Layout, set: ViewSet) -> Self {
        let grid = layout.grid;
        let (r0, c0) = grid.center();
        let used = layout.channels.min(3);
        let coordinate = |v: usize| T::from_i32(i32::try_from(v).unwrap_or(i32::MAX));
        let unit = T::from_f32(INTENSITY_SCALE / 255.0);
        let mut levels = [T::ZERO; 256];
        for (level, l) in (0i32..).zip(levels.iter_mut()) {
            *l = T::from_i32(level) * unit;
        }
        let x_last = layout.width.saturating_sub(2);
        let y_last = layout.height.saturating_sub(2);
        let mut views = Views {
            taps: [Tap::default(); MAX_VIEWS],
            len: 0,
            terms: [0.0; GROUPS],
            centre: grid.index(r0, c0) * layout.view_stride,
            channels: layout.channels,
            row_stride: layout.row_stride,
            x_max: coordinate(layout.width.saturating_sub(1)),
            y_max: coordinate(layout.height.saturating_sub(1)),
            x_last,
            y_last,
            x_cell: coordinate(x_last),
            y_cell: coordinate(y_last),
            levels,
        };
        for r in 0..grid.rows {
            for c in 0..grid.cols {
                let (dr, dc) = (r as isize - r0 as isize, c as isize - c0 as isize);
                if !set.contains(dr, dc) || views.len >= MAX_VIEWS {
                    continue;
                }
                // Left, right, up, down.
                let horizontal = (dc != 0).then_some(usize::from(dc > 0));
                let vertical = (dr != 0).then_some(2 + usize::from(dr > 0));
                let (group, second_group) = match (horizontal, vertical) {
                    (Some(h), v) => (h, v),
                    (None, Some(v)) => (v, None),
                    (None, None) => continue,
                };
                for g in [Some(group), second_group].into_iter().flatten() {
                    views.terms[g] += used as f32;
                }
                let reach = dr.unsigned_abs().max(dc.unsigned_abs()) as f32;
                let h = 0.5 / reach;
                views.taps[views.len] = Tap {
                    start: grid.index(r, c) * layout.view_stride,
                    du: T::from_f32(dc as f32),
                    dv: T::from_f32(dr as f32),
                    in_row: dr == 0,
                    in_column: dc == 0,
                    h: T::from_f32(h),
                    inv: T::from_f32(0.5 / h),
                    group,
                    second_group,
                };
                views.len += 1;
            }
        }
        views
    }

    /// Accumulates the statistics of pixel `(x, y)` at disparity `d` into `out`
    /// (zeroed first), each view weighted by `robust / (robust + Σ r²)` (`robust` the
    /// squared residual scale times the channels, in scaled intensity²). Views whose
    /// samples leave the image are skipped.
    #[inline]
    pub(crate) fn pixel<S: Sample>(
        &self,
        data: &[S],
        x: usize,
        y: usize,
        d: T,
        robust: T,
        out: &mut [T; STATS],
    ) {
        // A layout has 1, 3 or 4 channels (`Layout::validate`): one or three are used.
        match self.channels {
            1 => self.pixel_channels::<S, 1, 1>(data, x, y, d, robust, out),
            3 => self.pixel_channels::<S, 3, 3>(data, x, y, d, robust, out),
            4 => self.pixel_channels::<S, 4, 3>(data, x, y, d, robust, out),
            _ => *out = [T::ZERO; STATS],
        }
    }

    /// The robust photometric cost of pixel `(x, y)` at disparity `d`: the sum over the
    /// groups of their weighted residual energy `E`, the same value as summing the `E`
    /// of [`Views::pixel`]'s groups, at a third of the sampling (the derivative's
    /// samples are not needed). `None` when the cost is not below `bar`, as soon as
    /// that is known: every term is non-negative and rounded sums are monotonic, so the
    /// sum of the views so far (in the same order) is a lower bound of the cost.
    #[inline]
    pub(crate) fn cost<S: Sample>(
        &self,
        data: &[S],
        x: usize,
        y: usize,
        d: T,
        robust: T,
        bar: Option<T>,
    ) -> Option<T> {
        match self.channels {
            1 => self.cost_channels::<S, 1, 1>(data, x, y, d, robust, bar),
            3 => self.cost_channels::<S, 3, 3>(data, x, y, d, robust, bar),
            4 => self.cost_channels::<S, 4, 3>(data, x, y, d, robust, bar),
            _ => None,
        }
    }

    /// The centre view's samples of pixel `(x, y)` and its coordinates in `T`.
    #[inline(always)]
    fn centre<S: Sample, const CH: usize, const N: usize>(
        &self,
        data: &[S],
        x: usize,
        y: usize,
    ) -> Option<([T; N], T, T)> {
        let base = self.centre + y * self.row_stride + x * CH;
        let centre = samples::<S, N>(data, base)?.map(|s| texel(s, &self.levels));
        // `refine_band` checked that every coordinate converts without saturating.
        Some((centre, T::from_i32(x as i32), T::from_i32(y as i32)))
    }

    /// Whether the samples of `tap` at `d ± h` (the derivative's) lie inside the image:
    /// both the statistics and the cost skip the views where they do not.
    #[inline(always)]
    fn sees(&self, tap: &Tap<T>, xf: T, yf: T, d: T) -> bool {
        let (dp, dm) = (d + tap.h, d - tap.h);
        // Off the view's own axis a position is the pixel's (the offset is zero), which
        // lies inside.
        let inside_x = |dd: T| {
            let p = xf - dd * tap.du;
            p >= T::ZERO && p <= self.x_max
        };
        let inside_y = |dd: T| {
            let p = yf - dd * tap.dv;
            p >= T::ZERO && p <= self.y_max
        };
        (tap.in_column || (inside_x(dp) && inside_x(dm)))
            && (tap.in_row || (inside_y(dp) && inside_y(dm)))
    }

    fn pixel_channels<S: Sample, const CH: usize, const N: usize>(
        &self,
        data: &[S],
        x: usize,
        y: usize,
        d: T,
        robust: T,
        out: &mut [T; STATS],
    ) {
        *out = [T::ZERO; STATS];
        let Some((centre, xf, yf)) = self.centre::<S, CH, N>(data, x, y) else {
            return;
        };
        for tap in &self.taps[..self.len] {
            if !self.sees(tap, xf, yf, d) {
                continue;
            }
            let (dp, dm) = (d + tap.h, d - tap.h);
            let plus =
                self.bilinear::<S, CH, N>(data, tap, (x, y), (xf - dp * tap.du, yf - dp * tap.dv));
            let minus =
                self.bilinear::<S, CH, N>(data, tap, (x, y), (xf - dm * tap.du, yf - dm * tap.dv));
            let at = self.bilinear::<S, CH, N>(data, tap, (x, y), (xf - d * tap.du, yf - d * tap.dv));
            let (Some(plus), Some(minus), Some(at)) = (plus, minus, at) else {
                continue;
            };
            let (mut a, mut b, mut e) = (T::ZERO, T::ZERO, T::ZERO);
            for c in 0..N {
                let g = (plus[c] - minus[c]) * tap.inv;
                let r = at[c] - centre[c];
                a += g * g;
                b += g * (g * d - r);
                e += r * r;
            }
            // Cauchy weight of the view (iteratively reweighted least squares): a view
            // that disagrees by much more than the noise (an occluder, a highlight)
            // hardly counts.
            let w = robust / (robust + e);
            let (a, b, e) = (w * a, w * b, w * e);
            for g in [Some(tap.group), tap.second_group].into_iter().flatten() {
                if let Some(sums) = out.get_mut(3 * g..3 * g + 3) {
                    sums[0] += a;
                    sums[1] += b;
                    sums[2] += e;
                }
            }
        }
    }

    fn cost_channels<S: Sample, const CH: usize, const N: usize>(
        &self,
        data: &[S],
        x: usize,
        y: usize,
        d: T,
        robust: T,
        bar: Option<T>,
    ) -> Option<T> {
        let total = |energy: &[T; GROUPS]| energy.iter().fold(T::ZERO, |sum, &e| sum + e);
        let below = |c: T| bar.is_none_or(|bar| c < bar);
        let Some((centre, xf, yf)) = self.centre::<S, CH, N>(data, x, y) else {
            return below(T::ZERO).then_some(T::ZERO);
        };
        // Per group, in the order `pixel` sums them, so that the cost has its bits.
        let mut energy = [T::ZERO; GROUPS];
        for tap in &self.taps[..self.len] {
            if !self.sees(tap, xf, yf, d) {
                continue;
            }
            let Some(at) =
                self.bilinear::<S, CH, N>(data, tap, (x, y), (xf - d * tap.du, yf - d * tap.dv))
            else {
                continue;
            };
            let mut e = T::ZERO;
            for c in 0..N {
                let r = at[c] - centre[c];
                e += r * r;
            }
            let e = robust / (robust + e) * e;
            for g in [Some(tap.group), tap.second_group].into_iter().flatten() {
                if let Some(sum) = energy.get_mut(g) {
                    *sum += e;
                }
            }
            if !below(total(&energy)) {
                return None;
            }
        }
        let cost = total(&energy);
        below(cost).then_some(cost)
    }

    /// Bilinear sample of the `N` used channels (of `CH`) at `(px, py)`, inside the
    /// image, for the centre-view pixel `pixel` (`None` only for a layout the samples do
    /// not fill).
    #[inline(always)]
    fn bilinear<S: Sample, const CH: usize, const N: usize>(
        &self,
        data: &[S],
        tap: &Tap<T>,
        pixel: (usize, usize),
        (px, py): (T, T),
    ) -> Option<[T; N]> {
        let levels = &self.levels;
        let mut out = [T::ZERO; N];
        // One slice per pair of horizontally adjacent samples: one bounds check.
        let pair = |at: usize| data.get(at..at.wrapping_add(CH + N));
        if tap.in_row {
            // Horizontal neighbours: the row is exact, one lerp.
            let (x0, ax) = cell(px, self.x_last, self.x_cell);
            let s = pair(tap.start + pixel.1 * self.row_stride + x0 * CH)?;
            for c in 0..N {
                let (s0, s1) = (texel(s[c], levels), texel(s[CH + c], levels));
                out[c] = s0 + ax * (s1 - s0);
            }
        } else if tap.in_column {
            let (y0, ay) = cell(py, self.y_last, self.y_cell);
            let i0 = tap.start + y0 * self.row_stride + pixel.0 * CH;
            let (s0, s1) = (
                samples::<S, N>(data, i0)?,
                samples::<S, N>(data, i0 + self.row_stride)?,
            );
            for c in 0..N {
                let (s0, s1) = (texel(s0[c], levels), texel(s1[c], levels));
                out[c] = s0 + ay * (s1 - s0);
            }
        } else {
            let (x0, ax) = cell(px, self.x_last, self.x_cell);
            let (y0, ay) = cell(py, self.y_last, self.y_cell);
            let i00 = tap.start + y0 * self.row_stride + x0 * CH;
            let (t, b) = (pair(i00)?, pair(i00 + self.row_stride)?);
            for c in 0..N {
                let (s00, s01) = (texel(t[c], levels), texel(t[CH + c], levels));
                let (s10, s11) = (texel(b[c], levels), texel(b[CH + c], levels));
                let top = s00 + ax * (s01 - s00);
                let bottom = s10 + ax * (s11 - s10);
                out[c] = top + ay * (bottom - top);
            }
        }
        Some(out)
    }
}
