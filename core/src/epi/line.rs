//! The structure tensor of one EPI line: disparity and coherence of every sample of the
//! centre view along one image row (horizontal EPI) or column (vertical EPI), tested over
//! every shear hypothesis.

use super::band::Band;
use super::hypotheses::Hypotheses;
use super::kernels::{apply_pair, centre_weights, deinterleave, truncated_gaussian, Kernel};
use super::planes::{shift, Planes, Sources};
use super::{ColorMode, EpiParams, Search, INTENSITY_SCALE};
use crate::error::{check_scratch, Error, Result};
use crate::lightfield::GRID_MAX;
use crate::scalar::Scalar;
use core::ops::Range;

/// Everything that does not change from line to line, converted to `T` once.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LineEstimator<T: Scalar> {
    derivative: Kernel<T>,
    smoothing: Kernel<T>,
    outer: Kernel<T>,
    band: Band<T>,
    views: usize,
    centre: usize,
    channels: usize,
    hypotheses: Hypotheses,
    interpolate: bool,
    /// Whether some hypothesis shifts a view by a half-integer.
    half_shifts: bool,
    /// The views some hypothesis (fine, or coarse when its gray planes read them) shifts
    /// by a half-integer: only their half-shifted planes are filled.
    half_views: [bool; GRID_MAX],
    /// Whether some hypothesis reads a view at an offset the stored planes do not hold
    /// (the fallback planes then exist).
    fallback: bool,
    coarse: Option<Coarse<T>>,
}

/// Whether some hypothesis of `hyps` shifts view `k` (of the centre `centre`) by a
/// half-integer (the test [`LineEstimator::sources`] makes).
fn half_shift(hyps: &Hypotheses, k: usize, centre: usize) -> bool {
    (0..hyps.count()).any(|i| {
        let offset = (k as f32 - centre as f32) * hyps.shear(i);
        offset - libm::floorf(offset) == 0.5
    })
}

/// Whether some hypothesis of `hyps` reads one of `views` views where the stored planes
/// (`half_ready`: with the half-shifted ones) do not reach (the test
/// [`LineEstimator::sources`] makes).
fn off_planes(
    hyps: &Hypotheses,
    views: usize,
    centre: usize,
    half_ready: bool,
    reach: usize,
) -> bool {
    (0..hyps.count()).any(|i| {
        (0..views).any(|k| {
            let offset = (k as f32 - centre as f32) * hyps.shear(i);
            let floor = libm::floorf(offset);
            let frac = offset - floor;
            let stored = frac == 0.0 || (frac == 0.5 && half_ready);
            !stored || (floor as isize).unsigned_abs() > reach
        })
    })
}

/// The half-shifted views and whether fallback planes are needed, for any hypotheses
/// `params` can make: shears are multiples of `shear_step`, so with `2·shear_step` an
/// integer every offset is a multiple of half a sample (odd ones only at odd distances
/// from the centre, and only when `2·shear_step` is odd), within the stored reach
/// (|shear| ≤ MAX_DISPARITY + 1). The coarse pass's shears are multiples of the fine
/// step too (`Hypotheses::centred`), the range probe's are integers. Any other step may
/// need every kind of plane.
fn planes_bound(params: &EpiParams, views: usize, centre: usize) -> ([bool; GRID_MAX], bool) {
    let mut half = [false; GRID_MAX];
    if !params.shear {
        // One hypothesis at shear 0 (the range probe's are integers).
        return (half, false);
    }
    let twice = 2.0 * params.shear_step;
    let halves = libm::roundf(twice);
    let dyadic = twice == halves;
    let odd = dyadic && (halves as i64) % 2 == 1;
    for (k, h) in half.iter_mut().enumerate().take(views) {
        *h = !dyadic || (odd && k.abs_diff(centre) % 2 == 1);
    }
    (half, !dyadic)
}

/// Whether some hypothesis of `hyps` shifts one of `views` views by a half-integer.
fn shifts_by_halves(hyps: &Hypotheses, views: usize, centre: usize) -> bool {
    (0..views).any(|k| half_shift(hyps, k, centre))
}

/// Ranking offsets below a zero crossing's score (in [0, 1]): a single hypothesis
/// (`coherence − 1`), an estimate outside its hypothesis' window (`coherence − 2`) and a
/// degenerate tensor (no texture, or an orientation the window can never hold).
const SINGLE: f32 = -1.0;
const OUT_OF_WINDOW: f32 = -2.0;
const DEGENERATE: f32 = -3.0;
/// Traces up to this are degenerate (no texture): 10⁻⁶ at an intensity scale of 64, scaled
/// with the trace (the square of the intensity scale) so that `f32` decides the same at
/// any intensity scale.
const TINY_TRACE: f32 = 1e-6 * (INTENSITY_SCALE / 64.0) * (INTENSITY_SCALE / 64.0);
/// Samples per register block of the tensor sums: the gradients and sums of a block are
/// accumulated over every channel and view before they are stored (8: 123–124 ms,
/// 16: 114–121 ms, 32: 128–134 ms CPU per bench estimate, docs/stages/epi.md).
pub(super) const BLOCK: usize = 16;
/// Samples the tensor kernel keeps in registers at a time (a divisor of `BLOCK`).
const LANES: usize = 16;
/// The smallest chunk of the tensor kernel: a span's last samples are computed in chunks
/// of `TAIL` or `2·TAIL` rather than a whole `LANES` chunk overlapping the one before
/// (which recomputed 5.6 % of the fine pass's tensor samples on HCI cotton).
const TAIL: usize = 4;
/// The coarse pass tests shears `COARSE_STEPS` shear steps apart (at most 2 px, the
/// largest step the residual window still covers), as few as cover the range centred on
/// it: 2 and 3 steps gave the same HCI scores as 4 (docs/stages/epi.md).
const COARSE_STEPS: f32 = 4.0;
// The coarse pass scores every second sample along the line (the tensor is smoothed over
// ±3·outer_sigma samples anyway); the others take their left neighbour's: see
// `LineEstimator::coarse_sweep`.
/// The coarse pass sums the tensor of the views at most this far from the centre.
const COARSE_VIEWS: usize = 2;
/// A sample whose coarse estimate lies within this many shear steps of a fine shear is
/// tested at that shear only (its residual there is small, and so is the residual's
/// slope-proportional bias the zero crossing cancels): 31 % / 37 % of the samples of HCI
/// cotton / backgammon, ≈ −5 % CPU, and both HCI scenes a little better, stage and
/// pipeline; 0.2 and 0.25 cost cotton's pipeline MSE +0.03 / +0.08 (docs/stages/epi.md).
const NEAR: f32 = 0.15;
/// A sample the coarse pass brackets between two fine shears is not tested at the upper
/// one when its fine residual slope at the lower one puts it less than this many shear
/// steps above that one (the lower one is then its nearest) with at least
/// `SETTLE_COHERENCE` (see `Guide::settle`): −8 % / −12 % of the fine pass's tensor samples
/// on HCI cotton / backgammon; 0.3 steps without the coherence test cost backgammon's
/// pipeline MSE×100 +0.028, and settling residuals below the lower shear too +0.035
/// (docs/stages/epi.md).
const FINE_NEAR: f32 = 0.5;
/// See `FINE_NEAR`: 0.9 keeps both HCI scenes' pipeline scores within +0.02 MSE×100.
const SETTLE_COHERENCE: f32 = 0.9;
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
    if core::any::TypeId::of::<T>() == core::any::TypeId::of::<f32>() {
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
pub(super) fn lane_sqrt(x: f32) -> f32 {
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

/// The tensor of one hypothesis: raw sums over views (`jxx`, `jxk`, `jkk`, whole blocks)
/// and smoothed along the line (`sxx`, `sxk`, `skk`).
struct Tensor<'a, T> {
    jxx: &'a mut [T],
    jxk: &'a mut [T],
    jkk: &'a mut [T],
    sxx: &'a mut [T],
    sxk: &'a mut [T],
    skk: &'a mut [T],
}

/// Per sample: the best candidate so far (`best_d`, `best_c`, ranked by `score`), and the
/// residual and coherence at the previous hypothesis (`prev_c < 0`: none usable).
struct State<'a, T> {
    best_d: &'a mut [T],
    best_c: &'a mut [T],
    score: &'a mut [T],
    prev_r: &'a mut [T],
    prev_c: &'a mut [T],
}

