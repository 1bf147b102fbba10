//! The coarse pass: the gray planes swept over a few widely spaced shears at every second
//! sample, turned into the guide that tells the fine sweep which shears each sample needs.

use super::estimator::{Coarse, LineEstimator};
use super::guide::Guide;
use super::scoring::{State, DEGENERATE, SINGLE};
use super::tensor::Tensor;
use crate::epi::hypotheses::Hypotheses;
use crate::epi::kernels::deinterleave;
use crate::epi::planes::Planes;
use crate::error::{Error, Result};
use crate::scalar::Scalar;

// The coarse pass scores every second sample along the line (the tensor is smoothed over
// ±3·outer_sigma samples anyway); the others take their left neighbour's: see
// `LineEstimator::coarse_sweep`.
/// A sample whose coarse estimate lies within this many shear steps of a fine shear is
/// tested at that shear only (its residual there is small, and so is the residual's
/// slope-proportional bias the zero crossing cancels): 31 % / 37 % of the samples of HCI
/// cotton / backgammon, ≈ −5 % CPU, and both HCI scenes a little better, stage and
/// pipeline; 0.2 and 0.25 cost cotton's pipeline MSE +0.03 / +0.08 (docs/stages/epi.md).
const NEAR: f32 = 0.15;

impl<T: Scalar> LineEstimator<T> {
    /// The coarse pass: the gray mean of the channels' planes (the filters are linear)
    /// swept over the coarse hypotheses, every second sample scored; returns
    /// which fine hypotheses each sample needs, held in `coarse_work` (5 lines).
    pub(super) fn coarse_guide<'w>(
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
    pub(super) fn coarse_sweep(
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
}
