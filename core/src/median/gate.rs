//! Which windows hold something: a step above the gate (the pixel is filtered at all),
//! or a value that changed since the previous pass (the pixel must be filtered again).
//!
//! Both are "some pixel of the window's rows and columns has a flag". Per column the
//! flagged rows are counted over a sliding range of rows (one row enters and one leaves
//! per output row), and along an output row the last flagged column is carried, so the
//! test costs O(1) per pixel instead of a scan of the window.
//!
//! A window holds a step larger than the gate exactly when one of its columns does,
//! counting for each of its rows the step to the right neighbour (also when that lies
//! right of the window) and the step to the lower neighbour when that row is in the
//! window too. A NaN makes no step (NaN compares false), nor does ∞ next to ∞; an
//! infinite value next to a finite one does (the difference is infinite).

use core::ops::Range;

/// Whether the step from column `x` of `row` to its right neighbour exceeds `gate`.
#[inline(always)]
pub(super) fn right_step(row: &[f32], x: usize, gate: f32) -> bool {
    match (row.get(x), row.get(x + 1)) {
        (Some(&v), Some(&right)) => (right - v).abs() > gate,
        _ => false,
    }
}

/// Adds `delta` to `counts[x]` for every column `x` of row `yy` of `map` with a step
/// above `gate` to its right or lower neighbour.
pub(super) fn count_steps(
    map: &[f32],
    width: usize,
    gate: f32,
    yy: usize,
    counts: &mut [f32],
    delta: f32,
) {
    let start = yy * width;
    let (Some(row), Some(below)) = (
        map.get(start..start + width),
        map.get(start + width..start + 2 * width),
    ) else {
        return;
    };
    let (Some(counts), Some(last)) = (counts.get_mut(..width), width.checked_sub(1)) else {
        return;
    };
    let step = |v: f32, other: f32| (other - v).abs() > gate;
    // Branch-free over the row (vector code); the last column has no right step.
    let (inner, last_count) = counts.split_at_mut(last);
    let columns = row.iter().zip(row.get(1..).unwrap_or_default()).zip(below);
    for (count, ((&v, &right), &down)) in inner.iter_mut().zip(columns) {
        *count += if step(v, right) | step(v, down) {
            delta
        } else {
            0.0
        };
    }
    if let (Some(count), Some(&v), Some(&down)) =
        (last_count.first_mut(), row.get(last), below.get(last))
    {
        *count += if step(v, down) { delta } else { 0.0 };
    }
}

/// Adds `delta` to `counts[x]` for every column `x` of row `yy` whose value in `map`
/// differs (in any bit) from the one in `previous`.
pub(super) fn count_changes(
    map: &[f32],
    previous: &[f32],
    width: usize,
    yy: usize,
    counts: &mut [f32],
    delta: f32,
) {
    let start = yy * width;
    let (Some(now), Some(before)) = (
        map.get(start..start + width),
        previous.get(start..start + width),
    ) else {
        return;
    };
    for ((count, a), b) in counts.iter_mut().zip(now).zip(before) {
        *count += if a.to_bits() != b.to_bits() {
            delta
        } else {
            0.0
        };
    }
}

/// Per column, how many rows of a sliding range have a flag.
pub(super) struct ColumnCounts<'a> {
    counts: &'a mut [f32],
    rows: Range<usize>,
}

impl<'a> ColumnCounts<'a> {
    /// No rows counted yet; `counts` needs one element per column.
    pub(super) fn new(counts: &'a mut [f32]) -> Self {
        counts.fill(0.0);
        ColumnCounts { counts, rows: 0..0 }
    }

    /// Counts the rows `rows` instead of the previous ones (both ends may only grow, as
    /// they do from one output row to the next); `count_row(yy, counts, delta)` adds
    /// `delta` to the counts of the columns of row `yy` that have a flag.
    pub(super) fn slide_to(
        &mut self,
        rows: Range<usize>,
        count_row: impl Fn(usize, &mut [f32], f32),
    ) {
        let old = self.rows.clone();
        // Rows that left: [old.start, min(rows.start, old.end)); rows that entered:
        // [max(rows.start, old.end), rows.end).
        for yy in old.start..rows.start.min(old.end) {
            count_row(yy, self.counts, -1.0);
        }
        for yy in rows.start.max(old.end)..rows.end {
            count_row(yy, self.counts, 1.0);
        }
        self.rows = rows;
    }

    /// Whether column `x` has a counted row with a flag.
    #[inline(always)]
    pub(super) fn any(&self, x: usize) -> bool {
        self.counts.get(x).is_some_and(|&c| c > 0.0)
    }
}

