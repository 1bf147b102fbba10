//! Photometric refinement of the EPI disparity over many views.
//!
//! The structure tensor measures the slope of EPI lines to a few hundredths of a pixel
//! at best, and fails in whole regions near occlusions. This stage compares the centre
//! view with many views ([`ViewSet`]) directly, in two steps.
//!
//! **Propagation** ([`RefineParams::propagation`] rounds, jump flooding with jumps 8, 4,
//! 2, 1 px): each pixel tries the disparities of its four neighbours at the jump that
//! differ from its own by more than `PROPAGATION_OFFER` (0.25 px; smaller corrections
//! are the iterations' work) and keeps one whose robust photometric cost (the pixel
//! alone) is below
//! `PROPAGATION_ACCEPT` times its own, which pulls wrong regions to their surroundings.
//! A candidate's cost needs one sample per view (no derivative) and its sum stops
//! once it reaches the bar (its terms are non-negative; checked after each chunk of
//! views): neither changes the result. A pixel's own
//! cost is only computed once a neighbour offers another disparity, from the
//! Gauss–Newton statistics at its disparity (their residual energy is the same sum of
//! weighted terms), which the first iteration then keeps unless a candidate wins. A disparity within `SAME_CANDIDATE`
//! (0.05 px) of one tried this round, or of the last `REMEMBERED` ones the pixel
//! rejected in earlier rounds, is not tried again (an equal one could not pass the
//! bar, which only falls; a nearly equal one rarely does).
//! With a candidate map ([`Start::candidate`], the plane sweep's per-pixel winners) the
//! first round also offers each pixel its own candidate, by the same rule, where the
//! candidates of two opposite neighbours lie within 0.125 px of it (a line of them).
//!
//! **Gauss–Newton** ([`RefineParams::iterations`]): for view `v` at camera offset
//! `(u, v)` the residual `r = I_v(x − d·u, y − d·v) − I_c(x, y)` per colour channel
//! (bilinear sample) and `g = ∂r/∂d` (a central difference over ±½ px of image motion),
//! each view weighted by the Cauchy weight `s² / (s² + Σ r²)`
//! ([`RefineParams::robust_scale`]) so that occluded or specular views hardly count,
//! give normal equations summed over the views and a square window:
//!
//! ```text
//! d ← Σ_w (A_j d_j − b_j) / Σ_w A_j,     A_j = Σ_v g², b_j = Σ_v g·r   (at d_j)
//! ```
//!
//! i.e. the window average of the per-pixel Gauss–Newton updates weighted by their
//! curvature. A pixel that moved by less than `SETTLED` (10⁻² px; `SETTLED_EARLY`,
//! 2·10⁻² px, before the last iteration) in the previous iteration keeps its `A, B, E`:
//! to first order `B` does not depend on `d`, and the skipped sampling is most of an
//! iteration's cost once the map has settled (measured on HCI, `docs/stages/refine.md`).
//! After the first iteration, a pixel that kept its statistics and whose window's other
//! pixels moved by less than [`RefineParams::skip_settled`] (0.05 px) is not updated
//! again: it keeps its disparity and the confidence of its last update (its window
//! sums would change only by those moves, the gate and the damping).
//! The window only takes neighbours within `WINDOW_GATE` of the pixel's disparity (it
//! never straddles a depth edge); the step is clamped to
//! [`RefineParams::max_step`] and the result to the EPI range. Views are summed in four
//! half-plane groups (left, right, up, down): with [`RefineParams::occlusion`] a half
//! that fits much worse than its opposite is dropped, and when the horizontal and
//! vertical views disagree, only the axis with the smaller error is used.
//!
//! With [`RefineParams::slanted`] (off by default) the window is slanted: each
//! neighbour's statistics are moved along the local plane, `B_j − o_j A_j` with
//! `o_j = g_x·Δx_j + g_y·Δy_j`, and gated by `|d_j − d − o_j|`; the slope `(g_x, g_y)` is
//! the mean central difference across the window of its rows (columns) that lie on one
//! smooth surface with the pixel (`SLANT_GATE`), so the window reaches no further and the
//! bands' halo stays as it is.
//!
//! With a [`RefineParams::sampling_slack`] (the pipelines set one on warped views only)
//! a view's residual counts in its Cauchy weight, the residual energy and the
//! propagation's costs only by how far it falls outside the values the centre view's
//! linear interpolation spans over `±slack` px along the view's motion (after Birchfield
//! and Tomasi): interpolated views do not reproduce the centre view's sampled occlusion
//! edges. The Gauss–Newton step keeps the plain residual.
//!
//! The output confidence is `1 / (1 + ε²/s²)` with `ε² = E / A` the squared disparity
//! error the final residual energy `E` amounts to and `s`
//! [`RefineParams::confidence_scale`]: near 1 where the views agree on a textured
//! surface, low in occlusions, textureless areas and wrong regions.
//!
//! # Bands
//! Work is cut into bands of [`RefineParams::band_rows`] image rows. A band is computed
//! on its rows plus a halo of `iterations · radius + Σ jumps` rows on each side ([`halo`],
//! clipped at the image), which is exactly the reach of its result, so bands are
//! independent and the map is bit-identical for any banding and thread count.
//!
//! # Numbers
//! The stage computes in the scalar type `T` of its scratch (`f32` or Q16.16); the
//! disparity maps it reads and writes are `f32` (converted at the ends). Q16.16 saturates
//! at ±32768 and resolves 2^-16, so the scales below keep it precise and in range. All
//! are powers of two, applied to every term alike: `f32` gives the same bits as unscaled, and
//! the ratios the stage uses (`B / A`, `E / A`, mean residuals) do not change.
//! - Intensities are multiplied by `INTENSITY_SCALE` = 16, so that the squared residual
//!   of one 8-bit level is 256 LSB rather than one: the robust weights, `E` and the `A` of
//!   weakly textured pixels keep their precision. (Measured, Q16 vs f32 refinement on
//!   HCI cotton: with the statistics scaled down instead by 2^-2 / 2^-4 / 2^-9 so that
//!   sums can never overflow, 99.78 / 99.39 / 91.6 % of pixels within 0.02 px; unscaled
//!   99.87 %.)
//! - Window sums are formed unscaled: on the HCI scenes the largest total `A` of a window
//!   is 6738 (cotton; 2649 backgammon), well inside the range. A window whose total `A`
//!   exceeds `MAX / 32` (1024 in Q16.16, never reached in `f32`) is summed again with each
//!   term scaled by 2^-8, which covers every window on a 9×9 grid; such strongly textured
//!   windows do not need the low bits. Below that limit `|B| ≤ 8A + √(AE)` cannot
//!   overflow either (|d| ≤ 8 px). The damping and the group term counts take the same
//!   scale as the sums.
//! - The propagation's costs are scaled by a power of two (`photo::cost_scale`, 2^12 at
//!   the default robust scale) so that their sum of at most `views · robust` stays below
//!   2^13: unscaled, one view's weighted energy is at most 0.077 (5033 LSB) and the
//!   rounding of the small terms flipped decisions between a candidate's cost and 0.7
//!   times the pixel's own. (Measured, Q16 vs f32 default pipeline on the synthetic
//!   scenes of `pipeline::fixed_tests`: with the median 97.97–100 % → 98.93–100 %;
//!   `f32` decisions are unchanged, bit for bit.)
//! - One pixel's statistics (with the damping and the occlusion floor) are multiplied by
//!   `STAT_SCALE` = 4 (with a robust scale): weakly textured windows, whose `A` and `B`
//!   are a few hundred LSB unscaled, decided between the horizontal and the vertical
//!   solution (`AXIS_AGREEMENT`) on rounding (measured, Q16 vs f32 default pipeline on
//!   the synthetic scenes of `pipeline::fixed_tests`, with the median: 98.93–100 % →
//!   99.56–100 %; refinement alone 99.90–100 % → 100 %). The window sums of `A` therefore exceed the
//!   `MAX / 32` limit above from 256 unscaled (re-summed at 2^-6 of unscaled: still
//!   2^18 LSB for such a window). A view adds at most `3 · (reach · 16)² · 4` to `A`
//!   (49152 at reach 4), so a pixel whose views see full-contrast edges at the largest
//!   reach can saturate; on HCI the largest view term is 779 unscaled (3116 scaled).
//!
//! The tests in `pipeline::fixed_tests` and `docs/stages/fixed-point.md` measure Q16.16
//! against `f32`.

