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

/// The power of two by which [`Views::cost`] scales its terms, as `scale · robust`
/// (`robust` the squared residual scale times the channels, scaled intensity²;
/// `memberships` the views counted once per group they belong to): each view's weighted
/// energy is at most `robust`, so the cost stays below `2^13` while its terms use the
/// bits of Q16.16 (at the default scale one term is at most 0.077 unscaled, 5033 LSB;
/// a propagation decision compares costs to a share of 0.7, which the rounding of small
/// terms flipped). Powers of two scale `f32` exactly: its decisions do not change.
/// One (no scaling) without a robust scale (`robust` = `MAX`).
pub(crate) fn cost_scale(robust: f32, memberships: f32) -> f32 {
    if !(robust > 0.0 && robust < f32::MAX && memberships > 0.0) {
        return 1.0;
    }
    let room = libm::floorf(libm::log2f(8192.0 / (robust * memberships)));
    libm::ldexpf(1.0, room.clamp(0.0, 16.0) as i32)
}

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
    /// One half in `T`.
    half: T,
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

/// The scaled intensities of `L` consecutive samples from `at`: a pixel's `CH` samples
/// and, when `L > CH`, the next pixel's first (zero past the end of the data), a lane
/// that keeps three channels in four SIMD lanes and that no sum reads (`None` when the
/// pixel itself lies past the end).
#[inline(always)]
fn lanes<T: Scalar, S: Sample, const CH: usize, const L: usize>(
    data: &[S],
    at: usize,
    levels: &[T; 256],
) -> Option<[T; L]> {
    if let Some(s) = samples::<S, L>(data, at) {
        return Some(s.map(|v| texel(v, levels)));
    }
    let s = data.get(at..at.wrapping_add(CH.min(L)))?;
    let mut out = [T::ZERO; L];
    for (o, &v) in out.iter_mut().zip(s) {
        *o = texel(v, levels);
    }
    Some(out)
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
            half: T::from_f32(0.5),
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
                    if let Some(terms) = views.terms.get_mut(g) {
                        *terms += used as f32;
                    }
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
    /// (zeroed first), each view weighted by `scaled / (robust + Σ r²)` (`robust` the
    /// squared residual scale times the channels, in scaled intensity²; `scaled` the
    /// same times the statistics' power-of-two scale). Views whose
    /// samples leave the image are skipped.
    #[inline]
    pub(crate) fn pixel<S: Sample>(
        &self,
        data: &[S],
        x: usize,
        y: usize,
        d: T,
        robust: (T, T),
        out: &mut [T; STATS],
    ) {
        // A layout has 1, 3 or 4 channels (`Layout::validate`): one or three are used.
        match self.channels {
            1 => self.pixel_channels::<S, 1, 1, 1>(data, x, y, d, robust, out),
            3 => self.pixel_channels::<S, 3, 3, 4>(data, x, y, d, robust, out),
            4 => self.pixel_channels::<S, 4, 3, 4>(data, x, y, d, robust, out),
            _ => *out = [T::ZERO; STATS],
        }
    }

    /// The robust photometric cost of pixel `(x, y)` at disparity `d`: the sum over the
    /// groups of their weighted residual energy `E` times `scale / robust` (`scaled` =
    /// `scale`: a power of two, see [`cost_scale`]), at a third of the sampling of
    /// [`Views::pixel`] (the derivative's samples are not needed). `None` when the cost
    /// is not below `bar`, as soon as that is known: every term is non-negative and
    /// rounded sums are monotonic, so the sum of the views so far (in the same order) is a
    /// lower bound of the cost.
    #[inline]
    pub(crate) fn cost<S: Sample>(
        &self,
        data: &[S],
        x: usize,
        y: usize,
        d: T,
        robust: (T, T),
        bar: Option<T>,
    ) -> Option<T> {
        match self.channels {
            1 => self.cost_channels::<S, 1, 1, 1>(data, x, y, d, robust, bar),
            3 => self.cost_channels::<S, 3, 3, 4>(data, x, y, d, robust, bar),
            4 => self.cost_channels::<S, 4, 3, 4>(data, x, y, d, robust, bar),
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
        let centre = lanes::<T, S, CH, N>(data, base, &self.levels)?;
        // `refine_band` checked that every coordinate converts without saturating.
        Some((centre, T::from_i32(x as i32), T::from_i32(y as i32)))
    }

    /// Whether the derivative's samples of `tap` lie inside the image: at `d ± h` for an
    /// oblique view, half a pixel either side of the position at `d` along the axis of
    /// a view in the centre row or column ([`Views::axis`]). Both the statistics and the
    /// cost skip the views where they do not.
    #[inline(always)]
    fn sees(&self, tap: &Tap<T>, xf: T, yf: T, d: T) -> bool {
        let along = |coordinate: T, offset: T, max: T| {
            let p = coordinate - d * offset;
            p - self.half >= T::ZERO && p + self.half <= max
        };
        if tap.in_row {
            return along(xf, tap.du, self.x_max);
        }
        if tap.in_column {
            return along(yf, tap.dv, self.y_max);
        }
        let (dp, dm) = (d + tap.h, d - tap.h);
        let inside = |dd: T| {
            let (px, py) = (xf - dd * tap.du, yf - dd * tap.dv);
            px >= T::ZERO && px <= self.x_max && py >= T::ZERO && py <= self.y_max
        };
        inside(dp) && inside(dm)
    }

    fn pixel_channels<S: Sample, const CH: usize, const N: usize, const L: usize>(
        &self,
        data: &[S],
        x: usize,
        y: usize,
        d: T,
        (robust, scaled): (T, T),
        out: &mut [T; STATS],
    ) {
        *out = [T::ZERO; STATS];
        let Some((centre, xf, yf)) = self.centre::<S, CH, L>(data, x, y) else {
            return;
        };
        // `len` ≤ MAX_VIEWS (`new` stops there): the default never happens.
        for tap in self.taps.get(..self.len).unwrap_or_default() {
            // The image at the sample position on either side (half a pixel of image
            // motion) and at it: `g = (first − second) · factor`.
            let samples = if tap.in_row || tap.in_column {
                self.axis::<S, CH, L>(data, tap, (x, y), (xf, yf), d)
            } else {
                self.oblique::<S, CH, L>(data, tap, (x, y), (xf, yf), d)
            };
            let Some(([first, second, at], factor)) = samples else {
                continue;
            };
            // Every lane at once (SIMD-friendly), then the used channels summed in order.
            let (mut gg, mut gr, mut rr) = ([T::ZERO; L], [T::ZERO; L], [T::ZERO; L]);
            for c in 0..L {
                let g = (first[c] - second[c]) * factor;
                let r = at[c] - centre[c];
                gg[c] = g * g;
                gr[c] = g * (g * d - r);
                rr[c] = r * r;
            }
            let (mut a, mut b, mut e) = (T::ZERO, T::ZERO, T::ZERO);
            for c in 0..N.min(L) {
                a += gg[c];
                b += gr[c];
                e += rr[c];
            }
            // Cauchy weight of the view (iteratively reweighted least squares): a view
            // that disagrees by much more than the noise (an occluder, a highlight)
            // hardly counts.
            let w = scaled / (robust + e);
            let (a, b, e) = (w * a, w * b, w * e);
            let mut add = |g: usize| {
                if let Some(sums) = out.get_mut(3 * g..3 * g + 3) {
                    sums[0] += a;
                    sums[1] += b;
                    sums[2] += e;
                }
            };
            add(tap.group);
            if let Some(g) = tap.second_group {
                add(g);
            }
        }
    }

    fn cost_channels<S: Sample, const CH: usize, const N: usize, const L: usize>(
        &self,
        data: &[S],
        x: usize,
        y: usize,
        d: T,
        (robust, scaled): (T, T),
        bar: Option<T>,
    ) -> Option<T> {
        let total = |energy: &[T; GROUPS]| energy.iter().fold(T::ZERO, |sum, &e| sum + e);
        let below = |c: T| bar.is_none_or(|bar| c < bar);
        let Some((centre, xf, yf)) = self.centre::<S, CH, L>(data, x, y) else {
            return below(T::ZERO).then_some(T::ZERO);
        };
        // Per group, in the order `pixel` sums them, so that the cost has its bits.
        let mut energy = [T::ZERO; GROUPS];
        // `len` ≤ MAX_VIEWS (`new` stops there): the default never happens.
        for tap in self.taps.get(..self.len).unwrap_or_default() {
            if !self.sees(tap, xf, yf, d) {
                continue;
            }
            let Some(at) =
                self.bilinear::<S, CH, L>(data, tap, (x, y), (xf - d * tap.du, yf - d * tap.dv))
            else {
                continue;
            };
            let mut rr = [T::ZERO; L];
            for c in 0..L {
                let r = at[c] - centre[c];
                rr[c] = r * r;
            }
            let mut e = T::ZERO;
            for &v in &rr[..N.min(L)] {
                e += v;
            }
            let e = scaled / (robust + e) * e;
            let mut add = |g: usize| {
                if let Some(sum) = energy.get_mut(g) {
                    *sum += e;
                }
            };
            add(tap.group);
            if let Some(g) = tap.second_group {
                add(g);
            }
            if !below(total(&energy)) {
                return None;
            }
        }
        let cost = total(&energy);
        below(cost).then_some(cost)
    }

    /// The samples of a view in the centre row or column of the grid, whose image
    /// motion lies along one image axis: at `p − ½`, `p + ½` and `p`, `p` the position
    /// at `d` along that axis, from the three samples around them (one cell split, one
    /// bounds check). `p` itself is interpolated as by [`Views::bilinear`]. The
    /// derivative's factor is the view's offset: `g = −∂I/∂p · offset`.
    /// `None` when `p ± ½` leaves the image.
    #[inline(always)]
    fn axis<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        tap: &Tap<T>,
        (x, y): (usize, usize),
        (xf, yf): (T, T),
        d: T,
    ) -> Option<([[T; L]; 3], T)> {
        let (coordinate, offset, max, last, base, stride) = if tap.in_row {
            let base = tap.start + y * self.row_stride;
            (xf, tap.du, self.x_max, self.x_last + 1, base, CH)
        } else {
            let base = tap.start + x * CH;
            (
                yf,
                tap.dv,
                self.y_max,
                self.y_last + 1,
                base,
                self.row_stride,
            )
        };
        let half = self.half;
        let p = coordinate - d * offset;
        let low = p - half;
        if !(low >= T::ZERO && p + half <= max) {
            return None;
        }
        // `low = k + f`: the samples k, k + 1 and k + 2 (k + 2 only weighs when inside).
        let (k, f) = split(low);
        let at = |i: usize| lanes::<T, S, CH, L>(data, base + i * stride, &self.levels);
        let start = base + k * CH;
        let run = (tap.in_row && k + 2 <= last)
            .then(|| data.get(start..start.wrapping_add(2 * CH + L)))
            .flatten();
        let (t0, t1, t2) = if let Some(run) = run {
            // The three pixels lie side by side in the row: one bounds check.
            let lane = |o: usize| -> [T; L] {
                let mut out = [T::ZERO; L];
                for (c, v) in out.iter_mut().enumerate() {
                    *v = texel(run[o + c], &self.levels);
                }
                out
            };
            (lane(0), lane(CH), lane(2 * CH))
        } else {
            let (t0, t1) = (at(k)?, at(k + 1)?);
            (t0, t1, if k + 2 <= last { at(k + 2)? } else { t1 })
        };
        let lerp = |s0: [T; L], s1: [T; L], a: T| {
            let mut out = [T::ZERO; L];
            for c in 0..L {
                out[c] = s0[c] + a * (s1[c] - s0[c]);
            }
            out
        };
        let centre = if f < half {
            lerp(t0, t1, f + half)
        } else {
            lerp(t1, t2, f - half)
        };
        Some(([lerp(t0, t1, f), lerp(t1, t2, f), centre], offset))
    }

    /// The samples of any other view: bilinear at `d + h`, `d − h` and `d`, with the
    /// central difference's factor `1 / (2h)`. `None` when a sample leaves the image.
    #[inline(always)]
    fn oblique<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        tap: &Tap<T>,
        pixel: (usize, usize),
        (xf, yf): (T, T),
        d: T,
    ) -> Option<([[T; L]; 3], T)> {
        if !self.sees(tap, xf, yf, d) {
            return None;
        }
        let (dp, dm) = (d + tap.h, d - tap.h);
        let sample = |dd: T| {
            self.bilinear::<S, CH, L>(data, tap, pixel, (xf - dd * tap.du, yf - dd * tap.dv))
        };
        Some(([sample(dp)?, sample(dm)?, sample(d)?], tap.inv))
    }

    /// Bilinear sample of the `L` lanes at `(px, py)` (see [`lanes`]), inside the image,
    /// for the centre-view pixel `pixel` (`None` only for a layout the samples do not
    /// fill).
    #[inline(always)]
    fn bilinear<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        tap: &Tap<T>,
        pixel: (usize, usize),
        (px, py): (T, T),
    ) -> Option<[T; L]> {
        let levels = &self.levels;
        let lerp = |s0: [T; L], s1: [T; L], a: T| {
            let mut out = [T::ZERO; L];
            for c in 0..L {
                out[c] = s0[c] + a * (s1[c] - s0[c]);
            }
            out
        };
        let at = |i: usize| lanes::<T, S, CH, L>(data, i, levels);
        Some(if tap.in_row {
            // Horizontal neighbours: the row is exact, one lerp.
            let (x0, ax) = cell(px, self.x_last, self.x_cell);
            let i0 = tap.start + pixel.1 * self.row_stride + x0 * CH;
            lerp(at(i0)?, at(i0 + CH)?, ax)
        } else if tap.in_column {
            let (y0, ay) = cell(py, self.y_last, self.y_cell);
            let i0 = tap.start + y0 * self.row_stride + pixel.0 * CH;
            lerp(at(i0)?, at(i0 + self.row_stride)?, ay)
        } else {
            let (x0, ax) = cell(px, self.x_last, self.x_cell);
            let (y0, ay) = cell(py, self.y_last, self.y_cell);
            let i00 = tap.start + y0 * self.row_stride + x0 * CH;
            let i10 = i00 + self.row_stride;
            let top = lerp(at(i00)?, at(i00 + CH)?, ax);
            let bottom = lerp(at(i10)?, at(i10 + CH)?, ax);
            lerp(top, bottom, ay)
        })
    }
}
