//! Scoring a hypothesis: the residual slope and coherence of the smoothed tensor, and each
//! sample's best candidate so far (a zero crossing of the residual between two shears
//! ranked above a single hypothesis' estimate).

use super::estimator::LineEstimator;
use super::tensor::Tensor;
use crate::epi::hypotheses::Hypotheses;
use crate::epi::INTENSITY_SCALE;
use crate::scalar::Scalar;
use core::ops::Range;

/// Ranking offsets below a zero crossing's score (in [0, 1]): a single hypothesis
/// (`coherence − 1`), an estimate outside its hypothesis' window (`coherence − 2`) and a
/// degenerate tensor (no texture, or an orientation the window can never hold).
pub(super) const SINGLE: f32 = -1.0;
pub(super) const OUT_OF_WINDOW: f32 = -2.0;
pub(super) const DEGENERATE: f32 = -3.0;
/// Traces up to this are degenerate (no texture): 10⁻⁶ at an intensity scale of 64, scaled
/// with the trace (the square of the intensity scale) so that `f32` decides the same at
/// any intensity scale.
const TINY_TRACE: f32 = 1e-6 * (INTENSITY_SCALE / 64.0) * (INTENSITY_SCALE / 64.0);
/// Residual slope and coherence of the smoothed tensor at the samples `range` into
/// `tensor.jxx` / `tensor.jxk` (coherence < 0 marks a degenerate tensor: no texture, or an
/// orientation no window holds). Normalised by the trace so that fixed point never
/// overflows: a, b ∈ [−1, 1], coherence √(a² + b²) ∈ [0, 1], and the slope of the dominant
/// eigenvector is b / (a + √…) = 2Jxk / (Jxx − Jkk + √…).
fn slopes<T: Scalar>(tensor: &mut Tensor<'_, T>, range: Range<usize>) {
    let Tensor {
        jxx,
        jxk,
        sxx,
        sxk,
        skk,
        ..
    } = tensor;
    let (Some(sxx), Some(sxk), Some(skk), Some(slope), Some(coherence)) = (
        sxx.get(range.clone()),
        sxk.get(range.clone()),
        skk.get(range.clone()),
        jxx.get_mut(range.clone()),
        jxk.get_mut(range),
    ) else {
        return;
    };
    let sums = sxx.iter().zip(sxk).zip(skk);
    let out = slope.iter_mut().zip(coherence.iter_mut());
    if T::IS_F32 {
        // `T` is `f32` (its conversions are the identity): the same formulas without
        // branches so that the loop vectorises: every division by a safe denominator (1
        // where the scalar form does not divide) and `lane_sqrt` (the `libm` square root
        // is inline assembly on x86, which no loop vectorises).
        let tiny_trace = TINY_TRACE.max(f32::EPSILON);
        let min_den = 1.0 / 64.0;
        for (((&xx, &xk), &kk), (r, c)) in sums.zip(out) {
            let (xx, xk, kk) = (xx.to_f32(), xk.to_f32(), kk.to_f32());
            let trace = xx + kk;
            let flat = trace <= tiny_trace;
            let safe_trace = if flat { 1.0 } else { trace };
            let a = (xx - kk) / safe_trace;
            let b = 2.0 * xk / safe_trace;
            let root = lane_sqrt(a * a + b * b);
            // `Scalar::min` with one: a NaN root gives one.
            #[allow(clippy::eq_op)]
            let coherence = if (root != root) | (1.0 < root) {
                1.0
            } else {
                root
            };
            let den = a + coherence;
            let bent = den <= min_den;
            let slope = b / if bent { 1.0 } else { den };
            let valid = !(flat | bent);
            *r = T::from_f32(if valid { slope } else { 0.0 });
            *c = T::from_f32(if valid { coherence } else { DEGENERATE });
        }
        return;
    }
    let degenerate = T::from_f32(DEGENERATE);
    let tiny_trace = T::from_f32(TINY_TRACE).max(T::EPSILON);
    let min_den = T::from_f32(1.0 / 64.0);
    let two = T::from_i32(2);
    for (((&xx, &xk), &kk), (r, c)) in sums.zip(out) {
        let trace = xx + kk;
        (*r, *c) = if trace <= tiny_trace {
            (T::ZERO, degenerate)
        } else {
            let a = (xx - kk) / trace;
            let b = two * xk / trace;
            let coherence = (a * a + b * b).sqrt().min(T::ONE);
            let den = a + coherence;
            if den <= min_den {
                (T::ZERO, degenerate)
            } else {
                (b / den, coherence)
            }
        };
    }
}

