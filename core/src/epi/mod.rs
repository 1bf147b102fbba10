//! Initial disparity from epipolar-plane images (structure tensor, Wanner & Goldluecke),
//! over shear hypotheses so that any disparity in −8…8 px is measured at a small slope.
//!
//! The stage works line by line: a horizontal EPI line is one image row of the centre
//! view (views of the centre camera row), a vertical EPI line is one image column (views
//! of the centre camera column). Lines are independent, so a band is any run of lines and
//! the result never depends on how lines are grouped or threaded. Scratch covers one line.
//! The two directions are fused per pixel with [`fuse`]. A linear array (one row or one
//! column of cameras) has one direction only ([`Direction::exists`]): its estimate is
//! that direction's, with nothing to fuse.

mod band;
mod half;
mod hypotheses;
mod kernels;
mod line;
mod planes;
mod range;
mod upsample;

pub use half::{line_len, lines, map_size};
pub use hypotheses::{Hypotheses, MAX_DISPARITY, MAX_HYPOTHESES};
pub use range::{estimate_range, RANGE_LINE_STEP};
pub use upsample::{upsample_rows, upsample_scratch_len, UPSAMPLE_SIGMA};

use core::ops::{ControlFlow, Range};

use crate::error::{check_scratch, Error, Result};
use crate::float::clamp_f32;
use crate::lightfield::{Layout, LightField, Sample};
use crate::progress::Progress;
use crate::scalar::Scalar;
use crate::setup::{DisparityOut, Setup, StageParams};
// The firmware stream runs lines over its own band buffers.
pub(crate) use line::LineEstimator;

/// Intensities enter the kernels as `sample · INTENSITY_SCALE`: it keeps the tensor of
/// faint textures well above the Q16.16 resolution without overflowing it.
/// 64 rather than 16 (a power of two: `f32` results are bit-identical): on weak texture
/// (HCI cotton) the trace at 16 kept too few bits, and Q16.16 agreed with `f32` within
/// 0.02 px on 96.3 % of pixels, at 64 on 99.8 %; the largest trace is then 142 on the HCI
/// scenes and 1661 on binary 0/255 noise, far below 32768 (docs/stages/fixed-point.md).
/// 128 (four times those traces, below 2^15 on 9-view EPIs by the bound in
/// docs/stages/fixed-point.md; Q16 saturates, never wraps, beyond):
/// the Q16.16 EPI map agrees on 99.86 % of cotton, where 64 gave 99.70 %.
pub const INTENSITY_SCALE: f32 = 128.0;

/// Where the disparity range comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DisparityRange {
    /// Estimated from the light field by [`estimate_range`].
    Auto,
    /// Given by the user (px between adjacent views).
    Fixed {
        /// Smallest disparity.
        min: f32,
        /// Largest disparity.
        max: f32,
    },
}

/// How the horizontal and vertical estimates of a pixel are combined.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fusion {
    /// Keep the estimate with the higher confidence (the paper's rule).
    Coherence,
    /// Confidence-weighted mean when both agree within 0.1 px, else the more confident.
    Weighted,
}

/// How colour channels enter the tensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorMode {
    /// One tensor summed over the R, G, B channels.
    Tensor,
    /// Mean of the channels first (a third of the work).
    Gray,
}

/// Which shear hypotheses each sample is tested at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Search {
    /// Every hypothesis of the range.
    Exhaustive,
    /// A gray pass at four times the shear step (at most 2 px) estimates every sample
    /// first; then only the hypotheses within `(1 + margin)·shear_step` of that estimate
    /// are tested in full colour: the two that bracket it, and a neighbour when it lies
    /// within `margin` steps of one of them; an estimate within 0.15 steps of a hypothesis
    /// is tested at that one only (and those within `0.5 + margin` steps). A coherent
    /// sample whose fine residual at the lower of two such hypotheses puts it less than
    /// half a step above that one keeps that estimate and skips the upper one. Samples the
    /// gray pass cannot place inside a window are tested at every hypothesis.
    CoarseToFine {
        /// Extra reach, in shear steps, 0…2.
        margin: f32,
    },
}

