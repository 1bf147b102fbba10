//! Colour-distance weights of the median from a 256-entry table of 16-bit values.

use super::TABLE;

/// Colour-distance weights: `table[d² >> shift]` for the squared 8-bit colour distance
/// `d²`, in units of 1/65535.
pub(super) struct Weights {
    table: [u16; TABLE],
    shift: u32,
    /// The smallest squared distance of weight zero: every larger one weighs zero too
    /// (the table does not increase).
    zero_from: u32,
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
        let mut table = [0u16; TABLE];
        for (i, w) in table.iter_mut().enumerate() {
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
}

#[cfg(test)]
mod tests {
    use super::*;

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
