//! One pixel of the median: an exact test that settles most pixels without their
//! window's selection, and the selection for the rest.
//!
//! A pixel takes the median only when the weight of the votes below `own − snap` or
//! above `own + snap` reaches half of the window's weight. Votes are cheap (a few float
//! operations on contiguous rows), weights are not (a colour distance and a table look-up
//! per neighbour), so the test classifies every vote first, weighs the votes outside
//! the snap band, and weighs votes inside it, nearest rows first, only until they
//! outweigh the outside: most pixels near a depth edge stop after a few rows. Only when
//! the test cannot rule a change out does the pixel go through [`Window::select`], which
//! weighs and selects exactly as a direct implementation would.

use core::ops::Range;

use super::select::weighted_median;
use super::slopes::SlopeRing;
use super::weights::Weights;
use super::{MedianParams, MAX_RADIUS, MAX_TAPS};
use crate::lightfield::{Sample, View};

/// Most columns (and rows) of a window.
const SPAN: usize = 2 * MAX_RADIUS + 1;

/// What every pixel of one call shares.
pub(super) struct Window<'a, 'g, S: Sample> {
    pub(super) input: &'a [f32],
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) guide: &'a View<'g, S>,
    pub(super) slopes: &'a SlopeRing<'a>,
    pub(super) weights: &'a Weights,
    pub(super) params: MedianParams,
}

impl<S: Sample> Window<'_, '_, S> {
    fn rows_and_columns(&self, x: usize, y: usize) -> (Range<usize>, Range<usize>) {
        let r = self.params.radius;
        (
            y.saturating_sub(r)..(y + r + 1).min(self.height),
            x.saturating_sub(r)..(x + r + 1).min(self.width),
        )
    }

    /// The 8-bit colour of `(x, y)` (the channels beyond the third are ignored).
    fn colour(&self, x: usize, y: usize) -> [i32; 3] {
        let channels = self.guide.channels();
        let row = self.guide.row(y).unwrap_or(&[]);
        let mut centre = [0i32; 3];
        for (k, c) in centre.iter_mut().enumerate().take(channels.min(3)) {
            *c = row
                .get(x * channels + k)
                .map_or(0, |s| i32::from(s.level()));
        }
        centre
    }

    /// The weight of neighbour `xx` of the guide row `colours` for a pixel of colour
    /// `centre`, or `None` outside the row.
    #[inline(always)]
    fn weight(&self, colours: &[S], xx: usize, centre: &[i32; 3]) -> Option<u32> {
        let channels = self.guide.channels();
        let start = xx * channels;
        let pixel = colours.get(start..start + channels.min(3))?;
        let mut d2 = 0u32;
        for (s, c) in pixel.iter().zip(centre) {
            let d = i32::from(s.level()) - c;
            d2 += (d * d) as u32;
        }
        Some(self.weights.get(d2))
    }

    /// `false` when the pixel `(x, y)` of finite value `own` certainly keeps it: the
    /// votes outside `own ± snap` weigh less than half of the window on either side.
    /// `true` when [`Self::select`] must decide.
    pub(super) fn may_change(&self, x: usize, y: usize, own: f32) -> bool {
        let (ys, xs) = self.rows_and_columns(x, y);
        let n = xs.len().min(SPAN);
        let (lo, hi) = (own - self.params.snap, own + self.params.snap);
        let mut dxs = [0.0f32; SPAN];
        for (k, d) in dxs[..n].iter_mut().enumerate() {
            *d = x as f32 - (xs.start + k) as f32;
        }
        // Per window row, bit k for column xs.start + k.
        let mut below = [0u16; SPAN];
        let mut above = [0u16; SPAN];
        let mut inside = [0u16; SPAN];
        let mut outside = 0u16;
        for (i, yy) in ys.clone().enumerate().take(SPAN) {
            let start = yy * self.width;
            let Some(values) = self.input.get(start + xs.start..start + xs.end) else {
                continue;
            };
            let (b, a, f) = if self.params.planar {
                let Some((gx, gy)) = self.slopes.row(yy, xs.clone()) else {
                    continue;
                };
                classify_planar(values, gx, gy, &dxs[..n], y as f32 - yy as f32, lo, hi)
            } else {
                classify_flat(values, lo, hi)
            };
            below[i] = b;
            above[i] = a;
            inside[i] = f & !(b | a);
            outside |= b | a;
        }
        if outside == 0 {
            return false;
        }
        let centre = self.colour(x, y);
        let (mut weight_below, mut weight_above) = (0u64, 0u64);
        for (i, yy) in ys.clone().enumerate().take(SPAN) {
            let mut bits = below[i] | above[i];
            if bits == 0 {
                continue;
            }
            let colours = self.guide.row(yy).unwrap_or(&[]);
            while bits != 0 {
                let k = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let w = u64::from(self.weight(colours, xs.start + k, &centre).unwrap_or(0));
                if below[i] >> k & 1 != 0 {
                    weight_below += w;
                } else {
                    weight_above += w;
                }
            }
        }
        // With I the inside weight and T = I + B + A the total, the selection moves the
        // pixel iff B ≥ ⌈T/2⌉ or T − A < ⌈T/2⌉, i.e. iff B ≥ I + A or A > I + B; both
        // fail for every I at least as large as a partial sum that makes them fail.
        let kept = |weight_inside: u64| {
            weight_below < weight_inside + weight_above
                && weight_above <= weight_inside + weight_below
        };
        let rows = ys.len().min(SPAN);
        let centre_row = y - ys.start;
        let mut weight_inside = 0u64;
        // Rows by distance from the pixel's own: their colours are likeliest alike.
        for step in 0..2 * rows {
            let distance = step.div_ceil(2);
            let i = if step % 2 == 1 {
                centre_row.checked_sub(distance)
            } else {
                Some(centre_row + distance).filter(|&i| i < rows)
            };
            let Some(i) = i else {
                continue;
            };
            let mut bits = inside[i];
            if bits == 0 {
                continue;
            }
            let colours = self.guide.row(ys.start + i).unwrap_or(&[]);
            while bits != 0 {
                let k = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                weight_inside +=
                    u64::from(self.weight(colours, xs.start + k, &centre).unwrap_or(0));
            }
            if kept(weight_inside) {
                return false;
            }
        }
        true
    }