mod choose;
mod gauss_newton;
mod params;
mod photo;
mod propagation;
mod state;

pub use choose::choose;
pub use params::{RefineParams, ViewSet, RESAMPLED_SLACK, SKIP_SETTLED};

use core::ops::{ControlFlow, Range};

use crate::align::Interpolation;
use crate::error::{check_scratch, checked_product, Error, Result};
use crate::geometry::Homography;
use crate::lightfield::{LightField, Sample, GRID_MAX};
use crate::progress::Progress;
use crate::scalar::Scalar;
use crate::setup::{DisparityOut, Setup};
use photo::{Mapped, Photometric, Rectified, Views, INTENSITY_SCALE, STATS};
use state::{Planes, Region};

/// Progress stage name.
pub const STAGE: &str = "refine";

/// Progress stage name of the fused start's second refinement and choice ([`choose`]).
pub const STAGE_FUSED: &str = "fused start";

/// A half of a pair of groups is dropped when its mean squared residual exceeds the
/// other's by this factor plus [`OCCLUSION_FLOOR`].
const OCCLUSION_RATIO: f32 = 2.0;
/// Mean squared residual (unit intensity²) below which groups are never dropped:
/// about the noise of 8-bit images with a little aliasing.
const OCCLUSION_FLOOR: f32 = 1.0e-4;
/// Neighbours whose disparity differs by more than this (px) are left out of a pixel's
/// window: they lie across a depth edge.
const WINDOW_GATE: f32 = 0.1;
/// The slanted window ([`RefineParams::slanted`]) measures the slope along a row or
/// column of the 3 × 3 neighbourhood only where adjacent disparities differ by at most
/// this (px): slopes up to this many px per px, never across a depth edge.
const SLANT_GATE: f32 = 0.25;
/// Horizontal and vertical solutions further apart than this (px) disagree.
const AXIS_AGREEMENT: f32 = 0.05;
/// Per-pixel statistics (and the damping and occlusion floor with them) are multiplied
/// by this power of two (with a robust scale).
const STAT_SCALE: f32 = 4.0;
/// A pixel whose disparity moved by less than this (px) in a Gauss–Newton iteration
/// keeps its statistics for the last one. 10⁻² px skips 66 % of the later iterations'
/// sampling on HCI cotton (10⁻³: 24 %); the score changes are in `docs/stages/refine.md`.
const SETTLED: f32 = 1.0e-2;
/// As [`SETTLED`], for the iterations before the last: their statistics only steer
/// an intermediate step, which the last iteration measures again where it moved by
/// `SETTLED` or more. (Measured on HCI: 2·10⁻² skips 13.5 % of the stage's sampling
/// calls on cotton for +0.010 BadPix0.07; 2·10⁻² in the last iteration too cost cotton
/// +0.036 BadPix0.07 and +0.04 MSE×100.)
const SETTLED_EARLY: f32 = 2.0e-2;
/// Curvature added per term so that textureless pixels keep their disparity.
const DAMPING_PER_TERM: f32 = 1.0e-6;

