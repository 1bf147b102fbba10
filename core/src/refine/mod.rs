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
//!   scenes of `fixed_tests`: with the median 97.97–100 % → 98.93–100 %; `f32` decisions
//!   are unchanged, bit for bit.)
//! - One pixel's statistics (with the damping and the occlusion floor) are multiplied by
//!   `STAT_SCALE` = 4 (with a robust scale): weakly textured windows, whose `A` and `B`
//!   are a few hundred LSB unscaled, decided between the horizontal and the vertical
//!   solution (`AXIS_AGREEMENT`) on rounding (measured, Q16 vs f32 default pipeline on
//!   the synthetic scenes of `fixed_tests`, with the median: 98.93–100 % → 99.56–100 %;
//!   refinement alone 99.90–100 % → 100 %). The window sums of `A` therefore exceed the
//!   `MAX / 32` limit above from 256 unscaled (re-summed at 2^-6 of unscaled: still
//!   2^18 LSB for such a window). A view adds at most `3 · (reach · 16)² · 4` to `A`
//!   (49152 at reach 4), so a pixel whose views see full-contrast edges at the largest
//!   reach can saturate; on HCI the largest view term is 779 unscaled (3116 scaled).
//!
//! The tests (`fixed_tests`) and `docs/stages/fixed-point.md` measure Q16.16 against `f32`.

mod params;
mod photo;

pub use params::{RefineParams, ViewSet, RESAMPLED_SLACK, SKIP_SETTLED};

use core::ops::{ControlFlow, Range};

use crate::align::Interpolation;
use crate::error::{check_scratch, checked_product, Error, Result};
use crate::geometry::Homography;
use crate::lightfield::{LightField, Sample, GRID_MAX};
use crate::plan::Plan;
use crate::progress::Progress;
use crate::scalar::Scalar;
use photo::{Mapped, Photometric, Rectified, Views, GROUPS, INTENSITY_SCALE, STATS};

/// Progress stage name.
pub const STAGE: &str = "refine";

/// A half of a pair of groups is dropped when its mean squared residual exceeds the
/// other's by this factor plus [`OCCLUSION_FLOOR`].
const OCCLUSION_RATIO: f32 = 2.0;
/// Mean squared residual (unit intensity²) below which groups are never dropped:
/// about the noise of 8-bit images with a little aliasing.
const OCCLUSION_FLOOR: f32 = 1.0e-4;
/// Neighbours whose disparity differs by more than this (px) are left out of a pixel's
/// window: they lie across a depth edge.
const WINDOW_GATE: f32 = 0.1;
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

fn jumps(plan: &Plan) -> &'static [usize] {
    let rounds = plan.params().refine.propagation.min(JUMPS.len());
    &JUMPS[JUMPS.len() - rounds..]
}

/// Rows of context a band needs on each side.
pub fn halo(plan: &Plan) -> usize {
    let p = &plan.params().refine;
    p.iterations * p.radius + jumps(plan).iter().sum::<usize>()
}

fn region_rows(plan: &Plan) -> usize {
    let rows = plan.params().refine.band_rows + 2 * halo(plan);
    rows.min(plan.layout().height)
}

/// Values per region pixel the propagation keeps besides the statistics: the state of
/// its own cost (or the cost itself) and the candidates it rejected.
const MEMORY: usize = 1 + REMEMBERED;

/// Scratch (elements of the scalar type) one band needs: `2 + 12 + 5` values per pixel
/// of the band and its halo; independent of the image height.
pub fn scratch_len(plan: &Plan) -> usize {
    region_rows(plan)
        .saturating_mul(plan.layout().width)
        .saturating_mul(2 + STATS + MEMORY)
}

/// Number of bands.
pub fn band_count(plan: &Plan) -> usize {
    plan.layout()
        .height
        .div_ceil(plan.params().refine.band_rows.max(1))
}

/// Image rows of band `index`.
pub fn band_rows(plan: &Plan, index: usize) -> Result<Range<usize>> {
    let count = band_count(plan);
    if index >= count {
        return Err(Error::OutOfRange {
            what: "refine band",
            index,
            len: count,
        });
    }
    let rows = plan.params().refine.band_rows;
    let start = index * rows;
    Ok(start..(start + rows).min(plan.layout().height))
}

