//! One pixel of the median: an exact test that settles most pixels without weighing
//! their whole window, and a selection among the votes on the median's side for the rest.
//!
//! A pixel takes the median only when the weight of the votes below `own − snap` or
//! above `own + snap` reaches half of the window's weight. Votes are cheap (a few float
//! operations on a window row's 16 lanes at once), weights are not (a colour distance
//! and a table look-up per neighbour), so [`Window::decide`] classifies every vote
//! first, weighs the votes outside the snap band, and weighs votes inside it, nearest
//! rows first, only until they outweigh the outside: most pixels near a depth edge stop
//! after a few rows. When a change cannot be ruled out, the median lies on the side that
//! reaches half, and [`Window::select_side`] selects among that side's votes only. The
//! direct whole-window selection, [`Window::select`], is kept for the one case where
//! the two could differ in a bit (a median of ±0).

use core::ops::Range;

use super::ring::{ColourLanes, Lanes, RowRing, LANES};
use super::select::{key, weighted_median, weighted_median_of_keys};
use super::weights::Weights;
use super::{MedianParams, MAX_RADIUS, MAX_TAPS};
use crate::lightfield::{Sample, View};

/// Most columns (and rows) of a window.
pub(super) const SPAN: usize = 2 * MAX_RADIUS + 1;
/// Columns below which `x as f32 − xx as f32` is exact: 2²⁴ less the widest reach.
const EXACT_COLUMNS: usize = (1 << 24) - 2 * LANES;

/// The offsets `r − k` of the lanes of a window of radius `r` (see [`Window::offsets`]).
pub(super) fn lane_offsets(radius: usize) -> [f32; LANES] {
    let mut offsets = [0.0f32; LANES];
    for (k, d) in offsets.iter_mut().enumerate() {
        *d = radius as f32 - k as f32;
    }
    offsets
}

/// The lanes (per window row) of the side of `own ± snap` that holds the median, and
/// the weight of its votes the median needs at or below it.
struct Side {
    lanes: [u16; SPAN],
    target: u64,
}

/// A decision in progress: per window row the classes of its votes and (once
/// measured) its weight table indices, and the weights summed so far.
#[derive(Default)]
struct Sums {
    below: [u16; SPAN],
    above: [u16; SPAN],
    inside: [u16; SPAN],
    indices: [[u32; LANES]; SPAN],
    /// Rows whose `indices` are measured, rows with a vote outside, rows whose inside
    /// votes are in `weight_inside` (bit i: row i).
    measured: u16,
    outside: u16,
    inside_weighed: u16,
    weight_below: u64,
    weight_above: u64,
    weight_inside: u64,
}

/// With I the inside weight and T = I + B + A the total, the selection moves the pixel
/// iff B ≥ ⌈T/2⌉ or T − A < ⌈T/2⌉, i.e. iff B ≥ I + A or A > I + B; both fail for
/// every I at least as large as a partial sum that makes them fail.
fn kept(s: &Sums) -> bool {
    s.weight_below < s.weight_inside + s.weight_above
        && s.weight_above <= s.weight_inside + s.weight_below
}

/// The votes outside `own ± snap` weigh less than `1/(q + 1)` of the rows weighed on
/// either side (qB < I + A and qA < I + B): on the rows sampled by the first phases of
/// [`Window::decide`], the pixel keeps its value without the rest of its window.
fn clearly_kept(s: &Sums, q: u64) -> bool {
    q * s.weight_below < s.weight_inside + s.weight_above
        && q * s.weight_above < s.weight_inside + s.weight_below
}

/// The outside share `1/(q + 1)` below which the rows at a distance divisible by 4
/// keep the pixel: a ninth (a quarter, q = 3, and a sixth, q = 5, raised backgammon's
/// MSE×100 by 0.18 and 0.026).
const QUARTER_SHARE: u64 = 8;
/// The same for the rows at an even distance.
const EVEN_SHARE: u64 = 2;

