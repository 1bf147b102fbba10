//! A cost volume of a band: its window sums over the hypotheses and each pixel's
//! winner, its neighbours' costs and the mean cost.

use core::ops::Range;

use super::fixedpoint::window_sum;
use super::{copy, ints, take, take_ints};
use crate::error::{Error, Result};

/// The views a cost volume sums.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Source {
    All,
    Horizontal,
    Vertical,
}

/// One cost volume's rows and per-pixel winners over a band.
pub(super) struct Volume<'a> {
    /// Which views it sums.
    pub(super) source: Source,
    /// Window radii along x and y.
    rx: usize,
    pub(super) ry: usize,
    /// One row of fixed-point pixel costs, padded by the radius on each side (unused
    /// when `rx` is 0: the costs go straight into their filtered row).
    padded: &'a mut [i32],
    /// Two rows of partial window sums along x ([`window_sum`]).
    partial: [&'a mut [i32]; 2],
    /// Horizontally filtered cost rows of the band and its halo.
    costs: &'a mut [i32],
    /// The window sum of the band row last aggregated ([`Volume::aggregate`]), in its
    /// first `width` values (a padded row's room).
    column: &'a mut [i32],
    best: &'a mut [f32],
    pub(super) best_at: &'a mut [f32],
    before: &'a mut [f32],
    after: &'a mut [f32],
    last: &'a mut [f32],
    /// The sum of the costs over the hypotheses (then the confidence).
    pub(super) sum: &'a mut [f32],
}

impl<'a> Volume<'a> {
    pub(super) fn take(
        s: &'a mut [f32],
        source: Source,
        (rx, ry): (usize, usize),
        padded: usize,
        costs: usize,
        len: usize,
    ) -> Result<(Self, &'a mut [f32])> {
        let (padded, s) = take(s, padded)?;
        let (partial0, s) = take(s, padded.len())?;
        let (partial1, s) = take(s, padded.len())?;
        let (costs, s) = take(s, costs)?;
        let (column, s) = take(s, padded.len())?;
        let (best, s) = take(s, len)?;
        let (best_at, s) = take(s, len)?;
        let (before, s) = take(s, len)?;
        let (after, s) = take(s, len)?;
        let (last, s) = take(s, len)?;
        let (sum, s) = take(s, len)?;
        best.fill(f32::INFINITY);
        best_at.fill(0.0);
        before.fill(f32::INFINITY);
        after.fill(f32::INFINITY);
        last.fill(f32::INFINITY);
        sum.fill(0.0);
        Ok((
            Volume {
                source,
                rx,
                ry,
                padded: ints(padded)?,
                partial: [ints(partial0)?, ints(partial1)?],
                costs: ints(costs)?,
                column: ints(column)?,
                best,
                best_at,
                before,
                after,
                last,
                sum,
            },
            s,
        ))
    }

    /// Where the fixed-point pixel costs of region row `k` go: the unpadded part of the
    /// padded row, or for a window one pixel wide (`rx` 0) the filtered row `k` itself.
    pub(super) fn body_mut(&mut self, width: usize, k: usize) -> &mut [i32] {
        let r = self.rx;
        if r == 0 {
            let at = k.saturating_mul(width);
            self.costs
                .get_mut(at..at.saturating_add(width))
                .unwrap_or(&mut [])
        } else {
            self.padded.get_mut(r..r + width).unwrap_or(&mut [])
        }
    }

    /// Pads the pixel-cost row with its end values and sums its windows along x into
    /// cost row `k` (a window one pixel wide is already there).
    pub(super) fn filter_row(&mut self, width: usize, k: usize) -> Result<()> {
        let r = self.rx;
        if r == 0 {
            return Ok(());
        }
        let (lead, tail) = take_ints(self.padded, r)?;
        let (body, trail) = take_ints(tail, width)?;
        lead.fill(body.first().copied().unwrap_or(0));
        trail.fill(body.last().copied().unwrap_or(0));
        let row = self
            .costs
            .get_mut(k * width..(k + 1) * width)
            .ok_or(Error::SizeOverflow { what: "a cost row" })?;
        let [p0, p1] = &mut self.partial;
        window_sum(self.padded, 2 * r + 1, row, p0, p1);
        Ok(())
    }