fn check_inputs<S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    disparity: &[f32],
) -> Result<()> {
    if lf.layout() != plan.layout() {
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
    if disparity.len() != plan.pixels() {
        return Err(Error::OutputSize {
            what: "the input disparity",
            needed: plan.pixels(),
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

/// Term counts of the groups over one window, as the window sums are scaled: the
/// divisors of the mean residuals and the damping's term counts.
struct Counts<T> {
    /// Per group, its terms over one window times the scale (exact).
    terms: [T; GROUPS],
    /// The same, at least one term's worth: the divisor of the group's mean residual.
    means: [T; GROUPS],
    /// The factor of the window sums.
    scale: T,
}

impl<T: Scalar> Counts<T> {
    fn new(terms: &[f32; GROUPS], area: f32, shift: i32) -> Self {
        let scale = libm::ldexpf(1.0, -shift);
        Counts {
            terms: terms.map(|t| T::from_f32(t * area * scale)),
            means: terms.map(|t| T::from_f32((t * area).max(1.0) * scale)),
            scale: T::from_f32(scale),
        }
    }
}

/// Window sums whose total curvature `A` exceeds `T::MAX · 2^-WIDE_LIMIT_SHIFT` are
/// summed again with every term scaled by `2^-WIDE_SHIFT` (see the module's "Numbers").
const WIDE_LIMIT_SHIFT: i32 = 5;
/// See [`WIDE_LIMIT_SHIFT`]: `2^8` covers the terms of any window on a 9×9 grid.
const WIDE_SHIFT: i32 = 8;

/// The window sum of the statistics of the pixels within `gate` of `d`, over
/// `ys × xs` of the region (`width` wide), in a fixed order so that every band sums
/// alike. Each term is multiplied by `scale` when one is given. (A row's interior
/// pixels at radius 1 take [`update_row`]'s [`window_rows`] instead.)
#[inline]
#[allow(clippy::too_many_arguments)]
fn window_sum<T: Scalar>(
    stats: &[T],
    previous: &[T],
    width: usize,
    ys: Range<usize>,
    xs: Range<usize>,
    d: T,
    gate: T,
    scale: Option<T>,
) -> [T; STATS] {
    let mut sum = [T::ZERO; STATS];
    if xs.len() == 3 {
        // Radius 1 away from the image's sides (fewer than three rows at the region's
        // ends): each window row as one array of three disparities and one of their
        // statistics. A neighbour outside the gate adds zero instead of being skipped
        // (the sum starts at +0 and never becomes −0, so adding +0 leaves it
        // unchanged): the same sums, without branches.
        for yy in ys.clone() {
            let at = yy * width + xs.start;
            let (Some(ds), Some(ss)) = (
                previous.get(at..).and_then(|s| s.first_chunk::<3>()),
                stats
                    .get(at * STATS..)
                    .and_then(|s| s.first_chunk::<{ 3 * STATS }>()),
            ) else {
                return window_sum_each(stats, previous, width, ys, xs, d, gate, scale);
            };
            for (&p, s) in ds.iter().zip(ss.chunks_exact(STATS)) {
                let outside = (p - d).abs() > gate;
                let terms = sum.iter_mut().zip(s);
                match scale {
                    None => terms.for_each(|(s, &v)| *s += if outside { T::ZERO } else { v }),
                    Some(f) => {
                        terms.for_each(|(s, &v)| *s += if outside { T::ZERO } else { v * f })
                    }
                }
            }
        }
        return sum;
    }
    window_sum_each(stats, previous, width, ys, xs, d, gate, scale)
}

/// The total curvature `A` of a window sum (all groups).
#[inline(always)]
fn curvature<T: Scalar>(sum: &[T; STATS]) -> T {
    (0..GROUPS).fold(T::ZERO, |a, g| a + sum[3 * g])
}

/// Rows `y − 1`, `y` and `y + 1` of a plane whose rows are `row_len` long (`None` for
/// `y` = 0 or rows past the plane).
#[inline(always)]
fn rows_around<T>(plane: &[T], row_len: usize, y: usize) -> Option<[&[T]; 3]> {
    let rows = plane
        .get(y.checked_sub(1)? * row_len..)?
        .get(..3 * row_len)?;
    let (r0, rest) = rows.split_at_checked(row_len)?;
    let (r1, r2) = rest.split_at_checked(row_len)?;
    Some([r0, r1, r2])
}

/// Rows `y − 1`, `y` and `y + 1` of the region's disparities and statistics (`width`
/// wide; `None` for `y` = 0 or rows past the region).
#[allow(clippy::type_complexity)]
#[inline(always)]
fn three_rows<'a, T>(
    previous: &'a [T],
    stats: &'a [T],
    width: usize,
    y: usize,
) -> Option<([&'a [T]; 3], [&'a [T]; 3])> {
    Some((
        rows_around(previous, width, y)?,
        rows_around(stats, width * STATS, y)?,
    ))
}

/// [`window_sum`] of a whole 3 × 3 window given as its three rows of disparities and
/// statistics: the same terms in the same order. A neighbour outside the gate is
/// skipped, which is adding +0 (the sum starts at +0 and never becomes −0; adding 0 to
/// a Q16 integer is exact): the same bits. Not inlined: inlined into the row's loop,
/// its sums were kept in vector lanes by group (for the curvature), which cost more
/// than the call.
#[allow(clippy::type_complexity)]
#[inline(never)]
fn window_rows<T: Scalar>(
    (ds, ss): &([&[T; 3]; 3], [&[T; 3 * STATS]; 3]),
    d: T,
    gate: T,
    scale: Option<T>,
) -> [T; STATS] {
    let mut sum = [T::ZERO; STATS];
    for (ds, ss) in ds.iter().zip(ss) {
        for (&p, s) in ds.iter().zip(ss.chunks_exact(STATS)) {
            if (p - d).abs() > gate {
                continue;
            }
            add_stats(&mut sum, s, scale);
        }
    }
    sum
}

/// Adds one pixel's statistics to a window's sum, scaled by `scale` when given (the
/// wide windows' re-sum).
#[inline(always)]
fn add_stats<T: Scalar>(sum: &mut [T; STATS], stat: &[T], scale: Option<T>) {
    let terms = sum.iter_mut().zip(stat);
    match scale {
        None => terms.for_each(|(s, &v)| *s += v),
        Some(f) => terms.for_each(|(s, &v)| *s += v * f),
    }
}

/// What one pixel's Gauss–Newton update needs besides its window sum.
struct Step<'a, T> {
    k: &'a Constants<T>,
    narrow: &'a Counts<T>,
    wide: &'a Counts<T>,
    /// Window sums whose total curvature exceeds this are summed again scaled.
    wide_limit: T,
    occlusion: bool,
    range: (f32, f32),
}

impl<T: Scalar> Step<'_, T> {
    /// The next disparity of a pixel at `d` (with the `E` and `A` + damping of its
    /// confidence) from its plain window sum `sum`, or, when the sum's total curvature
    /// exceeds `wide_limit`, from `scaled(wide scale)`, the window summed again scaled.
    #[inline(always)]
    fn update(&self, d: T, sum: [T; STATS], scaled: impl FnOnce(T) -> [T; STATS]) -> (T, T, T) {
        let wide = curvature(&sum) > self.wide_limit;
        let sum = if wide { scaled(self.wide.scale) } else { sum };
        self.next(&sum, wide, d)
    }

    /// The next disparity of a pixel at `d` whose window sum is `sum` (summed scaled,
    /// with the wide counts, when `wide`), with the `E` and `A` + damping of its
    /// confidence.
    #[inline(always)]
    fn next(&self, sum: &[T; STATS], wide: bool, d: T) -> (T, T, T) {
        let k = self.k;
        let counts = if wide { self.wide } else { self.narrow };
        let (a, b, e, terms) = select(sum, counts, k, self.occlusion, d);
        let damping = k.damping * terms;
        let target = (b + damping * d) / (a + damping);
        // `Scalar::clamp` (`max`, then `min`; a NaN gives the lower bound) as compares
        // that the compiler keeps as one `max` / `min` instruction each, with the same
        // bits: for the step they differ from `Scalar::max` / `min` only where the
        // value equals a bound (the same bits: `±max_step` is not zero), or on a NaN
        // bound (never); for the range they are `Scalar::max` / `min` of a value that
        // is not NaN (`d` is finite and the step is clamped).
        let (raw, max_step) = (target - d, k.max_step);
        let step = if raw > -max_step { raw } else { -max_step };
        let step = if step < max_step { step } else { max_step };
        let next = d + step;
        let next = if k.lo > next { k.lo } else { next };
        let next = if k.hi < next { k.hi } else { next };
        let next = if next.is_finite() { next } else { d };
        (next, e, a + damping)
    }

    /// The band's output for disparity `next`, its `E` and `A` + damping.
    #[inline(always)]
    fn output(&self, next: T, e: T, damped: T, out: &mut f32, confidence: &mut f32) {
        // Fixed-point rounding of the range ends must not step outside it.
        *out = crate::float::clamp_f32(next.to_f32(), self.range.0, self.range.1);
        let err2 = e / damped;
        let c = T::ONE / (T::ONE + err2 / self.k.confidence2);
        *confidence = if c.is_finite() {
            c.to_f32().clamp(0.0, 1.0)
        } else {
            0.0
        };
    }
}

/// Elements `x`, `x + 1` and `x + 2` of `row`.
#[inline(always)]
fn three_at<X>(row: &[X], x: usize) -> Option<&[X; 3]> {
    row.get(x..).and_then(|r| r.first_chunk::<3>())
}

/// The statistics of elements `x`, `x + 1` and `x + 2` of a row of statistics.
#[inline(always)]
fn three_stats_at<T>(row: &[T], x: usize) -> Option<&[T; 3 * STATS]> {
    row.get(x * STATS..)
        .and_then(|r| r.first_chunk::<{ 3 * STATS }>())
}

/// With [`RefineParams::skip_settled`], what a row's update keeps of the iteration
/// before: after the first iteration the rows `moved` above, at and below it (from
/// x = 0: how far each pixel moved in the iteration before; a pixel that moved by less
/// than `settled` kept its statistics, and its window settled when the other pixels
/// moved by less than `loose`), and the `E` and `A` + damping of the row's pixels (from
/// x = 1 in [`update_row`], as `next`), which a skipped pixel's confidence reuses and
/// an updated pixel's overwrites when `store`.
struct Reuse<'a, T> {
    moved: Option<[&'a [T]; 3]>,
    e: &'a mut [T],
    damped: &'a mut [T],
    settled: T,
    /// The largest move of the window's other pixels (at least `settled`).
    loose: T,
    store: bool,
}

/// The update of a row's interior pixels (x = 1 … width − 2) from the region's rows
/// `ds` / `ss` above, at and below it (see [`three_rows`]) into `next` (the row of the
/// next disparities from x = 1) and, in the last iteration, `outputs` (the band's
/// disparity and confidence rows from x = 1); with `reuse`, a pixel whose window settled
/// keeps its disparity (`next` holds it already) and its confidence.
#[inline(never)]
fn update_row<T: Scalar>(
    step: &Step<'_, T>,
    ds: [&[T]; 3],
    ss: [&[T]; 3],
    next: &mut [T],
    outputs: Option<(&mut [f32], &mut [f32])>,
    reuse: Option<Reuse<'_, T>>,
) {
    let n = next.len();
    // Every row holds the n + 2 pixels of the row's windows: the window lookups below
    // stay inside these (their `else` never happens).
    let ([d0, d1, d2], [s0, s1, s2]) = (ds, ss);
    let (Some(d0), Some(d1), Some(d2), Some(s0), Some(s1), Some(s2)) = (
        d0.get(..n + 2),
        d1.get(..n + 2),
        d2.get(..n + 2),
        s0.get(..(n + 2) * STATS),
        s1.get(..(n + 2) * STATS),
        s2.get(..(n + 2) * STATS),
    ) else {
        return;
    };
    let gate = step.k.gate;
    let mut outputs =
        outputs.and_then(|(out, confidence)| Some((out.get_mut(..n)?, confidence.get_mut(..n)?)));
    let mut reuse = reuse.and_then(|r| {
        let moved = match r.moved {
            Some([m0, m1, m2]) => Some([m0.get(..n + 2)?, m1.get(..n + 2)?, m2.get(..n + 2)?]),
            None => None,
        };
        Some((
            moved,
            r.e.get_mut(..n)?,
            r.damped.get_mut(..n)?,
            (r.settled, r.loose),
            r.store,
        ))
    });
    // Whether a pixel of column `x` (of the rows' n + 2) in the three rows moved by
    // `limit` or more (moves are never NaN); the window of pixel x spans columns
    // x … x + 2.
    let column = |m: &[&[T]; 3], limit: T, x: usize| {
        m.iter().any(|row| row.get(x).is_none_or(|&v| v >= limit))
    };
    let mut moved = match &reuse {
        Some((Some(m), _, _, (_, loose), _)) => [column(m, *loose, 0), column(m, *loose, 1)],
        _ => [true; 2],
    };
    for (x, next) in next.iter_mut().enumerate() {
        if let Some((Some(m), e, damped, (settled, loose), _)) = &reuse {
            let right = column(m, *loose, x + 2);
            let centre = m[1].get(x + 1).is_none_or(|&v| v >= *settled);
            let window = moved[0] | moved[1] | right | centre;
            moved = [moved[1], right];
            // `next` holds the pixel's disparity already.
            if !window {
                if let (Some((out, confidence)), Some(&d), Some(&e), Some(&damped)) =
                    (&mut outputs, d1.get(x + 1), e.get(x), damped.get(x))
                {
                    if let (Some(out), Some(confidence)) = (out.get_mut(x), confidence.get_mut(x)) {
                        step.output(d, e, damped, out, confidence);
                    }
                }
                continue;
            }
        }
        let (Some(d0), Some(d1), Some(d2), Some(s0), Some(s1), Some(s2)) = (
            three_at(d0, x),
            three_at(d1, x),
            three_at(d2, x),
            three_stats_at(s0, x),
            three_stats_at(s1, x),
            three_stats_at(s2, x),
        ) else {
            continue;
        };
        let d = d1[1];
        let rows = ([d0, d1, d2], [s0, s1, s2]);
        let sum = window_rows(&rows, d, gate, None);
        let (n, e, damped) = step.update(d, sum, |f| window_rows(&rows, d, gate, Some(f)));
        *next = n;
        if let Some((_, ke, kd, _, true)) = &mut reuse {
            if let (Some(ke), Some(kd)) = (ke.get_mut(x), kd.get_mut(x)) {
                (*ke, *kd) = (e, damped);
            }
        }
        if let Some((out, confidence)) = &mut outputs {
            if let (Some(out), Some(confidence)) = (out.get_mut(x), confidence.get_mut(x)) {
                step.output(n, e, damped, out, confidence);
            }
        }
    }
}

/// [`window_sum`] pixel by pixel.
#[inline]
#[allow(clippy::too_many_arguments)]
fn window_sum_each<T: Scalar>(
    stats: &[T],
    previous: &[T],
    width: usize,
    ys: Range<usize>,
    xs: Range<usize>,
    d: T,
    gate: T,
    scale: Option<T>,
) -> [T; STATS] {
    let mut sum = [T::ZERO; STATS];
    for yy in ys {
        for xx in xs.clone() {
            let j = yy * width + xx;
            // The window lies within the region, which `previous` covers.
            let Some(&p) = previous.get(j) else { continue };
            if (p - d).abs() > gate {
                continue;
            }
            let Some(stat) = stats.get(j * STATS..(j + 1) * STATS) else {
                continue;
            };
            add_stats(&mut sum, stat, scale);
        }
    }
    sum
}

/// Refines the rows `rows` of `disparity` (the whole EPI map, row-major) into `out`
/// and `confidence` (`rows.len() · width` each, first row of the band first), keeping
/// the result in `range` (the EPI stage's output range), computing in `T`. `scratch`
/// needs [`scratch_len`] elements.
#[allow(clippy::too_many_arguments)]
pub fn refine_band<T: Scalar, S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    disparity: &[f32],
    rows: Range<usize>,
    out: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
) -> Result<()> {
    check_inputs(plan, lf, range, disparity)?;
    let p = &plan.params().refine;
    let photo = Rectified {
        views: Views::<T>::new(plan.layout(), p.views).with_slack(p.sampling_slack),
        data: lf.data(),
    };
    band(
        plan, &photo, range, disparity, rows, out, confidence, scratch,
    )
}

/// [`refine_band`] on an aligned array: `lf` holds the INPUT views and `homographies`
/// (one per view, rectified → view pixels, as [`crate::align::warp_rows`] takes them)
/// rectify them; every compared view (the centre one too) is sampled through its
/// homography at the disparity-shifted position, one interpolation of the input instead
/// of a second one of a warped copy (which spreads occlusion edges by a different
/// amount in every view: docs/stages/align.md), with `interpolation`
/// (Catmull–Rom keeps the texture's contrast at every sub-pixel phase, which the
/// Gauss–Newton steps need: it loses much less to the misalignment than bilinear).
/// Slower than the rectified path (three samples and three projections per view and
/// pixel). Not yet used by the pipelines: the EPI stage and the others still read the
/// warped copy.
#[allow(clippy::too_many_arguments)]
pub fn refine_band_mapped<T: Scalar, S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    homographies: &[Homography],
    interpolation: Interpolation,
    range: (f32, f32),
    disparity: &[f32],
    rows: Range<usize>,
    out: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
) -> Result<()> {
    check_inputs(plan, lf, range, disparity)?;
    check_homographies(plan, homographies)?;
    let photo = Mapped {
        views: Views::<T>::new(plan.layout(), plan.params().refine.views),
        data: lf.data(),
        maps: homographies,
        interpolation,
    };
    band(
        plan, &photo, range, disparity, rows, out, confidence, scratch,
    )
}