/// Jumps (px) of the propagation rounds, largest first (jump flooding).
const JUMPS: [usize; 4] = [8, 4, 2, 1];
/// A neighbour offers its disparity to the propagation only when it differs from the
/// pixel's by more than this (px): smaller corrections are left to the Gauss–Newton
/// iterations (each moves up to `max_step`). (Measured on HCI, `docs/stages/refine.md`:
/// 0.25 instead of 0.1 (the window gate) makes the stage 1.25× faster, cotton
/// BadPix0.07 2.066 → 2.067 and MSE×100 1.158 → 1.077, backgammon 2.045 → 2.061 /
/// 3.065; 0.3 cost cotton +0.04 BadPix0.07.)
const PROPAGATION_OFFER: f32 = 0.25;
/// Propagation candidates closer than this (px) to one already tried count as tried:
/// nearly equal disparities have nearly equal costs. (Measured on HCI cotton: 0.05
/// saves 10 % of the stage and costs +0.004 BadPix0.07 points; 0.1 saved 13 % for
/// +0.027.)
const SAME_CANDIDATE: f32 = 0.05;
/// Rejected propagation candidates a pixel remembers across rounds (in its statistics'
/// slots, unused until the iterations).
const REMEMBERED: usize = 4;
/// A neighbour's disparity replaces a pixel's when its photometric cost is below this
/// share of the pixel's own.
const PROPAGATION_ACCEPT: f32 = 0.7;