/// The two EPI directions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Image rows, views of the centre camera row.
    Horizontal,
    /// Image columns, views of the centre camera column.
    Vertical,
}

/// Parameters of the EPI stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EpiParams {
    /// Gaussian pre-smoothing along the line (px), 0…4.
    pub inner_sigma: f32,
    /// Gaussian smoothing of the tensor along the line and across views, 0…5.
    pub outer_sigma: f32,
    /// The disparity range (outputs never leave it).
    pub range: DisparityRange,
    /// Shear the EPIs over the range (off: the paper's single unsheared EPI).
    pub shear: bool,
    /// Distance between shear hypotheses (px), 0.1…2.
    pub shear_step: f32,
    /// Largest residual slope a hypothesis accepts, in units of `shear_step`, 0.5…2.
    pub window: f32,
    /// Between adjacent shears, take the zero crossing of the residual slope (off: the
    /// single most coherent hypothesis, as in the reference).
    pub interpolate: bool,
    /// Fusion of the two directions.
    pub fusion: Fusion,
    /// Colour handling.
    pub color: ColorMode,
    /// [`ColorMode::Tensor`]: weight of each channel's difference from the channels' mean,
    /// 0…1. The R, G, B tensor is `3·J(mean) + Σ J(channel − mean)`; the channels enter
    /// as `mean + chroma·(channel − mean)`, so the tensor becomes `3·J(mean) +
    /// chroma²·Σ J(channel − mean)`: 1 the plain sum over R, G, B, smaller values keep
    /// edges of colour alone but less of the noise of each channel ([`mix_chroma`]).
    pub chroma: f32,
    /// Saturation (chroma relative to the channels' mean, 0…1) above which a sample
    /// keeps its channels' differences whole: the weight is `chroma + (1 −
    /// chroma)·q/(q + knee²·mean²)`, `q` the sum of the squared differences, so
    /// saturated colour (and its edges) keeps its full weight at any brightness and only
    /// pale colour, where dim pixels' channel noise dominates it, is scaled by `chroma`.
    /// 0: every sample is scaled by `chroma`.
    pub chroma_knee: f32,
    /// Which hypotheses each sample is tested at.
    pub search: Search,
    /// Estimate on views box-filtered 2× (a quarter of the samples, half the shears),
    /// then upsample the map guided by the centre view's colour ([`upsample_rows`]).
    pub half_resolution: bool,
}

impl Default for EpiParams {
    fn default() -> Self {
        EpiParams {
            // Chosen on the HCI scenes (docs/stages/epi.md): less inner smoothing keeps fine
            // texture, more outer smoothing steadies weakly textured surfaces, and half-pixel
            // shears keep residual slopes small.
            inner_sigma: 0.5,
            outer_sigma: 2.0,
            range: DisparityRange::Auto,
            shear: true,
            shear_step: 0.5,
            window: 1.0,
            interpolate: true,
            fusion: Fusion::Coherence,
            color: ColorMode::Tensor,
            chroma: 1.0,
            chroma_knee: 0.0,
            search: Search::CoarseToFine { margin: 0.0 },
            half_resolution: false,
        }
    }
}

impl StageParams for EpiParams {
    fn validate(&self) -> Result<()> {
        EpiParams::validate(self)
    }
}

