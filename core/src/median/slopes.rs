//! The map's local slopes for planar votes, kept for the rows of the current window.

/// Rows of slopes kept: one per window row.
pub(super) const SLOPE_ROWS: usize = 2 * super::MAX_RADIUS + 1;

/// Slopes (x then y, `width` each) of image row `yy` in slot `yy % SLOPE_ROWS`, computed
/// when the row first enters a window: each row once per call.
pub(super) struct SlopeRing<'a> {
    slopes: &'a mut [f32],
    slot_row: [usize; SLOPE_ROWS],
    width: usize,
}

impl<'a> SlopeRing<'a> {
    /// `slopes` needs `2 · SLOPE_ROWS · width` elements.
    pub(super) fn new(slopes: &'a mut [f32], width: usize) -> Self {
        SlopeRing {
            slopes,
            slot_row: [usize::MAX; SLOPE_ROWS],
            width,
        }
    }

    /// Makes sure the slopes of image row `yy` are in the ring.
    pub(super) fn load(&mut self, map: &[f32], height: usize, yy: usize, gate: f32) {
        let slot = yy % SLOPE_ROWS;
        if self.slot_row[slot] == yy {
            return;
        }
        let width = self.width;
        let Some(row) = self
            .slopes
            .get_mut(2 * slot * width..2 * (slot + 1) * width)
        else {
            return;
        };
        let (sx, sy) = row.split_at_mut(width);
        for (xx, (gx, gy)) in sx.iter_mut().zip(sy.iter_mut()).enumerate() {
            (*gx, *gy) = slope(map, width, height, xx, yy, gate);
        }
        self.slot_row[slot] = yy;
    }

    /// The x and y slopes of the columns `xs` of image row `yy` (which must be loaded).
    #[inline(always)]
    pub(super) fn row(&self, yy: usize, xs: core::ops::Range<usize>) -> Option<(&[f32], &[f32])> {
        let base = 2 * (yy % SLOPE_ROWS) * self.width;
        let gx = self.slopes.get(base + xs.start..base + xs.end)?;
        let base = base + self.width;
        let gy = self.slopes.get(base + xs.start..base + xs.end)?;
        Some((gx, gy))
    }

    /// The x and y slope at column `xx` of image row `yy` (which must be loaded).
    #[inline(always)]
    pub(super) fn at(&self, yy: usize, xx: usize) -> (f32, f32) {
        let base = 2 * (yy % SLOPE_ROWS) * self.width;
        let gx = self.slopes.get(base + xx).copied().unwrap_or(0.0);
        let gy = self
            .slopes
            .get(base + self.width + xx)
            .copied()
            .unwrap_or(0.0);
        (gx, gy)
    }
}

/// The map's slope at `(x, y)` by central differences; a side whose step exceeds `gate`
/// (a depth edge) is left out, and a slope with both sides out is zero.
#[inline(always)]
pub(super) fn slope(
    map: &[f32],
    width: usize,
    height: usize,
    x: usize,
    y: usize,
    gate: f32,
) -> (f32, f32) {
    let at = |xx: usize, yy: usize| map.get(yy * width + xx).copied().unwrap_or(f32::NAN);
    let v = at(x, y);
    let diff = |prev: Option<f32>, next: Option<f32>| -> f32 {
        let ok = |d: f32| d.is_finite() && d.abs() <= gate.max(1e-6);
        let back = prev.map(|p| v - p).filter(|&d| ok(d));
        let fwd = next.map(|n| n - v).filter(|&d| ok(d));
        match (back, fwd) {
            (Some(b), Some(f)) => 0.5 * (b + f),
            (Some(b), None) => b,
            (None, Some(f)) => f,
            (None, None) => 0.0,
        }
    };
    let gx = diff(
        x.checked_sub(1).map(|xx| at(xx, y)),
        (x + 1 < width).then(|| at(x + 1, y)),
    );
    let gy = diff(
        y.checked_sub(1).map(|yy| at(x, yy)),
        (y + 1 < height).then(|| at(x, y + 1)),
    );
    (gx, gy)
}