/// The coarse pass's result that decides which hypotheses a sample is tested at: those
/// closer than `reach[t]` to `estimate[t]` (`T::MAX` where the coarse pass found no
/// estimate inside a window: every hypothesis).
struct Guide<'a, T> {
    estimate: &'a mut [T],
    reach: &'a mut [T],
    /// Per 64-sample word of the line: no sample of it needs a shear at or below
    /// `lower[w]` or at or above `upper[w]` (the least `estimate − reach` and the largest
    /// `estimate + reach` of its samples, widened by a quarter step, far more than any
    /// rounding of the test in [`Self::needs_mask`]; settling only shrinks a reach).
    lower: &'a mut [T],
    upper: &'a mut [T],
}

impl<T: Scalar> Guide<'_, T> {
    /// Bit `i` set where sample `base + i` (of the 64 from `base`, within the line)
    /// needs the hypothesis `shear`: lies closer than its reach to its estimate.
    #[inline(always)]
    fn needs_mask(&self, shear: T, base: usize) -> u64 {
        let word = base / 64;
        let (Some(&lower), Some(&upper)) = (self.lower.get(word), self.upper.get(word)) else {
            return 0;
        };
        // Most words lie far from most shears: no sample to test.
        if (shear <= lower) | (shear >= upper) {
            return 0;
        }
        let (Some(estimate), Some(reach)) = (self.estimate.get(base..), self.reach.get(base..))
        else {
            return 0;
        };
        let (Some(estimate), Some(reach)) =
            (estimate.first_chunk::<64>(), reach.first_chunk::<64>())
        else {
            // The line's last, partial word.
            let mut mask = 0u64;
            for (bit, (&e, &r)) in estimate.iter().zip(reach).take(64).enumerate() {
                mask |= u64::from((shear - e).abs() < r) << bit;
            }
            return mask;
        };
        // Bytes first (a loop the vectoriser takes), then eight at a time into the word.
        let mut bytes = [0u8; 64];
        for ((b, &e), &r) in bytes.iter_mut().zip(estimate).zip(reach) {
            *b = u8::from((shear - e).abs() < r);
        }
        let mut mask = 0u64;
        for (k, eight) in bytes.chunks_exact(8).enumerate() {
            let mut word = [0u8; 8];
            word.copy_from_slice(eight);
            // Each byte is 0 or 1: multiplying gathers bit j of byte j into the top byte.
            let packed = u64::from_le_bytes(word).wrapping_mul(0x0102_0408_1020_4080) >> 56;
            mask |= packed << (8 * k);
        }
        mask
    }

    /// After hypothesis `shear` was scored at the samples `range`: a sample the coarse
    /// pass placed (finite reach) that needs `shear` and `next`, whose residual there
    /// (`state.prev_r`, inside the window: `state.prev_c ≥ 0`) lies in `0 ≤ r < below`
    /// and whose coherence there is at least `SETTLE_COHERENCE`, needs no further
    /// hypothesis: its zero crossing with `next` would lie within `below` of `shear`,
    /// where the fine residual slope is nearly unbiased on coherent texture (the crossings'
    /// residual gap is within 5 % of the shear step on 83 % / 80 % of the HCI cotton /
    /// backgammon crossings, docs/stages/epi.md). Its score becomes the top one.
    fn settle(
        &mut self,
        state: &mut State<'_, T>,
        shear: T,
        next: T,
        below: T,
        range: Range<usize>,
    ) {
        let coherent = T::from_f32(SETTLE_COHERENCE);
        let (Some(estimate), Some(reach), Some(residual), Some(coherence), Some(score)) = (
            self.estimate.get(range.clone()),
            self.reach.get_mut(range.clone()),
            state.prev_r.get(range.clone()),
            state.prev_c.get(range.clone()),
            state.score.get_mut(range),
        ) else {
            return;
        };
        for ((((&e, reach), &r), &c), score) in estimate
            .iter()
            .zip(reach.iter_mut())
            .zip(residual)
            .zip(coherence)
            .zip(score.iter_mut())
        {
            let placed = *reach < T::MAX;
            let both = ((shear - e).abs() < *reach) & ((next - e).abs() < *reach);
            let settled = placed & both & (c >= coherent) & (r >= T::ZERO) & (r < below);
            *reach = if settled { T::ZERO } else { *reach };
            // No later candidate beats the top score: a run that passes over the sample
            // (a merged gap) leaves its estimate alone, which then depends on its own
            // residual only, not on its neighbours' runs.
            *score = if settled { T::MAX } else { *score };
        }
    }
}

