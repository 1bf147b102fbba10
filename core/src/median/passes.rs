//! Every pass of the weighted median over one band of rows, from the map before the
//! first pass: the one median path of every driver (the whole map is one band).
//!
//! A pixel's value after one pass depends only on the input within `radius + 1` rows of
//! it, so pass `k` of `n` filters the band's rows grown by `(n − 1 − k) · (radius + 1)`
//! on each side (clipped to the image), and bands are independent: no map travels
//! between passes, and the result is the same for any banding.

use core::ops::Range;

use crate::error::{Error, Result};
use crate::lightfield::{Sample, View};
use crate::setup::Setup;

use super::{MedianParams, PassInput};

/// Map scratch (`f32` elements) of [`filter_band`]: three maps (the pass's input, the
/// previous pass's input and the output) and the filter's own [`super::scratch_len`].
pub fn band_scratch_len(setup: Setup<'_, MedianParams>) -> usize {
    setup
        .pixels()
        .saturating_mul(3)
        .saturating_add(super::scratch_len(setup))
}

/// Pixels (rows and columns) on each side that every pass together reads beyond a pixel:
/// `passes · (radius + 1)`, 0 when the stage is off. A region computed on its pixels plus
/// this halo (clipped at the image) gives the whole map's values, bit for bit.
pub fn halo(setup: Setup<'_, MedianParams>) -> usize {
    let params = setup.params();
    if params.enabled {
        params
            .passes
            .saturating_mul(params.radius.saturating_add(1))
    } else {
        0
    }
}

/// Every pass of the median over image rows `rows` of `input` (row-major, the map
/// before the first pass) into `out` (`rows.len() · width`, row-major). `maps` needs
/// [`band_scratch_len`] elements. `settled` is empty, or one byte per pixel of the map:
/// each pass then remembers which pixels its decision settled, and the next skips them
/// while their rows keep their values (faster, the same result; `super::filter_pass`).
pub fn filter_band<S: Sample>(
    setup: Setup<'_, MedianParams>,
    guide: &View<'_, S>,
    input: &[f32],
    rows: Range<usize>,
    out: &mut [f32],
    maps: &mut [f32],
    settled: &mut [u8],
) -> Result<()> {
    let layout = setup.layout();
    let (width, height) = (layout.width, layout.height);
    let pixels = setup.pixels();
    if rows.start > rows.end || rows.end > height {
        return Err(Error::OutOfRange {
            what: "median band end row",
            index: rows.end,
            len: height,
        });
    }
    let band = rows.start * width..rows.end * width;
    if input.len() != pixels || out.len() != band.len() {
        return Err(Error::OutputSize {
            what: "the median band",
            needed: band.len(),
            got: out.len(),
        });
    }
    let params = *setup.params();
    let passes = if params.enabled { params.passes } else { 0 };
    if passes == 0 {
        return copy(out, input.get(band));
    }
    let needed = band_scratch_len(setup);
    let too_small = Error::ScratchTooSmall {
        needed,
        got: maps.len(),
    };
    let (mut current, rest) = maps.split_at_mut_checked(pixels).ok_or(too_small)?;
    let (mut before, rest) = rest.split_at_mut_checked(pixels).ok_or(too_small)?;
    let (mut next, scratch) = rest.split_at_mut_checked(pixels).ok_or(too_small)?;
    let remember = !settled.is_empty();
    if remember && settled.len() != pixels {
        return Err(Error::OutputSize {
            what: "the median's settled pixels (one byte per pixel of the map)",
            needed: pixels,
            got: settled.len(),
        });
    }
    let reach = params.radius + 1;
    // Only the rows a later pass reads are ever written: pass k's rows lie within pass
    // k − 1's, grown by the reach of one pass, so no pass reads a row it did not fill.
    // The first pass reads the input one reach beyond its own rows: those are copied too
    // (a band that ends inside the map would otherwise read rows of the scratch).
    let first = rows.start.saturating_sub(passes * reach) * width;
    let last = ((rows.end + passes * reach).min(height)) * width;
    copy(
        current.get_mut(first..last).unwrap_or(&mut []),
        input.get(first..last),
    )?;
    for pass in 0..passes {
        let grow = (passes - 1 - pass) * reach;
        let pass_rows = rows.start.saturating_sub(grow)..(rows.end + grow).min(height);
        let span = pass_rows.start * width..pass_rows.end * width;
        let previous = (pass > 0).then_some(&*before);
        let flags = if remember {
            settled.get_mut(span.clone())
        } else {
            None
        };
        let out = next.get_mut(span).ok_or(too_small)?;
        let reads = PassInput {
            guide,
            input: current,
            previous,
        };
        super::run(setup, reads, pass_rows, out, flags, scratch)?;
        // next → current → before; the oldest map receives the next pass.
        core::mem::swap(&mut before, &mut current);
        core::mem::swap(&mut current, &mut next);
    }
    copy(out, current.get(band))
}

/// Copies `from` into `to` (the same length, else an error): without `copy_from_slice`'s
/// panic path, which the firmware's panic-free link refuses.
fn copy(to: &mut [f32], from: Option<&[f32]>) -> Result<()> {
    match from {
        Some(from) if from.len() == to.len() => {
            for (t, f) in to.iter_mut().zip(from) {
                *t = *f;
            }
            Ok(())
        }
        _ => Err(Error::OutputSize {
            what: "the median band",
            needed: to.len(),
            got: from.map_or(0, <[f32]>::len),
        }),
    }
}
