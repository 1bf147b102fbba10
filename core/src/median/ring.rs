//! The rows of the current window, padded for fixed-width reads: each row's disparities,
//! its local slopes for planar votes, and the guide's 8-bit colour levels.
//!
//! A pixel's window row is read as [`LANES`] consecutive values starting `radius` left
//! of the pixel, whatever the pixel's column: the padding left and right of the image
//! holds NaN disparities (no vote) and zero slopes, so the votes of a window row are
//! one fixed-size computation the compiler turns into vector instructions.

use crate::lightfield::{Sample, View};

/// Rows kept: one per window row.
pub(super) const RING_ROWS: usize = 2 * super::MAX_RADIUS + 1;
/// Values read per window row (the widest window, rounded up to a vector multiple).
pub(super) const LANES: usize = 16;
/// Padding left of column 0.
const PAD_LEFT: usize = super::MAX_RADIUS;
/// Padding right of the last column: a read of [`LANES`] values starting at column
/// `width − 1 − radius` (radius ≥ 1) ends `LANES − 2` columns beyond the last.
const PAD_RIGHT: usize = LANES - 1;

/// Elements of one padded row.
pub(super) fn stride(width: usize) -> usize {
    width.saturating_add(PAD_LEFT + PAD_RIGHT)
}

/// Planes per row: values, x and y slopes, three colour channels.
const PLANES: usize = 6;

/// `f32` elements a ring for rows of `width` needs.
pub(super) fn ring_len(width: usize) -> usize {
    stride(width).saturating_mul(PLANES * RING_ROWS)
}

/// Values, x slopes, y slopes and the guide's colour levels (each plane [`stride`]
/// long) of image row `yy` in slot `yy % RING_ROWS`, filled when the row first enters a
/// window: each row once per call. Levels are whole numbers in `f32`, so squared colour
/// distances computed from them are exact.
pub(super) struct RowRing<'a> {
    rows: &'a mut [f32],
    slot_row: [usize; RING_ROWS],
    width: usize,
    stride: usize,
    /// `2 · stride + LANES`: the elements from a lane's start in one plane to its end
    /// two planes further.
    three_planes: usize,
}

/// One window row of a pixel: [`LANES`] values and slopes from `radius` left of it.
pub(super) struct Lanes<'a> {
    pub(super) values: &'a [f32; LANES],
    pub(super) gx: &'a [f32; LANES],
    pub(super) gy: &'a [f32; LANES],
}

/// The guide's colour levels (three channels) of one window row of a pixel.
pub(super) type ColourLanes<'a> = [&'a [f32; LANES]; 3];

impl<'a> RowRing<'a> {
    /// `rows` needs [`ring_len`] elements.
    pub(super) fn new(rows: &'a mut [f32], width: usize) -> Self {
        RowRing {
            rows,
            slot_row: [usize::MAX; RING_ROWS],
            width,
            stride: stride(width),
            three_planes: stride(width).saturating_mul(2).saturating_add(LANES),
        }
    }