/// The coarse pass: its hypotheses and the reach of the fine ones around its estimate.
#[derive(Clone, Copy, Debug)]
struct Coarse<T> {
    hypotheses: Hypotheses,
    reach: T,
    /// The reach around an estimate within `NEAR` steps of a fine shear: that shear only
    /// (with the margin's extra reach).
    near_reach: T,
    /// Whether its gray planes need the half-shifted kinds (only when the fine ones have
    /// them too; otherwise half shifts take the fallback planes).
    half_shifts: bool,
}

impl<T: Scalar> LineEstimator<T> {
    /// `views` cameras along the EPI, the centre one at `centre`, `channels` loaded planes.
    pub(crate) fn new(
        params: &EpiParams,
        hypotheses: Hypotheses,
        views: usize,
        centre: usize,
        channels: usize,
    ) -> Self {
        let views = views.min(GRID_MAX);
        let mut outer_weights = [0.0f32; GRID_MAX];
        centre_weights(params.outer_sigma, views, centre, &mut outer_weights);
        // Inner Gaussian across views, truncated at the first and last view and
        // renormalised; then per view a Scharr cross smoothing ([3, 10, 3], renormalised
        // at the ends) and a central difference (one-sided at the ends). Averaging
        // per-view differences keeps the slope scale exact at the ends of the EPI,
        // where clamped ("nearest") borders would flatten the signal.
        let mut gauss = [[0.0f32; GRID_MAX]; GRID_MAX];
        for (k, row) in gauss.iter_mut().enumerate().take(views) {
            truncated_gaussian(params.inner_sigma, views, k, row);
        }
        let last = views.saturating_sub(1);
        let mut smooth = [[0.0f32; GRID_MAX]; GRID_MAX];
        let mut diff = [[0.0f32; GRID_MAX]; GRID_MAX];
        for i in 0..views {
            let (im, ip) = (i.saturating_sub(1), (i + 1).min(last));
            let side = if im < i { 3.0 } else { 0.0 } + if ip > i { 3.0 } else { 0.0 };
            let norm = 10.0 + side;
            smooth[i][i] += 10.0 / norm;
            if im < i {
                smooth[i][im] += 3.0 / norm;
            }
            if ip > i {
                smooth[i][ip] += 3.0 / norm;
            }
            if ip > im {
                let scale = 1.0 / (ip - im) as f32;
                diff[i][ip] += scale;
                diff[i][im] -= scale;
            }
        }
        let mut mix_smooth = [[0.0f32; GRID_MAX]; GRID_MAX];
        let mut mix_derivative = [[0.0f32; GRID_MAX]; GRID_MAX];
        let mut active = [false; GRID_MAX];
        for k in 0..views {
            for j in 0..views {
                for i in 0..views {
                    mix_smooth[k][j] += gauss[k][i] * smooth[i][j];
                    mix_derivative[k][j] += gauss[k][i] * diff[i][j];
                }
            }
            // The outer weight of view k enters as √w in both gradients, so the tensor
            // terms are plain products (w·gx² = (√w·gx)²).
            let root = crate::float::sqrtf(outer_weights[k].max(0.0));
            active[k] = T::from_f32(outer_weights[k]) != T::ZERO;
            for m in mix_smooth[k].iter_mut().chain(mix_derivative[k].iter_mut()) {
                *m *= root;
            }
        }
        let half_shifts = shifts_by_halves(&hypotheses, views, centre);
        let coarse = match params.search {
            Search::CoarseToFine { margin } if hypotheses.count() > 3 => {
                let step = hypotheses.step();
                Hypotheses::centred(
                    hypotheses.min(),
                    hypotheses.max(),
                    (COARSE_STEPS * step).min(2.0),
                    1.0,
                    step,
                )
                .ok()
                .map(|coarse| Coarse {
                    hypotheses: coarse,
                    reach: T::from_f32((1.0 + margin) * step),
                    near_reach: T::from_f32((0.5 + margin) * step),
                    half_shifts: half_shifts && shifts_by_halves(&coarse, views, centre),
                })
            }
            _ => None,
        };
        let mut half_views = [false; GRID_MAX];
        for (k, half) in half_views.iter_mut().enumerate().take(views) {
            *half = half_shifts
                && (half_shift(&hypotheses, k, centre)
                    || coarse
                        .as_ref()
                        .is_some_and(|c| c.half_shifts && half_shift(&c.hypotheses, k, centre)));
        }
        let reach = Planes::reach_for(centre.max(views.saturating_sub(1).saturating_sub(centre)));
        let fallback = off_planes(&hypotheses, views, centre, half_shifts, reach)
            || coarse
                .as_ref()
                .is_some_and(|c| off_planes(&c.hypotheses, views, centre, c.half_shifts, reach));
        LineEstimator {
            derivative: Kernel::derivative(params.inner_sigma),
            smoothing: Kernel::scharr_smoothing(params.inner_sigma),
            outer: Kernel::gaussian(params.outer_sigma),
            band: Band::new(&mix_smooth, &mix_derivative, active, views),
            views,
            centre,
            channels: match params.color {
                ColorMode::Gray => 1,
                ColorMode::Tensor => channels.clamp(1, 3),
            },
            hypotheses,
            interpolate: params.interpolate,
            half_shifts,
            half_views,
            fallback,
            coarse,
        }
    }

    /// Work elements (of `T`) for a line of `n` samples.
    /// Enough for every estimator `params` can make (any range of its hypotheses, the
    /// coarse pass's and the range probe's integer shears).
    pub(crate) fn work_len(
        params: &EpiParams,
        views: usize,
        centre: usize,
        channels: usize,
        n: usize,
    ) -> usize {
        let (half, fallback) = planes_bound(params, views, centre);
        Self::work_len_for(views, centre, channels, n, &half, fallback)
    }

    fn work_len_for(
        views: usize,
        centre: usize,
        channels: usize,
        n: usize,
        half: &[bool; GRID_MAX],
        fallback: bool,
    ) -> usize {
        let planes = Planes::new(views, centre, channels + 1, n, half, fallback);
        planes.bank_len() + 3 * planes.n_blocks + (12 + channels) * n
    }

    /// Work elements (of `T`) this estimator needs for a line of `n` samples.
    pub(crate) fn line_work_len(&self, n: usize) -> usize {
        Self::work_len_for(
            self.views,
            self.centre,
            self.channels,
            n,
            &self.half_views,
            self.fallback,
        )
    }

