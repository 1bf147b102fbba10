//! Loading one EPI line from a buffer of samples into the planes the line estimator
//! reads: the sample conversion, the `u8` level table and the colour weight. Shared by
//! the band estimator and the firmware stream, whose results must agree bit for bit.

use super::{ColorMode, EpiParams, INTENSITY_SCALE};
use crate::error::{Error, Result};
use crate::lightfield::Sample;
use crate::scalar::Scalar;

/// The kernels' input of every 8-bit level, `T::from_f32(level.to_unit() · INTENSITY_SCALE)`:
/// loading a `u8` sample becomes one table look-up, bit-identical to the conversion.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Levels<T>([T; 256]);

impl<T: Scalar> Levels<T> {
    /// The table for samples of type `S` (`None` unless `S` is `u8`, whose `level()` is
    /// the sample itself).
    pub(super) fn new<S: Sample>() -> Option<Self> {
        if !S::IS_U8 {
            return None;
        }
        let mut table = [T::ZERO; 256];
        for (level, v) in (0..=u8::MAX).zip(table.iter_mut()) {
            *v = T::from_f32(level.to_unit() * INTENSITY_SCALE);
        }
        Some(Levels(table))
    }
}

/// Where one EPI line lies in a buffer of samples: pixel `t` of `n` starts at
/// `start + t·step` and holds `channels` samples.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LineSpan {
    pub(crate) start: usize,
    pub(crate) step: usize,
    pub(crate) channels: usize,
    pub(crate) n: usize,
}

impl LineSpan {
    /// The elements of `data` that the line's pixels occupy; `BufferTooSmall` naming
    /// `what` when `data` ends before them.
    fn elements<'d, S>(self, data: &'d [S], what: &'static str) -> Result<&'d [S]> {
        let LineSpan {
            start,
            step,
            channels,
            n,
        } = self;
        let end = n
            .saturating_sub(1)
            .checked_mul(step)
            .and_then(|span| span.checked_add(start))
            .and_then(|last| last.checked_add(channels))
            .unwrap_or(usize::MAX);
        data.get(start..end).ok_or(Error::BufferTooSmall {
            what,
            needed: end,
            got: data.len(),
        })
    }
}

/// Loads one EPI line (`line` of `data`) as the line estimator reads it.
/// [`ColorMode::Tensor`] writes the first (at most 3) channels as planes of `n` one
/// after the other, [`ColorMode::Gray`] their mean as one plane; intensities scaled by
/// [`INTENSITY_SCALE`]. Shared by the band estimator and the firmware stream, whose
/// results must agree bit for bit. `what` names `data` in the error when the line runs
/// past its end.
pub(crate) fn load_line<T: Scalar, S: Sample>(
    data: &[S],
    what: &'static str,
    line: LineSpan,
    color: ColorMode,
    out: &mut [T],
) -> Result<()> {
    // Every pixel starts `step ≥ channels ≥ 1` elements after the previous one.
    let step = line.step.max(1);
    let (channels, n) = (line.channels, line.n);
    let src = LineSpan { step, ..line }.elements(data, what)?;
    let pixels = src.chunks(step).take(n);
    let used = channels.min(3);
    match color {
        ColorMode::Tensor => {
            let scale = INTENSITY_SCALE;
            let (first, rest) = out.split_at_mut(n.min(out.len()));
            let (second, third) = rest.split_at_mut(n.min(rest.len()));
            match used {
                3 => {
                    for (((o0, o1), o2), px) in first
                        .iter_mut()
                        .zip(second.iter_mut())
                        .zip(third.iter_mut())
                        .zip(pixels)
                    {
                        if let [r, g, b, ..] = *px {
                            *o0 = T::from_f32(r.to_unit() * scale);
                            *o1 = T::from_f32(g.to_unit() * scale);
                            *o2 = T::from_f32(b.to_unit() * scale);
                        }
                    }
                }
                _ => {
                    for (t, px) in pixels.enumerate() {
                        for (c, &v) in px.iter().take(used).enumerate() {
                            if let Some(o) = out.get_mut(c * n + t) {
                                *o = T::from_f32(v.to_unit() * scale);
                            }
                        }
                    }
                }
            }
        }
        ColorMode::Gray => {
            let scale = INTENSITY_SCALE / used as f32;
            for (o, px) in out.iter_mut().zip(pixels) {
                let sum: f32 = px.iter().take(used).map(|s| s.to_unit()).sum();
                *o = T::from_f32(sum * scale);
            }
        }
    }
    Ok(())
}