/// What every pixel of one call shares.
pub(super) struct Window<'a, 'g, S: Sample> {
    pub(super) input: &'a [f32],
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) guide: &'a View<'g, S>,
    pub(super) rows: &'a RowRing<'a>,
    /// Per window row (top first), where it lives in the ring ([`RowRing::base`]).
    pub(super) bases: &'a [usize; SPAN],
    /// Per window row, `y − yy` as `f32`.
    pub(super) dys: &'a [f32; SPAN],
    /// `r − k` for lane k: a pixel's offsets to its window columns.
    pub(super) offsets: [f32; LANES],
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

    /// The weight of the lanes `bits` of a window row whose weight table indices
    /// ([`Weights::index`]) are `indices`.
    #[inline(always)]
    fn weigh(&self, mut bits: u16, indices: &[u32; LANES]) -> u64 {
        let mut sum = 0u64;
        while bits != 0 {
            let k = bits.trailing_zeros() as usize & (LANES - 1);
            bits &= bits - 1;
            sum += u64::from(self.weights.at(indices[k]));
        }
        sum
    }

    /// The offsets `x − xx` of the lanes of the pixel in column `x`, computed as the
    /// selection computes them (exact, hence `r − k`, below 2²⁴).
    fn offsets(&self, x: usize) -> [f32; LANES] {
        let mut dxs = self.offsets;
        if x >= EXACT_COLUMNS {
            for (k, d) in dxs.iter_mut().enumerate() {
                *d = x as f32 - (x + k).wrapping_sub(self.params.radius) as f32;
            }
        }
        dxs
    }

    /// The value of the pixel `(x, y)` of finite value `own`: [`Self::decide`], then
    /// the selection on the side that holds the median when it may move.
    pub(super) fn value(&self, x: usize, y: usize, own: f32) -> f32 {
        match self.decide(x, y, own) {
            None => own,
            Some(side) => self.select_side(x, y, own, &side),
        }
    }

    /// `None` when the pixel `(x, y)` of finite value `own` keeps it. Else the side of
    /// `own ± snap` whose votes weigh at least half of the window: the median lies there.
    ///
    /// The pixel keeps its value when the votes outside `own ± snap` weigh less than
    /// half of the window on either side, or, first, when on the rows at a distance
    /// from its own divisible by 4 (a fifth of the window) they weigh less than a ninth
    /// of those rows' weight on either side, or on the rows at an even distance (about
    /// half) less than a third ([`clearly_kept`]). Most pixels near a depth edge are
    /// settled by a part of their window; only the others classify and weigh the rest.
    /// (These shortcuts change the output only where the sampled rows disagree strongly
    /// with the others; the shares were chosen on the HCI scenes, docs/bench-median.md.)
    fn decide(&self, x: usize, y: usize, own: f32) -> Option<Side> {
        let (ys, _) = self.rows_and_columns(x, y);
        let rows = ys.len().min(SPAN);
        let centre_row = y - ys.start;
        let all = ((1u32 << rows) - 1) as u16;
        // Bit i for window row i at a distance from the pixel's row divisible by 4, by 2.
        let quarter = (0x1111u16 << (centre_row & 3)) & all;
        let even = (0x5555u16 << (centre_row & 1)) & all;
        let mut state = Sums::default();
        // Lane k is column x − r + k.
        let dxs = self.offsets(x);
        let centre = self.rows.colour_at(y, x);
        let phases = [
            (quarter, Some(QUARTER_SHARE)),
            (even, Some(EVEN_SHARE)),
            (all, None),
        ];
        let mut done = 0u16;
        for (weighed, share) in phases {
            let rows_now = weighed & !done;
            done |= rows_now;
            state.outside |= self.classify_rows(&mut state, rows_now, x, own, &dxs);
            if state.outside == 0 {
                // No vote outside: B = A = 0 < I (the pixel's own vote weighs w₀ > 0).
                return None;
            }
            self.weigh_outside(&mut state, rows_now, x, &centre);
            let kept = |s: &Sums| match share {
                Some(q) => clearly_kept(s, q),
                None => kept(s),
            };
            if kept(&state) {
                return None;
            }
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
                if (weighed & !state.inside_weighed) >> i & 1 == 0 {
                    continue;
                }
                state.inside_weighed |= 1 << i;
                let (Some(&bits), Some(&base), Some(row)) = (
                    state.inside.get(i),
                    self.bases.get(i),
                    state.indices.get_mut(i),
                ) else {
                    continue;
                };
                if bits == 0 {
                    continue;
                }
                if state.measured >> i & 1 == 0 {
                    let Some(colours) = self.rows.colours_at(base, x, self.params.radius) else {
                        continue;
                    };
                    *row = table_indices(&colours, &centre, self.weights);
                    state.measured |= 1 << i;
                }
                state.weight_inside += self.weigh(bits, row);
                if kept(&state) {
                    return None;
                }
            }
        }
        // Every vote is weighed now: the sums are exact. The median is the smallest vote
        // whose weight of votes at or below it reaches ⌈T/2⌉; below `lo` when B reaches
        // it, else above `hi`, where the votes below and inside count first.
        let (below, inside, above) = (state.weight_below, state.weight_inside, state.weight_above);
        let half = (below + inside + above).div_ceil(2);
        Some(if below >= half {
            Side {
                lanes: state.below,
                target: half,
            }
        } else {
            Side {
                lanes: state.above,
                target: half.saturating_sub(below + inside),
            }
        })
    }

    /// Classifies the votes of the window rows `rows` (bit i: row i) into
    /// `state.below`, `above` and `inside`; returns the rows holding a vote outside
    /// `own ± snap`.
    #[inline(always)]
    fn classify_rows(
        &self,
        state: &mut Sums,
        rows: u16,
        x: usize,
        own: f32,
        dxs: &[f32; LANES],
    ) -> u16 {
        let r = self.params.radius;
        let (lo, hi) = (own - self.params.snap, own + self.params.snap);
        let lanes_in_window = (1u32 << (2 * r + 1)) - 1;
        let mut outside = 0u16;
        let per_row = self.bases.iter().zip(self.dys);
        let masks = state
            .below
            .iter_mut()
            .zip(state.above.iter_mut().zip(state.inside.iter_mut()));
        for (i, ((&base, &dy), (below, (above, inside)))) in per_row.zip(masks).enumerate() {
            if rows >> i & 1 == 0 {
                continue;
            }
            let Some(lanes) = self.rows.lanes_at(base, x, r) else {
                continue;
            };
            let (b, a, f) = classify(&lanes, dxs, dy, lo, hi);
            let (b, a, f) = (
                b & lanes_in_window,
                a & lanes_in_window,
                f & lanes_in_window,
            );
            *below = b as u16;
            *above = a as u16;
            *inside = (f & !(b | a)) as u16;
            outside |= u16::from(b | a != 0) << i;
        }
        outside
    }

    /// Adds the weights of the votes below and above of the rows `rows` to the sums.
    #[inline(always)]
    fn weigh_outside(&self, state: &mut Sums, rows: u16, x: usize, centre: &[f32; 3]) {
        let r = self.params.radius;
        let sides = state.below.iter().zip(&state.above);
        for (i, ((&base, row), (&below, &above))) in self
            .bases
            .iter()
            .zip(state.indices.iter_mut())
            .zip(sides)
            .enumerate()
        {
            if rows >> i & 1 == 0 || below | above == 0 {
                continue;
            }
            let Some(colours) = self.rows.colours_at(base, x, r) else {
                continue;
            };
            let live;
            (*row, live) = indices_live(&colours, centre, self.weights);
            state.measured |= 1 << i;
            // Across a strong colour edge every outside vote of a row may weigh zero.
            if (below | above) & live == 0 {
                continue;
            }
            state.weight_below += self.weigh(below, row);
            state.weight_above += self.weigh(above, row);
        }
    }

    /// The weighted median of the votes of `side` (the side of `own ± snap` that holds
    /// the window's median) with weights reaching `side.target`: the window's median,
    /// which the pixel takes when it differs from `own` by more than `snap`.
    ///
    /// Equal to the median of the whole window: the median is the smallest vote whose
    /// weight at or below it reaches half the total, and on the side that holds it the
    /// votes of the other side and inside count only as the offset already taken from
    /// the target. Votes are finite (slopes are at most the gate, 16 px, offsets at most
    /// 7, so no sum overflows), so the order is total, and a non-zero value has one bit
    /// pattern; a median of ±0, whose sign the selection's pivots decide, is left to
    /// [`Self::select`], which selects exactly as the whole window does.
    fn select_side(&self, x: usize, y: usize, own: f32, side: &Side) -> f32 {
        let (ys, _) = self.rows_and_columns(x, y);
        let r = self.params.radius;
        let dxs = self.offsets(x);
        let centre = self.rows.colour_at(y, x);
        let mut keys = [0u64; MAX_TAPS];
        let mut n = 0;
        let per_row = self.bases.iter().zip(self.dys);
        for ((&base, &dy), &bits) in per_row.zip(&side.lanes).take(ys.len()) {
            let mut bits = bits;
            if bits == 0 {
                continue;
            }
            let (Some(lanes), Some(colours)) = (
                self.rows.lanes_at(base, x, r),
                self.rows.colours_at(base, x, r),
            ) else {
                continue;
            };
            let votes = votes(&lanes, &dxs, dy);
            let indices = table_indices(&colours, &centre, self.weights);
            while bits != 0 {
                let k = bits.trailing_zeros() as usize & (LANES - 1);
                bits &= bits - 1;
                let w = self.weights.at(indices[k]);
                if let (true, Some(&vote), Some(slot)) = (w > 0, votes.get(k), keys.get_mut(n)) {
                    *slot = key(vote, w, n);
                    n += 1;
                }
            }
        }
        // `n` counts the keys written, at most MAX_TAPS: the default never happens.
        let keys = keys.get_mut(..n).unwrap_or_default();
        let m = match weighted_median_of_keys(keys, side.target) {
            Some(m) if m != 0.0 && side.target > 0 => m,
            _ => return self.select(x, y, own),
        };
        if (m - own).abs() > self.params.snap {
            m
        } else {
            own
        }
    }

    /// The value of the pixel `(x, y)` of finite value `own`: the weighted median of its
    /// window's votes when that differs from `own` by more than `snap`, else `own`
    /// (every vote weighed and selected, as the stage was first written).
    fn select(&self, x: usize, y: usize, own: f32) -> f32 {
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
                    let (gx, gy) = self.rows.slope_at(yy, xx);
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
            // `n` ≤ MAX_TAPS (checked where it grows): the default never happens.
            let (values, taps) = (
                values.get_mut(..n).unwrap_or_default(),
                taps.get_mut(..n).unwrap_or_default(),
            );
            let m = weighted_median(values, taps, half);
            if (m - own).abs() > p.snap {
                return m;
            }
        }
        own
    }
}