    /// Estimates one line of `n` samples. `load(view, out)` fills `out` (`channels` planes
    /// of `n`, one after the other) with the samples of that view along the line, scaled
    /// intensities. Writes the
    /// disparity and the confidence of every sample into `disparity` / `confidence`.
    pub(crate) fn estimate(
        &self,
        n: usize,
        mut load: impl FnMut(usize, &mut [T]) -> Result<()>,
        work: &mut [T],
        disparity: &mut [T],
        confidence: &mut [T],
    ) -> Result<()> {
        let (k_n, c_n) = (self.views, self.channels);
        let needed = self.line_work_len(n);
        check_scratch(needed, work.len())?;
        if disparity.len() < n || confidence.len() < n {
            return Err(Error::OutputSize {
                what: "the line output",
                needed: n,
                got: disparity.len().min(confidence.len()),
            });
        }
        if n == 0 {
            return Ok(());
        }
        // One plane slot per channel and one for the coarse pass's gray.
        let planes = Planes::new(
            k_n,
            self.centre,
            c_n + 1,
            n,
            &self.half_views,
            self.fallback,
        );
        let nb = planes.n_blocks;
        // `work_len` covers every part; the checked splits only keep panics out.
        let short = Error::ScratchTooSmall {
            needed,
            got: work.len(),
        };
        let mut rest = work;
        let mut take = |len: usize| -> Result<&mut [T]> {
            let (head, tail) = core::mem::take(&mut rest)
                .split_at_mut_checked(len)
                .ok_or(short)?;
            rest = tail;
            Ok(head)
        };
        let bank = take(planes.bank_len())?;
        let jxx = take(nb)?;
        let jxk = take(nb)?;
        let jkk = take(nb)?;
        let raw = take(c_n * n)?;
        let sxx = take(n)?;
        let sxk = take(n)?;
        let skk = take(n)?;
        let score = take(n)?;
        let prev_r = take(n)?;
        let prev_c = take(n)?;
        let coarse_work = take(5 * n)?;
        let mut tensor = Tensor {
            jxx,
            jxk,
            jkk,
            sxx,
            sxk,
            skk,
        };

        // Filtering along the line commutes with the shear (a shift along the line), so the
        // inner smoothing and the along-line parts of the Scharr filters run once per line,
        // into planes padded with their edge values (the clamped shift reads them).
        let half = T::from_f32(0.5);
        for k in 0..k_n {
            load(k, raw)?;
            for (c, raw) in raw.chunks_exact(n).enumerate() {
                // Kind 0 (derivative) lies before kind 1 (smoothing) in the bank.
                let (at_d, at_s) = (planes.plane(0, k, c), planes.plane(1, k, c));
                let (below, above) = bank.split_at_mut_checked(at_s).ok_or(short)?;
                let derivative = below.get_mut(at_d..at_d + planes.len).ok_or(short)?;
                let smoothing = above.get_mut(..planes.len).ok_or(short)?;
                let (d_head, d_tail) = derivative.split_at_mut_checked(planes.lead).ok_or(short)?;
                let (s_head, s_tail) = smoothing.split_at_mut_checked(planes.lead).ok_or(short)?;
                let (d_line, d_pad) = d_tail.split_at_mut_checked(n).ok_or(short)?;
                let (s_line, s_pad) = s_tail.split_at_mut_checked(n).ok_or(short)?;
                apply_pair(&self.derivative, &self.smoothing, raw, d_line, s_line);
                for (head, line, pad) in [(d_head, d_line, d_pad), (s_head, s_line, s_pad)] {
                    let (Some(&first), Some(&last)) = (line.first(), line.last()) else {
                        return Err(short);
                    };
                    head.fill(first);
                    pad.fill(last);
                }
                if !self.half_views.get(k).copied().unwrap_or(true) {
                    continue;
                }
                for (kind, at) in [(0, at_d), (1, at_s)] {
                    // out[t] = ½·in[t − w] + ½·in[t − w − 1]: the shift's interpolation.
                    let to = planes.plane(kind + 2, k, c);
                    let (stored, shifted) = bank.split_at_mut_checked(to).ok_or(short)?;
                    let plane = stored.get(at..at + planes.len).ok_or(short)?;
                    let shifted = shifted.get_mut(..planes.len).ok_or(short)?;
                    let (Some((s0, shifted)), Some(&p0)) =
                        (shifted.split_first_mut(), plane.first())
                    else {
                        return Err(short);
                    };
                    *s0 = half * p0 + half * p0;
                    for (o, (&below, &above)) in shifted
                        .iter_mut()
                        .zip(plane.iter().zip(plane.iter().skip(1)))
                    {
                        *o = half * above + half * below;
                    }
                }
            }
        }

        let guide = match &self.coarse {
            Some(coarse) => {
                Some(self.coarse_guide(coarse, &planes, bank, &mut tensor, coarse_work)?)
            }
            None => None,
        };
        let mut state = State {
            best_d: &mut disparity[..n],
            best_c: &mut confidence[..n],
            score,
            prev_r,
            prev_c,
        };
        self.sweep(
            &self.hypotheses,
            0..c_n,
            &planes,
            bank,
            &mut tensor,
            &mut state,
            guide,
        );
        let h = &self.hypotheses;
        let (lo, hi) = (T::from_f32(h.min()), T::from_f32(h.max()));
        for d in disparity.iter_mut().take(n) {
            *d = d.clamp(lo, hi);
        }
        Ok(())
    }