/// All bits set where `condition` holds (for [`lane_pick`]).
#[inline(always)]
fn lane_mask(condition: bool) -> u32 {
    0u32.wrapping_sub(u32::from(condition))
}

/// `a` where `mask` is set, else `b`, by bits: a select the vectoriser keeps as one
/// (`if` on a value loaded from the stored slot became a conditional store).
#[inline(always)]
fn lane_pick(mask: u32, a: f32, b: f32) -> f32 {
    f32::from_bits((a.to_bits() & mask) | (b.to_bits() & !mask))
}

/// `√x` (0 for `x` below the smallest normal `f32`, NaN included) in plain arithmetic
/// that vectorises: the bit-level first guess of `1/√x`, three Newton steps, `x·(1/√x)`
/// and one Newton correction of the root; within an ulp or two of the correctly rounded
/// root, the same bits on every target.
#[inline(always)]
pub(in crate::epi) fn lane_sqrt(x: f32) -> f32 {
    let normal = x >= f32::MIN_POSITIVE;
    let x = if normal { x } else { 1.0 };
    let mut y = f32::from_bits(0x5f37_5a86u32.wrapping_sub(x.to_bits() >> 1));
    let half = 0.5 * x;
    for _ in 0..3 {
        y *= 1.5 - half * y * y;
    }
    let root = x * y;
    let root = root + 0.5 * y * (x - root * root);
    if normal {
        root
    } else {
        0.0
    }
}

/// Per sample: the best candidate so far (`best_d`, `best_c`, ranked by `score`), and the
/// residual and coherence at the previous hypothesis (`prev_c < 0`: none usable).
pub(super) struct State<'a, T> {
    pub(super) best_d: &'a mut [T],
    pub(super) best_c: &'a mut [T],
    pub(super) score: &'a mut [T],
    pub(super) prev_r: &'a mut [T],
    pub(super) prev_c: &'a mut [T],
}

impl<T: Scalar> LineEstimator<T> {
    /// Scores hypothesis `i` of `hyps` at the samples `range` from the smoothed tensor.
    pub(super) fn score(
        &self,
        hyps: &Hypotheses,
        i: usize,
        tensor: &mut Tensor<'_, T>,
        state: &mut State<'_, T>,
        range: Range<usize>,
    ) {
        let window = T::from_f32(hyps.window());
        let step = T::from_f32(hyps.step());
        let degenerate = T::from_f32(DEGENERATE);
        let single = T::from_f32(SINGLE);
        let out_of_window = T::from_f32(OUT_OF_WINDOW);
        let min_gap = T::from_f32(1.0 / 256.0);
        let shear_t = T::from_f32(hyps.shear(i));
        let previous_shear = T::from_f32(hyps.shear(i.saturating_sub(1)));
        // The raw sums of the run are used up (the next run recomputes its own span):
        // their lines take each sample's residual slope and coherence.
        slopes(tensor, range.clone());
        let (slope, coherence_line) = (&tensor.jxx[..], &tensor.jxk[..]);
        if T::IS_F32 {
            self.score_lanes(hyps, i, slope, coherence_line, state, range);
            return;
        }
        let State {
            best_d,
            best_c,
            score,
            prev_r,
            prev_c,
        } = state;
        for t in range {
            // Every slice is `n` long and `range.end ≤ n`: the checked accesses never miss
            // (they replace the bounds checks' panics).
            let (Some(&r), Some(&coherence)) = (slope.get(t), coherence_line.get(t)) else {
                continue;
            };
            let (Some(score), Some(best_d), Some(best_c), Some(prev_r), Some(prev_c)) = (
                score.get_mut(t),
                best_d.get_mut(t),
                best_c.get_mut(t),
                prev_r.get_mut(t),
                prev_c.get_mut(t),
            ) else {
                continue;
            };
            let valid = coherence >= T::ZERO;
            let inside = valid && r.abs() <= window;
            let (mut cand_score, mut cand_d) = if !valid {
                (degenerate, shear_t)
            } else if inside {
                (coherence + single, shear_t + r)
            } else {
                (
                    coherence + out_of_window,
                    shear_t + r.clamp(-window, window),
                )
            };
            if self.interpolate {
                // The residual slope falls linearly through zero between the two
                // shears that bracket the disparity; its zero crossing cancels the
                // tensor's slope-proportional bias.
                let (pr, pc) = (*prev_r, *prev_c);
                if inside && pc >= T::ZERO && pr >= T::ZERO && r <= T::ZERO {
                    let gap = pr - r;
                    if gap > min_gap {
                        let crossing = previous_shear + step * (pr / gap).min(T::ONE);
                        let both = pc.min(coherence);
                        if both > cand_score {
                            cand_score = both;
                            cand_d = crossing;
                        }
                    }
                }
            }
            if cand_score > *score {
                *score = cand_score;
                *best_d = cand_d;
                *best_c = coherence.max(T::ZERO);
            }
            if inside {
                *prev_r = r;
                *prev_c = coherence;
            } else {
                *prev_c = degenerate;
            }
        }
    }