/// Bit masks of a window row's votes below `lo`, above `hi`, and of its finite values
/// (votes from non-finite values are in neither of the first two). Fixed-size lanes:
/// vector compares and mask extraction.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // one index over six fixed-size arrays vectorises
fn classify(lanes: &Lanes<'_>, dxs: &[f32; LANES], dy: f32, lo: f32, hi: f32) -> (u32, u32, u32) {
    let (mut below, mut above, mut finite) = (0u32, 0u32, 0u32);
    for k in 0..LANES {
        let v = lanes.values[k];
        // The same expression as the selection's, so the classes agree bit for bit.
        let vote = v + lanes.gx[k] * dxs[k] + lanes.gy[k] * dy;
        // The ring holds non-finite values as NaN, and a finite value's vote is finite
        // (slopes are at most 16, offsets at most 7): NaN votes are in no class,
        // and a vote is finite exactly when it is not NaN.
        finite |= u32::from(!vote.is_nan()) << k;
        below |= u32::from(vote < lo) << k;
        above |= u32::from(vote > hi) << k;
    }
    (below, above, finite)
}

/// The votes of a window row's lanes: the same expression as the selection's.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // one index over fixed-size arrays vectorises
fn votes(lanes: &Lanes<'_>, dxs: &[f32; LANES], dy: f32) -> [f32; LANES] {
    let mut votes = [0.0f32; LANES];
    for k in 0..LANES {
        votes[k] = lanes.values[k] + lanes.gx[k] * dxs[k] + lanes.gy[k] * dy;
    }
    votes
}

