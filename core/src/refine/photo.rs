//! Photo-consistency of one centre-view pixel against the other views at a disparity:
//! per view the residual `r = I_v(x − d·u, y − d·v) − I_c(x, y)` and its derivative
//! `g = ∂r/∂d`, accumulated as Gauss–Newton normal equations in four half-plane groups
//! of views (left, right, up, down) so that occluded halves can be dropped.

use crate::lightfield::{Layout, Sample, GRID_MAX};

use super::params::ViewSet;

/// Half-plane groups of views: left (`c < c0`), right, up (`r < r0`), down.
pub(crate) const GROUPS: usize = 4;
/// Statistics per group: `A = Σ g²`, `B = Σ g·(g·d − r)`, `E = Σ r²`.
pub(crate) const STATS: usize = 3 * GROUPS;
const MAX_VIEWS: usize = GRID_MAX * GRID_MAX;

/// One compared view.
#[derive(Clone, Copy, Debug, Default)]
struct Tap {
    /// Index of the view's first sample.
    start: usize,
    /// Camera offset from the centre (columns, rows).
    du: f32,
    dv: f32,
    /// Half the disparity step of the central difference: one pixel of image motion.
    h: f32,
    /// Bit `k` set when the view belongs to group `k`.
    groups: u8,
}

/// The compared views of a light field.
pub(crate) struct Views {
    taps: [Tap; MAX_VIEWS],
    len: usize,
    /// Views per group times channels: the number of terms of each group per pixel.
    pub terms: [f32; GROUPS],
    centre: usize,
    width: usize,
    height: usize,
    channels: usize,
    used: usize,
    row_stride: usize,
}

impl Views {
    pub(crate) fn new(layout: &Layout, set: ViewSet) -> Self {
        let grid = layout.grid;
        let (r0, c0) = grid.center();
        let used = layout.channels.min(3);
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
                views.taps[views.len] = Tap {
                    start: grid.index(r, c) * layout.view_stride,
                    du: dc as f32,
                    dv: dr as f32,
                    h: 0.5 / reach,
                    groups,
                };
                views.len += 1;
            }
        }
        views
    }

    /// Accumulates the statistics of pixel `(x, y)` at disparity `d` into `out`
    /// (zeroed first), each view weighted by `robust / (robust + Σ r²)` (`robust` the
    /// squared residual scale times the channels). Views whose samples leave the image are
    /// skipped.
    #[inline]
    pub(crate) fn pixel<S: Sample>(
        &self,
        data: &[S],
        x: usize,
        y: usize,
        d: f32,
        robust: f32,
        out: &mut [f32; STATS],
    ) {
        *out = [0.0; STATS];
        let ch = self.channels;
        let base = self.centre + y * self.row_stride + x * ch;
        let mut centre = [0.0f32; 3];
        for (c, v) in centre.iter_mut().enumerate().take(self.used) {
            *v = data[base + c].to_unit();
        }
        let (xf, yf) = (x as f32, y as f32);
        let (wmax, hmax) = ((self.width - 1) as f32, (self.height - 1) as f32);
        for tap in &self.taps[..self.len] {
            // Sample positions at d + h and d − h.
            let (xp, yp) = (xf - (d + tap.h) * tap.du, yf - (d + tap.h) * tap.dv);
            let (xm, ym) = (xf - (d - tap.h) * tap.du, yf - (d - tap.h) * tap.dv);
            let inside = |px: f32, py: f32| px >= 0.0 && px <= wmax && py >= 0.0 && py <= hmax;
            if !(inside(xp, yp) && inside(xm, ym)) {
                continue;
            }
            let mut plus = [0.0f32; 3];
            let mut minus = [0.0f32; 3];
            let mut at = [0.0f32; 3];
            self.bilinear(data, tap, xp, yp, &mut plus);
            self.bilinear(data, tap, xm, ym, &mut minus);
            self.bilinear(data, tap, xf - d * tap.du, yf - d * tap.dv, &mut at);
            let (mut a, mut b, mut e) = (0.0f32, 0.0f32, 0.0f32);
            let inv = 0.5 / tap.h;
            for c in 0..self.used {
                let g = (plus[c] - minus[c]) * inv;
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

    /// Bilinear sample of every used channel at `(px, py)`, inside the image.
    #[inline(always)]
    fn bilinear<S: Sample>(&self, data: &[S], tap: &Tap, px: f32, py: f32, out: &mut [f32; 3]) {
        let x0 = (px as usize).min(self.width - 2);
        let y0 = (py as usize).min(self.height - 2);
        let (ax, ay) = (px - x0 as f32, py - y0 as f32);
        let ch = self.channels;
        let i00 = tap.start + y0 * self.row_stride + x0 * ch;
        if tap.dv == 0.0 {
            // Horizontal neighbours: the row is exact, one lerp.
            let i0 = tap.start + (py as usize) * self.row_stride + x0 * ch;
            for (c, o) in out.iter_mut().enumerate().take(self.used) {
                let (s0, s1) = (data[i0 + c].to_unit(), data[i0 + ch + c].to_unit());
                *o = s0 + ax * (s1 - s0);
            }
        } else if tap.du == 0.0 {
            let i0 = tap.start + y0 * self.row_stride + (px as usize) * ch;
            for (c, o) in out.iter_mut().enumerate().take(self.used) {
                let (s0, s1) = (
                    data[i0 + c].to_unit(),
                    data[i0 + self.row_stride + c].to_unit(),
                );
                *o = s0 + ay * (s1 - s0);
            }
        } else {
            let i10 = i00 + self.row_stride;
            for (c, o) in out.iter_mut().enumerate().take(self.used) {
                let (s00, s01) = (data[i00 + c].to_unit(), data[i00 + ch + c].to_unit());
                let (s10, s11) = (data[i10 + c].to_unit(), data[i10 + ch + c].to_unit());
                let top = s00 + ax * (s01 - s00);
                let bottom = s10 + ax * (s11 - s10);
                *o = top + ay * (bottom - top);
            }
        }
    }
}