    /// The window sum over rows `y − r ..= y + r` (clamped to the image) into
    /// `column`: from the previous row's sum (`next`, the band row above `y` was the last
    /// aggregated) by adding the entering row and subtracting the leaving one, else tap
    /// by tap. The sums are exact in integers, so both give the same value.
    pub(super) fn aggregate(
        &mut self,
        width: usize,
        height: usize,
        y: usize,
        first: usize,
        next: bool,
    ) -> Result<()> {
        let r = self.ry;
        let costs = &*self.costs;
        let row = |yy: usize| {
            let k = yy.min(height.saturating_sub(1)).saturating_sub(first);
            costs
                .get(k * width..(k + 1) * width)
                .ok_or(Error::SizeOverflow { what: "a cost row" })
        };
        if next {
            let enter = row(y + r)?;
            let leave = row(y.saturating_sub(1).saturating_sub(r))?;
            for ((c, &e), &l) in self.column.iter_mut().zip(enter).zip(leave) {
                *c = c.wrapping_sub(l).wrapping_add(e);
            }
        } else {
            for j in 0..=2 * r {
                let src = row((y + j).saturating_sub(r))?;
                if j == 0 {
                    copy(self.column, src);
                } else {
                    for (c, &s) in self.column.iter_mut().zip(src) {
                        *c = c.wrapping_add(s);
                    }
                }
            }
        }
        Ok(())
    }

    /// Takes hypothesis `at`'s costs of band row `band` from the filtered rows `row`
    /// (a window one row tall).
    pub(super) fn update_from_row(
        &mut self,
        row: Range<usize>,
        band: Range<usize>,
        at: f32,
    ) -> Result<()> {
        let costs = core::mem::take(&mut self.costs);
        let result = match costs.get(row) {
            Some(row) => {
                self.update(row, band, at);
                Ok(())
            }
            None => Err(Error::SizeOverflow { what: "a cost row" }),
        };
        self.costs = costs;
        result
    }

    /// Takes hypothesis `at`'s window sums of band row `band` from `column`.
    pub(super) fn update_from_column(&mut self, band: Range<usize>, at: f32) {
        let column = core::mem::take(&mut self.column);
        self.update(column, band, at);
        self.column = column;
    }

    /// Takes hypothesis `at`'s window sums `agg` (fixed point) of band row `band`.
    fn update(&mut self, agg: &[i32], band: Range<usize>, at: f32) {
        let best = self.best.get_mut(band.clone()).unwrap_or(&mut []);
        let best_at = self.best_at.get_mut(band.clone()).unwrap_or(&mut []);
        let before = self.before.get_mut(band.clone()).unwrap_or(&mut []);
        let after = self.after.get_mut(band.clone()).unwrap_or(&mut []);
        let last = self.last.get_mut(band.clone()).unwrap_or(&mut []);
        let sum = self.sum.get_mut(band).unwrap_or(&mut []);
        let state = best
            .iter_mut()
            .zip(best_at.iter_mut())
            .zip(before.iter_mut())
            .zip(after.iter_mut())
            .zip(last.iter_mut())
            .zip(sum.iter_mut());
        for ((((((b, bi), be), af), l), s), &a) in state.zip(agg.iter()) {
            // Window sums are below 2³¹ ([`fixed_scale`]): one conversion per lane.
            let a = a as f32;
            let better = a < *b;
            let next = *bi + 1.0 == at;
            *af = if better {
                f32::INFINITY
            } else if next {
                a
            } else {
                *af
            };
            *be = if better { *l } else { *be };
            *b = if better { a } else { *b };
            *bi = if better { at } else { *bi };
            *l = a;
            *s += a;
        }
    }

    /// Turns the winners into disparities (in `best_at`) and confidences (in `sum`).
    pub(super) fn finish(&mut self, mean_scale: f32, min: f32, max: f32, spacing: f32) {
        let pixels = self.best_at.iter_mut().zip(self.sum.iter_mut()).zip(
            self.best
                .iter()
                .zip(self.before.iter().zip(self.after.iter())),
        );
        for ((bi, c), (&b, (&be, &af))) in pixels {
            let curvature = 2.0 * (be.max(af) - b);
            let offset = if be.is_finite() && af.is_finite() && curvature > 0.0 {
                ((be - af) / curvature).clamp(-0.5, 0.5)
            } else {
                0.0
            };
            *bi = (min + (*bi + offset) * spacing).max(min).min(max);
            let mean = *c * mean_scale;
            *c = if mean > 0.0 {
                (1.0 - b / mean).clamp(0.0, 1.0)
            } else {
                0.0
            };
        }
    }
}