    /// The candidates of [`Self::score`] for `f32` (`T` is `f32`: its conversions are the
    /// identity), without branches so that the loop vectorises: the same decisions and
    /// values, selects instead of branches (the state's as bit masks, which keep the
    /// stores unconditional: a conditional store keeps the loop scalar) and the crossing's
    /// division by a safe denominator. Scores every sample of `range`.
    fn score_lanes(
        &self,
        hyps: &Hypotheses,
        i: usize,
        slope: &[T],
        coherence_line: &[T],
        state: &mut State<'_, T>,
        range: Range<usize>,
    ) {
        let window = hyps.window();
        let step = hyps.step();
        let min_gap = 1.0 / 256.0;
        let shear = hyps.shear(i);
        let previous_shear = hyps.shear(i.saturating_sub(1));
        let interpolate = self.interpolate;
        let State {
            best_d,
            best_c,
            score,
            prev_r,
            prev_c,
        } = state;
        let (Some(slope), Some(coherence_line)) =
            (slope.get(range.clone()), coherence_line.get(range.clone()))
        else {
            return;
        };
        let (Some(score), Some(best_d), Some(best_c), Some(prev_r), Some(prev_c)) = (
            score.get_mut(range.clone()),
            best_d.get_mut(range.clone()),
            best_c.get_mut(range.clone()),
            prev_r.get_mut(range.clone()),
            prev_c.get_mut(range),
        ) else {
            return;
        };
        let states = score
            .iter_mut()
            .zip(best_d.iter_mut())
            .zip(best_c.iter_mut())
            .zip(prev_r.iter_mut().zip(prev_c.iter_mut()));
        for ((&r, &coherence), (((score, best_d), best_c), (prev_r, prev_c))) in
            slope.iter().zip(coherence_line).zip(states)
        {
            let (r, coherence) = (r.to_f32(), coherence.to_f32());
            let valid = coherence >= 0.0;
            let magnitude = if r < 0.0 { -r } else { r };
            let inside = valid & (magnitude <= window);
            let clamped = if -window > r { -window } else { r };
            let clamped = if window < clamped { window } else { clamped };
            let (rank, offset) = if inside {
                (SINGLE, r)
            } else {
                (OUT_OF_WINDOW, clamped)
            };
            let cand_score = if valid { coherence + rank } else { DEGENERATE };
            let cand_d = if valid { shear + offset } else { shear };
            // The residual slope falls linearly through zero between the two shears that
            // bracket the disparity; its zero crossing cancels the tensor's
            // slope-proportional bias.
            let (pr, pc) = (prev_r.to_f32(), prev_c.to_f32());
            let gap = pr - r;
            let cross =
                interpolate & inside & (pc >= 0.0) & (pr >= 0.0) & (r <= 0.0) & (gap > min_gap);
            let fraction = pr / if cross { gap } else { 1.0 };
            let fraction = if 1.0 < fraction { 1.0 } else { fraction };
            let crossing = previous_shear + step * fraction;
            let both = if coherence < pc { coherence } else { pc };
            let take = cross & (both > cand_score);
            let cand_score = if take { both } else { cand_score };
            let cand_d = if take { crossing } else { cand_d };
            let better = lane_mask(cand_score > score.to_f32());
            let confidence = if 0.0 > coherence { 0.0 } else { coherence };
            *best_d = T::from_f32(lane_pick(better, cand_d, best_d.to_f32()));
            *best_c = T::from_f32(lane_pick(better, confidence, best_c.to_f32()));
            *score = T::from_f32(lane_pick(better, cand_score, score.to_f32()));
            *prev_r = T::from_f32(lane_pick(lane_mask(inside), r, prev_r.to_f32()));
            *prev_c = T::from_f32(if inside { coherence } else { DEGENERATE });
        }
    }
}