    /// Makes sure image row `yy` is in the ring; with `planar` its slopes (steps above
    /// `gate` left out), else zero slopes. Channels of the guide beyond the third are
    /// ignored, missing ones are zero.
    pub(super) fn load<S: Sample>(
        &mut self,
        map: &[f32],
        guide: &View<'_, S>,
        yy: usize,
        gate: f32,
        planar: bool,
    ) {
        let slot = yy % RING_ROWS;
        if self.slot_row[slot] == yy {
            return;
        }
        let (width, stride, height) = (self.width, self.stride, guide.height());
        let Some(rows) = self
            .rows
            .get_mut(PLANES * slot * stride..PLANES * (slot + 1) * stride)
        else {
            return;
        };
        // `stride` ≥ PAD_LEFT + width + PAD_RIGHT unless it saturated, and then `new`'s
        // caller could not have had `ring_len` elements: the returns below never happen.
        let Some((values, rest)) = rows.split_at_mut_checked(stride) else {
            return;
        };
        let Some((sx, rest)) = rest.split_at_mut_checked(stride) else {
            return;
        };
        let Some((sy, colours)) = rest.split_at_mut_checked(stride) else {
            return;
        };
        let columns = PAD_LEFT..PAD_LEFT + width;
        let channels = guide.channels();
        let samples = guide.row(yy).unwrap_or(&[]);
        // The three planes in one sweep over the row's pixels (missing channels zero).
        let Some((c0, rest)) = colours.split_at_mut_checked(stride) else {
            return;
        };
        let Some((c1, c2)) = rest.split_at_mut_checked(stride) else {
            return;
        };
        // Only the padding is cleared: the sweep writes every column of the row (a
        // row of the guide shorter than the image, which a view never has, is cleared).
        let complete = samples.len() >= width.saturating_mul(channels) && channels > 0;
        for plane in [&mut *c0, &mut *c1, &mut *c2] {
            clear_padding(plane, width, complete);
        }
        let (Some(c0), Some(c1), Some(c2)) = (
            c0.get_mut(columns.clone()),
            c1.get_mut(columns.clone()),
            c2.get_mut(columns.clone()),
        ) else {
            return;
        };
        let level = |s: &S| f32::from(s.level());
        let planes = c0.iter_mut().zip(c1.iter_mut().zip(c2.iter_mut()));
        if channels == 3 {
            // The common case with a fixed stride: no per-pixel channel test.
            for ((l0, (l1, l2)), pixel) in planes.zip(samples.chunks_exact(3)) {
                if let [a, b, c] = pixel {
                    (*l0, *l1, *l2) = (level(a), level(b), level(c));
                }
            }
        } else {
            for ((l0, (l1, l2)), pixel) in planes.zip(samples.chunks_exact(channels.max(1))) {
                *l0 = pixel.first().map_or(0.0, level);
                *l1 = pixel.get(1).map_or(0.0, level);
                *l2 = pixel.get(2).map_or(0.0, level);
            }
        }
        let Some(row) = map.get(yy * width..(yy + 1) * width) else {
            return;
        };
        let Some((left, rest)) = values.split_at_mut_checked(PAD_LEFT) else {
            return;
        };
        let Some((inside, right)) = rest.split_at_mut_checked(width) else {
            return;
        };
        left.fill(f32::NAN);
        // Non-finite values as NaN: a vote is then finite exactly when it equals itself,
        // and NaN votes fall in neither class (one compare per lane instead of three).
        for (v, &d) in inside.iter_mut().zip(row) {
            *v = if d.is_finite() { d } else { f32::NAN };
        }
        right.fill(f32::NAN);
        // `row_slopes` writes every column of the row.
        clear_padding(sx, width, planar);
        clear_padding(sy, width, planar);
        if planar {
            let (Some(sx), Some(sy)) = (sx.get_mut(columns.clone()), sy.get_mut(columns)) else {
                return;
            };
            row_slopes(map, width, height, yy, gate, sx, sy);
        }
        self.slot_row[slot] = yy;
    }

    /// Where image row `yy` lives in the ring: the argument of [`Self::lanes_at`].
    #[inline(always)]
    pub(super) fn base(&self, yy: usize) -> usize {
        PLANES * (yy % RING_ROWS) * self.stride
    }

    /// Where the lanes of the pixel in column `x` start in the row at `base`.
    #[inline(always)]
    fn start(base: usize, x: usize, radius: usize) -> Option<usize> {
        Some(base.wrapping_add((x + PAD_LEFT).checked_sub(radius)?))
    }

