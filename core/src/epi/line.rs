//! The structure tensor of one EPI line: disparity and coherence of every sample of the
//! centre view along one image row (horizontal EPI) or column (vertical EPI), tested over
//! every shear hypothesis.

use super::hypotheses::Hypotheses;
use super::kernels::{centre_weights, Kernel};
use super::{ColorMode, EpiParams};
use crate::error::{Error, Result};
use crate::lightfield::GRID_MAX;
use crate::scalar::Scalar;

/// Everything that does not change from line to line, converted to `T` once.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LineEstimator<T: Scalar> {
    derivative: Kernel<T>,
    smoothing: Kernel<T>,
    outer: Kernel<T>,
    /// Outer (Gaussian) smoothing across views, evaluated at the centre view only.
    weights: [T; GRID_MAX],
    views: usize,
    centre: usize,
    channels: usize,
    hypotheses: Hypotheses,
}

/// Scores below every coherence: an estimate outside its hypothesis' window (`coherence −
/// 2`) and a degenerate tensor (no texture, or an orientation the window can never hold).
const OUT_OF_WINDOW: f32 = -2.0;
const DEGENERATE: f32 = -3.0;

impl<T: Scalar> LineEstimator<T> {
    /// `views` cameras along the EPI, the centre one at `centre`, `channels` loaded planes.
    pub(crate) fn new(
        params: &EpiParams,
        hypotheses: Hypotheses,
        views: usize,
        centre: usize,
        channels: usize,
    ) -> Self {
        let mut weights = [T::ZERO; GRID_MAX];
        centre_weights(
            params.outer_sigma,
            views.min(GRID_MAX),
            centre,
            &mut weights,
        );
        LineEstimator {
            derivative: Kernel::derivative(params.inner_sigma),
            smoothing: Kernel::scharr_smoothing(params.inner_sigma),
            outer: Kernel::gaussian(params.outer_sigma),
            weights,
            views: views.min(GRID_MAX),
            centre,
            channels: match params.color {
                ColorMode::Gray => 1,
                ColorMode::Tensor => channels.clamp(1, 3),
            },
            hypotheses,
        }
    }

    /// Planes the loader must fill per view.
    pub(crate) fn channels(&self) -> usize {
        self.channels
    }

    /// Work elements (of `T`) for a line of `n` samples.
    pub(crate) fn work_len(views: usize, channels: usize, n: usize) -> usize {
        (2 * views * channels + 2 * views + 7) * n
    }

