//! The band estimator: one direction's line estimator bound to a light field, and the
//! public entry that estimates a run of lines of one direction ([`estimate_band`]).

use core::ops::Range;

use super::half;
use super::load::{load_levels, load_line, mix_chroma, Chroma, Levels, LineSpan};
use super::{check_layout, ColorMode, Direction, EpiParams, Hypotheses, LineEstimator};
use crate::error::{check_scratch, Error, Result};
use crate::float::clamp_f32;
use crate::lightfield::{LightField, Sample};
use crate::scalar::Scalar;
use crate::setup::{DisparityOut, Setup};

/// Disparity and confidence of the lines `lines` of `direction` into `out`, written line
/// after line (`(line − lines.start) · line_len + t`): for [`Direction::Vertical`] that is
/// the transpose of the image layout. `scratch` needs [`band_scratch_len`](super::band_scratch_len) elements.
pub fn estimate_band<T: Scalar, S: Sample>(
    setup: Setup<'_, EpiParams>,
    hypotheses: &Hypotheses,
    lf: &LightField<'_, S>,
    direction: Direction,
    lines: Range<usize>,
    out: DisparityOut<'_>,
    scratch: &mut [T],
) -> Result<()> {
    let DisparityOut {
        disparity,
        confidence,
    } = out;
    check_layout(setup, lf)?;
    let total = half::lines(setup, direction);
    if lines.start > lines.end || lines.end > total {
        return Err(Error::OutOfRange {
            what: "band end line",
            index: lines.end,
            len: total,
        });
    }
    let n = half::line_len(setup, direction);
    let needed = lines.len() * n;
    if disparity.len() != needed || confidence.len() != needed {
        return Err(Error::OutputSize {
            what: "the band disparity/confidence",
            needed,
            got: disparity.len().min(confidence.len()),
        });
    }
    // At half resolution a disparity moves half as far per view, in half-size samples.
    let half = setup.params().half_resolution;
    let hypotheses = &if half {
        Hypotheses::new(
            setup.params(),
            0.5 * hypotheses.min(),
            0.5 * hypotheses.max(),
        )?
    } else {
        *hypotheses
    };
    let band = BandEstimator::new(setup, *hypotheses, lf, direction);
    let (d_line, c_line, work) = band.split_scratch(scratch)?;
    for (i, line) in lines.enumerate() {
        band.line(line, work, d_line, c_line)?;
        let out = i * n..(i + 1) * n;
        // Both outputs hold `lines.len() · n` values (checked above): the error never
        // happens; the checked form keeps the panic out of the firmware image.
        let (Some(d), Some(c)) = (disparity.get_mut(out.clone()), confidence.get_mut(out)) else {
            return Err(Error::OutputSize {
                what: "the band disparity/confidence",
                needed,
                got: disparity.len().min(confidence.len()),
            });
        };
        write_line(hypotheses, d_line, c_line, d, c);
        if half {
            // Back to full-resolution px (a power of two: exact).
            d.iter_mut().for_each(|v| *v *= 2.0);
        }
    }
    Ok(())
}

/// Converts one line to `f32`, clamped to the output range (fixed-point rounding of the
/// range ends must not step outside it).
pub(super) fn write_line<T: Scalar>(
    h: &Hypotheses,
    d: &[T],
    c: &[T],
    out_d: &mut [f32],
    out_c: &mut [f32],
) {
    let (lo, hi) = (h.min(), h.max());
    for ((o, &v), (oc, &w)) in out_d.iter_mut().zip(d).zip(out_c.iter_mut().zip(c)) {
        *o = clamp_f32(v.to_f32(), lo, hi);
        *oc = w.to_f32().clamp(0.0, 1.0);
    }
}

/// One direction's line estimator bound to a light field.
pub(crate) struct BandEstimator<'p, 'a, T: Scalar, S: Sample> {
    estimator: LineEstimator<T>,
    lf: &'p LightField<'a, S>,
    direction: Direction,
    pub(super) n: usize,
    /// Lines are read through a 2×2 box filter ([`EpiParams::half_resolution`]).
    half: bool,
    color: ColorMode,
    chroma: Chroma,
    /// The scaled intensity of every 8-bit level, when the samples are `u8` and the
    /// channels enter the tensor one by one (see [`Levels`]).
    levels: Option<Levels<T>>,
}

