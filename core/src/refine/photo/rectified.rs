//! A pixel's statistics and cost over rectified views: the axis taps in chunks, then
//! the oblique taps, with the optional sampling slack.

use crate::lightfield::Sample;
use crate::scalar::Scalar;

use super::gather::{Chunk, Gathered};
use super::sampling::{lanes, unpack};
use super::statistics::{energies, used, Interval, LaneSlack, PixelProbe};
use super::{Views, CHUNK, STATS};

impl<T: Scalar> Views<T> {
    /// The pixel's sampling-slack interval and the regular taps' lanes of it; `None`
    /// unless `SLACK` (a constant, so that the plain residual's code has no trace of
    /// it).
    #[inline(always)]
    fn slacks<S: Sample, const CH: usize, const N: usize, const L: usize, const SLACK: bool>(
        &self,
        data: &[S],
        (x, y): (usize, usize),
        centre: &[T; L],
    ) -> (Option<Interval<T, L>>, Option<LaneSlack<T, N>>) {
        let slack = if SLACK {
            self.interval::<S, CH, L>(data, (x, y), centre)
        } else {
            None
        };
        let regular_slack = slack
            .as_ref()
            .map(|s| LaneSlack::<T, N>::new(s, |v| self.regular_in_row[v % CHUNK]));
        (slack, regular_slack)
    }

    pub(super) fn pixel_channels<
        S: Sample,
        const CH: usize,
        const N: usize,
        const L: usize,
        const SLACK: bool,
    >(
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
        let (slack, regular_slack) = self.slacks::<S, CH, N, L, SLACK>(data, (x, y), &centre);
        // The common case first: every regular tap sees the pixel, and none needs the
        // border's clamped samples.
        let mut cursor = 0;
        if self.regular {
            let (mut cells, mut fractions) = ([0i32; CHUNK], [T::ZERO; CHUNK]);
            if self.regular_cells::<3>((xf, yf), d, &mut cells, &mut fractions)
                && self.regular_statistics::<S, CH, N>(
                    data,
                    (x, y),
                    (&cells, &fractions),
                    &PixelProbe {
                        centre: &used::<T, L, N>(&centre),
                        d,
                        half: self.half,
                        robust: (robust, scaled),
                    },
                    regular_slack.as_ref(),
                    out,
                )
            {
                cursor = CHUNK;
            }
        }
        // The other axis taps, or those of a regular set near the image's sides, from
        // a chunk (zeroed: not needed when the regular taps are done).
        if cursor < self.axis_len {
            let mut chunk = Chunk::<T, S, N>::new();
            let centre_used = used::<T, L, N>(&centre);
            let probe = PixelProbe {
                centre: &centre_used,
                d,
                half: self.half,
                robust: (robust, scaled),
            };
            let gathered = if self.regular {
                self.fill_regular::<S, CH, N, 3>(data, (x, y), (xf, yf), d, &mut chunk)
            } else {
                Gathered::Not
            };
            // Two calls rather than one with the mask as an option: the common one keeps no
            // mask in its loop.
            let groups = &self.regular_groups;
            match gathered {
                Gathered::Every => chunk.statistics(
                    CHUNK,
                    &self.levels,
                    &probe,
                    Some((groups, None)),
                    regular_slack.as_ref(),
                    out,
                ),
                Gathered::Masked(seen) => chunk.statistics(
                    CHUNK,
                    &self.levels,
                    &probe,
                    Some((groups, Some(&seen))),
                    regular_slack.as_ref(),
                    out,
                ),
                Gathered::Not => {}
            }
            if gathered != Gathered::Not {
                cursor = CHUNK;
            }
            loop {
                let n =
                    self.fill::<S, CH, N, 3>(data, &mut cursor, (x, y), (xf, yf), d, &mut chunk);
                if n == 0 {
                    break;
                }
                let lane_slack = slack.as_ref().map(|s| chunk.slack(s));
                chunk.statistics(n, &self.levels, &probe, None, lane_slack.as_ref(), out);
            }
        }
        for tap in self.oblique_taps() {
            let tap = &tap;
            let Some(([first, second, at], factor)) =
                self.oblique::<S, CH, L>(data, tap, (xf, yf), d)
            else {
                continue;
            };
            let (mut gg, mut gr, mut rr) = ([T::ZERO; L], [T::ZERO; L], [T::ZERO; L]);
            for c in 0..L {
                let g = (first[c] - second[c]) * factor;
                let r = at[c] - centre[c];
                gg[c] = g * g;
                match &slack {
                    // See `statistics`.
                    Some(s) => {
                        let outside = s.outside(r, c);
                        rr[c] = outside * outside;
                    }
                    None => rr[c] = r * r,
                }
                gr[c] = g * (g * d - r);
            }
            let (mut a, mut b, mut e) = (T::ZERO, T::ZERO, T::ZERO);
            for c in 0..N.min(L) {
                a += gg[c];
                b += gr[c];
                e += rr[c];
            }
            tap.add_weighted(out, (a, b, e), (robust, scaled));
        }
    }

