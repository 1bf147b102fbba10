//! The EPI stage at half resolution ([`EpiParams::half_resolution`]): every view is read
//! through a 2×2 box filter, so a line holds half the samples, there are half the lines,
//! and a disparity of `d` px moves `d/2` half-resolution px per view: a quarter of the
//! samples over half the shear hypotheses. The half-resolution map goes back to full
//! resolution through [`super::upsample`].

use super::{ColorMode, Direction, EpiParams, LineSpan, INTENSITY_SCALE};
use crate::error::{Error, Result};
use crate::lightfield::Sample;
use crate::scalar::Scalar;
use crate::setup::Setup;

/// Width and height of the EPI stage's maps: the layout's, or half of each (rounded
/// down: an odd last row or column is left to the upsampling) at half resolution.
pub fn map_size(setup: Setup<'_, EpiParams>) -> (usize, usize) {
    let layout = setup.layout();
    if setup.params().half_resolution {
        (layout.width / 2, layout.height / 2)
    } else {
        (layout.width, layout.height)
    }
}

/// Lines of `direction` the EPI stage estimates ([`map_size`]).
pub fn lines(setup: Setup<'_, EpiParams>, direction: Direction) -> usize {
    let (width, height) = map_size(setup);
    match direction {
        Direction::Horizontal => height,
        Direction::Vertical => width,
    }
}

/// Samples per line of `direction` ([`map_size`]).
pub fn line_len(setup: Setup<'_, EpiParams>, direction: Direction) -> usize {
    let (width, height) = map_size(setup);
    match direction {
        Direction::Horizontal => width,
        Direction::Vertical => height,
    }
}

/// Loads one half-resolution EPI line of `span.n` samples: sample `t` is the mean of the
/// four pixels starting at `data[span.start + 2t·span.step]`, `+ span.step` (the next pixel
/// along the line) and `+ across` (the next line), each `span.channels` samples; the planes
/// as [`super::load_line`] writes them, intensities scaled by [`INTENSITY_SCALE`].
/// `BufferTooSmall` naming `what` when `data` ends before the last pixel.
pub(super) fn load_half_line<T: Scalar, S: Sample>(
    data: &[S],
    what: &'static str,
    span: LineSpan,
    across: usize,
    color: ColorMode,
    out: &mut [T],
) -> Result<()> {
    let LineSpan {
        start,
        step,
        channels,
        n,
    } = span;
    let step = step.max(1);
    let pair = step.saturating_mul(2);
    // The pixels `2t` of the line (and `2t + 1`, `step` further) from `start`, and the
    // same of the next line from `start + across`: `n` chunks of `pair` elements each
    // (the last one `step + channels`).
    let span = |from: usize| -> Result<&[S]> {
        let end = n
            .saturating_sub(1)
            .checked_mul(pair)
            .and_then(|last| last.checked_add(from))
            .and_then(|last| last.checked_add(step))
            .and_then(|last| last.checked_add(channels))
            .unwrap_or(usize::MAX);
        data.get(from..end).ok_or(Error::BufferTooSmall {
            what,
            needed: end,
            got: data.len(),
        })
    };
    let first = span(start)?;
    let second = span(start.saturating_add(across))?;
    let used = channels.min(3);
    let quads = first
        .chunks(pair)
        .zip(second.chunks(pair))
        .take(n)
        .map(|(a, b)| {
            (
                a,
                a.get(step..).unwrap_or(&[]),
                b,
                b.get(step..).unwrap_or(&[]),
            )
        });
    // The sum of channel `c` of the 2×2 pixels (each slice starts at one of them).
    let sum = |(a, a1, b, b1): (&[S], &[S], &[S], &[S]), c: usize| -> f32 {
        let get = |px: &[S]| px.get(c).map_or(0.0, |s| s.to_unit());
        (get(a) + get(a1)) + (get(b) + get(b1))
    };
    match color {
        ColorMode::Tensor => {
            let scale = 0.25 * INTENSITY_SCALE;
            let (p0, rest) = out.split_at_mut(n.min(out.len()));
            let (p1, p2) = rest.split_at_mut(n.min(rest.len()));
            if used == 3 {
                for (((o0, o1), o2), q) in p0.iter_mut().zip(p1.iter_mut()).zip(p2).zip(quads) {
                    *o0 = T::from_f32(sum(q, 0) * scale);
                    *o1 = T::from_f32(sum(q, 1) * scale);
                    *o2 = T::from_f32(sum(q, 2) * scale);
                }
            } else {
                for (o0, q) in p0.iter_mut().zip(quads) {
                    *o0 = T::from_f32(sum(q, 0) * scale);
                }
            }
        }
        ColorMode::Gray => {
            let scale = 0.25 * INTENSITY_SCALE / used as f32;
            for (o, q) in out.iter_mut().zip(quads) {
                let total: f32 = (0..used).map(|c| sum(q, c)).sum();
                *o = T::from_f32(total * scale);
            }
        }
    }
    Ok(())
}
