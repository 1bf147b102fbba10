//! The views' rows a band reads, in unit intensity: converted once per band and kept
//! ([`RowCache`]), with the luminance matching's one value per pixel ([`Luma`]).

use core::ops::Range;

use super::{PlaneSweepParams, SweepColor};
use crate::lightfield::{Sample, View};

/// Rows `first..first + rows` of a view in unit intensity ([`Sample::to_unit`]), kept
/// for a band at `start` of the cache (`row_len` values a row); `rows` 0 where the
/// cache had no room: that view is read and converted per hypothesis, to the same bits.
#[derive(Clone, Copy, Default)]
pub(super) struct RowCache {
    start: usize,
    first: usize,
    rows: usize,
}

impl RowCache {
    /// Row `y` from `cache`, if kept.
    pub(super) fn row<'c>(&self, cache: &'c [f32], y: usize, row_len: usize) -> Option<&'c [f32]> {
        let k = y.checked_sub(self.first).filter(|&k| k < self.rows)?;
        let at = self.start.checked_add(k.checked_mul(row_len)?)?;
        cache.get(at..at.checked_add(row_len)?)
    }

    /// Takes room for rows `rows` of `view` from `cache[*used..]` and converts them
    /// ([`unit_row`]); no room leaves the view uncached.
    pub(super) fn fill<S: Sample>(
        view: &View<'_, S>,
        rows: Range<usize>,
        cache: &mut [f32],
        used: &mut usize,
        row_len: usize,
        luma: Option<Luma>,
    ) -> Self {
        let Some(len) = rows.len().checked_mul(row_len) else {
            return RowCache::default();
        };
        let start = *used;
        let Some(room) = start
            .checked_add(len)
            .and_then(|end| cache.get_mut(start..end))
        else {
            return RowCache::default();
        };
        for (to, y) in room.chunks_exact_mut(row_len.max(1)).zip(rows.clone()) {
            match view.row(y) {
                Some(from) => unit_row(from, to, luma),
                None => return RowCache::default(),
            }
        }
        *used = start + len;
        RowCache {
            start,
            first: rows.start,
            rows: rows.len(),
        }
    }
}

/// Matching on luminance ([`SweepColor::Gray`]): the views' interleaved `channels`, of
/// which the first `channels.min(3)` (the colour channels, as the RGB matching's) are
/// averaged.
#[derive(Clone, Copy)]
pub(super) struct Luma {
    pub(super) channels: usize,
}

impl Luma {
    /// The luminance matching of views with `channels` interleaved samples under
    /// `params`: with [`SweepColor::Gray`] and more than one channel (one channel is
    /// matched as it is).
    pub(super) fn of(params: &PlaneSweepParams, channels: usize) -> Option<Luma> {
        (params.color == SweepColor::Gray && channels != 1).then_some(Luma { channels })
    }

    /// Values per pixel that the sweep matches (and keeps in a band's converted rows)
    /// of views with `channels` interleaved samples: one with `luma`, else every sample.
    pub(super) fn values(luma: Option<Luma>, channels: usize) -> usize {
        if luma.is_some() {
            1
        } else {
            channels
        }
    }
}

/// A view's row `from` in unit intensity into `to` ([`Sample::to_unit`]): its samples as
/// they are, or with `luma` one value per pixel, the mean of its colour channels (the
/// same bits wherever a row is converted).
pub(super) fn unit_row<S: Sample>(from: &[S], to: &mut [f32], luma: Option<Luma>) {
    match luma {
        None => {
            for (t, s) in to.iter_mut().zip(from) {
                *t = s.to_unit();
            }
        }
        // The usual channel counts as literals: `luma_row` is inlined, so the pixel's
        // width is known to the compiler and the loop over its channels unrolls (the
        // loop with a run-time width costs more instructions than the one-channel
        // matching it feeds, docs/stages/sweep.md).
        Some(Luma { channels: 3 }) => luma_row(from, to, 3),
        Some(Luma { channels: 4 }) => luma_row(from, to, 4),
        Some(Luma { channels }) => luma_row(from, to, channels),
    }
}

/// [`unit_row`]'s luminance for pixels of `channels` interleaved samples.
#[inline(always)]
fn luma_row<S: Sample>(from: &[S], to: &mut [f32], channels: usize) {
    let used = channels.min(3);
    let scale = mean_scale::<S>(used);
    for (t, px) in to.iter_mut().zip(from.chunks_exact(channels.max(1))) {
        *t = pixel_mean(px.get(..used).unwrap_or(px), scale);
    }
}

/// What [`pixel_mean`] multiplies the sum of `used` samples by: `1/used`, and for 8-bit
/// levels, summed as they are, `1/255` as well.
fn mean_scale<S: Sample>(used: usize) -> f32 {
    let used = used.max(1) as f32;
    if S::IS_U8 {
        1.0 / (255.0 * used)
    } else {
        1.0 / used
    }
}

/// The mean of a pixel's colour `channels` in unit intensity (`scale` from
/// [`mean_scale`]): 8-bit levels summed as integers (exact) and scaled once, other
/// samples summed in unit intensity in channel order.
#[inline(always)]
fn pixel_mean<S: Sample>(channels: &[S], scale: f32) -> f32 {
    if S::IS_U8 {
        let sum = channels.iter().fold(0u32, |a, s| a + u32::from(s.level()));
        sum as f32 * scale
    } else {
        channels.iter().fold(0.0f32, |a, s| a + s.to_unit()) * scale
    }
}
