//! One hypothesis's matching costs of a centre row: every view's row at its constant
//! shift ([`Shift`]), blended, differenced against the centre, weighted and truncated.

use super::rows::{unit_row, Luma, RowCache};
use super::{take, GROUPS};
use crate::error::{Error, Result};
use crate::lightfield::{Sample, View};

/// `√2`: the noise weight of a whole-pixel shift is 1.
const NOISE_SCALE: f32 = core::f32::consts::SQRT_2;

/// One view of the sweep: its image and camera offset from the centre, the current
/// hypothesis's shift and where the band keeps its rows in unit intensity.
#[derive(Clone, Copy)]
pub(super) struct SweepView<'a, S: Sample> {
    pub(super) view: View<'a, S>,
    pub(super) u: f32,
    pub(super) v: f32,
    /// 0 for the centre row's views, 1 for the centre column's.
    pub(super) group: usize,
    /// The current hypothesis's shift ([`Shift::at`]).
    pub(super) shift: Shift,
    /// The view's rows the band converted ([`RowCache`]).
    pub(super) rows: RowCache,
}

/// A view's shift `t = −d·u` (row views) or `−d·v` (column views) at hypothesis `d`,
/// split into `⌊t⌋` and the blend weights `f = t − ⌊t⌋`, `g = 1 − f`, and the noise
/// weight `w = √2 / √(1 + g² + f²)`.
#[derive(Clone, Copy, Default)]
pub(super) struct Shift {
    floor: f32,
    f: f32,
    g: f32,
    w: f32,
}

impl Shift {
    pub(super) fn at(d: f32, offset: f32) -> Self {
        let t = -d * offset;
        let floor = libm::floorf(t);
        let f = t - floor;
        let g = 1.0 - f;
        // Under i.i.d. noise of deviation σ the residual's deviation is
        // σ·√(1 + g² + f²): linear interpolation averages noise away at half-pixel
        // shifts, which would pull faint texture towards those hypotheses.
        let w = NOISE_SCALE / libm::sqrtf(1.0 + g * g + f * f);
        Shift { floor, f, g, w }
    }
}

/// Row `y + floor + dy` of a view `height` rows tall, clamped to the image: the first
/// (`dy` 0) and second (`dy` 1) row a column view blends for row `y`.
pub(super) fn source_row(y: usize, floor: f32, dy: f32, height: usize) -> usize {
    (y as f32 + floor + dy).min(height as f32 - 1.0).max(0.0) as usize
}