impl EpiParams {
    /// The paper's variant: one unsheared EPI per direction, the usual scales (0.8, 1.5),
    /// coherence fusion.
    pub fn paper() -> Self {
        EpiParams {
            inner_sigma: 0.8,
            outer_sigma: 1.5,
            shear: false,
            chroma: 1.0,
            chroma_knee: 0.0,
            range: DisparityRange::Fixed {
                min: -MAX_DISPARITY,
                max: MAX_DISPARITY,
            },
            ..Self::default()
        }
    }

    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        let within = |v: f32, lo: f32, hi: f32| v.is_finite() && v >= lo && v <= hi;
        if !within(self.inner_sigma, 0.0, 4.0) {
            return Err(Error::InvalidParameter {
                name: "inner_sigma",
                reason: "must be between 0 and 4 px",
            });
        }
        if !within(self.outer_sigma, 0.0, 5.0) {
            return Err(Error::InvalidParameter {
                name: "outer_sigma",
                reason: "must be between 0 and 5 px",
            });
        }
        if !within(self.shear_step, 0.1, 2.0) {
            return Err(Error::InvalidParameter {
                name: "shear_step",
                reason: "must be between 0.1 and 2 px",
            });
        }
        if !within(self.window, 0.5, 2.0) {
            return Err(Error::InvalidParameter {
                name: "window",
                reason: "must be between 0.5 and 2 shear steps",
            });
        }
        if !within(self.chroma, 0.0, 1.0) {
            return Err(Error::InvalidParameter {
                name: "chroma",
                reason: "must be between 0 and 1",
            });
        }
        if !within(self.chroma_knee, 0.0, 1.0) {
            return Err(Error::InvalidParameter {
                name: "chroma_knee",
                reason: "must be between 0 and 1 (unit intensity)",
            });
        }
        if let Search::CoarseToFine { margin } = self.search {
            if !within(margin, 0.0, 2.0) {
                return Err(Error::InvalidParameter {
                    name: "search margin",
                    reason: "must be between 0 and 2 shear steps",
                });
            }
        }
        if let DisparityRange::Fixed { min, max } = self.range {
            Hypotheses::new(self, min, max)?;
        }
        Ok(())
    }
}

impl Direction {
    /// The directions, horizontal first.
    pub const BOTH: [Direction; 2] = [Direction::Horizontal, Direction::Vertical];

    /// Whether the grid of `layout` has this direction's EPIs: more than one view along
    /// its camera axis (a row of cameras has no vertical EPIs, a column no horizontal).
    pub fn exists(&self, layout: &Layout) -> bool {
        match self {
            Direction::Horizontal => layout.grid.has_horizontal_parallax(),
            Direction::Vertical => layout.grid.has_vertical_parallax(),
        }
    }
    /// Number of lines (image rows or columns).
    pub fn lines(&self, layout: &Layout) -> usize {
        match self {
            Direction::Horizontal => layout.height,
            Direction::Vertical => layout.width,
        }
    }
    /// Samples per line.
    pub fn line_len(&self, layout: &Layout) -> usize {
        match self {
            Direction::Horizontal => layout.width,
            Direction::Vertical => layout.height,
        }
    }
    /// Views along the EPI and the centre one.
    fn views(&self, layout: &Layout) -> (usize, usize) {
        let g = layout.grid;
        let (r0, c0) = g.center();
        match self {
            Direction::Horizontal => (g.cols, c0),
            Direction::Vertical => (g.rows, r0),
        }
    }
}

fn used_channels(setup: Setup<'_, EpiParams>) -> usize {
    match setup.params().color {
        ColorMode::Gray => 1,
        ColorMode::Tensor => setup.layout().channels.min(3),
    }
}

/// Scratch (elements of `T`) one band of `direction` needs; independent of the band size.
pub fn band_scratch_len(setup: Setup<'_, EpiParams>, direction: Direction) -> usize {
    let (views, centre) = direction.views(setup.layout());
    let n = direction.line_len(setup.layout());
    LineEstimator::<f32>::work_len(setup.params(), views, centre, used_channels(setup), n) + 2 * n
}

/// Vertical lines the serial stage estimates before it fuses them into the row-major maps
/// (a tile of `VERTICAL_TILE` columns: each row of the maps is then read and written once
/// per tile instead of once per column, whose stride missed the cache on every pixel).
const VERTICAL_TILE: usize = 4;