/// [`table_indices`], and bit k set where the weight is not zero (the distance is
/// below [`Weights::zero_from`]), from float compares as in [`classify`].
#[inline(always)]
fn indices_live(
    colours: &ColourLanes<'_>,
    centre: &[f32; 3],
    weights: &Weights,
) -> ([u32; LANES], u16) {
    let mut indices = [0u32; LANES];
    let mut live = 0u32;
    let zero_from = weights.zero_from();
    let [c0, c1, c2] = colours;
    for k in 0..LANES {
        let (a, b, c) = (c0[k] - centre[0], c1[k] - centre[1], c2[k] - centre[2]);
        let sum = a * a + b * b + c * c;
        indices[k] = weights.index(sum);
        live |= u32::from(sum < zero_from) << k;
    }
    (indices, live as u16)
}

/// Weight table indices ([`Weights::index`]) of a window row's lanes for the colour
/// `centre`: the squared colour distance is the integer sum of squared level
/// differences, and in `f32` the levels, their differences, squares and sum (at most
/// 3 · 255²) are whole numbers below 2²³, so every step is exact. ([`indices_live`]
/// without the mask, which the inlined loop then drops.)
#[inline(always)]
fn table_indices(colours: &ColourLanes<'_>, centre: &[f32; 3], weights: &Weights) -> [u32; LANES] {
    indices_live(colours, centre, weights).0
}
