//! The coarse pass's guide to the fine sweep: which samples each fine hypothesis is tested
//! at, and the samples a fine residual settles early.

use super::scoring::State;
use crate::scalar::Scalar;
use core::ops::Range;

/// See `FINE_NEAR`: 0.9 keeps both HCI scenes' pipeline scores within +0.02 MSE×100.
const SETTLE_COHERENCE: f32 = 0.9;

/// The coarse pass's result that decides which hypotheses a sample is tested at: those
/// closer than `reach[t]` to `estimate[t]` (`T::MAX` where the coarse pass found no
/// estimate inside a window: every hypothesis).
pub(super) struct Guide<'a, T> {
    pub(super) estimate: &'a mut [T],
    pub(super) reach: &'a mut [T],
    /// Per 64-sample word of the line: no sample of it needs a shear at or below
    /// `lower[w]` or at or above `upper[w]` (the least `estimate − reach` and the largest
    /// `estimate + reach` of its samples, widened by a quarter step, far more than any
    /// rounding of the test in [`Self::needs_mask`]; settling only shrinks a reach).
    pub(super) lower: &'a mut [T],
    pub(super) upper: &'a mut [T],
}

impl<T: Scalar> Guide<'_, T> {
    /// Bit `i` set where sample `base + i` (of the 64 from `base`, within the line)
    /// needs the hypothesis `shear`: lies closer than its reach to its estimate.
    #[inline(always)]
    pub(super) fn needs_mask(&self, shear: T, base: usize) -> u64 {
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
    pub(super) fn settle(
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
