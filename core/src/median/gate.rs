//! The step gate: which windows hold a step between adjacent pixels larger than the gate.
//!
//! A window holds such a step exactly when one of its columns does, counting for each of
//! its rows the step to the right neighbour (also when that lies right of the window) and
//! the step to the lower neighbour when that row is in the window too. Per column, the
//! rows whose right or lower step exceeds the gate are counted over a sliding range of
//! rows (one row enters and one leaves per output row), so the test costs O(1) per pixel
//! instead of a scan of the window. Non-finite values make no step (NaN compares false).

use core::ops::Range;

/// Whether the step from `(x, y)` to its right neighbour exceeds `gate`.
#[inline(always)]
pub(super) fn right_step(row: &[f32], x: usize, gate: f32) -> bool {
    match (row.get(x), row.get(x + 1)) {
        (Some(&v), Some(&right)) => (right - v).abs() > gate,
        _ => false,
    }
}

/// Per column, how many rows of `rows` have a right or lower step above the gate.
pub(super) struct StepCounts<'a> {
    counts: &'a mut [f32],
    rows: Range<usize>,
}

impl<'a> StepCounts<'a> {
    /// No rows counted yet; `counts` needs one element per column.
    pub(super) fn new(counts: &'a mut [f32]) -> Self {
        counts.fill(0.0);
        StepCounts { counts, rows: 0..0 }
    }

    /// Counts the rows `rows` instead of the previous ones (both ends may only grow, as
    /// they do from one output row to the next).
    pub(super) fn slide_to(&mut self, map: &[f32], width: usize, gate: f32, rows: Range<usize>) {
        let old = self.rows.clone();
        // Rows that left: [old.start, min(rows.start, old.end)); rows that entered:
        // [max(rows.start, old.end), rows.end).
        for yy in old.start..rows.start.min(old.end) {
            self.add_row(map, width, gate, yy, -1.0);
        }
        for yy in rows.start.max(old.end)..rows.end {
            self.add_row(map, width, gate, yy, 1.0);
        }
        self.rows = rows;
    }

    fn add_row(&mut self, map: &[f32], width: usize, gate: f32, yy: usize, delta: f32) {
        let start = yy * width;
        let (Some(row), Some(below)) = (
            map.get(start..start + width),
            map.get(start + width..start + 2 * width),
        ) else {
            return;
        };
        for (x, ((count, &v), &down)) in self.counts.iter_mut().zip(row).zip(below).enumerate() {
            let step = right_step(row, x, gate) || (down - v).abs() > gate;
            if step {
                *count += delta;
            }
        }
    }

    /// Whether column `x` has a counted row with a step.
    #[inline(always)]
    pub(super) fn any(&self, x: usize) -> bool {
        self.counts.get(x).is_some_and(|&c| c > 0.0)
    }
}