    pub(super) fn cost_channels<
        S: Sample,
        const CH: usize,
        const N: usize,
        const L: usize,
        const SLACK: bool,
    >(
        &self,
        data: &[S],
        x: usize,
        y: usize,
        d: T,
        (robust, scaled): (T, T),
        bar: Option<T>,
    ) -> Option<T> {
        let below = |c: T| bar.is_none_or(|bar| c < bar);
        let Some((centre, xf, yf)) = self.centre::<S, CH, L>(data, x, y) else {
            return below(T::ZERO).then_some(T::ZERO);
        };
        let (slack, regular_slack) = self.slacks::<S, CH, N, L, SLACK>(data, (x, y), &centre);
        // The views' weighted energies in a fixed order: a running sum of non-negative
        // terms, so a partial sum at or above the bar decides.
        let mut cost = T::ZERO;
        let mut cursor = 0;
        let centre_used = used::<T, L, N>(&centre);
        // The common case first, as in `pixel_channels`: the same energies as from the
        // chunk `fill_regular` gathers (the same bits).
        if self.regular {
            let (mut cells, mut fractions) = ([0i32; CHUNK], [T::ZERO; CHUNK]);
            let mut words = [[0u32; CHUNK]; 2];
            if self.regular_cells::<2>((xf, yf), d, &mut cells, &mut fractions)
                && self
                    .regular_words::<S, CH, 2>(data, (x, y), &cells, &mut words)
                    .is_some()
            {
                let levels = &self.levels;
                // `j` < 2, `c` < N ≤ 3 (`energies`).
                let texel = |j: usize, c: usize, v: usize| unpack(words[j][v], c, levels);
                let slack = regular_slack.as_ref();
                for e in energies(&texel, &fractions, &centre_used, (robust, scaled), slack) {
                    cost += e;
                }
                if !below(cost) {
                    return None;
                }
                cursor = CHUNK;
            }
        }
        // The other axis taps (see `pixel_channels`).
        if cursor < self.axis_len {
            let mut chunk = Chunk::<T, S, N>::new();
            let gathered = if self.regular {
                self.fill_regular::<S, CH, N, 2>(data, (x, y), (xf, yf), d, &mut chunk)
            } else {
                Gathered::Not
            };
            match gathered {
                Gathered::Every => {
                    let slack = regular_slack.as_ref();
                    for e in chunk.energies(&self.levels, &centre_used, (robust, scaled), slack) {
                        cost += e;
                    }
                }
                Gathered::Masked(seen) => {
                    let slack = regular_slack.as_ref();
                    let energies =
                        chunk.energies(&self.levels, &centre_used, (robust, scaled), slack);
                    for (e, keep) in energies.into_iter().zip(seen) {
                        cost += if keep { e } else { T::ZERO };
                    }
                }
                Gathered::Not => {}
            }
            if gathered != Gathered::Not {
                if !below(cost) {
                    return None;
                }
                cursor = CHUNK;
            }
            loop {
                let n =
                    self.fill::<S, CH, N, 2>(data, &mut cursor, (x, y), (xf, yf), d, &mut chunk);
                if n == 0 {
                    break;
                }
                let lane_slack = slack.as_ref().map(|s| chunk.slack(s));
                let energies = chunk.energies(
                    &self.levels,
                    &centre_used,
                    (robust, scaled),
                    lane_slack.as_ref(),
                );
                for &e in energies.get(..n).unwrap_or_default() {
                    cost += e;
                    if !below(cost) {
                        return None;
                    }
                }
            }
        }
        for tap in self.oblique_taps() {
            let tap = &tap;
            if !self.sees(tap, xf, yf, d) {
                continue;
            }
            let Some(at) = self.bilinear::<S, CH, L>(data, tap, (xf - d * tap.du, yf - d * tap.dv))
            else {
                continue;
            };
            // Counted once per group the view belongs to (two separate sums, so the
            // rounding matches summing each group on its own).
            let e = tap.weighted_cost(&at, &centre, N, (robust, scaled), slack.as_ref());
            cost += e;
            if tap.second_group.is_some() {
                cost += e;
            }
            if !below(cost) {
                return None;
            }
        }
        below(cost).then_some(cost)
    }

    /// With a sampling slack ([`Views::with_slack`]), the centre view's [`Interval`] at
    /// pixel `(x, y)` (value `centre`): along x and y, the values of its linear
    /// interpolation at `±slack` px (neighbours past the image's side repeat the
    /// pixel), and for oblique views both. `None` without a slack.
    #[inline(always)]
    fn interval<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        (x, y): (usize, usize),
        centre: &[T; L],
    ) -> Option<Interval<T, L>> {
        let slack = self.slack?;
        let base = self.centre + y * self.row_stride + x * CH;
        let at = |i: usize| lanes::<T, S, CH, L>(data, i, &self.levels);
        let left = if x > 0 { at(base - CH)? } else { *centre };
        let right = if x <= self.x_last {
            at(base + CH)?
        } else {
            *centre
        };
        let up = if y > 0 {
            at(base - self.row_stride)?
        } else {
            *centre
        };
        let down = if y <= self.y_last {
            at(base + self.row_stride)?
        } else {
            *centre
        };
        let mut out = Interval {
            lo: [[T::ZERO; L]; 3],
            hi: [[T::ZERO; L]; 3],
        };
        // Compare and select (the samples are finite: no NaN tests).
        let lower = |a: T, b: T| if b < a { b } else { a };
        let upper = |a: T, b: T| if b > a { b } else { a };
        for (axis, (a, b)) in [(left, right), (up, down)].into_iter().enumerate() {
            for c in 0..L {
                let (ea, eb) = (slack * (a[c] - centre[c]), slack * (b[c] - centre[c]));
                out.lo[axis][c] = lower(lower(ea, eb), T::ZERO);
                out.hi[axis][c] = upper(upper(ea, eb), T::ZERO);
            }
        }
        for c in 0..L {
            out.lo[2][c] = lower(out.lo[0][c], out.lo[1][c]);
            out.hi[2][c] = upper(out.hi[0][c], out.hi[1][c]);
        }
        Some(out)
    }
}
