//! Colour-distance weights of the median from a 256-entry table of 16-bit values.

use super::TABLE;

/// Colour-distance weights: `table[d² >> shift]` for the squared 8-bit colour distance
/// `d²`, in units of 1/65535.
pub(super) struct Weights {
    table: [u16; TABLE],
    shift: u32,
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
        Weights { table, shift }
    }

    /// The weight of a squared colour distance (zero beyond the table).
    #[inline(always)]
    pub(super) fn get(&self, d2: u32) -> u32 {
        self.table
            .get((d2 >> self.shift) as usize)
            .map_or(0, |&w| u32::from(w))
    }
}
