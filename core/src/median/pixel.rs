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
use super::support;
use super::weights::Weights;
use super::{MedianParams, MAX_TAPS, SPAN};
use crate::lightfield::{Sample, View};

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

/// What [`Window::decide`] found.
enum Decision {
    /// The pixel keeps its value; `by_quarter_rows`: the first phase (the rows at a
    /// distance from the pixel's own divisible by 4) settled it.
    Kept { by_quarter_rows: bool },
    /// The median lies on this side of `own ± snap`.
    Side(Side),
}

/// A decision in progress: per window row the classes of its votes, and the weights
/// summed so far.
#[derive(Default)]
struct Sums {
    below: [u16; SPAN],
    above: [u16; SPAN],
    inside: [u16; SPAN],
    weight_below: u64,
    weight_above: u64,
    weight_inside: u64,
}

/// Per window row, the weight table indices of its lanes ([`Weights::index`]), once a
/// decision has measured them: kept by the caller across pixels, so that no decision
/// clears them (a row is read only after the same decision measured it).
pub(super) type RowIndices = [[u32; LANES]; SPAN];

/// The window rows of the pixels of one image row in the order [`Window::decide`]
/// visits them: first the rows at a distance from the pixels' row divisible by 4, then
/// the other rows at an even distance, then the rest (`ends`: where each phase's rows
/// end), each phase's rows by distance (the nearest first: their colours are likeliest
/// alike, so a pixel kept is kept after fewer rows).
pub(super) struct RowOrder {
    rows: [u8; SPAN],
    ends: [usize; 3],
}

impl RowOrder {
    /// For a window of `rows` rows (at most [`SPAN`]) whose pixels lie on row
    /// `centre_row` of it.
    pub(super) fn new(rows: usize, centre_row: usize) -> Self {
        let rows = rows.min(SPAN);
        let mut order = RowOrder {
            rows: [0; SPAN],
            ends: [0; 3],
        };
        let mut n = 0;
        for (phase, end) in order.ends.iter_mut().enumerate() {
            // Window rows centre, −1, +1, −2, +2, … .
            for step in 0..2 * rows {
                let distance = step.div_ceil(2);
                let i = if step % 2 == 1 {
                    centre_row.checked_sub(distance)
                } else {
                    Some(centre_row + distance).filter(|&i| i < rows)
                };
                let in_phase = match phase {
                    0 => distance % 4 == 0,
                    1 => distance % 4 == 2,
                    _ => distance % 2 == 1,
                };
                if let (Some(i), true, Some(slot)) = (i, in_phase, order.rows.get_mut(n)) {
                    *slot = i as u8;
                    n += 1;
                }
            }
            *end = n;
        }
        order
    }
}

/// With I the inside weight and T = I + B + A the total, the selection moves the pixel
/// iff B ≥ ⌈T/2⌉ or T − A < ⌈T/2⌉, i.e. iff B ≥ I + A or A > I + B; both fail for
/// every I at least as large as a partial sum that makes them fail.
fn kept(below: u64, above: u64, inside: u64) -> bool {
    below < inside + above && above <= inside + below
}

/// The votes outside `own ± snap` weigh less than `1/(q + 1)` of the rows weighed on
/// either side (qB < I + A and qA < I + B): on the rows sampled by the first phases of
/// [`Window::decide`], the pixel keeps its value without the rest of its window.
fn clearly_kept(below: u64, above: u64, inside: u64, q: u64) -> bool {
    q * below < inside + above && q * above < inside + below
}

/// The outside share `1/(q + 1)` below which the rows at a distance divisible by 4
/// keep the pixel: a ninth (a quarter, q = 3, and a sixth, q = 5, raised backgammon's
/// MSE×100 by 0.18 and 0.026).
const QUARTER_SHARE: u64 = 8;
/// The same for the rows at an even distance.
const EVEN_SHARE: u64 = 2;
/// How many times more alike the pixel a thin structure's pixels are, on average, than
/// the votes for the median's value ([`Window::keeps_structure`]).
const CONTRAST: u64 = 2;