fn check_homographies(plan: &Plan, homographies: &[Homography]) -> Result<()> {
    let views = plan.layout().grid.len();
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

/// The body of [`refine_band`] over the views `photo` compares.
#[allow(clippy::too_many_arguments)]
fn band<T: Scalar, P: Photometric<T>>(
    plan: &Plan,
    photo: &P,
    range: (f32, f32),
    disparity: &[f32],
    rows: Range<usize>,
    out: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
) -> Result<()> {
    let (width, height) = (plan.layout().width, plan.layout().height);
    if rows.start >= rows.end || rows.end > height {
        return Err(Error::OutOfRange {
            what: "band end row",
            index: rows.end,
            len: height,
        });
    }
    let p = plan.params().refine;
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
    let halo = halo(plan);
    let first = rows.start.saturating_sub(halo);
    let last = (rows.end + halo).min(height);
    let region = last - first;
    let pixels = region * width;
    let needed = pixels * (2 + STATS + MEMORY);
    check_scratch(needed, scratch.len())?;
    let input = disparity
        .get(first * width..last * width)
        .ok_or(Error::OutputSize {
            what: "the input disparity",
            needed: last * width,
            got: disparity.len(),
        })?;
    if input.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            what: "the input disparity",
        });
    }
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

    let r = p.radius;
    let views = photo.views();
    let area = ((2 * r + 1) * (2 * r + 1)) as f32;
    let (narrow, wide) = (
        Counts::<T>::new(&views.terms, area, 0),
        Counts::<T>::new(&views.terms, area, WIDE_SHIFT),
    );
    let wide_limit = T::MAX * T::from_f32(libm::ldexpf(1.0, -WIDE_LIMIT_SHIFT));
    let k = Constants::<T>::new(&p, plan.layout().channels.min(3), range);
    let used = plan.layout().channels.min(3) as f32;
    let memberships = views.terms.iter().sum::<f32>() / used;
    let robust = p.robust_scale * p.robust_scale * used * INTENSITY_SCALE * INTENSITY_SCALE;
    let scale = photo::cost_scale(if p.robust_scale > 0.0 { robust } else { 0.0 }, memberships);
    // The robust scale with and without the cost's scale.
    let cost_robust = (k.robust, k.robust * T::from_f32(scale));
    let stat_robust = (k.robust, k.robust * T::from_f32(k.stat_scale));
    // A cost from the statistics' residual energies: the same weighted terms, scaled by
    // the statistics' power of two instead of the cost's (both powers of two).
    let cost_per_energy = T::from_f32(scale / k.stat_scale);
    // Region rows (relative to `first`) within `reach` rows of the band.
    let near = |reach: usize| -> Range<usize> {
        let lo = rows.start.saturating_sub(reach).max(first) - first;
        let hi = (rows.end + reach).min(last) - first;
        lo..hi
    };
    // Propagation: each pixel tries the disparities of its four neighbours at each
    // jump and keeps the one the views agree on best (robust cost of the pixel alone),
    // which pulls wrong regions to their surroundings' disparity.
    // `memory[i · MEMORY]` holds the state of pixel i's cost at its current disparity:
    // `unknown`, `fresh` (its statistics were measured there: the cost is their residual
    // energy, and the first iteration need not measure them again) or the cost itself
    // (non-negative: a candidate's, accepted). It is read and written only for pixel i,
    // so the order of pixels does not matter.
    // A round only visits the rows that the later rounds and the iterations can still
    // carry to the band (it reads its neighbours up to `jump` rows further, which the
    // round before visited): the rows outside would not change the result.
    // The cost of a pixel at its own disparity is only needed once a neighbour offers
    // another one. It comes from the statistics, not from `Photometric::cost`: the
    // first iteration needs them at that disparity unless a candidate wins (HCI
    // backgammon: 154 k of its 271 k measurements), and they cost about 1.5 times a cost.
    // Always, whatever row the pixel is in, so that every band decides alike.
    // `memory[i · MEMORY + 1..][..REMEMBERED]` hold the last candidates pixel i rejected
    // (`MAX` for none): a round visits a subset of the rows the round before visited,
    // so every band sees the same history for the rows it keeps.
    let (unknown, fresh) = (-T::ONE, -(T::ONE + T::ONE));
    let jumps = jumps(plan);
    let reach_after = |round: usize| -> usize {
        p.iterations * r
            + jumps
                .get(round + 1..)
                .map_or(0, |j| j.iter().sum::<usize>())
    };
    if !jumps.is_empty() {
        let span = near(reach_after(0));
        let near_memory = memory
            .get_mut(span.start * width * MEMORY..span.end * width * MEMORY)
            .unwrap_or_default();
        for kept in near_memory.chunks_exact_mut(MEMORY) {
            kept[0] = unknown;
            if let Some(rejected) = kept.get_mut(1..) {
                rejected.fill(T::MAX);
            }
        }
    }
    for (round, &jump) in jumps.iter().enumerate() {
        previous.copy_from_slice(current);
        for y in near(reach_after(round)) {
            for x in 0..width {
                let i = y * width + x;
                // `near` rows lie within the region, which `previous` covers.
                let Some(&own) = previous.get(i) else {
                    continue;
                };
                // A missing neighbour (past the region) offers the pixel's own value,
                // which the gate skips.
                let at = |j: Option<usize>| j.and_then(|j| previous.get(j)).copied();
                let candidates = [
                    at(x.checked_sub(jump).map(|xx| y * width + xx)).unwrap_or(own),
                    at((x + jump < width).then(|| i + jump)).unwrap_or(own),
                    at(y.checked_sub(jump).map(|yy| yy * width + x)).unwrap_or(own),
                    at((y + jump < region).then(|| i + jump * width)).unwrap_or(own),
                ];
                // Most pixels agree with all four: one test for them (fewer mispredicted
                // branches than four). A loop rather than `array::map`, which the
                // compiler left as a call per pixel (1.8 % of the stage's instructions).
                // A pair of opposite neighbours on a line through the pixel (second
                // difference within the offer's gate) offers nothing: on a slanted
                // surface their disparities are those of other points of the same
                // plane, which do not fit this pixel better (cotton: 9 % fewer first-round
                // costs, BadPix0.07 1.910 → 1.892, `docs/stages/refine.md`).
                let bent = (
                    (candidates[0] + candidates[1] - own - own).abs() > k.offer,
                    (candidates[2] + candidates[3] - own - own).abs() > k.offer,
                );
                let mut offers = [false; 4];
                for (n, (offer, &d)) in offers.iter_mut().zip(&candidates).enumerate() {
                    let pair_bent = if n < 2 { bent.0 } else { bent.1 };
                    *offer = pair_bent && (d - own).abs() > k.offer;
                }
                if offers == [false; 4] {
                    continue;
                }
                let (Some(kept), Some(stat)) = (
                    memory
                        .get_mut(i * MEMORY..)
                        .and_then(|s| s.first_chunk_mut::<MEMORY>()),
                    stats
                        .get_mut(i * STATS..)
                        .and_then(|s| s.first_chunk_mut::<STATS>()),
                ) else {
                    continue;
                };
                // Disparities already tried this round, and the last ones rejected in
                // earlier rounds: one within `SAME_CANDIDATE` of those is not tried (an
                // equal one would give the same cost, which cannot pass the bar a second
                // time: the bar only falls).
                let mut tried = [own; 4];
                let mut bar = None;
                for (n, (d, offer)) in candidates.into_iter().zip(offers).enumerate() {
                    let near = |t: &T| (*t - d).abs() <= k.same;
                    if !offer
                        || tried.get(..n).is_some_and(|t| t.iter().any(near))
                        || kept[1..].iter().any(near)
                    {
                        continue;
                    }
                    if let Some(t) = tried.get_mut(n) {
                        *t = d;
                    }
                    if kept[0] == unknown {
                        photo.pixel(x, first + y, own, stat_robust, stat);
                        kept[0] = fresh;
                    }
                    let limit = *bar.get_or_insert_with(|| {
                        let own_cost = if kept[0] == fresh {
                            (0..GROUPS).fold(T::ZERO, |e, g| e + stat[3 * g + 2]) * cost_per_energy
                        } else {
                            kept[0]
                        };
                        own_cost * k.accept
                    });
                    if let Some(c) = photo.cost(x, first + y, d, cost_robust, Some(limit)) {
                        bar = Some(c);
                        kept[0] = c;
                        if let Some(current) = current.get_mut(i) {
                            *current = d;
                        }
                    } else {
                        // The newest first, the oldest dropped (element by element:
                        // `rotate_right` costs a call per rejection).
                        for j in (2..MEMORY).rev() {
                            kept[j] = kept[j - 1];
                        }
                        kept[1] = d;
                    }
                }
            }
        }
    }
    // See `RefineParams::skip_settled` (nothing settles before the second iteration).
    let skip = p.skip_settled > 0.0 && p.iterations > 1;
    let skip_moved = T::from_f32(p.skip_settled);
    for iteration in 0..p.iterations {
        // Rows whose statistics the remaining iterations can still reach the band from.
        let measured = near((p.iterations - iteration) * r);
        let updated = near((p.iterations - iteration - 1) * r);
        let last_iteration = iteration + 1 == p.iterations;
        let settled = if last_iteration {
            k.settled
        } else {
            k.settled_early
        };
        // Per-pixel normal equations at each pixel's own disparity.
        for y in measured.clone() {
            for x in 0..width {
                let i = y * width + x;
                // A pixel that moved by less than `SETTLED` (`SETTLED_EARLY` before
                // the last iteration) since its statistics were measured keeps them
                // (every row measured now was measured and updated by the iteration
                // before): to first order `B` does not change with
                // `d` (`r` grows by `g·Δd`), and the step from the stale `A`, `B` is
                // that from the fresh ones within a few `SETTLED`.
                // `measured` rows lie within the region, which the tables cover.
                let (Some(&now), Some(&before), Some(stat)) = (
                    current.get(i),
                    previous.get(i),
                    stats
                        .get_mut(i * STATS..)
                        .and_then(|s| s.first_chunk_mut::<STATS>()),
                ) else {
                    continue;
                };
                if iteration > 0 {
                    let moved = (now - before).abs();
                    // How far the pixel moved, for the windows of `skip_settled` (the
                    // first plane of `memory`: the propagation's state is no longer read).
                    if skip {
                        if let Some(m) = memory.get_mut(i) {
                            *m = moved;
                        }
                    }
                    if moved < settled {
                        continue;
                    }
                }
                // The propagation measured them at this disparity (the same bits as now):
                // `memory` covers these rows when there was a propagation.
                if iteration == 0
                    && !jumps.is_empty()
                    && memory.get(i * MEMORY).is_some_and(|&m| m == fresh)
                {
                    continue;
                }
                photo.pixel(x, first + y, now, stat_robust, stat);
            }
        }
        let span = measured.start * width..measured.end * width;
        if let (Some(to), Some(from)) = (previous.get_mut(span.clone()), current.get(span)) {
            to.copy_from_slice(from);
        }
        // With `skip_settled`, `memory` holds three planes from here: how far each pixel
        // moved in the iteration before (written by the statistics pass after the first
        // iteration), and each pixel's last `E` and `A` + damping, which a pixel whose
        // window settled keeps for its confidence.
        let (moved, planes) = memory.split_at_mut_checked(pixels).unwrap_or_default();
        let (kept_e, kept_damped) = planes.split_at_mut_checked(pixels).unwrap_or_default();
        let (check, store) = (skip && iteration > 0, skip && !last_iteration);
        let loose = if skip_moved > settled {
            skip_moved
        } else {
            settled
        };
        let step = Step {
            k: &k,
            narrow: &narrow,
            wide: &wide,
            wide_limit,
            occlusion: p.occlusion,
            range,
        };
        for y in updated {
            // A row whose pixels have whole 3 × 3 windows (radius 1, not at the
            // region's ends): its interior pixels go to `update_row`, which walks the
            // three rows' slices side by side (no per-window offsets or bounds checks);
            // only the first and the last pixel take `window_sum` here.
            let interior = if r == 1 && y + 1 < region && width >= 3 {
                three_rows(previous, stats, width, y)
            } else {
                None
            };
            let stride = if interior.is_some() { width - 1 } else { 1 };
            for x in (0..width).step_by(stride.max(1)) {
                // Window sum over the neighbours whose disparity is within
                // `WINDOW_GATE` of this pixel's: the window does not reach across depth
                // edges.
                let j = y * width + x;
                let Some(&d) = previous.get(j) else {
                    continue;
                };
                let (ys, xs) = (
                    y.saturating_sub(r)..(y + r + 1).min(region),
                    x.saturating_sub(r)..(x + r + 1).min(width),
                );
                if check {
                    let mut window = ys.clone().flat_map(|yy| {
                        let row = moved.get(yy * width..(yy + 1) * width).unwrap_or_default();
                        row.get(xs.clone()).unwrap_or_default().iter()
                    });
                    // `current` holds `d` already (copied above).
                    let centre = moved.get(j).is_some_and(|&m| m < settled);
                    if centre && window.all(|&m| m < loose) {
                        if last_iteration {
                            let o = (first + y - rows.start) * width + x;
                            if let (Some(out), Some(confidence), Some(&e), Some(&damped)) = (
                                out.get_mut(o),
                                confidence.get_mut(o),
                                kept_e.get(j),
                                kept_damped.get(j),
                            ) {
                                step.output(d, e, damped, out, confidence);
                            }
                        }
                        continue;
                    }
                }
                let sum = window_sum(
                    stats,
                    previous,
                    width,
                    ys.clone(),
                    xs.clone(),
                    d,
                    k.gate,
                    None,
                );
                let (next, e, damped) = step.update(d, sum, |f| {
                    window_sum(stats, previous, width, ys, xs, d, k.gate, Some(f))
                });
                if let Some(current) = current.get_mut(j) {
                    *current = next;
                }
                if let (true, Some(ke), Some(kd)) =
                    (store, kept_e.get_mut(j), kept_damped.get_mut(j))
                {
                    (*ke, *kd) = (e, damped);
                }
                if last_iteration {
                    let o = (first + y - rows.start) * width + x;
                    if let (Some(out), Some(confidence)) = (out.get_mut(o), confidence.get_mut(o)) {
                        step.output(next, e, damped, out, confidence);
                    }
                }
            }
            let Some((ds, ss)) = interior else {
                continue;
            };
            let inner = |at: usize| at + 1..at + width - 1;
            let next = current.get_mut(inner(y * width)).unwrap_or_default();
            let outputs = if last_iteration {
                let o = (first + y - rows.start) * width;
                match (out.get_mut(inner(o)), confidence.get_mut(inner(o))) {
                    (Some(out), Some(confidence)) => Some((out, confidence)),
                    _ => None,
                }
            } else {
                None
            };
            let reuse = if skip {
                let moved = check.then(|| rows_around(moved, width, y)).flatten();
                match (
                    kept_e.get_mut(inner(y * width)),
                    kept_damped.get_mut(inner(y * width)),
                ) {
                    (Some(e), Some(damped)) => Some(Reuse {
                        moved,
                        e,
                        damped,
                        settled,
                        loose,
                        store,
                    }),
                    _ => None,
                }
            } else {
                None
            };
            update_row(&step, ds, ss, next, outputs, reuse);
        }
    }
    Ok(())
}