/// The weighted, truncated absolute differences of row `y` of the centre view to every
/// view at the current hypothesis (each view's [`SweepView::shift`]), per interleaved
/// sample, summed over the centre row's views into the first row of `acc` and over the
/// centre column's into the second (one value per pixel with `luma`, else per sample).
/// Rows the band kept in `cache` are read from there, the others converted here (with
/// `luma` into two rows of `acc` after the centre row).
#[allow(clippy::too_many_arguments)]
pub(super) fn pixel_costs<S: Sample>(
    centre: &View<'_, S>,
    centre_rows: RowCache,
    cache: &[f32],
    views: &[SweepView<'_, S>],
    y: usize,
    tau: f32,
    luma: Option<Luma>,
    acc: &mut [f32],
) -> Result<()> {
    let missing = Error::InvalidParameter {
        name: "light field",
        reason: "holds fewer rows than its layout: build the light field from the whole frame",
    };
    let width = centre.width();
    let row_len = width * Luma::values(luma, centre.channels());
    let (acc, rest) = take(acc, GROUPS * row_len)?;
    let (cen, spare) = take(rest, row_len)?;
    let cen = match centre_rows.row(cache, y, row_len) {
        Some(row) => row,
        None => {
            // The centre row in unit intensity, converted once for every view.
            let c_row = centre.row(y).ok_or(missing)?;
            unit_row(c_row, cen, luma);
            &*cen
        }
    };
    // The first view of a group stores its terms, the others add theirs (bit-identical
    // to adding to zero: the terms are never −0); a group without views is zeroed.
    let mut seen = [false; GROUPS];
    for sv in views {
        let acc = acc
            .get_mut(sv.group * row_len..(sv.group + 1) * row_len)
            .ok_or(Error::ScratchTooSmall {
                needed: GROUPS * row_len,
                got: 0,
            })?;
        let first = match seen.get_mut(sv.group) {
            Some(seen) => !core::mem::replace(seen, true),
            None => false,
        };
        let read = Read {
            cache,
            luma,
            missing,
        };
        if first {
            view_costs::<S, true>(sv, read, cen, y, tau, acc, spare)?;
        } else {
            view_costs::<S, false>(sv, read, cen, y, tau, acc, spare)?;
        }
    }
    for (group, seen) in acc.chunks_mut(row_len.max(1)).zip(seen) {
        if !seen {
            group.fill(0.0);
        }
    }
    Ok(())
}

/// `x.min(tau)` as one `minps`: `x` when below `tau`, else `tau` (also for a NaN `x`,
/// as `f32::min` gives), the same bits as `f32::min` for the non-negative `x` and
/// positive `tau` here without its extra NaN test.
#[inline(always)]
fn truncated(x: f32, tau: f32) -> f32 {
    if x < tau {
        x
    } else {
        tau
    }
}

/// Adds `term` to `a`, or stores it for a group's first view.
#[inline(always)]
fn put<const FIRST: bool>(a: &mut f32, term: f32) {
    if FIRST {
        *a = term;
    } else {
        *a += term;
    }
}

/// Where [`view_costs`] reads a view's rows: the band's converted rows, the
/// luminance matching if on, the error for a row the view lacks.
#[derive(Clone, Copy)]
pub(super) struct Read<'c> {
    cache: &'c [f32],
    luma: Option<Luma>,
    missing: Error,
}

/// One view's weighted, truncated absolute differences to the centre row `cen` at its
/// current shift into its group's row `acc` (stored if `FIRST`, else added), from the
/// band's converted rows in `read.cache` where kept, else from the view: its samples
/// converted as they are read, or with luminance matching its rows converted into
/// `spare` first ([`unit_row`], the same bits as the kept rows).
fn view_costs<S: Sample, const FIRST: bool>(
    sv: &SweepView<'_, S>,
    read: Read<'_>,
    cen: &[f32],
    y: usize,
    tau: f32,
    acc: &mut [f32],
    spare: &mut [f32],
) -> Result<()> {
    let Read {
        cache,
        luma,
        missing,
    } = read;
    let width = sv.view.width();
    let row_len = width * Luma::values(luma, sv.view.channels());
    let shift = sv.shift;
    if sv.v == 0.0 {
        // Source x = x + t, t = −d·u: the row shifted by ⌊t⌋ and blended by f.
        match sv.rows.row(cache, y, row_len) {
            Some(src) => shifted::<f32, FIRST>(src, width, shift, cen, tau, acc),
            None => {
                let src = sv.view.row(y).ok_or(missing)?;
                if luma.is_some() {
                    let (row, _) = take(spare, row_len)?;
                    unit_row(src, row, luma);
                    shifted::<f32, FIRST>(row, width, shift, cen, tau, acc);
                } else {
                    shifted::<S, FIRST>(src, width, shift, cen, tau, acc);
                }
            }
        }
    } else {
        // Source y + t, t = −d·v: a blend of two rows (clamped to the image).
        let height = sv.view.height();
        let (y0, y1) = (
            source_row(y, shift.floor, 0.0, height),
            source_row(y, shift.floor, 1.0, height),
        );
        match (
            sv.rows.row(cache, y0, row_len),
            sv.rows.row(cache, y1, row_len),
        ) {
            (Some(s0), Some(s1)) => blend::<f32, FIRST>(s0, s1, shift, cen, tau, acc),
            _ => {
                let s0 = sv.view.row(y0).ok_or(missing)?;
                let s1 = sv.view.row(y1).ok_or(missing)?;
                if luma.is_some() {
                    let (r0, rest) = take(spare, row_len)?;
                    let (r1, _) = take(rest, row_len)?;
                    unit_row(s0, r0, luma);
                    unit_row(s1, r1, luma);
                    blend::<f32, FIRST>(r0, r1, shift, cen, tau, acc);
                } else {
                    blend::<S, FIRST>(s0, s1, shift, cen, tau, acc);
                }
            }
        }
    }
    Ok(())
}