impl<'p, 'a, T: Scalar, S: Sample> BandEstimator<'p, 'a, T, S> {
    pub(crate) fn new(
        setup: Setup<'_, EpiParams>,
        hypotheses: Hypotheses,
        lf: &'p LightField<'a, S>,
        direction: Direction,
    ) -> Self {
        let (views, centre) = direction.views(setup.layout());
        let params = setup.params();
        BandEstimator {
            estimator: LineEstimator::new(
                params,
                hypotheses,
                views,
                centre,
                setup.layout().channels,
            ),
            lf,
            direction,
            n: half::line_len(setup, direction),
            half: params.half_resolution,
            color: params.color,
            chroma: Chroma::of(params),
            levels: match params.color {
                ColorMode::Tensor => Levels::new::<S>(),
                ColorMode::Gray => None,
            },
        }
    }

    /// Splits scratch into the line's disparity, confidence and work buffers.
    #[allow(clippy::type_complexity)]
    pub(crate) fn split_scratch<'s>(
        &self,
        scratch: &'s mut [T],
    ) -> Result<(&'s mut [T], &'s mut [T], &'s mut [T])> {
        let n = self.n;
        let needed = self.estimator.line_work_len(n) + 2 * n;
        check_scratch(needed, scratch.len())?;
        let too_small = Error::ScratchTooSmall {
            needed,
            got: scratch.len(),
        };
        let (d, rest) = scratch.split_at_mut_checked(n).ok_or(too_small)?;
        let (c, work) = rest.split_at_mut_checked(n).ok_or(too_small)?;
        Ok((d, c, work))
    }

    /// Estimates line `line` into `d` / `c` (length `n`, as `T`).
    pub(crate) fn line(&self, line: usize, work: &mut [T], d: &mut [T], c: &mut [T]) -> Result<()> {
        let layout = *self.lf.layout();
        let data = self.lf.data();
        let ch_n = layout.channels;
        let grid = layout.grid;
        let (r0, c0) = grid.center();
        let color = self.color;
        let chroma = self.chroma;
        let direction = self.direction;
        // Start of the line in view k, and the step between its samples.
        let locate = |k: usize| -> (usize, usize) {
            match direction {
                Direction::Horizontal => (
                    grid.index(r0, k) * layout.view_stride + line * layout.row_stride,
                    ch_n,
                ),
                Direction::Vertical => (
                    grid.index(k, c0) * layout.view_stride + line * ch_n,
                    layout.row_stride,
                ),
            }
        };
        let n = self.n;
        // All channels of a view in one pass over its pixels (a vertical line strides
        // through the image: one pass instead of one per channel).
        let levels = self.levels.as_ref();
        let half = self.half;
        // At half resolution, line `line` is full-resolution lines `2·line` and
        // `2·line + 1`, and a sample the mean of two pixels along each.
        let locate_half = |k: usize| -> (usize, usize, usize) {
            match direction {
                Direction::Horizontal => (
                    grid.index(r0, k) * layout.view_stride + 2 * line * layout.row_stride,
                    ch_n,
                    layout.row_stride,
                ),
                Direction::Vertical => (
                    grid.index(k, c0) * layout.view_stride + 2 * line * ch_n,
                    layout.row_stride,
                    ch_n,
                ),
            }
        };
        let load = |k: usize, out: &mut [T]| -> Result<()> {
            if half {
                let (start, step, across) = locate_half(k);
                return half::load_half_line(
                    data,
                    "the light-field buffer",
                    LineSpan {
                        start,
                        step,
                        channels: ch_n,
                        n,
                    },
                    across,
                    color,
                    out,
                );
            }
            let (start, step) = locate(k);
            match levels {
                Some(levels) if ch_n >= 3 => load_levels(
                    data,
                    "the light-field buffer",
                    LineSpan {
                        start,
                        step,
                        channels: ch_n,
                        n,
                    },
                    levels,
                    out,
                ),
                _ => load_line(
                    data,
                    "the light-field buffer",
                    LineSpan {
                        start,
                        step,
                        channels: ch_n,
                        n,
                    },
                    color,
                    out,
                ),
            }?;
            mix_chroma(color, ch_n, chroma, n, out);
            Ok(())
        };
        self.estimator.estimate(n, load, work, d, c)
    }
}
