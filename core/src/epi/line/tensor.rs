//! The structure tensor of one shear hypothesis: per sample, the outer-weighted sums of
//! the gradient products over every view and channel, computed in register-sized chunks.

use super::estimator::LineEstimator;
use crate::epi::band::Band;
use crate::epi::planes::Sources;
use crate::lightfield::GRID_MAX;
use crate::scalar::Scalar;
use core::ops::Range;

/// Samples the tensor kernel keeps in registers at a time (a divisor of `BLOCK`).
pub(super) const LANES: usize = 16;
/// The smallest chunk of the tensor kernel: a span's last samples are computed in chunks
/// of `TAIL` or `2·TAIL` rather than a whole `LANES` chunk overlapping the one before
/// (which recomputed 5.6 % of the fine pass's tensor samples on HCI cotton).
pub(super) const TAIL: usize = 4;

/// The tensor of one hypothesis: raw sums over views (`jxx`, `jxk`, `jkk`, whole blocks)
/// and smoothed along the line (`sxx`, `sxk`, `skk`).
pub(super) struct Tensor<'a, T> {
    pub(super) jxx: &'a mut [T],
    pub(super) jxk: &'a mut [T],
    pub(super) jkk: &'a mut [T],
    pub(super) sxx: &'a mut [T],
    pub(super) sxk: &'a mut [T],
    pub(super) skk: &'a mut [T],
}

impl<T: Scalar> LineEstimator<T> {
    /// The outer-weighted tensor (xx, xk, kk) of the samples `span` (at least, within the
    /// first `len` samples) into `tensor.jxx` etc., summed over the source channels and the
    /// views.
    pub(super) fn tensor_span(
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
    pub(super) fn tensor_line<const TAPS: usize>(
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
    pub(super) fn tensor_chunk<const TAPS: usize, const L: usize>(
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
    pub(super) fn tensor_lanes<const TAPS: usize, const L: usize>(
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
    use crate::epi::hypotheses::Hypotheses;
    use crate::epi::EpiParams;

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