fn jumps(setup: Setup<'_, RefineParams>) -> &'static [usize] {
    let rounds = setup.params().propagation.min(JUMPS.len());
    &JUMPS[JUMPS.len() - rounds..]
}

/// Rows of context a band needs on each side.
pub fn halo(setup: Setup<'_, RefineParams>) -> usize {
    let p = setup.params();
    p.iterations * p.radius + jumps(setup).iter().sum::<usize>()
}

fn region_rows(setup: Setup<'_, RefineParams>) -> usize {
    let rows = setup.params().band_rows + 2 * halo(setup);
    rows.min(setup.layout().height)
}

/// Values per region pixel the propagation keeps besides the statistics: the state of
/// its own cost (or the cost itself) and the candidates it rejected.
const MEMORY: usize = 1 + REMEMBERED;

/// Scratch (elements of the scalar type) one band needs: `2 + 12 + 5` values per pixel
/// of the band and its halo; independent of the image height.
pub fn scratch_len(setup: Setup<'_, RefineParams>) -> usize {
    region_rows(setup)
        .saturating_mul(setup.layout().width)
        .saturating_mul(2 + STATS + MEMORY)
}

/// Number of bands.
pub fn band_count(setup: Setup<'_, RefineParams>) -> usize {
    setup
        .layout()
        .height
        .div_ceil(setup.params().band_rows.max(1))
}

/// Image rows of band `index`.
pub fn band_rows(setup: Setup<'_, RefineParams>, index: usize) -> Result<Range<usize>> {
    let count = band_count(setup);
    if index >= count {
        return Err(Error::OutOfRange {
            what: "refine band",
            index,
            len: count,
        });
    }
    let rows = setup.params().band_rows;
    let start = index * rows;
    Ok(start..(start + rows).min(setup.layout().height))
}

fn check_inputs<S: Sample>(
    setup: Setup<'_, RefineParams>,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    disparity: &[f32],
) -> Result<()> {
    if lf.layout() != setup.layout() {
        return Err(Error::InvalidParameter {
            name: "plan",
            reason: "was made for a different light-field layout: build it from this light field",
        });
    }
    if !(range.0.is_finite() && range.1.is_finite() && range.0 <= range.1) {
        return Err(Error::InvalidParameter {
            name: "disparity range",
            reason: "must be finite with min <= max",
        });
    }
    if disparity.len() != setup.pixels() {
        return Err(Error::OutputSize {
            what: "the input disparity",
            needed: setup.pixels(),
            got: disparity.len(),
        });
    }
    Ok(())
}

/// The stage's constants in the scalar type, scaled as the module's "Numbers" says.
struct Constants<T> {
    /// Output range (the EPI range).
    lo: T,
    hi: T,
    /// Squared residual scale times the channels, in scaled intensity².
    robust: T,
    /// Curvature damping per (statistics-scaled) term.
    damping: T,
    /// The power of two the per-pixel statistics are multiplied by.
    stat_scale: f32,
    gate: T,
    /// With [`RefineParams::slanted`]: how the window's plane is measured.
    slant: Option<Slant<T>>,
    offer: T,
    same: T,
    accept: T,
    max_step: T,
    occlusion_ratio: T,
    occlusion_floor: T,
    axis_agreement: T,
    settled: T,
    settled_early: T,
    /// Squared confidence scale.
    confidence2: T,
}

impl<T: Scalar> Constants<T> {
    fn new(p: &RefineParams, channels: usize, range: (f32, f32)) -> Self {
        let stat_scale = if p.robust_scale > 0.0 {
            STAT_SCALE
        } else {
            1.0
        };
        let intensity2 = INTENSITY_SCALE * INTENSITY_SCALE;
        Constants {
            lo: T::from_f32(range.0),
            hi: T::from_f32(range.1),
            robust: if p.robust_scale > 0.0 {
                T::from_f32(p.robust_scale * p.robust_scale * channels as f32 * intensity2)
            } else {
                T::MAX
            },
            damping: T::from_f32(DAMPING_PER_TERM * intensity2 * stat_scale),
            stat_scale,
            gate: T::from_f32(WINDOW_GATE),
            slant: (p.slanted && p.radius > 0).then(|| Slant::new(p.radius)),
            offer: T::from_f32(PROPAGATION_OFFER),
            same: T::from_f32(SAME_CANDIDATE),
            accept: T::from_f32(PROPAGATION_ACCEPT),
            max_step: T::from_f32(p.max_step),
            occlusion_ratio: T::from_f32(OCCLUSION_RATIO),
            occlusion_floor: T::from_f32(OCCLUSION_FLOOR * intensity2 * stat_scale),
            axis_agreement: T::from_f32(AXIS_AGREEMENT),
            settled: T::from_f32(SETTLED),
            settled_early: T::from_f32(SETTLED_EARLY),
            confidence2: T::from_f32(p.confidence_scale * p.confidence_scale),
        }
    }
}

/// How the slanted window ([`RefineParams::slanted`]) measures its plane: per axis, the
/// mean central difference across the window (`±radius` px) of the window's rows
/// (columns) that lie on one smooth surface with the pixel.
struct Slant<T> {
    /// The window's radius (px, 1…4).
    radius: usize,
    /// A difference across the window counts when each end lies within this of the
    /// row's centre (`radius ·` [`SLANT_GATE`]).
    reach: T,
    /// `1 / (2 · radius · n)` for `n` differences averaged (`[0]`: none, slope 0).
    mean: [T; 10],
}

impl<T: Scalar> Slant<T> {
    fn new(radius: usize) -> Self {
        let span = 2.0 * radius as f32;
        let mut mean = [T::ZERO; 10];
        for (n, m) in mean.iter_mut().enumerate().skip(1) {
            *m = T::from_f32(1.0 / (span * n as f32));
        }
        Slant {
            radius,
            reach: T::from_f32(radius as f32 * SLANT_GATE),
            mean,
        }
    }
}

/// How a band measures its pixels: the views it compares, the stage's constants, the
/// robust scales of the statistics and the costs, and the output range.
struct Measure<'a, T, P> {
    photo: &'a P,
    k: Constants<T>,
    /// `(robust, robust · scale)` of a pixel's statistics (`Photometric::pixel`).
    stat_robust: (T, T),
    /// `(robust, robust · scale)` of a candidate's cost (`Photometric::cost`).
    cost_robust: (T, T),
    /// A cost per residual energy of the statistics.
    cost_per_energy: T,
    /// Output range (the EPI range).
    range: (f32, f32),
}