/// Sums the groups that see the pixel: all of them, or without the worse half of the
/// left/right and up/down pairs when it fits much worse (an occluder). When the
/// horizontal and vertical views then disagree on the disparity by more than
/// [`AXIS_AGREEMENT`], only the axis with the smaller error `E / A` is kept: along
/// edges parallel to an axis, that axis' views only see aliasing and noise.
/// Returns `(A, B, E, terms)` (the terms scaled like the statistics).
#[inline]
fn select<T: Scalar>(
    sum: &[T; STATS],
    counts: &Counts<T>,
    k: &Constants<T>,
    occlusion: bool,
    d: T,
) -> (T, T, T, T) {
    let mut keep = [true; GROUPS];
    if occlusion {
        for pair in [[0, 1], [2, 3]] {
            // Groups are 0…GROUPS − 1: the defaults never happen.
            let mean = |g: usize| match (sum.get(3 * g + 2), counts.means.get(g)) {
                (Some(&e), Some(&m)) => e / m,
                _ => T::ZERO,
            };
            let (m0, m1) = (mean(pair[0]), mean(pair[1]));
            let drop = if m0 > k.occlusion_ratio * m1 + k.occlusion_floor {
                keep.get_mut(pair[0])
            } else if m1 > k.occlusion_ratio * m0 + k.occlusion_floor {
                keep.get_mut(pair[1])
            } else {
                None
            };
            if let Some(keep) = drop {
                *keep = false;
            }
        }
    }
    let axis = |groups: [usize; 2]| {
        let (mut a, mut b, mut e, mut n) = (T::ZERO, T::ZERO, T::ZERO, T::ZERO);
        for g in groups {
            let (Some(true), Some(group), Some(&terms)) = (
                keep.get(g).copied(),
                sum.get(3 * g..3 * g + 3),
                counts.terms.get(g),
            ) else {
                continue;
            };
            if let [ga, gb, ge] = *group {
                a += ga;
                b += gb;
                e += ge;
                n += terms;
            }
        }
        (a, b, e, n)
    };
    let h = axis([0, 1]);
    let v = axis([2, 3]);
    let damping = k.damping;
    let solve = |s: (T, T, T, T)| (s.1 + damping * s.3 * d) / (s.0 + damping * s.3);
    let error = |s: (T, T, T, T)| s.2 / (s.0 + damping * s.3);
    if h.3 > T::ZERO && v.3 > T::ZERO && (solve(h) - solve(v)).abs() > k.axis_agreement {
        return if error(h) <= error(v) { h } else { v };
    }
    (h.0 + v.0, h.1 + v.1, h.2 + v.2, h.3 + v.3)
}