/// What every pixel of one call shares.
pub(super) struct Window<'a, 'g, S: Sample> {
    pub(super) input: &'a [f32],
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) guide: &'a View<'g, S>,
    /// Per window row (top first), where it lives in the ring ([`RowRing::base`]).
    pub(super) bases: &'a [usize; SPAN],
    /// Per window row, `y − yy` as `f32`.
    pub(super) dys: &'a [f32; SPAN],
    /// `r − k` for lane k: a pixel's offsets to its window columns.
    pub(super) offsets: [f32; LANES],
    pub(super) weights: &'a Weights,
    pub(super) params: MedianParams,
    /// The order of the window rows for the decisions.
    pub(super) order: &'a RowOrder,
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
    ///
    /// The bits are walked as a `u32` (one `blsr` per lane, where a `u16` takes three
    /// instructions) and summed in a `u32`: at most 16 weights below 2¹⁶.
    #[inline(always)]
    fn weigh(&self, bits: u16, indices: &[u32; LANES]) -> u64 {
        let mut bits = u32::from(bits);
        let mut sum = 0u32;
        while bits != 0 {
            let k = bits.trailing_zeros() as usize & (LANES - 1);
            bits &= bits - 1;
            sum += self.weights.at(indices[k]);
        }
        u64::from(sum)
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
    /// the selection on the side that holds the median when it may move; and whether
    /// the rows of its window at a distance from its own divisible by 4 kept it (then
    /// it keeps its value as long as those rows and the rows next to them, which their
    /// slopes read, do not change: [`super::filter_pass`]).
    pub(super) fn value(
        &self,
        ring: &RowRing<'_>,
        x: usize,
        y: usize,
        own: f32,
        indices: &mut RowIndices,
    ) -> (f32, bool) {
        match self.decide(ring, x, y, own, indices) {
            Decision::Kept { by_quarter_rows } => (own, by_quarter_rows),
            Decision::Side(side) => {
                let m = self.select_side(ring, x, y, own, &side);
                let moved = m.to_bits() != own.to_bits();
                if moved && self.keeps_structure(ring, x, y, own, m) {
                    (own, false)
                } else {
                    (m, false)
                }
            }
        }
    }

    /// Whether the pixel `(x, y)` of finite value `own`, which the median would move,
    /// to the median `m`, lies on a thin structure and keeps its value (`support.rs`):
    /// the votes closer to `own` than half the way to `m` (at least within `snap`)
    /// joined to it 8-connected are long and narrow: their bounding box is at least
    /// `r + 1` long (from the pixel to the window's border, where a structure ends
    /// inside the window) and they number at most `thin` times that length (a mean
    /// width of at most `thin` pixels). Only pixels that would move are tested.
    #[inline(never)]
    fn keeps_structure(&self, ring: &RowRing<'_>, x: usize, y: usize, own: f32, m: f32) -> bool {
        let p = &self.params;
        if p.thin <= 0.0 {
            return false;
        }
        let (ys, _) = self.rows_and_columns(x, y);
        let r = p.radius;
        let dxs = self.offsets(x);
        // Blurred or slanted structures ramp towards the background: their pixels are
        // those nearer their own value than the background's.
        let reach = p.snap.max(0.5 * (m - own).abs());
        let (lo, hi) = (own - reach, own + reach);
        let lanes_in_window = (1u32 << (2 * r + 1)) - 1;
        let centre = ring.colour_at(y, x);
        let mut inside = [0u16; SPAN];
        let mut outside = [0u16; SPAN];
        let mut indices: RowIndices = [[0; LANES]; SPAN];
        let per_row = self.bases.iter().zip(self.dys);
        let rows = inside.iter_mut().zip(&mut outside).zip(&mut indices);
        for ((&base, &dy), ((inside, outside), indices)) in per_row.zip(rows).take(ys.len()) {
            let (Some(lanes), Some(colours)) =
                (ring.lanes_at(base, x, r), ring.colours_at(base, x, r))
            else {
                continue;
            };
            let (b, a, f) = classify(&lanes, &dxs, dy, lo, hi);
            *inside = (f & !(b | a) & lanes_in_window) as u16;
            *outside = ((b | a) & lanes_in_window) as u16;
            *indices = table_indices(&colours, &centre, self.weights);
        }
        let reach = support::connected(&inside, ys.len(), y - ys.start, r);
        if !support::is_thin(&reach, r + 1, p.thin) {
            return false;
        }
        // The structure has a colour of its own: its pixels are, on average, at least
        // twice as alike the pixel as the votes for the other value (a blotch of wrong
        // disparity on one surface is not).
        let (mut joined, mut joined_weight, mut others, mut others_weight) =
            (0u64, 0u64, 0u64, 0u64);
        for ((&j, &o), row) in reach.iter().zip(&outside).zip(&indices) {
            joined += u64::from(j.count_ones());
            joined_weight += self.weigh(j, row);
            others += u64::from(o.count_ones());
            others_weight += self.weigh(o, row);
        }
        joined_weight * others >= CONTRAST * others_weight * joined
    }

    /// Whether the pixel `(x, y)` of finite value `own` keeps it (and whether the first
    /// phase settled that), else the side of `own ± snap` whose votes weigh at least
    /// half of the window: the median lies there.
    ///
    /// The pixel keeps its value when the votes outside `own ± snap` weigh less than
    /// half of the window on either side, or, first, when on the rows at a distance
    /// from its own divisible by 4 (a fifth of the window) they weigh less than a ninth
    /// of those rows' weight on either side, or on the rows at an even distance (about
    /// half) less than a third ([`clearly_kept`]). Most pixels near a depth edge are
    /// settled by a part of their window; only the others classify and weigh the rest.
    /// (These shortcuts change the output only where the sampled rows disagree strongly
    /// with the others; the shares were chosen on the HCI scenes, docs/stages/median.md.)
    fn decide(
        &self,
        ring: &RowRing<'_>,
        x: usize,
        y: usize,
        own: f32,
        indices: &mut RowIndices,
    ) -> Decision {
        let mut state = Sums::default();
        // Lane k is column x − r + k.
        let dxs = self.offsets(x);
        let centre = ring.colour_at(y, x);
        let shares = [Some(QUARTER_SHARE), Some(EVEN_SHARE), None];
        let own_weight = u64::from(self.weights.get(0));
        let mut start = 0;
        for (phase, (&end, share)) in self.order.ends.iter().zip(shares).enumerate() {
            let settled = Decision::Kept {
                by_quarter_rows: phase == 0,
            };
            let rows = self.order.rows.get(start..end).unwrap_or_default();
            start = end;
            let outside = self.classify_rows(ring, &mut state, rows, x, own, &dxs);
            if phase == 0 && !outside {
                // No vote outside: B = A = 0 < I (the pixel's own vote weighs w₀ > 0).
                return settled;
            }
            if outside {
                self.weigh_outside(ring, &mut state, indices, rows, x, &centre);
            }
            // The pixel's own vote is inside and weighs `own_weight`, and its row is
            // in the first phase: I at the end of any phase is at least that, so a
            // phase that keeps the pixel with it keeps it with the whole phase's I.
            let kept = |s: &Sums| {
                let inside = s.weight_inside.max(own_weight);
                match share {
                    Some(q) => clearly_kept(s.weight_below, s.weight_above, inside, q),
                    None => kept(s.weight_below, s.weight_above, inside),
                }
            };
            if kept(&state) {
                return settled;
            }
            // Rows by distance from the pixel's own: their colours are likeliest alike.
            for &i in rows {
                let i = usize::from(i);
                let (Some(&bits), Some(&base), Some(row)) =
                    (state.inside.get(i), self.bases.get(i), indices.get_mut(i))
                else {
                    continue;
                };
                if bits == 0 {
                    continue;
                }
                // `weigh_outside` measured the rows with a vote outside.
                let measured = state.below.get(i).zip(state.above.get(i));
                if measured.is_none_or(|(&b, &a)| b | a == 0) {
                    let Some(colours) = ring.colours_at(base, x, self.params.radius) else {
                        continue;
                    };
                    *row = table_indices(&colours, &centre, self.weights);
                }
                state.weight_inside += self.weigh(bits, row);
                if kept(&state) {
                    return settled;
                }
            }
        }
        // Every vote is weighed now: the sums are exact. The median is the smallest vote
        // whose weight of votes at or below it reaches ⌈T/2⌉; below `lo` when B reaches
        // it, else above `hi`, where the votes below and inside count first.
        let (below, inside, above) = (state.weight_below, state.weight_inside, state.weight_above);
        let half = (below + inside + above).div_ceil(2);
        Decision::Side(if below >= half {
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

    /// Classifies the votes of the window rows `rows` into `state.below`, `above` and
    /// `inside`; returns whether one of them holds a vote outside `own ± snap`.
    #[inline(always)]
    fn classify_rows(
        &self,
        ring: &RowRing<'_>,
        state: &mut Sums,
        rows: &[u8],
        x: usize,
        own: f32,
        dxs: &[f32; LANES],
    ) -> bool {
        let r = self.params.radius;
        let (lo, hi) = (own - self.params.snap, own + self.params.snap);
        let lanes_in_window = (1u32 << (2 * r + 1)) - 1;
        let mut outside = 0u32;
        for &i in rows {
            let i = usize::from(i);
            let (Some(&base), Some(&dy)) = (self.bases.get(i), self.dys.get(i)) else {
                continue;
            };
            let Some(lanes) = ring.lanes_at(base, x, r) else {
                continue;
            };
            let (b, a, f) = classify(&lanes, dxs, dy, lo, hi);
            let (b, a, f) = (
                b & lanes_in_window,
                a & lanes_in_window,
                f & lanes_in_window,
            );
            let (Some(below), Some(above), Some(inside)) = (
                state.below.get_mut(i),
                state.above.get_mut(i),
                state.inside.get_mut(i),
            ) else {
                continue;
            };
            *below = b as u16;
            *above = a as u16;
            *inside = (f & !(b | a)) as u16;
            outside |= b | a;
        }
        outside != 0
    }

    /// Adds the weights of the votes below and above of the rows `rows` to the sums,
    /// and keeps the weight table indices of the rows with such votes in `indices`.
    #[inline(always)]
    fn weigh_outside(
        &self,
        ring: &RowRing<'_>,
        state: &mut Sums,
        indices: &mut RowIndices,
        rows: &[u8],
        x: usize,
        centre: &[f32; 3],
    ) {
        let r = self.params.radius;
        for &i in rows {
            let i = usize::from(i);
            let (Some(&base), Some(&below), Some(&above), Some(row)) = (
                self.bases.get(i),
                state.below.get(i),
                state.above.get(i),
                indices.get_mut(i),
            ) else {
                continue;
            };
            if below | above == 0 {
                continue;
            }
            let Some(colours) = ring.colours_at(base, x, r) else {
                continue;
            };
            let live;
            (*row, live) = indices_live(&colours, centre, self.weights);
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
    // Out of line: its key array would otherwise enlarge every decision's frame.
    #[inline(never)]
    fn select_side(&self, ring: &RowRing<'_>, x: usize, y: usize, own: f32, side: &Side) -> f32 {
        let (ys, _) = self.rows_and_columns(x, y);
        let r = self.params.radius;
        let dxs = self.offsets(x);
        let centre = ring.colour_at(y, x);
        let mut keys = [0u64; MAX_TAPS];
        let mut n = 0;
        let per_row = self.bases.iter().zip(self.dys);
        for ((&base, &dy), &bits) in per_row.zip(&side.lanes).take(ys.len()) {
            // As a `u32`, as in `weigh`.
            let mut bits = u32::from(bits);
            if bits == 0 {
                continue;
            }
            let (Some(lanes), Some(colours)) =
                (ring.lanes_at(base, x, r), ring.colours_at(base, x, r))
            else {
                continue;
            };
            let votes = votes(&lanes, &dxs, dy);
            let indices = table_indices(&colours, &centre, self.weights);
            while bits != 0 {
                let k = bits.trailing_zeros() as usize & (LANES - 1);
                bits &= bits - 1;
                let w = self.weights.at(indices[k]);
                // Without a branch on the weight: a key of weight zero is written and
                // then overwritten by the next one (`n` stays).
                if let (Some(&vote), Some(slot)) = (votes.get(k), keys.get_mut(n)) {
                    *slot = key(vote, w, n);
                    n += usize::from(w > 0);
                }
            }
        }
        // `n` counts the keys written, at most MAX_TAPS: the default never happens.
        let keys = keys.get_mut(..n).unwrap_or_default();
        let m = match weighted_median_of_keys(keys, side.target) {
            Some(m) if m != 0.0 && side.target > 0 => m,
            _ => return self.select(ring, x, y, own),
        };
        if (m - own).abs() > self.params.snap {
            m
        } else {
            own
        }
    }

    /// The value of the pixel `(x, y)` of finite value `own`: the weighted median of its
    /// window's votes when that differs from `own` by more than `snap`, else `own`
    /// (every vote weighed and selected: the plain form of the rule).
    fn select(&self, ring: &RowRing<'_>, x: usize, y: usize, own: f32) -> f32 {
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
                    let (gx, gy) = ring.slope_at(yy, xx);
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