/// What a band refines: the start's disparity (the whole map, row-major) and,
/// optionally, a per-pixel candidate map of the same size (the plane sweep's, see
/// `PlaneSweepParams::candidate`) that the first propagation round offers each pixel
/// as it offers a neighbour's disparity.
#[derive(Clone, Copy, Debug)]
pub struct Start<'a> {
    /// The start's disparity.
    pub disparity: &'a [f32],
    /// The per-pixel candidates, or `None`.
    pub candidate: Option<&'a [f32]>,
}

/// Refines the rows `rows` of `disparity` (the whole EPI map, row-major) into `out`
/// (`rows.len() · width` values each, first row of the band first), keeping the result
/// in `range` (the EPI stage's output range), computing in `T`. `scratch` needs
/// [`scratch_len`] elements.
pub fn refine_band<T: Scalar, S: Sample>(
    setup: Setup<'_, RefineParams>,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    disparity: &[f32],
    rows: Range<usize>,
    out: DisparityOut<'_>,
    scratch: &mut [T],
) -> Result<()> {
    let start = Start {
        disparity,
        candidate: None,
    };
    refine_band_from(setup, lf, range, start, rows, out, scratch)
}

/// [`refine_band`] from a [`Start`]: with a candidate map, the first propagation round
/// also tries each pixel's candidate.
pub fn refine_band_from<T: Scalar, S: Sample>(
    setup: Setup<'_, RefineParams>,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    start: Start<'_>,
    rows: Range<usize>,
    out: DisparityOut<'_>,
    scratch: &mut [T],
) -> Result<()> {
    check_inputs(setup, lf, range, start.disparity)?;
    if let Some(candidate) = start.candidate {
        if candidate.len() != setup.pixels() {
            return Err(Error::OutputSize {
                what: "the candidate disparity",
                needed: setup.pixels(),
                got: candidate.len(),
            });
        }
    }
    with_rectified(setup, lf, |photo| {
        band(setup, photo, range, start, rows, out, scratch)
    })
}

