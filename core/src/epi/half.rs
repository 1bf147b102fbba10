//! The EPI stage at half resolution ([`EpiParams::half_resolution`]): every view is read
//! through a 2×2 box filter, so a line holds half the samples, there are half the lines,
//! and a disparity of `d` px moves `d/2` half-resolution px per view: a quarter of the
//! samples over half the shear hypotheses. The half-resolution map goes back to full
//! resolution through [`super::upsample`].

use super::{ColorMode, Direction, EpiParams, INTENSITY_SCALE};
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

/// Loads one half-resolution EPI line of `n` samples: sample `t` is the mean of the four
/// pixels starting at `data[start + 2t·step]`, `+ step` (the next pixel along the line)
/// and `+ across` (the next line), each `channels` samples; the planes as [`super::load_line`]
/// writes them, intensities scaled by [`INTENSITY_SCALE`]. `BufferTooSmall` naming `what`
/// when `data` ends before the last pixel.
#[allow(clippy::too_many_arguments)]
pub(super) fn load_half_line<T: Scalar, S: Sample>(
    data: &[S],
    what: &'static str,
    start: usize,
    step: usize,
    across: usize,
    channels: usize,
    n: usize,
    color: ColorMode,
    out: &mut [T],
) -> Result<()> {
    let step = step.max(1);
    let pair = step.saturating_mul(2);
    let end = n
        .saturating_sub(1)
        .checked_mul(pair)
        .and_then(|span| span.checked_add(start))
        .and_then(|last| last.checked_add(step))
        .and_then(|last| last.checked_add(across))
        .and_then(|last| last.checked_add(channels))
        .unwrap_or(usize::MAX);
    let src = data.get(start..end).ok_or(Error::BufferTooSmall {
        what,
        needed: end,
        got: data.len(),
    })?;
    let used = channels.min(3);
    // The mean of one channel of the 2×2 pixels at `at` (within `src`, checked above).
    let mean = |at: usize, c: usize| -> f32 {
        let get = |i: usize| src.get(i + c).map_or(0.0, |s| s.to_unit());
        (get(at) + get(at + step)) + (get(at + across) + get(at + across + step))
    };
    match color {
        ColorMode::Tensor => {
            let scale = 0.25 * INTENSITY_SCALE;
            for c in 0..used {
                let Some(plane) = out.get_mut(c * n..(c + 1) * n) else {
                    break;
                };
                for (t, o) in plane.iter_mut().enumerate() {
                    *o = T::from_f32(mean(t * pair, c) * scale);
                }
            }
        }
        ColorMode::Gray => {
            let scale = 0.25 * INTENSITY_SCALE / used as f32;
            for (t, o) in out.iter_mut().take(n).enumerate() {
                let sum: f32 = (0..used).map(|c| mean(t * pair, c)).sum();
                *o = T::from_f32(sum * scale);
            }
        }
    }
    Ok(())
}