    /// The coarse pass: the gray mean of the channels' planes (the filters are linear)
    /// swept over the coarse hypotheses, every second sample scored; returns
    /// which fine hypotheses each sample needs, held in `coarse_work` (5 lines).
    fn coarse_guide<'w>(
        &self,
        coarse: &Coarse<T>,
        planes: &Planes,
        bank: &mut [T],
        tensor: &mut Tensor<'_, T>,
        coarse_work: &'w mut [T],
    ) -> Result<Guide<'w, T>> {
        let (n, c_n) = (planes.n, self.channels);
        let short = Error::ScratchTooSmall {
            needed: 5 * n,
            got: coarse_work.len(),
        };
        let kinds = if coarse.half_shifts { 4 } else { 2 };
        let scale = T::from_f32(1.0 / c_n as f32);
        for kind in 0..kinds {
            for k in 0..self.views {
                if kind >= 2 && !self.half_views.get(k).copied().unwrap_or(true) {
                    continue;
                }
                let to = planes.plane(kind, k, c_n);
                let (stored, gray) = bank.split_at_mut_checked(to).ok_or(short)?;
                let gray = gray.get_mut(..planes.len).ok_or(short)?;
                if c_n == 3 {
                    // The loops below in one pass over the planes: the same sums in the
                    // same order.
                    let plane = |c| {
                        let at = planes.plane(kind, k, c);
                        stored.get(at..at + planes.len).ok_or(short)
                    };
                    let (first, second, third) = (plane(0)?, plane(1)?, plane(2)?);
                    for (g, ((&u, &v), &w)) in
                        gray.iter_mut().zip(first.iter().zip(second).zip(third))
                    {
                        *g = (T::ZERO + u + v + w) * scale;
                    }
                    continue;
                }
                for c in 0..c_n {
                    let at = planes.plane(kind, k, c);
                    let plane = stored.get(at..at + planes.len).ok_or(short)?;
                    // The first channel as `0 + v`, the sum the others are added to.
                    if c == 0 {
                        for (g, &v) in gray.iter_mut().zip(plane) {
                            *g = T::ZERO + v;
                        }
                    } else {
                        for (g, &v) in gray.iter_mut().zip(plane) {
                            *g += v;
                        }
                    }
                }
                for g in gray.iter_mut() {
                    *g *= scale;
                }
            }
        }
        let (estimate, rest) = coarse_work.split_at_mut_checked(n).ok_or(short)?;
        let (reach, rest) = rest.split_at_mut_checked(n).ok_or(short)?;
        let (score, rest) = rest.split_at_mut_checked(n).ok_or(short)?;
        let (prev_r, prev_c) = rest.split_at_mut_checked(n).ok_or(short)?;
        // The sweep's state holds the even samples, sample 2m at m.
        let half = n.div_ceil(2);
        let mut compact = State {
            best_d: estimate.get_mut(..half).ok_or(short)?,
            best_c: reach.get_mut(..half).ok_or(short)?,
            score: score.get_mut(..half).ok_or(short)?,
            prev_r: prev_r.get_mut(..half).ok_or(short)?,
            prev_c: prev_c.get_mut(..half).ok_or(short)?,
        };
        self.coarse_sweep(&coarse.hypotheses, c_n, planes, bank, tensor, &mut compact);
        // Estimates clamped to the fine shears (each sample then needs at least the
        // nearest one), reach per sample (the coherence's slot is reused), at the scored
        // samples (compact), then spread to the line.
        let h = &self.hypotheses;
        let (first, last) = (
            T::from_f32(h.shear(0)),
            T::from_f32(h.shear(h.count().saturating_sub(1))),
        );
        let single = T::from_f32(SINGLE);
        let inverse_step = 1.0 / h.step();
        let (Some(compact_d), Some(compact_reach), Some(compact_score)) = (
            estimate.get_mut(..half),
            reach.get_mut(..half),
            score.get(..half),
        ) else {
            return Err(short);
        };
        for ((d, reach), &score) in compact_d
            .iter_mut()
            .zip(compact_reach.iter_mut())
            .zip(compact_score)
        {
            *d = d.clamp(first, last);
            // Steps from the first fine shear (≥ 0 after the clamp); the nearest shear is
            // `steps` rounded, here by truncation after adding ½ (a tie is never near).
            // (Compare and select rather than `f32::max`, and a signed conversion, equal
            // for these small non-negative values: the loop vectorises.)
            let steps = (d.to_f32() - h.shear(0)) * inverse_step;
            let steps = if steps > 0.0 { steps } else { 0.0 };
            let nearest = (steps + 0.5) as i32 as f32;
            let off = steps - nearest;
            let near = (off < NEAR) & (-off < NEAR);
            *reach = if score < single {
                T::MAX
            } else if near {
                coarse.near_reach
            } else {
                coarse.reach
            };
        }
        // Each word's bounds (see `Guide::lower`) from its 32 compact samples, in four
        // running minima / maxima by plain selects (`minps` / `maxps`; a NaN estimate,
        // needed by no shear, fails the comparisons and is skipped).
        let words = n.div_ceil(64);
        let (lower, upper) = (
            prev_r.get_mut(..words).ok_or(short)?,
            prev_c.get_mut(..words).ok_or(short)?,
        );
        let widen = T::from_f32(0.25 * h.step());
        let low = |least: T, low: T| if low < least { low } else { least };
        let high = |most: T, high: T| if high > most { high } else { most };
        // (Words and quads by index: a zip of `chunks` divides by the chunk size where it
        // is not inlined, a panic path the firmware's link rejects.)
        for (w, (lower, upper)) in lower.iter_mut().zip(upper.iter_mut()).enumerate() {
            let span = 32 * w..(32 * w + 32).min(half);
            let (Some(estimate), Some(reach)) =
                (compact_d.get(span.clone()), compact_reach.get(span))
            else {
                continue;
            };
            let mut least = [T::MAX; 4];
            let mut most = [T::ZERO - T::MAX; 4];
            let quads = estimate.len().min(reach.len()) / 4;
            for q in 0..quads {
                let (Some(e), Some(r)) = (
                    estimate.get(4 * q..).and_then(<[T]>::first_chunk::<4>),
                    reach.get(4 * q..).and_then(<[T]>::first_chunk::<4>),
                ) else {
                    continue;
                };
                for (((least, most), &e), &r) in least.iter_mut().zip(most.iter_mut()).zip(e).zip(r)
                {
                    *least = low(*least, e - r);
                    *most = high(*most, e + r);
                }
            }
            let (last_e, last_r) = (
                estimate.get(4 * quads..).unwrap_or_default(),
                reach.get(4 * quads..).unwrap_or_default(),
            );
            for ((&e, &r), (least, most)) in last_e
                .iter()
                .zip(last_r)
                .zip(least.iter_mut().zip(most.iter_mut()))
            {
                *least = low(*least, e - r);
                *most = high(*most, e + r);
            }
            *lower = least.iter().fold(T::MAX, |a, &b| low(a, b)) - widen;
            *upper = most.iter().fold(T::ZERO - T::MAX, |a, &b| high(a, b)) + widen;
        }
        // Spread to the line: the samples between the scored ones take their left
        // neighbour's estimate and reach (backwards: sample m is read before 2m and
        // 2m + 1 are written).
        for line in [&mut *estimate, &mut *reach] {
            for m in (0..half).rev() {
                let Some(&v) = line.get(m) else {
                    continue;
                };
                for o in line.get_mut(2 * m..(2 * m + 2).min(n)).unwrap_or_default() {
                    *o = v;
                }
            }
        }
        Ok(Guide {
            estimate,
            reach,
            lower,
            upper,
        })
    }

    /// The coarse pass's sweep of `hyps` on the gray planes (slot `slot`): the tensor of the
    /// whole line, but its outer smoothing, slopes and scores at the even samples only,
    /// into `state` compacted (sample 2m at m, ⌈n/2⌉ samples): the same values there as
    /// [`Self::sweep`] without a guide (every sample's candidates depend on that sample
    /// only; the odd ones are overwritten with their left neighbour's anyway), for half
    /// the smoothing and scoring.
    fn coarse_sweep(
        &self,
        hyps: &Hypotheses,
        slot: usize,
        planes: &Planes,
        bank: &mut [T],
        tensor: &mut Tensor<'_, T>,
        state: &mut State<'_, T>,
    ) {
        let n = planes.n;
        let half = n.div_ceil(2);
        let degenerate = T::from_f32(DEGENERATE);
        state.best_d.fill(T::ZERO);
        state.best_c.fill(T::ZERO);
        state.score.fill(T::from_f32(DEGENERATE - 1.0));
        state.prev_c.fill(degenerate);
        for i in 0..hyps.count() {
            let sources = self.sources(planes, bank, hyps.shear(i), slot..slot + 1);
            self.tensor_span(bank, &sources, tensor, 0..n, planes.n_blocks);
            let Tensor {
                jxx,
                jxk,
                jkk,
                sxx,
                sxk,
                skk,
            } = &mut *tensor;
            // Each raw sum line is split into its even and odd samples (in the smoothed
            // line's slot), then smoothed at the even samples back into its own slot.
            for (raw, split) in [(&mut **jxx, &mut **sxx), (jxk, sxk), (jkk, skk)] {
                if let Some(raw) = raw.get_mut(..n) {
                    deinterleave(raw, split);
                    self.outer.apply_even(split, n, raw);
                }
            }
            // `score` reads the smoothed sums from the `s` slots and writes slopes and
            // coherences into the `j` ones: the roles swap.
            let mut compact = Tensor {
                jxx: sxx,
                jxk: sxk,
                jkk: skk,
                sxx: jxx,
                sxk: jxk,
                skk: jkk,
            };
            self.score(hyps, i, &mut compact, state, 0..half);
        }
    }

    /// Tests the hypotheses `hyps` on the channel planes `slots`, keeping each sample's
    /// best candidate in `state`. With a `guide`, a sample is only tested at the
    /// hypotheses it needs (see [`Guide::needs_mask`]); the tensor is then computed only
    /// within the outer smoothing's reach of those samples.
    #[allow(clippy::too_many_arguments)]
    fn sweep(
        &self,
        hyps: &Hypotheses,
        slots: Range<usize>,
        planes: &Planes,
        bank: &mut [T],
        tensor: &mut Tensor<'_, T>,
        state: &mut State<'_, T>,
        mut guide: Option<Guide<'_, T>>,
    ) {
        let n = planes.n;
        let settle_below = T::from_f32(FINE_NEAR * hyps.step());
        let degenerate = T::from_f32(DEGENERATE);
        let lowest = T::from_f32(DEGENERATE - 1.0);
        state.best_d.fill(T::ZERO);
        state.best_c.fill(T::ZERO);
        state.score.fill(lowest);
        state.prev_c.fill(degenerate);
        let reach = self.outer.radius();
        // Needed samples closer than this share their tensor blocks: one run.
        let merge = 2 * reach + BLOCK;
        for i in 0..hyps.count() {
            let shear = hyps.shear(i);
            let shear_t = T::from_f32(shear);
            // The first sample at or after `from` that needs this hypothesis (`needed`) or
            // does not (`!needed`), `n` where none does, from the needs of 64 samples at a
            // time (`chunk`: the latest such word; the samples a run settles lie before any
            // later query).
            let mut chunk = (usize::MAX, 0u64);
            let mut find = |guide: &Option<Guide<'_, T>>, from: usize, needed: bool| -> usize {
                let Some(g) = guide else {
                    return if needed { from.min(n) } else { n };
                };
                let mut at = from;
                while at < n {
                    let word = at / 64;
                    if chunk.0 != word {
                        chunk = (word, g.needs_mask(shear_t, word * 64));
                    }
                    // Past the line's end a word has no needs: its `!needed` bits stop there.
                    let wanted = if needed { chunk.1 } else { !chunk.1 };
                    let bits = wanted & (u64::MAX << (at % 64));
                    if bits != 0 {
                        return (word * 64 + bits.trailing_zeros() as usize).min(n);
                    }
                    at = (word + 1) * 64;
                }
                n
            };
            let sources = self.sources(planes, bank, shear, slots.clone());
            let mut t = 0;
            let mut start = find(&guide, 0, true);
            loop {
                // Not tested here: no zero crossing with the next hypothesis.
                for c in state.prev_c.get_mut(t..start).unwrap_or_default() {
                    *c = degenerate;
                }
                if start >= n {
                    break;
                }
                // Needed samples closer than `merge` to the run's end join it; the first
                // one further away starts the next run. (A needed sample right after the
                // end joins it: the run skips each stretch of them at once.)
                let mut end = start + 1;
                let next = loop {
                    end = find(&guide, end, false);
                    let next = find(&guide, end, true);
                    if next < n && next < end + merge {
                        end = next + 1;
                    } else {
                        break next;
                    }
                };
                // The outer smoothing of samples start..end reads the tensor within its
                // reach (clamped to the line).
                let span = start.saturating_sub(reach)..(end + reach).min(n);
                self.tensor_span(bank, &sources, tensor, span, planes.n_blocks);
                let sums = &mut *tensor;
                let (jxx, jxk, jkk) = (
                    sums.jxx.get(..n).unwrap_or_default(),
                    sums.jxk.get(..n).unwrap_or_default(),
                    sums.jkk.get(..n).unwrap_or_default(),
                );
                self.outer.apply_range(jxx, sums.sxx, start..end);
                self.outer.apply_range(jxk, sums.sxk, start..end);
                self.outer.apply_range(jkk, sums.skk, start..end);
                self.score(hyps, i, sums, state, start..end);
                if let Some(g) = guide.as_mut() {
                    if i + 1 < hyps.count() {
                        let next = T::from_f32(hyps.shear(i + 1));
                        g.settle(state, shear_t, next, settle_below, start..end);
                    }
                }
                (t, start) = (end, next);
            }
        }
    }

    /// Scores hypothesis `i` of `hyps` at the samples `range` from the smoothed tensor.
    fn score(
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
        if core::any::TypeId::of::<T>() == core::any::TypeId::of::<f32>() {
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

    /// Where hypothesis `shear` reads every view: the stored planes at a whole-sample
    /// offset (the half-shifted ones for half-sample offsets), or, for any other fraction
    /// and for shifts beyond the stored padding, a fallback plane interpolated here.
    fn sources(&self, planes: &Planes, bank: &mut [T], shear: f32, slots: Range<usize>) -> Sources {
        let mut sources = Sources {
            d: [[0; GRID_MAX]; 3],
            s: [[0; GRID_MAX]; 3],
            slots: slots.len().min(3),
            active: self.band.active,
        };
        if slots.start >= self.channels {
            for (k, a) in sources.active.iter_mut().enumerate() {
                *a &= k.abs_diff(self.centre) <= COARSE_VIEWS;
            }
        }
        let stored_len = planes.stored_len();
        let half_ready = match &self.coarse {
            Some(coarse) if slots.start >= self.channels => coarse.half_shifts,
            _ => self.half_shifts,
        };
        for k in 0..self.views.min(GRID_MAX) {
            let offset = (k as f32 - self.centre as f32) * shear;
            let floor = libm::floorf(offset);
            let frac = offset - floor;
            let whole = floor as isize;
            let stored_kind = if frac == 0.0 {
                Some(0)
            } else if frac == 0.5 && half_ready {
                Some(2)
            } else {
                None
            };
            for (slot, c) in slots.clone().enumerate().take(3) {
                match stored_kind {
                    Some(kind) if whole.unsigned_abs() <= planes.reach => {
                        // Sample t of the sheared view is stored sample t − whole.
                        let start = |kind| {
                            let at = (planes.plane(kind, k, c) + planes.lead) as isize - whole;
                            at as usize
                        };
                        sources.d[slot][k] = start(kind);
                        sources.s[slot][k] = start(kind + 1);
                    }
                    _ => {
                        let Some((stored, spare)) = bank.split_at_mut_checked(stored_len) else {
                            continue;
                        };
                        for kind in 0..2 {
                            let from = planes.plane(kind, k, c) + planes.lead;
                            let to = planes.fallback(kind, k, c);
                            let at = to.wrapping_sub(stored_len);
                            let (Some(out), Some(input)) = (
                                spare.get_mut(at..at.wrapping_add(planes.n_blocks)),
                                stored.get(from..from + planes.n),
                            ) else {
                                continue;
                            };
                            let Some((line, tail)) = out.split_at_mut_checked(planes.n) else {
                                continue;
                            };
                            shift(input, line, offset);
                            if let Some(&last) = line.last() {
                                tail.fill(last);
                            }
                            if kind == 0 {
                                sources.d[slot][k] = to;
                            } else {
                                sources.s[slot][k] = to;
                            }
                        }
                    }
                }
            }
        }
        sources
    }

    /// The outer-weighted tensor (xx, xk, kk) of the samples `span` (at least, within the
    /// first `len` samples) into `tensor.jxx` etc., summed over the source channels and the
    /// views.
    fn tensor_span(
        &self,
        bank: &[T],
        sources: &Sources,
        tensor: &mut Tensor<'_, T>,
        span: Range<usize>,
        len: usize,
    ) {
        match Band::<T>::width_for(self.band.taps) {
            3 => self.tensor_line::<3>(bank, sources, tensor, span, len),
            5 => self.tensor_line::<5>(bank, sources, tensor, span, len),
            7 => self.tensor_line::<7>(bank, sources, tensor, span, len),
            9 => self.tensor_line::<9>(bank, sources, tensor, span, len),
            _ => self.tensor_line::<GRID_MAX>(bank, sources, tensor, span, len),
        }
    }

    /// The tensor of `span` in chunks of `LANES` samples starting anywhere (a sample's sums
    /// do not depend on its chunk: every lane runs the same operations in the same order),
    /// the rest in chunks of `TAIL` and `2·TAIL` lanes, the last one overlapping its
    /// predecessor: fewer than `TAIL` samples outside `span` are computed (a short span
    /// widens to `TAIL`).
    fn tensor_line<const TAPS: usize>(
        &self,
        bank: &[T],
        sources: &Sources,
        tensor: &mut Tensor<'_, T>,
        span: Range<usize>,
        len: usize,
    ) {
        // `len` (whole blocks of the line) ≥ LANES.
        let end = span.end.max(span.start + TAIL).min(len);
        let start = span.start.min(end.saturating_sub(TAIL));
        let mut at = start;
        while end.saturating_sub(at) >= LANES {
            self.tensor_chunk::<TAPS, LANES>(bank, sources, tensor, at);
            at += LANES;
        }
        // The rest, fewer than `LANES` samples: a `2·TAIL` chunk, then one more chunk
        // ending at `end` (overlapping what is done; within the line: chunks that would
        // start before it start at 0, `len ≥ LANES`), or one `LANES` chunk ending there
        // when the rest needs more than three `TAIL` chunks.
        let chunk_before = |size: usize| end.saturating_sub(size);
        let rest = end.saturating_sub(at);
        if rest > 3 * TAIL {
            self.tensor_chunk::<TAPS, LANES>(bank, sources, tensor, chunk_before(LANES));
            return;
        }
        if rest > 2 * TAIL {
            self.tensor_chunk::<TAPS, { 2 * TAIL }>(bank, sources, tensor, at);
            at += 2 * TAIL;
        }
        let rest = end.saturating_sub(at);
        if rest > TAIL {
            self.tensor_chunk::<TAPS, { 2 * TAIL }>(bank, sources, tensor, chunk_before(2 * TAIL));
        } else if rest > 0 {
            self.tensor_chunk::<TAPS, TAIL>(bank, sources, tensor, chunk_before(TAIL));
        }
    }

    /// The tensor of the `L` samples from `at` into the raw sum lines.
    #[inline(always)]
    fn tensor_chunk<const TAPS: usize, const L: usize>(
        &self,
        bank: &[T],
        sources: &Sources,
        tensor: &mut Tensor<'_, T>,
        at: usize,
    ) {
        let [sxx, sxk, skk] = self.tensor_lanes::<TAPS, L>(bank, sources, at);
        let store = |line: &mut [T], sums: &[T; L]| {
            if let Some(out) = line.get_mut(at..).and_then(|l| l.first_chunk_mut::<L>()) {
                *out = *sums;
            }
        };
        store(tensor.jxx, &sxx);
        store(tensor.jxk, &sxk);
        store(tensor.jkk, &skk);
    }

    /// The tensor of samples `t0..t0 + L`: the samples of every view's planes are
    /// looked up once, then per channel and view both gradients across the view's band
    /// and their products, all in registers.
    #[inline(always)]
    fn tensor_lanes<const TAPS: usize, const L: usize>(
        &self,
        bank: &[T],
        sources: &Sources,
        t0: usize,
    ) -> [[T; L]; 3] {
        let zero = [T::ZERO; L];
        let mut xx = [T::ZERO; L];
        let mut xk = [T::ZERO; L];
        let mut kk = [T::ZERO; L];
        let band = &self.band;
        let views = self.views.min(GRID_MAX);
        let last = views.saturating_sub(1);
        let at = |from: usize| {
            bank.get(from + t0..)
                .and_then(|b| b.first_chunk::<L>())
                .unwrap_or(&zero)
        };
        for (sd, ss) in sources.d.iter().zip(&sources.s).take(sources.slots) {
            // Views past the last read the last one (with zero weight), as the band's
            // clamped rows do.
            let mut d = [&zero; GRID_MAX];
            let mut s = [&zero; GRID_MAX];
            for ((dk, sk), (&from_d, &from_s)) in d
                .iter_mut()
                .zip(s.iter_mut())
                .zip(sd.iter().zip(ss))
                .take(views)
            {
                (*dk, *sk) = (at(from_d), at(from_s));
            }
            if let (Some(&d_last), Some(&s_last)) = (d.get(last), s.get(last)) {
                for (dk, sk) in d.iter_mut().zip(s.iter_mut()).skip(views) {
                    (*dk, *sk) = (d_last, s_last);
                }
            }
            let views = band
                .start
                .iter()
                .zip(&band.smooth)
                .zip(&band.derivative)
                .zip(&sources.active)
                .take(views);
            for (((&start, smooth), derivative), &active) in views {
                // `start + TAPS ≤ GRID_MAX` (Band::new); a miss would skip the view.
                let (Some(dw), Some(sw), Some(smooth), Some(derivative)) = (
                    d.get(start..).and_then(|w| w.first_chunk::<TAPS>()),
                    s.get(start..).and_then(|w| w.first_chunk::<TAPS>()),
                    smooth.first_chunk::<TAPS>(),
                    derivative.first_chunk::<TAPS>(),
                ) else {
                    continue;
                };
                if !active {
                    continue;
                }
                let mut taps = dw.iter().zip(sw).zip(smooth).zip(derivative);
                let Some((((&p, &q), &a), &b)) = taps.next() else {
                    continue;
                };
                // The first tap sets the gradients (the same values as adding it to zero,
                // up to the sign of a zero, which the squares and products below ignore).
                let mut gx = [T::ZERO; L];
                let mut gk = [T::ZERO; L];
                for ((x, y), (&p, &q)) in gx.iter_mut().zip(gk.iter_mut()).zip(p.iter().zip(q)) {
                    *x = a * p;
                    *y = b * q;
                }
                for (((&p, &q), &a), &b) in taps {
                    // A zero weight (a pruned entry, the centre of an interior view's
                    // derivative: 13 of the 90 products per channel at 9 views) would
                    // add nothing but the sign of a zero, which the products below ignore.
                    if a != T::ZERO {
                        for (x, &p) in gx.iter_mut().zip(p) {
                            *x += a * p;
                        }
                    }
                    if b != T::ZERO {
                        for (y, &q) in gk.iter_mut().zip(q) {
                            *y += b * q;
                        }
                    }
                }
                for ((((sxx, sxk), skk), &x), &y) in xx
                    .iter_mut()
                    .zip(xk.iter_mut())
                    .zip(kk.iter_mut())
                    .zip(&gx)
                    .zip(&gk)
                {
                    *sxx += x * x;
                    *sxk += x * y;
                    *skk += y * y;
                }
            }
        }
        [xx, xk, kk]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every span's tensor, computed in `LANES` chunks and narrower tails, equals the
    /// whole line's bit for bit, and the chunks write nothing further than `TAIL − 1`
    /// samples outside the span (and never outside the line).
    #[test]
    fn the_tensor_of_any_span_is_the_whole_line_s_and_stays_near_the_span() {
        let params = EpiParams::default();
        let views = 9;
        let hyps = Hypotheses::sheared(-1.0, 1.0, 0.5, 1.0).unwrap();
        let estimator = LineEstimator::<f32>::new(&params, hyps, views, 4, 3);
        let len = 3 * LANES;
        // Planes of pseudo-random values, each view's read from its own offset.
        let plane = len + 2 * LANES;
        let mut seed = 0x2545_f491u32;
        let bank: std::vec::Vec<f32> = (0..2 * 3 * views * plane)
            .map(|_| {
                seed ^= seed << 13;
                seed ^= seed >> 17;
                seed ^= seed << 5;
                (seed % 1000) as f32 / 8.0
            })
            .collect();
        let mut sources = Sources {
            d: [[0; GRID_MAX]; 3],
            s: [[0; GRID_MAX]; 3],
            slots: 3,
            active: estimator.band.active,
        };
        for c in 0..3 {
            for k in 0..views {
                sources.d[c][k] = (2 * (c * views + k)) * plane + k;
                sources.s[c][k] = (2 * (c * views + k) + 1) * plane + 2 * k;
            }
        }
        let lines = |fill: f32| {
            [
                std::vec![fill; len],
                std::vec![fill; len],
                std::vec![fill; len],
            ]
        };
        let mut smoothed = lines(0.0);
        // The tensor of `span` in fresh NaN lines (the smoothed lines are work space).
        let mut tensor_of = |span: core::ops::Range<usize>| {
            let mut out = lines(f32::NAN);
            let [jxx, jxk, jkk] = &mut out;
            let [sxx, sxk, skk] = &mut smoothed;
            let mut tensor = Tensor {
                jxx,
                jxk,
                jkk,
                sxx,
                sxk,
                skk,
            };
            estimator.tensor_span(&bank, &sources, &mut tensor, span, len);
            out
        };
        let whole = tensor_of(0..len);
        assert!(whole.iter().flatten().all(|v| v.is_finite()));
        for start in 0..len {
            for end in start + 1..=len {
                let part = tensor_of(start..end);
                for (p, w) in part.iter().zip(&whole) {
                    for t in 0..len {
                        let near = t + TAIL > start && t < end + TAIL - 1;
                        if (start..end).contains(&t) {
                            assert_eq!(p[t].to_bits(), w[t].to_bits(), "{start}..{end} at {t}");
                        } else if p[t].is_finite() {
                            assert!(near, "{start}..{end} wrote {t}");
                            assert_eq!(p[t].to_bits(), w[t].to_bits());
                        }
                    }
                }
            }
        }
    }
}