/// Hands `body` the views of a rectified array as the refinement compares them: the
/// tables of the views `setup` selects, with its sampling slack, over `lf`'s samples.
/// The tables are built in place in this frame (inlined into the caller's), never
/// moved: they are large, and a firmware's stack is small.
#[inline(always)]
fn with_rectified<T: Scalar, S: Sample, R>(
    setup: Setup<'_, RefineParams>,
    lf: &LightField<'_, S>,
    body: impl FnOnce(&Rectified<'_, T, S>) -> R,
) -> R {
    let p = setup.params();
    let mut views = Views::<T>::empty();
    views.init(setup.layout(), p.views);
    views.set_slack(p.sampling_slack);
    body(&Rectified {
        views: &views,
        data: lf.data(),
    })
}

/// An array that is not rectified: its input views, one homography per view
/// (rectified → view pixels, as [`crate::align::warp_rows`] takes them) that rectifies
/// them, and the interpolation its views are sampled with.
#[derive(Clone, Copy, Debug)]
pub struct MappedViews<'a, 'l, S: Sample> {
    /// The input views.
    pub lf: &'a LightField<'l, S>,
    /// One homography per view (row-major grid order).
    pub homographies: &'a [Homography],
    /// How the views are sampled.
    pub interpolation: Interpolation,
}

/// [`refine_band`] on an aligned array: every compared view (the centre one too) is
/// sampled through its homography at the disparity-shifted position, one interpolation
/// of the input instead of a second one of a warped copy (which spreads occlusion edges
/// by a different amount in every view: docs/stages/align.md), with the views'
/// interpolation (Catmull–Rom keeps the texture's contrast at every sub-pixel phase,
/// which the Gauss–Newton steps need: it loses much less to the misalignment than
/// bilinear). Slower than the rectified path (three samples and three projections per
/// view and pixel). Not yet used by the pipelines: the EPI stage and the others still
/// read the warped copy.
pub fn refine_band_mapped<T: Scalar, S: Sample>(
    setup: Setup<'_, RefineParams>,
    views: MappedViews<'_, '_, S>,
    range: (f32, f32),
    disparity: &[f32],
    rows: Range<usize>,
    out: DisparityOut<'_>,
    scratch: &mut [T],
) -> Result<()> {
    let MappedViews {
        lf,
        homographies,
        interpolation,
    } = views;
    check_inputs(setup, lf, range, disparity)?;
    check_homographies(setup, homographies)?;
    let photo = Mapped {
        views: Views::<T>::new(setup.layout(), setup.params().views),
        data: lf.data(),
        maps: homographies,
        interpolation,
    };
    let start = Start {
        disparity,
        candidate: None,
    };
    band(setup, &photo, range, start, rows, out, scratch)
}

fn check_homographies(setup: Setup<'_, RefineParams>, homographies: &[Homography]) -> Result<()> {
    let views = setup.layout().grid.len();
    if homographies.len() != views {
        return Err(Error::OutputSize {
            what: "the homography slice (one per view)",
            needed: views,
            got: homographies.len(),
        });
    }
    if !homographies
        .iter()
        .all(|h| h.m.iter().all(|v| v.is_finite()))
    {
        return Err(Error::NonFinite {
            what: "the homography",
        });
    }
    Ok(())
}

/// The values `span` of the whole-frame map `map` (`what` in errors), every one finite.
fn finite_rows<'a>(map: &'a [f32], span: Range<usize>, what: &'static str) -> Result<&'a [f32]> {
    let needed = span.end;
    let values = map.get(span).ok_or(Error::OutputSize {
        what,
        needed,
        got: map.len(),
    })?;
    if values.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite { what });
    }
    Ok(values)
}