    /// Window row at `base` ([`Self::base`] of a loaded row) of the pixel in column
    /// `x`, from column `x − radius` on: values and slopes.
    #[inline(always)]
    pub(super) fn lanes_at(&self, base: usize, x: usize, radius: usize) -> Option<Lanes<'_>> {
        let start = Self::start(base, x, radius)?;
        // One range for the three planes: the first and last lanes need no more check.
        let block = self
            .rows
            .get(start..start.checked_add(self.three_planes)?)?;
        Some(Lanes {
            values: block.first_chunk()?,
            gx: block.get(self.stride..)?.first_chunk()?,
            gy: block.last_chunk()?,
        })
    }

    /// The colour levels of the lanes of [`Self::lanes_at`].
    #[inline(always)]
    pub(super) fn colours_at(
        &self,
        base: usize,
        x: usize,
        radius: usize,
    ) -> Option<ColourLanes<'_>> {
        let start = Self::start(base, x, radius)?.checked_add(3 * self.stride)?;
        let block = self
            .rows
            .get(start..start.checked_add(self.three_planes)?)?;
        Some([
            block.first_chunk()?,
            block.get(self.stride..)?.first_chunk()?,
            block.last_chunk()?,
        ])
    }

    /// The x and y slope at column `xx` of image row `yy` (which must be loaded).
    #[inline(always)]
    pub(super) fn slope_at(&self, yy: usize, xx: usize) -> (f32, f32) {
        let at = PLANES * (yy % RING_ROWS) * self.stride + PAD_LEFT + xx;
        let get = |i: usize| self.rows.get(i).copied().unwrap_or(0.0);
        (get(at + self.stride), get(at + 2 * self.stride))
    }

    /// The colour levels at column `xx` of image row `yy` (which must be loaded).
    #[inline(always)]
    pub(super) fn colour_at(&self, yy: usize, xx: usize) -> [f32; 3] {
        let at = PLANES * (yy % RING_ROWS) * self.stride + PAD_LEFT + xx;
        let get = |i: usize| self.rows.get(i).copied().unwrap_or(0.0);
        [
            get(at + 3 * self.stride),
            get(at + 4 * self.stride),
            get(at + 5 * self.stride),
        ]
    }
}

/// Zeroes a padded plane of a row of `width` columns: only its padding when the
/// row's columns are written next (`written`), else all of it.
fn clear_padding(plane: &mut [f32], width: usize, written: bool) {
    if !written {
        plane.fill(0.0);
        return;
    }
    let (left, rest) = plane.split_at_mut(PAD_LEFT.min(plane.len()));
    left.fill(0.0);
    if let Some(right) = rest.get_mut(width..) {
        right.fill(0.0);
    }
}

/// One side-aware central difference, as [`slope`] takes it, from the backward and
/// forward differences `back` and `fwd` of sides that exist (`has_back`, `has_fwd`)
/// and the gate `limit`: branch-free selects, so a row of them is vector code. A
/// difference within the limit is finite (the limit is), so `|d| ≤ limit` is
/// [`slope`]'s test.
#[inline(always)]
fn central(back: f32, fwd: f32, has_back: bool, has_fwd: bool, limit: f32) -> f32 {
    let ok_back = has_back & (back.abs() <= limit);
    let ok_fwd = has_fwd & (fwd.abs() <= limit);
    let both = 0.5 * (back + fwd);
    let one = if ok_back { back } else { fwd };
    if ok_back & ok_fwd {
        both
    } else if ok_back | ok_fwd {
        one
    } else {
        0.0
    }
}

/// [`slope`] of every column of row `yy` into `sx` and `sy` (`width` each): the
/// interior columns' x slopes and every y slope as vector code, the two end columns'
/// x slopes by [`slope`].
fn row_slopes(
    map: &[f32],
    width: usize,
    height: usize,
    yy: usize,
    gate: f32,
    sx: &mut [f32],
    sy: &mut [f32],
) {
    let limit = gate.max(1e-6);
    let Some(row) = map.get(yy * width..(yy + 1) * width) else {
        return;
    };
    // A missing row above or below: the row itself, whose differences are not used.
    let (has_up, has_down) = (yy > 0, yy + 1 < height);
    let up = if has_up {
        map.get((yy - 1) * width..yy * width).unwrap_or(row)
    } else {
        row
    };
    let down = if has_down {
        map.get((yy + 1) * width..(yy + 2) * width).unwrap_or(row)
    } else {
        row
    };
    for (gy, ((&v, &u), &d)) in sy.iter_mut().zip(row.iter().zip(up).zip(down)) {
        *gy = central(v - u, d - v, has_up, has_down, limit);
    }
    if width >= 3 {
        let (left, middle, right) = (&row[..width - 2], &row[1..width - 1], &row[2..]);
        let inner = sx.get_mut(1..width - 1).unwrap_or_default();
        for (gx, ((&l, &v), &r)) in inner.iter_mut().zip(left.iter().zip(middle).zip(right)) {
            *gx = central(v - l, r - v, true, true, limit);
        }
    }
    for xx in [0, width.saturating_sub(1)] {
        if let Some(gx) = sx.get_mut(xx) {
            *gx = slope(map, width, height, xx, yy, gate).0;
        }
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