/// The serial stage with progress: every band in order into `out` / `confidence`
/// (row-major, `plan.pixels()` each).
#[allow(clippy::too_many_arguments)]
pub fn refine_with_progress<T: Scalar, S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    disparity: &[f32],
    out: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<()> {
    check_inputs(plan, lf, range, disparity)?;
    let pixels = plan.pixels();
    if out.len() != pixels || confidence.len() != pixels {
        return Err(Error::OutputSize {
            what: "the refined disparity/confidence",
            needed: pixels,
            got: out.len().min(confidence.len()),
        });
    }
    let width = plan.layout().width;
    let bands = band_count(plan);
    for band in 0..bands {
        let report = Progress {
            stage: STAGE,
            done: band as u64,
            total: bands as u64,
        };
        if progress(report).is_break() {
            return Err(Error::Cancelled);
        }
        let rows = band_rows(plan, band)?;
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
        refine_band(plan, lf, range, disparity, rows, out, confidence, scratch)?;
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

/// The serial stage: refines `disparity` into `out` with a new `confidence`, computing
/// in `T`.
pub fn refine<T: Scalar, S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    disparity: &[f32],
    out: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
) -> Result<()> {
    refine_with_progress(
        plan,
        lf,
        range,
        disparity,
        out,
        confidence,
        scratch,
        &mut |_| ControlFlow::Continue(()),
    )
}

#[cfg(test)]
mod fixed_tests;
#[cfg(test)]
mod tests;