    /// The value of the pixel `(x, y)` of finite value `own`: the weighted median of its
    /// window's votes when that differs from `own` by more than `snap`, else `own`.
    pub(super) fn select(&self, x: usize, y: usize, own: f32) -> f32 {
        let p = &self.params;
        let (ys, xs) = self.rows_and_columns(x, y);
        let centre = self.colour(x, y);
        let mut values = [0.0f32; MAX_TAPS];
        let mut taps = [0u32; MAX_TAPS];
        let mut n = 0;
        let (mut total, mut below, mut above) = (0u64, 0u64, 0u64);
        for yy in ys {
            let start = yy * self.width;
            let Some(row) = self.input.get(start..start + self.width) else {
                continue;
            };
            let colours = self.guide.row(yy).unwrap_or(&[]);
            for xx in xs.clone() {
                let Some(&v) = row.get(xx) else {
                    continue;
                };
                let Some(w) = self.weight(colours, xx, &centre) else {
                    continue;
                };
                if !v.is_finite() || w == 0 || n >= MAX_TAPS {
                    continue;
                }
                let v = if p.planar {
                    let (gx, gy) = self.slopes.at(yy, xx);
                    v + gx * (x as f32 - xx as f32) + gy * (y as f32 - yy as f32)
                } else {
                    v
                };
                values[n] = v;
                taps[n] = w;
                total += u64::from(w);
                if v < own - p.snap {
                    below += u64::from(w);
                } else if v > own + p.snap {
                    above += u64::from(w);
                }
                n += 1;
            }
        }
        // The median lies within `snap` of the pixel's value (which then stays) unless
        // the weight beyond `own ± snap` on one side reaches half.
        let half = total.div_ceil(2);
        if n > 0 && (below >= half || total - above < half) {
            let m = weighted_median(&mut values[..n], &mut taps[..n], half);
            if (m - own).abs() > p.snap {
                return m;
            }
        }
        own
    }
}

/// Bit masks of a window row's planar votes below `lo`, above `hi`, and of its finite
/// values (votes from non-finite values are in neither of the first two).
#[inline(always)]
fn classify_planar(
    values: &[f32],
    gx: &[f32],
    gy: &[f32],
    dxs: &[f32],
    dy: f32,
    lo: f32,
    hi: f32,
) -> (u16, u16, u16) {
    let (mut below, mut above, mut finite) = (0u16, 0u16, 0u16);
    for (k, (((&v, &gx), &gy), &dx)) in values.iter().zip(gx).zip(gy).zip(dxs).enumerate() {
        // The same expression as the selection's, so the classes agree bit for bit.
        let vote = v + gx * dx + gy * dy;
        let ok = v.is_finite();
        finite |= u16::from(ok) << k;
        below |= u16::from(ok && vote < lo) << k;
        above |= u16::from(ok && vote > hi) << k;
    }
    (below, above, finite)
}

/// [`classify_planar`] for flat votes (each neighbour votes its own value).
#[inline(always)]
fn classify_flat(values: &[f32], lo: f32, hi: f32) -> (u16, u16, u16) {
    let (mut below, mut above, mut finite) = (0u16, 0u16, 0u16);
    for (k, &v) in values.iter().enumerate() {
        let ok = v.is_finite();
        finite |= u16::from(ok) << k;
        below |= u16::from(ok && v < lo) << k;
        above |= u16::from(ok && v > hi) << k;
    }
    (below, above, finite)
}