/// The body of [`refine_band`] over the views `photo` compares.
// Not inlined: its locals and the compared views' tables of `refine_band` are not in one
// frame (docs/EMBEDDED.md, "Stack").
#[inline(never)]
fn band<T: Scalar, P: Photometric<T>>(
    setup: Setup<'_, RefineParams>,
    photo: &P,
    range: (f32, f32),
    start: Start<'_>,
    rows: Range<usize>,
    out: DisparityOut<'_>,
    scratch: &mut [T],
) -> Result<()> {
    let Start {
        disparity,
        candidate,
    } = start;
    let DisparityOut {
        disparity: out,
        confidence,
    } = out;
    let (width, height) = (setup.layout().width, setup.layout().height);
    if rows.start >= rows.end || rows.end > height {
        return Err(Error::OutOfRange {
            what: "band end row",
            index: rows.end,
            len: height,
        });
    }
    let p = *setup.params();
    if rows.len() > p.band_rows {
        return Err(Error::InvalidParameter {
            name: "rows",
            reason: "a band may not have more rows than refine.band_rows",
        });
    }
    let needed = checked_product(&[rows.len(), width], "the band")?;
    if out.len() != needed || confidence.len() != needed {
        return Err(Error::OutputSize {
            what: "the band disparity/confidence",
            needed,
            got: out.len().min(confidence.len()),
        });
    }
    // Sample positions reach `|d| · reach ≤ 8 · 8` px beyond the image before the
    // inside test: the coordinates must not saturate in `T`.
    let reach = i32::try_from(width.max(height))
        .ok()
        .and_then(|n| n.checked_add(2 * 8 * (GRID_MAX as i32)));
    if reach.is_none_or(|n| T::from_i32(n) >= T::MAX) {
        return Err(Error::InvalidParameter {
            name: "scalar",
            reason: "views this large exceed the fixed-point range in the refinement: use f32",
        });
    }
    let halo = halo(setup);
    let first = rows.start.saturating_sub(halo);
    let last = (rows.end + halo).min(height);
    let pixels = (last - first) * width;
    let needed = pixels * (2 + STATS + MEMORY);
    check_scratch(needed, scratch.len())?;
    let region = first * width..last * width;
    let input = finite_rows(disparity, region.clone(), "the input disparity")?;
    let candidate = candidate
        .map(|map| finite_rows(map, region.clone(), "the candidate disparity"))
        .transpose()?;
    let too_small = Error::ScratchTooSmall {
        needed,
        got: scratch.len(),
    };
    let (current, rest) = scratch.split_at_mut_checked(pixels).ok_or(too_small)?;
    let (previous, rest) = rest.split_at_mut_checked(pixels).ok_or(too_small)?;
    let (stats, rest) = rest.split_at_mut_checked(pixels * STATS).ok_or(too_small)?;
    let memory = rest.get_mut(..pixels * MEMORY).ok_or(too_small)?;
    for (c, &v) in current.iter_mut().zip(input) {
        *c = T::from_f32(v);
    }

    let k = Constants::<T>::new(&p, setup.layout().channels.min(3), range);
    let used = setup.layout().channels.min(3) as f32;
    let memberships = photo.views().terms.iter().sum::<f32>() / used;
    let robust = p.robust_scale * p.robust_scale * used * INTENSITY_SCALE * INTENSITY_SCALE;
    let scale = photo::cost_scale(if p.robust_scale > 0.0 { robust } else { 0.0 }, memberships);
    let measure = Measure {
        photo,
        // The robust scale with and without the cost's scale.
        cost_robust: (k.robust, k.robust * T::from_f32(scale)),
        stat_robust: (k.robust, k.robust * T::from_f32(k.stat_scale)),
        // A cost from the statistics' residual energies: the same weighted terms, scaled
        // by the statistics' power of two instead of the cost's (both powers of two).
        cost_per_energy: T::from_f32(scale / k.stat_scale),
        range,
        k,
    };
    let region = Region {
        width,
        rows,
        first,
        last,
    };
    let mut planes = Planes {
        current,
        previous,
        stats,
        memory,
    };
    let jumps = jumps(setup);
    propagation::propagate(
        &measure,
        &region,
        &mut planes,
        jumps,
        p.iterations * p.radius,
        candidate,
    );
    gauss_newton::iterate(
        &measure,
        &p,
        &region,
        &mut planes,
        !jumps.is_empty(),
        (out, confidence),
    );
    Ok(())
}

