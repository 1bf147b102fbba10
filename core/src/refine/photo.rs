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
    /// Bit `k` set when the view belongs to group `k`.
    groups: u8,
}

/// The compared views of a light field.
pub(crate) struct Views<T> {
    taps: [Tap<T>; MAX_VIEWS],
    len: usize,
    /// Views per group times channels: the number of terms of each group per pixel.
    pub terms: [f32; GROUPS],
    centre: usize,
    width: usize,
    height: usize,
    channels: usize,
    used: usize,
    row_stride: usize,
    /// Largest sample position along x and y, and the last bilinear cell's origin.
    x_max: T,
    y_max: T,
    x_cell: T,
    y_cell: T,
    /// `INTENSITY_SCALE / 255`: an 8-bit sample's scaled intensity per level.
    unit: T,
}

/// The scaled intensity of a sample in `T`. 8-bit samples take one integer conversion
/// and one multiplication in `T`, so fixed point does no `f32` arithmetic in the
/// sampling loop; `f32` samples cross the `f32 → T` boundary here. (For `T = f32` both
/// equal `to_unit() · INTENSITY_SCALE` bit for bit.)
#[inline(always)]
fn texel<T: Scalar, S: Sample>(sample: S, unit: T) -> T {
    // Resolved at compile time for each sample type.
    match (&sample as &dyn Any).downcast_ref::<u8>() {
        Some(&level) => T::from_i32(i32::from(level)) * unit,
        None => T::from_f32(sample.to_unit() * INTENSITY_SCALE),
    }
}

impl<T: Scalar> Views<T> {
    /// The views of `set`.
    pub(crate) fn new(layout: &Layout, set: ViewSet) -> Self {
        let grid = layout.grid;
        let (r0, c0) = grid.center();
        let used = layout.channels.min(3);
        let coordinate = |v: usize| T::from_i32(i32::try_from(v).unwrap_or(i32::MAX));
        let mut views = Views {
            taps: [Tap::default(); MAX_VIEWS],
            len: 0,
            terms: [0.0; GROUPS],
            centre: grid.index(r0, c0) * layout.view_stride,
            width: layout.width,
            height: layout.height,
            channels: layout.channels,
            used,
            row_stride: layout.row_stride,
            x_max: coordinate(layout.width - 1),
            y_max: coordinate(layout.height - 1),
            x_cell: coordinate(layout.width - 2),
            y_cell: coordinate(layout.height - 2),
            unit: T::from_f32(INTENSITY_SCALE / 255.0),
        };
        for r in 0..grid.rows {
            for c in 0..grid.cols {
                let (dr, dc) = (r as isize - r0 as isize, c as isize - c0 as isize);
                if !set.contains(dr, dc) || views.len >= MAX_VIEWS {
                    continue;
                }
                let groups = u8::from(dc < 0)
                    | u8::from(dc > 0) << 1
                    | u8::from(dr < 0) << 2
                    | u8::from(dr > 0) << 3;
                for (k, t) in views.terms.iter_mut().enumerate() {
                    if groups & (1 << k) != 0 {
                        *t += used as f32;
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
                    groups,
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
        *out = [T::ZERO; STATS];
        let ch = self.channels;
        let base = self.centre + y * self.row_stride + x * ch;
        let mut centre = [T::ZERO; 3];
        for (c, v) in centre.iter_mut().enumerate().take(self.used) {
            *v = texel(data[base + c], self.unit);
        }
        // `refine_band` checked that every coordinate converts without saturating.
        let (xf, yf) = (T::from_i32(x as i32), T::from_i32(y as i32));
        for tap in &self.taps[..self.len] {
            // Sample positions at d + h and d − h.
            let (dp, dm) = (d + tap.h, d - tap.h);
            let (xp, yp) = (xf - dp * tap.du, yf - dp * tap.dv);
            let (xm, ym) = (xf - dm * tap.du, yf - dm * tap.dv);
            let inside = |px: T, py: T| {
                px >= T::ZERO && px <= self.x_max && py >= T::ZERO && py <= self.y_max
            };
            if !(inside(xp, yp) && inside(xm, ym)) {
                continue;
            }
            let mut plus = [T::ZERO; 3];
            let mut minus = [T::ZERO; 3];
            let mut at = [T::ZERO; 3];
            self.bilinear(data, tap, (x, y), (xp, yp), &mut plus);
            self.bilinear(data, tap, (x, y), (xm, ym), &mut minus);
            let (xa, ya) = (xf - d * tap.du, yf - d * tap.dv);
            self.bilinear(data, tap, (x, y), (xa, ya), &mut at);
            let (mut a, mut b, mut e) = (T::ZERO, T::ZERO, T::ZERO);
            for c in 0..self.used {
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
            for k in 0..GROUPS {
                if tap.groups & (1 << k) != 0 {
                    out[3 * k] += a;
                    out[3 * k + 1] += b;
                    out[3 * k + 2] += e;
                }
            }
        }
    }

    /// The bilinear cell (origin, fraction) of position `p` in `[0, last + 1]`, `last`
    /// the last cell's origin (`last_t` in `T`).
    #[inline(always)]
    fn cell(p: T, last: usize, last_t: T) -> (usize, T) {
        let (whole, fraction) = p.floor_fract();
        let whole = whole.max(0) as usize;
        if whole > last {
            // The last row or column itself: the last cell at fraction 1.
            (last, p - last_t)
        } else {
            (whole, fraction)
        }
    }

    /// Bilinear sample of every used channel at `(px, py)`, inside the image, for the
    /// centre-view pixel `pixel`.
    #[inline(always)]
    fn bilinear<S: Sample>(
        &self,
        data: &[S],
        tap: &Tap<T>,
        pixel: (usize, usize),
        (px, py): (T, T),
        out: &mut [T; 3],
    ) {
        let ch = self.channels;
        let unit = self.unit;
        if tap.in_row {
            // Horizontal neighbours: the row is exact, one lerp.
            let (x0, ax) = Self::cell(px, self.width - 2, self.x_cell);
            let i0 = tap.start + pixel.1 * self.row_stride + x0 * ch;
            for (c, o) in out.iter_mut().enumerate().take(self.used) {
                let (s0, s1) = (texel(data[i0 + c], unit), texel(data[i0 + ch + c], unit));
                *o = s0 + ax * (s1 - s0);
            }
        } else if tap.in_column {
            let (y0, ay) = Self::cell(py, self.height - 2, self.y_cell);
            let i0 = tap.start + y0 * self.row_stride + pixel.0 * ch;
            for (c, o) in out.iter_mut().enumerate().take(self.used) {
                let (s0, s1) = (
                    texel(data[i0 + c], unit),
                    texel(data[i0 + self.row_stride + c], unit),
                );
                *o = s0 + ay * (s1 - s0);
            }
        } else {
            let (x0, ax) = Self::cell(px, self.width - 2, self.x_cell);
            let (y0, ay) = Self::cell(py, self.height - 2, self.y_cell);
            let i00 = tap.start + y0 * self.row_stride + x0 * ch;
            let i10 = i00 + self.row_stride;
            for (c, o) in out.iter_mut().enumerate().take(self.used) {
                let (s00, s01) = (texel(data[i00 + c], unit), texel(data[i00 + ch + c], unit));
                let (s10, s11) = (texel(data[i10 + c], unit), texel(data[i10 + ch + c], unit));
                let top = s00 + ax * (s01 - s00);
                let bottom = s10 + ax * (s11 - s10);
                *o = top + ay * (bottom - top);
            }
        }
    }
}