/// Scratch (elements of `T`) of [`estimate`], [`estimate_band`] and [`estimate_range`]
/// (the serial stage's vertical tile included).
pub fn scratch_len(setup: Setup<'_, EpiParams>) -> usize {
    let tile = 2 * (VERTICAL_TILE - 1) * Direction::Vertical.line_len(setup.layout());
    band_scratch_len(setup, Direction::Horizontal)
        .max(band_scratch_len(setup, Direction::Vertical).saturating_add(tile))
}

fn check_layout<S: Sample>(setup: Setup<'_, EpiParams>, lf: &LightField<'_, S>) -> Result<()> {
    if lf.layout() != setup.layout() {
        return Err(Error::InvalidParameter {
            name: "plan",
            reason: "was made for a different light-field layout: build it from this light field",
        });
    }
    Ok(())
}

/// Disparity and confidence of the lines `lines` of `direction` into `out`, written line
/// after line (`(line − lines.start) · line_len + t`): for [`Direction::Vertical`] that is
/// the transpose of the image layout. `scratch` needs [`band_scratch_len`] elements.
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
fn write_line<T: Scalar>(h: &Hypotheses, d: &[T], c: &[T], out_d: &mut [f32], out_c: &mut [f32]) {
    let (lo, hi) = (h.min(), h.max());
    for ((o, &v), (oc, &w)) in out_d.iter_mut().zip(d).zip(out_c.iter_mut().zip(c)) {
        *o = clamp_f32(v.to_f32(), lo, hi);
        *oc = w.to_f32().clamp(0.0, 1.0);
    }
}

/// Combines the horizontal `(dh, ch)` and vertical `(dv, cv)` estimates of one pixel.
#[inline]
pub fn fuse(fusion: Fusion, dh: f32, ch: f32, dv: f32, cv: f32) -> (f32, f32) {
    match fusion {
        Fusion::Coherence => {
            if cv > ch {
                (dv, cv)
            } else {
                (dh, ch)
            }
        }
        Fusion::Weighted => {
            let sum = ch + cv;
            if libm::fabsf(dh - dv) <= 0.1 && sum > 0.0 {
                ((ch * dh + cv * dv) / sum, ch.max(cv))
            } else if cv > ch {
                (dv, cv)
            } else {
                (dh, ch)
            }
        }
    }
}

/// One direction's line estimator bound to a light field.
pub(crate) struct BandEstimator<'p, 'a, T: Scalar, S: Sample> {
    estimator: LineEstimator<T>,
    lf: &'p LightField<'a, S>,
    direction: Direction,
    n: usize,
    /// Lines are read through a 2×2 box filter ([`EpiParams::half_resolution`]).
    half: bool,
    color: ColorMode,
    chroma: Chroma,
    /// The scaled intensity of every 8-bit level, when the samples are `u8` and the
    /// channels enter the tensor one by one (see [`Levels`]).
    levels: Option<Levels<T>>,
}

/// The kernels' input of every 8-bit level, `T::from_f32(level.to_unit() · INTENSITY_SCALE)`:
/// loading a `u8` sample becomes one table look-up, bit-identical to the conversion.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Levels<T>([T; 256]);

