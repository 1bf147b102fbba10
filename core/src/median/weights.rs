//! Colour-distance weights of the median from a 256-entry table of 16-bit values.

use super::TABLE;

/// Entries of the padded table: [`TABLE`] weights, then zeros, so that every index up
/// to [`Weights::cap`]` >> shift` = `TABLE` reads a weight without a bounds check
/// (indices are masked to this power of two).
const PADDED: usize = 2 * TABLE;

/// Colour-distance weights: `table[d² >> shift]` for the squared 8-bit colour distance
/// `d²`, in units of 1/65535.
pub(super) struct Weights {
    table: [u16; PADDED],
    shift: u32,
    /// The smallest squared distance of weight zero: every larger one weighs zero too
    /// (the table does not increase).
    zero_from: u32,
    /// Where [`Self::index`] clamps distances: `min(TABLE << shift, 2²²)`.
    cap: f32,
}

impl Weights {
    pub(super) fn new(color_sigma: f32) -> Self {
        let sigma = color_sigma * 255.0;
        let two_sigma2 = 2.0 * sigma * sigma;
        // The table reaches 12·2σ², where the weight (e^−12 ≈ 6e−6) rounds to zero.
        let reach = 12.0 * two_sigma2;
        let mut shift = 0u32;
        while ((TABLE as f32) * (1u32 << shift) as f32) < reach && shift < 20 {
            shift += 1;
        }
        let mut table = [0u16; PADDED];
        for (i, w) in table.iter_mut().enumerate().take(TABLE) {
            // The bin's mid value, so the table is unbiased within a bin.
            let d2 = if shift == 0 {
                i as f32
            } else {
                (i as f32 + 0.5) * (1u32 << shift) as f32
            };
            let v = libm::expf(-d2 / two_sigma2) * 65535.0;
            *w = libm::roundf(v) as u16;
        }
        // The pixel itself always counts fully.
        table[0] = table[0].max(1);
        // exp decreases and rounding keeps the order, so the zeros are the table's tail.
        let first_zero = table.iter().position(|&w| w == 0).unwrap_or(TABLE) as u32;
        Weights {
            table,
            shift,
            zero_from: first_zero << shift,
            cap: ((TABLE as u32) << shift).min(1 << 22) as f32,
        }
    }

    /// The smallest squared distance of weight zero, as `f32` (exact: below 2²⁴).
    #[inline(always)]
    pub(super) fn zero_from(&self) -> f32 {
        self.zero_from.min(1 << 24) as f32
    }

    /// The weight of a squared colour distance (zero beyond the table).
    #[inline(always)]
    pub(super) fn get(&self, d2: u32) -> u32 {
        self.table
            .get((d2 >> self.shift) as usize)
            .map_or(0, |&w| u32::from(w))
    }

    /// The table index of a squared colour distance `d2` (a whole number below 2²²
    /// in `f32`, as the median computes them in vector lanes), clamped to `TABLE`: the
    /// argument of [`Self::at`]. Clamped at `TABLE << shift`, whose entry, like every
    /// one beyond the table, is zero (or at 2²², above every distance of 8-bit colours,
    /// where `shift` ≥ 14 keeps the index below 12), then moved into the low mantissa
    /// bits by adding 2²³ (exact; no float-to-integer conversion).
    #[inline(always)]
    pub(super) fn index(&self, d2: f32) -> u32 {
        const TWO_23: f32 = 8_388_608.0;
        // A compare and select, not `f32::min`: the same value for every input (NaN
        // included: both give `cap`), but `min`'s NaN rule has no single wasm SIMD
        // instruction, and its lowering there made the median 2× slower in the browser
        // (docs/stages/median.md).
        let clamped = if d2 < self.cap { d2 } else { self.cap };
        ((clamped + TWO_23).to_bits() & 0x007F_FFFF) >> self.shift
    }

    /// The weight of a table index from [`Self::index`]: equal to [`Self::get`] of the
    /// distance, without a bounds check (the index is at most `TABLE`).
    #[inline(always)]
    pub(super) fn at(&self, index: u32) -> u32 {
        u32::from(self.table[index as usize & (PADDED - 1)])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The vector loops look weights up by [`Weights::index`] and [`Weights::at`]:
    /// equal to [`Weights::get`] for every distance of 8-bit colours and every σ.
    #[test]
    fn indexed_weights_equal_the_table() {
        for sigma in [0.005, 0.01, 0.02, 0.04, 0.0437, 0.1, 0.25, 0.3, 0.5] {
            let weights = Weights::new(sigma);
            for d2 in 0..=3 * 255 * 255u32 {
                let at = weights.at(weights.index(d2 as f32));
                assert_eq!(at, weights.get(d2), "σ {sigma}, d² {d2}");
            }
        }
    }

    /// The median skips look-ups from `zero_from` on: that must be exactly where the
    /// weights are zero, for any σ and every squared distance of 8-bit colours.
    #[test]
    fn weights_are_zero_exactly_from_zero_from() {
        for sigma in [0.005, 0.01, 0.02, 0.04, 0.1, 0.25, 0.5] {
            let weights = Weights::new(sigma);
            let limit = weights.zero_from();
            let mut zeros = 0;
            for d2 in 0..=3 * 255 * 255u32 {
                let zero = weights.get(d2) == 0;
                assert_eq!(zero, d2 as f32 >= limit, "σ {sigma}, d² {d2}");
                zeros += usize::from(zero);
            }
            // The small σ must reach zero within the colour range for the test to bite.
            if sigma <= 0.1 {
                assert!(zeros > 0, "σ {sigma}: no zero weight");
            }
        }
    }
}