/// How [`mix_chroma`] weighs the channels' differences from their mean
/// ([`EpiParams::chroma`], [`EpiParams::chroma_knee`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Chroma {
    /// The weight of weak colour.
    pub(crate) keep: f32,
    /// The knee, a saturation.
    pub(crate) knee: f32,
}

impl Chroma {
    pub(crate) fn of(params: &EpiParams) -> Self {
        Chroma {
            keep: params.chroma,
            knee: params.chroma_knee,
        }
    }
}

/// Scales each channel's difference from the channels' mean in a line [`load_line`]
/// wrote in [`ColorMode::Tensor`] from at least three channels (planes of `n` one after
/// the other): `mean + w·(channel − mean)`, `w = keep + (1 − keep)·q/(q + knee²·mean²)`
/// with `q` the sum of the squared differences (`w = keep` when the knee is 0). The mean, and
/// so the coarse search's gray plane, stays the same; `keep` 1 leaves the line alone.
/// Shared by the band estimator and the firmware stream.
pub(crate) fn mix_chroma<T: Scalar>(
    color: ColorMode,
    channels: usize,
    chroma: Chroma,
    n: usize,
    out: &mut [T],
) {
    if color != ColorMode::Tensor || channels < 3 || chroma.keep >= 1.0 {
        return;
    }
    let third = T::from_f32(1.0 / 3.0);
    let keep = T::from_f32(chroma.keep);
    let rest_weight = T::from_f32(1.0 - chroma.keep);
    let knee2 = T::from_f32(chroma.knee * chroma.knee);
    let shrink = chroma.knee > 0.0;
    let (first, rest) = out.split_at_mut(n.min(out.len()));
    let (second, rest) = rest.split_at_mut(n.min(rest.len()));
    let third_plane = rest.get_mut(..n).unwrap_or(&mut []);
    for ((a, b), c) in first
        .iter_mut()
        .zip(second.iter_mut())
        .zip(third_plane.iter_mut())
    {
        let mean = (*a + *b + *c) * third;
        let (da, db, dc) = (*a - mean, *b - mean, *c - mean);
        let w = if shrink {
            let q = da * da + db * db + dc * dc;
            let den = q + knee2 * (mean * mean);
            if den > T::ZERO {
                keep + rest_weight * (q / den)
            } else {
                keep
            }
        } else {
            keep
        };
        *a = mean + w * da;
        *b = mean + w * db;
        *c = mean + w * dc;
    }
}

/// [`load_line`] of the first three channels in [`ColorMode::Tensor`] (`channels ≥ 3`)
/// through the level table of `u8` samples: the same values. Horizontal lines (`step ==
/// channels`) read their pixels as contiguous chunks.
pub(super) fn load_levels<T: Scalar, S: Sample>(
    data: &[S],
    what: &'static str,
    line: LineSpan,
    levels: &Levels<T>,
    out: &mut [T],
) -> Result<()> {
    let (channels, n) = (line.channels, line.n);
    let step = line.step.max(channels).max(1);
    let src = LineSpan { step, ..line }.elements(data, what)?;
    let (first, rest) = out.split_at_mut(n.min(out.len()));
    let (second, third) = rest.split_at_mut(n.min(rest.len()));
    let table = &levels.0;
    let planes = first
        .iter_mut()
        .zip(second.iter_mut())
        .zip(third.iter_mut());
    let put = |((o0, o1), o2): ((&mut T, &mut T), &mut T), px: &[S]| {
        if let [r, g, b, ..] = *px {
            *o0 = table[usize::from(r.level())];
            *o1 = table[usize::from(g.level())];
            *o2 = table[usize::from(b.level())];
        }
    };
    if step == channels {
        for (o, px) in planes.zip(src.chunks_exact(step)) {
            put(o, px);
        }
        // `src` ends `channels` after the last pixel's start: the last chunk is whole.
    } else {
        for (o, px) in planes.zip(src.chunks(step)) {
            put(o, px);
        }
    }
    Ok(())
}