/// Per column, how many of the rows that the first phase of a pixel's decision reads
/// (its window's rows at a distance from its own row divisible by 4, and the rows next
/// to them, whose values enter their slopes) have a flag, for pixels of one row at a
/// time; the rows move with the pixel's row. For the pixels of row `centre` these are
/// the rows from `centre + q − 1` to `centre + q + 1` for the multiples q of 4 within
/// the radius, inside the image: the bands of adjacent q are 4 rows apart, so no row is
/// counted twice.
pub(super) struct QuarterRowCounts<'a> {
    counts: &'a mut [f32],
    centre: Option<usize>,
    radius: usize,
    height: usize,
}

impl<'a> QuarterRowCounts<'a> {
    /// No rows counted yet; `counts` needs one element per column.
    pub(super) fn new(counts: &'a mut [f32], radius: usize, height: usize) -> Self {
        counts.fill(0.0);
        QuarterRowCounts {
            counts,
            centre: None,
            radius,
            height,
        }
    }

    /// Counts the rows of the pixels of row `centre`; `count_row(yy, counts, delta)`
    /// adds `delta` to the counts of the columns of row `yy` that have a flag.
    pub(super) fn move_to(&mut self, centre: usize, count_row: impl Fn(usize, &mut [f32], f32)) {
        match self.centre {
            Some(previous) if previous + 1 == centre => {
                // Each band moves down one row: its top row leaves, the row below enters.
                let reach = self.radius / 4 * 4;
                for q in (0..=2 * reach).step_by(4) {
                    if let Some(top) = (previous + q).checked_sub(reach + 1) {
                        if top < self.height {
                            count_row(top, self.counts, -1.0);
                        }
                    }
                    if let Some(below) = (centre + q + 1).checked_sub(reach) {
                        if below < self.height {
                            count_row(below, self.counts, 1.0);
                        }
                    }
                }
            }
            Some(previous) if previous == centre => {}
            _ => {
                self.counts.fill(0.0);
                let reach = self.radius / 4 * 4;
                for q in (0..=2 * reach).step_by(4) {
                    for k in 0..3 {
                        // centre + (q − reach) + (k − 1), when inside the image.
                        let Some(yy) = (centre + q + k).checked_sub(reach + 1) else {
                            continue;
                        };
                        if yy < self.height {
                            count_row(yy, self.counts, 1.0);
                        }
                    }
                }
            }
        }
        self.centre = Some(centre);
    }

    /// Whether column `x` has a counted row with a flag.
    #[inline(always)]
    pub(super) fn any(&self, x: usize) -> bool {
        self.counts.get(x).is_some_and(|&c| c > 0.0)
    }
}

/// The first run of pixels from column `from` on whose columns `x − reach ..= x + reach`
/// hold one with `flagged(c)`, or `None`: a flagged column `c` covers the pixels
/// `c − reach ..= c + reach`, and flagged columns at most `2 · reach + 1` apart cover one
/// run.
pub(super) fn changed_span(
    flagged: impl Fn(usize) -> bool,
    from: usize,
    reach: usize,
    width: usize,
) -> Option<Range<usize>> {
    let first = (from.saturating_sub(reach)..width).find(|&c| flagged(c))?;
    let mut last = first;
    loop {
        let next = (last + 1..(last + 2 * reach + 2).min(width)).find(|&c| flagged(c));
        match next {
            Some(c) => last = c,
            None => break,
        }
    }
    Some(first.saturating_sub(reach).max(from)..(last + reach + 1).min(width))
}

/// The last flagged column met so far along an output row, for windows reaching `reach`
/// columns either side of the pixel.
pub(super) struct LastFlagged {
    column: Option<usize>,
    reach: usize,
}

impl LastFlagged {
    /// Before column `x`, for a walk over the columns from `x` on: the columns from
    /// `x − reach` to `x + reach − 1` enter with `flagged` (columns further left reach
    /// no pixel of the walk).
    pub(super) fn at(
        x: usize,
        reach: usize,
        width: usize,
        flagged: impl Fn(usize) -> bool,
    ) -> Self {
        let column = (x.saturating_sub(reach)..(x + reach).min(width))
            .rev()
            .find(|&c| flagged(c));
        LastFlagged { column, reach }
    }

    /// Moves to the pixel in column `x` (called for every column in order): column
    /// `x + reach` enters. Returns whether the window of `x` holds a flagged column.
    #[inline(always)]
    pub(super) fn step(&mut self, x: usize, width: usize, flagged: impl Fn(usize) -> bool) -> bool {
        let c = x + self.reach;
        if c < width && flagged(c) {
            self.column = Some(c);
        }
        self.column.is_some_and(|c| c + self.reach >= x)
    }
}
