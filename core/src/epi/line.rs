//! The structure tensor of one EPI line: disparity and coherence of every sample of the
//! centre view along one image row (horizontal EPI) or column (vertical EPI), tested over
//! every shear hypothesis.

mod coarse;
mod estimator;
mod guide;
mod scoring;
mod sources;
mod sweep;
mod tensor;

use super::band::Band;
use super::hypotheses::Hypotheses;
use super::kernels::{apply_pair, centre_weights, truncated_gaussian, Kernel};
use super::planes::Planes;
use super::{ColorMode, EpiParams, Search};
use crate::error::{check_scratch, Error, Result};
use crate::lightfield::GRID_MAX;
use crate::scalar::Scalar;
use estimator::{Coarse, COARSE_STEPS};
use scoring::State;
use tensor::Tensor;

pub(crate) use estimator::LineEstimator;
#[cfg(test)]
pub(super) use scoring::lane_sqrt;

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

/// Entry `(i, j)` of the per-view Scharr cross smoothing (`[3, 10, 3]`, renormalised at
/// the ends) and of the central difference (one-sided at the ends) across `last + 1`
/// views: the same values as the matrices built row by row (every entry is written once
/// onto zero).
fn scharr_and_difference(i: usize, j: usize, last: usize) -> (f32, f32) {
    let (im, ip) = (i.saturating_sub(1), (i + 1).min(last));
    let side = if im < i { 3.0 } else { 0.0 } + if ip > i { 3.0 } else { 0.0 };
    let norm = 10.0 + side;
    let smooth = if j == i {
        10.0 / norm
    } else if (j == im && im < i) || (j == ip && ip > i) {
        3.0 / norm
    } else {
        0.0
    };
    let diff = if ip > im && (j == ip || j == im) {
        let scale = 1.0 / (ip - im) as f32;
        if j == ip {
            scale
        } else {
            -scale
        }
    } else {
        0.0
    };
    (smooth, diff)
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
        let last = views.saturating_sub(1);
        let mut active = [false; GRID_MAX];
        for (a, &w) in active.iter_mut().zip(&outer_weights).take(views) {
            *a = T::from_f32(w) != T::ZERO;
        }
        // Row k of the mixing matrices: row k of the inner Gaussian times the Scharr and
        // the difference matrices (their entries computed where used), each view's
        // outer weight entering as √w in both gradients, so that the tensor terms are
        // plain products (w·gx² = (√w·gx)²). Computed row by row where the band needs
        // them: the five 17×17 tables made this the firmware's deepest stack frame.
        let inner_sigma = params.inner_sigma;
        let mix_rows = |k: usize| {
            let mut mix_smooth = [0.0f32; GRID_MAX];
            let mut mix_derivative = [0.0f32; GRID_MAX];
            let mut gauss = [0.0f32; GRID_MAX];
            truncated_gaussian(inner_sigma, views, k, &mut gauss);
            let mixed = mix_smooth.iter_mut().zip(mix_derivative.iter_mut());
            for (j, (ms, md)) in mixed.enumerate().take(views) {
                for (i, &g) in gauss.iter().enumerate().take(views) {
                    let (smooth, diff) = scharr_and_difference(i, j, last);
                    *ms += g * smooth;
                    *md += g * diff;
                }
            }
            let root = crate::float::sqrtf(outer_weights.get(k).map_or(0.0, |w| w.max(0.0)));
            for m in mix_smooth.iter_mut().chain(mix_derivative.iter_mut()) {
                *m *= root;
            }
            (mix_smooth, mix_derivative)
        };
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
            band: Band::new(mix_rows, active, views),
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
        self.sweep(&planes, bank, &mut tensor, &mut state, guide);
        let h = &self.hypotheses;
        let (lo, hi) = (T::from_f32(h.min()), T::from_f32(h.max()));
        for d in disparity.iter_mut().take(n) {
            *d = d.clamp(lo, hi);
        }
        Ok(())
    }
}

#[cfg(test)]
mod mixing_tests {
    use super::*;

    /// The Scharr and difference matrices as whole tables, row by row.
    fn matrices(views: usize) -> ([[f32; GRID_MAX]; GRID_MAX], [[f32; GRID_MAX]; GRID_MAX]) {
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
        (smooth, diff)
    }

    #[test]
    fn entries_equal_the_tables_bit_for_bit() {
        for views in 1..=GRID_MAX {
            let (smooth, diff) = matrices(views);
            for i in 0..views {
                for j in 0..views {
                    let (s, d) = scharr_and_difference(i, j, views - 1);
                    assert_eq!(
                        s.to_bits(),
                        smooth[i][j].to_bits(),
                        "{views} views ({i}, {j})"
                    );
                    assert_eq!(
                        d.to_bits(),
                        diff[i][j].to_bits(),
                        "{views} views ({i}, {j})"
                    );
                }
            }
        }
        // A tap is there: the test would see a wrong one.
        assert!(scharr_and_difference(1, 0, 2).0 > 0.0);
    }
}