    /// Estimates one line of `n` samples. `load(view, channel, out)` fills `out` (length `n`)
    /// with the samples of that view along the line, scaled intensities. Writes the
    /// disparity and the confidence of every sample into `disparity` / `confidence`.
    pub(crate) fn estimate(
        &self,
        n: usize,
        mut load: impl FnMut(usize, usize, &mut [T]) -> Result<()>,
        work: &mut [T],
        disparity: &mut [T],
        confidence: &mut [T],
    ) -> Result<()> {
        let (k_n, c_n) = (self.views, self.channels);
        let needed = Self::work_len(k_n, c_n, n);
        if work.len() < needed {
            return Err(Error::ScratchTooSmall {
                needed,
                got: work.len(),
            });
        }
        if disparity.len() < n || confidence.len() < n {
            return Err(Error::OutputSize {
                what: "the line output",
                needed: n,
                got: disparity.len().min(confidence.len()),
            });
        }
        let (pre_d, rest) = work.split_at_mut(k_n * c_n * n);
        let (pre_s, rest) = rest.split_at_mut(k_n * c_n * n);
        let (sh_d, rest) = rest.split_at_mut(k_n * n);
        let (sh_s, rest) = rest.split_at_mut(k_n * n);
        let (raw, rest) = rest.split_at_mut(n);
        let (jxx, rest) = rest.split_at_mut(n);
        let (jxk, rest) = rest.split_at_mut(n);
        let (jkk, rest) = rest.split_at_mut(n);
        let (sxx, rest) = rest.split_at_mut(n);
        let (sxk, rest) = rest.split_at_mut(n);
        let skk = &mut rest[..n];

        // Filtering along the line commutes with the shear (a shift along the line), so the
        // inner smoothing and the along-line parts of the Scharr filters run once per line.
        for k in 0..k_n {
            for c in 0..c_n {
                load(k, c, raw)?;
                let at = (k * c_n + c) * n;
                self.derivative.apply(raw, &mut pre_d[at..at + n]);
                self.smoothing.apply(raw, &mut pre_s[at..at + n]);
            }
        }

        let best_d = &mut disparity[..n];
        let best_c = &mut confidence[..n];
        let lowest = T::from_f32(DEGENERATE - 1.0);
        for (d, c) in best_d.iter_mut().zip(best_c.iter_mut()) {
            *d = T::ZERO;
            *c = lowest;
        }
        let h = &self.hypotheses;
        let window = T::from_f32(h.window());
        let degenerate = T::from_f32(DEGENERATE);
        let out_of_window = T::from_f32(OUT_OF_WINDOW);
        let tiny_trace = T::from_f32(1e-6).max(T::EPSILON);
        let min_den = T::from_f32(1.0 / 64.0);
        let two = T::from_i32(2);
        let (side, middle, half) = (
            T::from_f32(3.0 / 16.0),
            T::from_f32(10.0 / 16.0),
            T::from_f32(0.5),
        );
        for i in 0..h.count() {
            let shear = h.shear(i);
            let shear_t = T::from_f32(shear);
            for v in jxx.iter_mut().chain(jxk.iter_mut()).chain(jkk.iter_mut()) {
                *v = T::ZERO;
            }
            for c in 0..c_n {
                for k in 0..k_n {
                    let offset = (k as f32 - self.centre as f32) * shear;
                    let at = (k * c_n + c) * n;
                    shift(&pre_d[at..at + n], &mut sh_d[k * n..(k + 1) * n], offset);
                    shift(&pre_s[at..at + n], &mut sh_s[k * n..(k + 1) * n], offset);
                }
                for k in 0..k_n {
                    let w = self.weights[k];
                    if w == T::ZERO {
                        continue;
                    }
                    let (km, kp) = (k.saturating_sub(1), (k + 1).min(k_n - 1));
                    // One-sided difference at the first and last view: same scale as the
                    // central one, so the end views do not bias the slope towards zero.
                    let half = if kp - km == 2 { half } else { T::ONE };
                    let (dm, d0, dp) = (
                        &sh_d[km * n..km * n + n],
                        &sh_d[k * n..k * n + n],
                        &sh_d[kp * n..kp * n + n],
                    );
                    let (sm, sp) = (&sh_s[km * n..km * n + n], &sh_s[kp * n..kp * n + n]);
                    for t in 0..n {
                        let gx = side * (dm[t] + dp[t]) + middle * d0[t];
                        let gk = half * (sp[t] - sm[t]);
                        let wgx = w * gx;
                        jxx[t] += wgx * gx;
                        jxk[t] += wgx * gk;
                        jkk[t] += w * gk * gk;
                    }
                }
            }
            self.outer.apply(jxx, sxx);
            self.outer.apply(jxk, sxk);
            self.outer.apply(jkk, skk);
            for t in 0..n {
                let trace = sxx[t] + skk[t];
                let (score, d) = if trace <= tiny_trace {
                    (degenerate, T::ZERO)
                } else {
                    // Normalised by the trace so that fixed point never overflows:
                    // a, b ∈ [−1, 1], coherence r = √(a² + b²) ∈ [0, 1], and the slope of
                    // the dominant eigenvector is b / (a + r) = 2Jxk / (Jxx − Jkk + √…).
                    let a = (sxx[t] - skk[t]) / trace;
                    let b = two * sxk[t] / trace;
                    let r = (a * a + b * b).sqrt().min(T::ONE);
                    let den = a + r;
                    if den <= min_den {
                        (degenerate, T::ZERO)
                    } else {
                        let d = b / den;
                        if d.abs() <= window {
                            (r, d)
                        } else {
                            (r + out_of_window, d.clamp(-window, window))
                        }
                    }
                };
                if score > best_c[t] {
                    best_c[t] = score;
                    best_d[t] = shear_t + d;
                }
            }
        }
        let (lo, hi) = (T::from_f32(h.min()), T::from_f32(h.max()));
        for (d, c) in best_d.iter_mut().zip(best_c.iter_mut()) {
            *d = d.clamp(lo, hi);
            *c = c.max(T::ZERO);
        }
        Ok(())
    }
}

/// `out[t] = input(t − offset)`, linear interpolation, clamped at the ends. Integer offsets
/// are exact copies (no interpolation blur).
fn shift<T: Scalar>(input: &[T], out: &mut [T], offset: f32) {
    let n = input.len().min(out.len());
    if n == 0 {
        return;
    }
    let last = n as isize - 1;
    let floor = libm::floorf(offset);
    let whole = floor as isize;
    let frac = offset - floor;
    let at = |i: isize| input[i.clamp(0, last) as usize];
    if frac == 0.0 {
        for (t, o) in out.iter_mut().enumerate().take(n) {
            *o = at(t as isize - whole);
        }
        return;
    }
    let (wa, wb) = (T::from_f32(1.0 - frac), T::from_f32(frac));
    for (t, o) in out.iter_mut().enumerate().take(n) {
        let i = t as isize - whole;
        *o = wa * at(i) + wb * at(i - 1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shift_moves_content_and_clamps() {
        let input = [0.0f32, 1.0, 2.0, 3.0, 4.0];
        let mut out = [0.0; 5];
        shift(&input, &mut out, 2.0);
        assert_eq!(out, [0.0, 0.0, 0.0, 1.0, 2.0]);
        shift(&input, &mut out, -1.0);
        assert_eq!(out, [1.0, 2.0, 3.0, 4.0, 4.0]);
        shift(&input, &mut out, 0.25);
        assert_eq!(out[2], 1.75);
    }
}