impl<T: Scalar> Levels<T> {
    /// The table for samples of type `S` (`None` unless `S` is `u8`, whose `level()` is
    /// the sample itself).
    fn new<S: Sample>() -> Option<Self> {
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
fn load_levels<T: Scalar, S: Sample>(
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

/// Resolves the hypotheses of `setup`: the fixed range, or [`estimate_range`] for `Auto`.
pub fn hypotheses<T: Scalar, S: Sample>(
    setup: Setup<'_, EpiParams>,
    lf: &LightField<'_, S>,
    scratch: &mut [T],
) -> Result<Hypotheses> {
    let params = setup.params();
    match params.range {
        DisparityRange::Fixed { min, max } => Hypotheses::new(params, min, max),
        DisparityRange::Auto if !params.shear => {
            Hypotheses::new(params, -MAX_DISPARITY, MAX_DISPARITY)
        }
        DisparityRange::Auto => {
            let (min, max) = estimate_range(setup, lf, scratch)?;
            Hypotheses::new(params, min, max)
        }
    }
}

/// Lines per progress report.
const PROGRESS_LINES: usize = 32;

type ProgressFn<'f> = dyn FnMut(Progress) -> ControlFlow<()> + 'f;

fn report(
    progress: &mut ProgressFn<'_>,
    stage: &'static str,
    done: usize,
    total: usize,
) -> Result<()> {
    match progress(Progress {
        stage,
        done: done as u64,
        total: total as u64,
    }) {
        ControlFlow::Continue(()) => Ok(()),
        ControlFlow::Break(()) => Err(Error::Cancelled),
    }
}

/// The serial stage with progress: both directions over every line, fused into
/// `disparity` / `confidence` (row-major, `setup.pixels()` each); a linear array's one
/// direction alone. Returns the hypotheses.
pub(crate) fn estimate_with_progress<T: Scalar, S: Sample>(
    setup: Setup<'_, EpiParams>,
    lf: &LightField<'_, S>,
    disparity: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
    progress: &mut ProgressFn<'_>,
) -> Result<Hypotheses> {
    check_layout(setup, lf)?;
    if setup.params().half_resolution {
        return Err(Error::InvalidParameter {
            name: "half_resolution",
            reason:
                "runs through the schedule (its upsampling is a step of its own): use pipeline::run",
        });
    }
    let pixels = setup.pixels();
    if disparity.len() != pixels || confidence.len() != pixels {
        return Err(Error::OutputSize {
            what: "the disparity/confidence map",
            needed: pixels,
            got: disparity.len().min(confidence.len()),
        });
    }
    let needed = scratch_len(setup);
    check_scratch(needed, scratch.len())?;
    report(progress, STAGE_RANGE, 0, 1)?;
    let hyps = hypotheses(setup, lf, scratch)?;
    report(progress, STAGE_RANGE, 1, 1)?;
    let horizontal = Direction::Horizontal.exists(setup.layout());
    if horizontal {
        estimate_rows(setup, &hyps, lf, disparity, confidence, scratch, progress)?;
    }
    if Direction::Vertical.exists(setup.layout()) {
        let maps = (disparity, confidence);
        estimate_columns(setup, &hyps, lf, horizontal, maps, scratch, progress)?;
    }
    Ok(hyps)
}

/// The horizontal lines of [`estimate_with_progress`], written into the maps.
fn estimate_rows<T: Scalar, S: Sample>(
    setup: Setup<'_, EpiParams>,
    hyps: &Hypotheses,
    lf: &LightField<'_, S>,
    disparity: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
    progress: &mut ProgressFn<'_>,
) -> Result<()> {
    let width = setup.layout().width;
    let height = setup.layout().height;
    let band = BandEstimator::new(setup, *hyps, lf, Direction::Horizontal);
    let (d_line, c_line, work) = band.split_scratch(scratch)?;
    for y in 0..height {
        if y % PROGRESS_LINES == 0 {
            report(progress, STAGE_HORIZONTAL, y, height)?;
        }
        band.line(y, work, d_line, c_line)?;
        let row = y * width..(y + 1) * width;
        // Both maps hold `pixels` values (checked by the caller): the skip never happens.
        let (Some(out_d), Some(out_c)) = (disparity.get_mut(row.clone()), confidence.get_mut(row))
        else {
            continue;
        };
        write_line(hyps, d_line, c_line, out_d, out_c);
    }
    report(progress, STAGE_HORIZONTAL, height, height)
}

/// The vertical lines of [`estimate_with_progress`], fused into the maps' horizontal
/// estimate when `horizontal` (the grid has one), else written as they are.
fn estimate_columns<T: Scalar, S: Sample>(
    setup: Setup<'_, EpiParams>,
    hyps: &Hypotheses,
    lf: &LightField<'_, S>,
    horizontal: bool,
    (disparity, confidence): (&mut [f32], &mut [f32]),
    scratch: &mut [T],
    progress: &mut ProgressFn<'_>,
) -> Result<()> {
    let width = setup.layout().width;
    let height = setup.layout().height;
    let fusion = setup.params().fusion;
    // Vertical lines in tiles of `VERTICAL_TILE` columns (their disparity lines, then
    // their confidence lines, before the band's work), each tile fused row by row.
    let band = BandEstimator::new(setup, *hyps, lf, Direction::Vertical);
    let n = band.n;
    let tile_len = VERTICAL_TILE * n;
    let too_small = Error::ScratchTooSmall {
        needed: scratch_len(setup),
        got: scratch.len(),
    };
    let (tile_d, rest) = scratch.split_at_mut_checked(tile_len).ok_or(too_small)?;
    let (tile_c, work) = rest.split_at_mut_checked(tile_len).ok_or(too_small)?;
    let (lo, hi) = (hyps.min(), hyps.max());
    for x0 in (0..width).step_by(VERTICAL_TILE) {
        let columns = VERTICAL_TILE.min(width - x0);
        // Indexed slices, not zipped `chunks_exact_mut`: the zip's length (a division by
        // the chunk size) kept a panic path in the firmware image.
        let line_len = n.max(1);
        for g in 0..columns {
            let lines = g * line_len..(g + 1) * line_len;
            let (Some(d_line), Some(c_line)) =
                (tile_d.get_mut(lines.clone()), tile_c.get_mut(lines))
            else {
                break;
            };
            let x = x0 + g;
            if x % PROGRESS_LINES == 0 {
                report(progress, STAGE_VERTICAL, x, width)?;
            }
            band.line(x, work, d_line, c_line)?;
        }
        for y in 0..height {
            let row = y * width + x0..y * width + x0 + columns;
            // Both maps hold `pixels` values (checked by the caller): the skip never
            // happens.
            let (Some(out_d), Some(out_c)) =
                (disparity.get_mut(row.clone()), confidence.get_mut(row))
            else {
                continue;
            };
            for (g, (d, c)) in out_d.iter_mut().zip(out_c.iter_mut()).enumerate() {
                let (Some(&dv), Some(&cv)) = (tile_d.get(g * n + y), tile_c.get(g * n + y)) else {
                    continue;
                };
                let (dv, cv) = (clamp_f32(dv.to_f32(), lo, hi), cv.to_f32().clamp(0.0, 1.0));
                (*d, *c) = if horizontal {
                    fuse(fusion, *d, *c, dv, cv)
                } else {
                    (dv, cv)
                };
            }
        }
    }
    report(progress, STAGE_VERTICAL, width, width)
}

/// Progress stage names.
pub const STAGE_RANGE: &str = "epi range";
/// See [`STAGE_RANGE`].
pub const STAGE_HORIZONTAL: &str = "epi horizontal";
/// See [`STAGE_RANGE`].
pub const STAGE_VERTICAL: &str = "epi vertical";
/// See [`STAGE_RANGE`].
pub const STAGE_UPSAMPLE: &str = "epi upsample";

/// The serial stage: disparity and confidence of the centre view (row-major, `f32`,
/// `setup.pixels()` each), computed in `T`. `scratch` needs [`scratch_len`] elements.
pub fn estimate<T: Scalar, S: Sample>(
    setup: Setup<'_, EpiParams>,
    lf: &LightField<'_, S>,
    disparity: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
) -> Result<Hypotheses> {
    estimate_with_progress(setup, lf, disparity, confidence, scratch, &mut |_| {
        ControlFlow::Continue(())
    })
}

#[cfg(test)]
pub(crate) mod test_scenes;

#[cfg(test)]
mod tests;