/// `min(w·|g·s0 + f·s1 − c|, τ)` per sample into `acc` (stored if `FIRST`, else added):
/// the kernel of every view, on rows in unit intensity (`T = f32`) or converted here.
#[inline(always)]
fn blend<T: Sample, const FIRST: bool>(
    s0: &[T],
    s1: &[T],
    shift: Shift,
    cen: &[f32],
    tau: f32,
    acc: &mut [f32],
) {
    let Shift { f, g, w, .. } = shift;
    for (((a, &p0), &p1), &c) in acc.iter_mut().zip(s0).zip(s1).zip(cen) {
        let value = g * p0.to_unit() + f * p1.to_unit();
        put::<FIRST>(a, truncated(w * libm::fabsf(value - c), tau));
    }
}

/// A row view's costs: its row `src` (`width` pixels) shifted by `⌊t⌋` pixels and
/// blended by `f`, the taps clamped to the row at its ends.
fn shifted<T: Sample, const FIRST: bool>(
    src: &[T],
    width: usize,
    shift: Shift,
    cen: &[f32],
    tau: f32,
    acc: &mut [f32],
) {
    let channels = src.len() / width.max(1);
    let k = shift.floor as isize;
    // Pixels whose two taps x + k and x + k + 1 lie inside the row.
    let lo = (-k).max(0).min(width as isize) as usize;
    let hi = (width as isize - 1 - k)
        .min(width as isize)
        .max(lo as isize) as usize;
    let inner = lo * channels..hi * channels;
    let from = (lo as isize + k).max(0) as usize * channels;
    let s0 = src.get(from..from + inner.len()).unwrap_or(&[]);
    let s1 = src
        .get(from + channels..from + channels + inner.len())
        .unwrap_or(&[]);
    let c_in = cen.get(inner.clone()).unwrap_or(&[]);
    blend::<T, FIRST>(
        s0,
        s1,
        shift,
        c_in,
        tau,
        acc.get_mut(inner).unwrap_or(&mut []),
    );
    // The edges, with the taps clamped to the row: left of `lo` they are the row's first
    // two pixels, from `hi` on its last pixel twice, so per channel one blended value.
    let Shift { f, g, w, .. } = shift;
    let last = width.saturating_sub(1);
    for (edge, (x0, x1)) in [(0..lo, (0, last.min(1))), (hi..width, (last, last))] {
        let mut values = [0.0f32; 4];
        for (ch, value) in values.iter_mut().enumerate().take(channels) {
            let p0 = src.get(x0 * channels + ch).map_or(0.0, |s| s.to_unit());
            let p1 = src.get(x1 * channels + ch).map_or(0.0, |s| s.to_unit());
            *value = g * p0 + f * p1;
        }
        let span = edge.start * channels..edge.end * channels;
        let (Some(a), Some(c)) = (acc.get_mut(span.clone()), cen.get(span)) else {
            continue;
        };
        let n = channels.max(1);
        for (a, c) in a.chunks_exact_mut(n).zip(c.chunks_exact(n)) {
            for ((a, &c), &value) in a.iter_mut().zip(c).zip(&values) {
                put::<FIRST>(a, truncated(w * libm::fabsf(value - c), tau));
            }
        }
    }
}
