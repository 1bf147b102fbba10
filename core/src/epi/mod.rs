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
mod band_estimator;
mod half;
mod hypotheses;
mod kernels;
mod line;
mod load;
mod planes;
mod range;
mod serial;
mod upsample;

pub use band_estimator::estimate_band;
pub use half::{line_len, lines, map_size};
pub use hypotheses::{Hypotheses, MAX_DISPARITY, MAX_HYPOTHESES};
pub use range::{estimate_range, RANGE_LINE_STEP};
pub use serial::{estimate, STAGE_HORIZONTAL, STAGE_RANGE, STAGE_UPSAMPLE, STAGE_VERTICAL};
pub use upsample::{upsample_rows, upsample_scratch_len, UPSAMPLE_SIGMA};

use crate::error::{Error, Result};
use crate::lightfield::{Layout, LightField, Sample};
use crate::scalar::Scalar;
use crate::setup::{Setup, StageParams};
pub(crate) use band_estimator::BandEstimator;
// The firmware stream runs lines over its own band buffers.
pub(crate) use line::LineEstimator;
pub(crate) use load::{load_line, mix_chroma, Chroma, LineSpan};

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
    /// edges of colour alone but less of the noise of each channel (`mix_chroma`).
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

#[cfg(test)]
pub(crate) mod test_scenes;

#[cfg(test)]
mod tests;