/// The serial stage with progress: every band in order into `out` (row-major,
/// `setup.pixels()` values each).
pub fn refine_with_progress<T: Scalar, S: Sample>(
    setup: Setup<'_, RefineParams>,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    disparity: &[f32],
    out: DisparityOut<'_>,
    scratch: &mut [T],
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<()> {
    let DisparityOut {
        disparity: out,
        confidence,
    } = out;
    check_inputs(setup, lf, range, disparity)?;
    let pixels = setup.pixels();
    if out.len() != pixels || confidence.len() != pixels {
        return Err(Error::OutputSize {
            what: "the refined disparity/confidence",
            needed: pixels,
            got: out.len().min(confidence.len()),
        });
    }
    let width = setup.layout().width;
    let bands = band_count(setup);
    for band in 0..bands {
        let report = Progress {
            stage: STAGE,
            done: band as u64,
            total: bands as u64,
        };
        if progress(report).is_break() {
            return Err(Error::Cancelled);
        }
        let rows = band_rows(setup, band)?;
        let span = rows.start * width..rows.end * width;
        // `band_rows` are image rows and both maps hold every pixel (checked above).
        let (Some(out), Some(confidence)) = (out.get_mut(span.clone()), confidence.get_mut(span))
        else {
            return Err(Error::OutputSize {
                what: "the refined disparity/confidence",
                needed: pixels,
                got: 0,
            });
        };
        let out = DisparityOut {
            disparity: out,
            confidence,
        };
        refine_band(setup, lf, range, disparity, rows, out, scratch)?;
    }
    match progress(Progress {
        stage: STAGE,
        done: bands as u64,
        total: bands as u64,
    }) {
        ControlFlow::Continue(()) => Ok(()),
        ControlFlow::Break(()) => Err(Error::Cancelled),
    }
}

/// The serial stage: refines `disparity` into `out` (a new disparity and confidence),
/// computing in `T`.
pub fn refine<T: Scalar, S: Sample>(
    setup: Setup<'_, RefineParams>,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    disparity: &[f32],
    out: DisparityOut<'_>,
    scratch: &mut [T],
) -> Result<()> {
    refine_with_progress(setup, lf, range, disparity, out, scratch, &mut |_| {
        ControlFlow::Continue(())
    })
}

#[cfg(test)]
mod tests;
