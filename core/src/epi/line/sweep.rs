//! The fine sweep: every hypothesis tested at the samples that need it, in runs that share
//! their tensor blocks.

use super::estimator::LineEstimator;
use super::guide::Guide;
use super::scoring::{State, DEGENERATE};
use super::tensor::Tensor;
use crate::epi::planes::{Planes, BLOCK};
use crate::scalar::Scalar;

/// A sample the coarse pass brackets between two fine shears is not tested at the upper
/// one when its fine residual slope at the lower one puts it less than this many shear
/// steps above that one (the lower one is then its nearest) with at least
/// `SETTLE_COHERENCE` (see `Guide::settle`): −8 % / −12 % of the fine pass's tensor samples
/// on HCI cotton / backgammon; 0.3 steps without the coherence test cost backgammon's
/// pipeline MSE×100 +0.028, and settling residuals below the lower shear too +0.035
/// (docs/stages/epi.md).
const FINE_NEAR: f32 = 0.5;

impl<T: Scalar> LineEstimator<T> {
    /// Tests the estimator's hypotheses on every channel plane, keeping each sample's
    /// best candidate in `state`. With a `guide`, a sample is only tested at the
    /// hypotheses it needs (see [`Guide::needs_mask`]); the tensor is then computed only
    /// within the outer smoothing's reach of those samples.
    pub(super) fn sweep(
        &self,
        planes: &Planes,
        bank: &mut [T],
        tensor: &mut Tensor<'_, T>,
        state: &mut State<'_, T>,
        mut guide: Option<Guide<'_, T>>,
    ) {
        let hyps = &self.hypotheses;
        let slots = 0..self.channels;
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
}
