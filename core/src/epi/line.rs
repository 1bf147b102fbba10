//! The structure tensor of one EPI line: disparity and coherence of every sample of the
//! centre view along one image row (horizontal EPI) or column (vertical EPI), tested over
//! every shear hypothesis.

use super::hypotheses::Hypotheses;
use super::kernels::{centre_weights, truncated_gaussian, Kernel};
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
    /// Mixing rows (weights over views) of view k: `mix_smooth`, the inner Gaussian
    /// followed by the Scharr cross smoothing (for the along-line gradient), and
    /// `mix_derivative`, the inner Gaussian followed by the across-view derivative
    /// (central; one-sided at the first and last view so that the ends keep the scale).
    /// Per view k, the significant entries of `mix_smooth[k]` and `mix_derivative[k]`.
    smooth_taps: [Taps<T>; GRID_MAX],
    derivative_taps: [Taps<T>; GRID_MAX],
    views: usize,
    centre: usize,
    channels: usize,
    hypotheses: Hypotheses,
    interpolate: bool,
}

/// Ranking offsets below a zero crossing's score (in [0, 1]): a single hypothesis
/// (`coherence − 1`), an estimate outside its hypothesis' window (`coherence − 2`) and a
/// degenerate tensor (no texture, or an orientation the window can never hold).
const SINGLE: f32 = -1.0;
const OUT_OF_WINDOW: f32 = -2.0;
const DEGENERATE: f32 = -3.0;
/// Samples per register block of the gradient sums.
const CHUNK: usize = 32;
/// Mixing entries below this fraction of their row's largest are dropped: the inner
/// Gaussian's 3σ tails (≈ 3·10⁻⁴ of the centre at σ = 0.5) would otherwise widen every
/// row by two views for no measurable change (docs/bench-epi.md).
const PRUNE: f32 = 1e-3;

/// The significant entries of one mixing row: `weights[i]` multiplies view `views[i]`.
#[derive(Clone, Copy, Debug)]
struct Taps<T: Scalar> {
    views: [usize; GRID_MAX],
    weights: [T; GRID_MAX],
    len: usize,
}

impl<T: Scalar> Taps<T> {
    /// The entries of `row` whose magnitude reaches `PRUNE` of the largest one.
    fn significant(row: &[f32]) -> Self {
        let largest = row.iter().fold(0.0f32, |m, &v| m.max(libm::fabsf(v)));
        let mut taps = Taps {
            views: [0; GRID_MAX],
            weights: [T::ZERO; GRID_MAX],
            len: 0,
        };
        for (j, &v) in row.iter().enumerate().take(GRID_MAX) {
            if v != 0.0 && libm::fabsf(v) >= PRUNE * largest {
                taps.views[taps.len] = j;
                taps.weights[taps.len] = T::from_f32(v);
                taps.len += 1;
            }
        }
        taps
    }

    fn views(&self) -> &[usize] {
        &self.views[..self.len]
    }

    fn weights(&self) -> &[T] {
        &self.weights[..self.len]
    }
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
        let mut weights = [T::ZERO; GRID_MAX];
        for (w, &v) in weights.iter_mut().zip(&outer_weights) {
            *w = T::from_f32(v);
        }
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
        let empty = Taps::significant(&[]);
        let mut smooth_taps = [empty; GRID_MAX];
        let mut derivative_taps = [empty; GRID_MAX];
        for k in 0..views {
            let mut mix_smooth = [0.0f32; GRID_MAX];
            let mut mix_derivative = [0.0f32; GRID_MAX];
            for j in 0..views {
                for i in 0..views {
                    mix_smooth[j] += gauss[k][i] * smooth[i][j];
                    mix_derivative[j] += gauss[k][i] * diff[i][j];
                }
            }
            // The outer weight of view k enters as √w in both gradients, so the tensor
            // terms are plain products (w·gx² = (√w·gx)²).
            let root = libm::sqrtf(outer_weights[k].max(0.0));
            for m in mix_smooth.iter_mut().chain(mix_derivative.iter_mut()) {
                *m *= root;
            }
            smooth_taps[k] = Taps::significant(&mix_smooth[..views]);
            derivative_taps[k] = Taps::significant(&mix_derivative[..views]);
        }
        LineEstimator {
            derivative: Kernel::derivative(params.inner_sigma),
            smoothing: Kernel::scharr_smoothing(params.inner_sigma),
            outer: Kernel::gaussian(params.outer_sigma),
            weights,
            smooth_taps,
            derivative_taps,
            views,
            centre,
            channels: match params.color {
                ColorMode::Gray => 1,
                ColorMode::Tensor => channels.clamp(1, 3),
            },
            hypotheses,
            interpolate: params.interpolate,
        }
    }

    /// Planes the loader must fill per view.
    pub(crate) fn channels(&self) -> usize {
        self.channels
    }

    /// Work elements (of `T`) for a line of `n` samples.
    pub(crate) fn work_len(views: usize, channels: usize, n: usize) -> usize {
        (2 * views * channels + 2 * views + 10) * n
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
        let (skk, rest) = rest.split_at_mut(n);
        let (score, rest) = rest.split_at_mut(n);
        let (prev_r, rest) = rest.split_at_mut(n);
        let prev_c = &mut rest[..n];

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
        for ((d, c), sc) in best_d
            .iter_mut()
            .zip(best_c.iter_mut())
            .zip(score.iter_mut())
        {
            *d = T::ZERO;
            *c = T::ZERO;
            *sc = lowest;
        }
        let h = &self.hypotheses;
        let window = T::from_f32(h.window());
        let step = T::from_f32(h.step());
        let degenerate = T::from_f32(DEGENERATE);
        let single = T::from_f32(SINGLE);
        let out_of_window = T::from_f32(OUT_OF_WINDOW);
        let tiny_trace = T::from_f32(1e-6).max(T::EPSILON);
        let min_den = T::from_f32(1.0 / 64.0);
        let min_gap = T::from_f32(1.0 / 256.0);
        let two = T::from_i32(2);
        let mut previous_shear = T::ZERO;
        for i in 0..h.count() {
            let shear = h.shear(i);
            let shear_t = T::from_f32(shear);
            jxx.fill(T::ZERO);
            jxk.fill(T::ZERO);
            jkk.fill(T::ZERO);
            for c in 0..c_n {
                for k in 0..k_n {
                    let offset = (k as f32 - self.centre as f32) * shear;
                    let at = (k * c_n + c) * n;
                    shift(&pre_d[at..at + n], &mut sh_d[k * n..(k + 1) * n], offset);
                    shift(&pre_s[at..at + n], &mut sh_s[k * n..(k + 1) * n], offset);
                }
                // Chunks of CHUNK samples; the last one overlaps its predecessor so that
                // every chunk has the constant length the compiler unrolls and keeps in
                // registers (overlapping samples are computed again, identically).
                let mut done = 0;
                while done < n {
                    let mut sums = [[T::ZERO; CHUNK]; 3];
                    let (t0, len) = if n >= CHUNK {
                        let t0 = done.min(n - CHUNK);
                        self.tensor_chunk(sh_d, sh_s, n, t0, CHUNK, &mut sums);
                        (t0, CHUNK)
                    } else {
                        self.tensor_chunk(sh_d, sh_s, n, 0, n, &mut sums);
                        (0, n)
                    };
                    let new = done - t0..len;
                    let span = done..t0 + len;
                    for ((((xx, xk), kk), &sxx), (&sxk, &skk)) in jxx[span.clone()]
                        .iter_mut()
                        .zip(jxk[span.clone()].iter_mut())
                        .zip(jkk[span].iter_mut())
                        .zip(sums[0][new.clone()].iter())
                        .zip(sums[1][new.clone()].iter().zip(sums[2][new].iter()))
                    {
                        *xx += sxx;
                        *xk += sxk;
                        *kk += skk;
                    }
                    done = t0 + len;
                }
            }
            self.outer.apply(jxx, sxx);
            self.outer.apply(jxk, sxk);
            self.outer.apply(jkk, skk);
            for t in 0..n {
                let trace = sxx[t] + skk[t];
                // Residual slope and coherence; coherence < 0 marks a degenerate tensor.
                let (r, coherence) = if trace <= tiny_trace {
                    (T::ZERO, degenerate)
                } else {
                    // Normalised by the trace so that fixed point never overflows:
                    // a, b ∈ [−1, 1], coherence √(a² + b²) ∈ [0, 1], and the slope of the
                    // dominant eigenvector is b / (a + √…) = 2Jxk / (Jxx − Jkk + √…).
                    let a = (sxx[t] - skk[t]) / trace;
                    let b = two * sxk[t] / trace;
                    let coherence = (a * a + b * b).sqrt().min(T::ONE);
                    let den = a + coherence;
                    if den <= min_den {
                        (T::ZERO, degenerate)
                    } else {
                        (b / den, coherence)
                    }
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
                if self.interpolate && i > 0 {
                    // The residual slope falls linearly through zero between the two
                    // shears that bracket the disparity; its zero crossing cancels the
                    // tensor's slope-proportional bias.
                    let (pr, pc) = (prev_r[t], prev_c[t]);
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
                if cand_score > score[t] {
                    score[t] = cand_score;
                    best_d[t] = cand_d;
                    best_c[t] = coherence.max(T::ZERO);
                }
                if inside {
                    prev_r[t] = r;
                    prev_c[t] = coherence;
                } else {
                    prev_c[t] = degenerate;
                }
            }
            previous_shear = shear_t;
        }
        let (lo, hi) = (T::from_f32(h.min()), T::from_f32(h.max()));
        for d in best_d.iter_mut() {
            *d = d.clamp(lo, hi);
        }
        Ok(())
    }

    /// Adds to `sums` (xx, xk, kk) the outer-weighted tensor of samples `t0..t0 + len`
    /// (`len ≤ CHUNK`) of one channel: gradients of every view across the views (rows of
    /// the mixing matrices) from the sheared planes `sh_d` / `sh_s` (`views · n`), kept
    /// out of memory.
    #[inline(always)]
    fn tensor_chunk(
        &self,
        sh_d: &[T],
        sh_s: &[T],
        n: usize,
        t0: usize,
        len: usize,
        sums: &mut [[T; CHUNK]; 3],
    ) {
        let [sum_xx, sum_xk, sum_kk] = sums;
        for k in 0..self.views {
            let w = self.weights[k];
            if w == T::ZERO {
                continue;
            }
            // Only the significant entries of the two rows (the inner Gaussian is short,
            // and the derivative row has no centre entry).
            let (smooth, derivative) = (&self.smooth_taps[k], &self.derivative_taps[k]);
            let mut ax = [T::ZERO; CHUNK];
            let mut ak = [T::ZERO; CHUNK];
            for (&j, &a) in smooth.views().iter().zip(smooth.weights()) {
                let at = j * n + t0;
                for (x, &p) in ax[..len].iter_mut().zip(&sh_d[at..at + len]) {
                    *x += a * p;
                }
            }
            for (&j, &b) in derivative.views().iter().zip(derivative.weights()) {
                let at = j * n + t0;
                for (y, &q) in ak[..len].iter_mut().zip(&sh_s[at..at + len]) {
                    *y += b * q;
                }
            }
            for ((((xx, xk), kk), &gx), &gk) in sum_xx[..len]
                .iter_mut()
                .zip(sum_xk[..len].iter_mut())
                .zip(sum_kk[..len].iter_mut())
                .zip(ax.iter())
                .zip(ak.iter())
            {
                *xx += gx * gx;
                *xk += gx * gk;
                *kk += gk * gk;
            }
        }
    }
}

/// `out[t] = input(t − offset)`, linear interpolation, clamped at the ends. Integer offsets
/// are exact copies (no interpolation blur).
fn shift<T: Scalar>(input: &[T], out: &mut [T], offset: f32) {
    let n = input.len().min(out.len());
    if n == 0 {
        return;
    }
    let (input, out) = (&input[..n], &mut out[..n]);
    let floor = libm::floorf(offset);
    let frac = offset - floor;
    // out[t] = (1 − f)·in[t − whole] + f·in[t − whole − 1]; with f = 0 only the first term.
    let whole = floor as isize;
    let lag = if frac == 0.0 { 0 } else { 1 };
    let last = n as isize - 1;
    let at = |i: isize| input[i.clamp(0, last) as usize];
    // Interior: every index in range, t ∈ [whole + lag, last + whole].
    let lo = (whole + lag as isize).clamp(0, n as isize) as usize;
    let hi = (last + whole + 1).clamp(lo as isize, n as isize) as usize;
    if frac == 0.0 {
        for (t, o) in out.iter_mut().enumerate().take(lo) {
            *o = at(t as isize - whole);
        }
        if hi > lo {
            let src = (lo as isize - whole) as usize;
            out[lo..hi].copy_from_slice(&input[src..src + (hi - lo)]);
        }
        for (t, o) in out.iter_mut().enumerate().skip(hi) {
            *o = at(t as isize - whole);
        }
        return;
    }
    let (wa, wb) = (T::from_f32(1.0 - frac), T::from_f32(frac));
    let edge = |t: usize| {
        let i = t as isize - whole;
        wa * at(i) + wb * at(i - 1)
    };
    for (t, o) in out.iter_mut().enumerate().take(lo) {
        *o = edge(t);
    }
    if hi > lo {
        let src = (lo as isize - whole) as usize;
        let a = &input[src..src + (hi - lo)];
        let b = &input[src - 1..src - 1 + (hi - lo)];
        for ((o, &x), &y) in out[lo..hi].iter_mut().zip(a).zip(b) {
            *o = wa * x + wb * y;
        }
    }
    for (t, o) in out.iter_mut().enumerate().skip(hi) {
        *o = edge(t);
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
        // Every offset agrees with the clamped definition, including huge ones.
        let input: [f32; 9] = core::array::from_fn(|i| (i * i) as f32);
        for offset in [
            -12.5f32, -3.0, -2.75, -0.5, 0.0, 0.5, 1.0, 3.25, 8.0, 8.5, 20.0,
        ] {
            shift(&input, &mut out, offset);
            for (t, &got) in out.iter().enumerate() {
                let x = t as f32 - offset;
                let (i, f) = (x.floor(), x - x.floor());
                let at = |i: f32| input[(i.max(0.0) as usize).min(4)];
                let want = (1.0 - f) * at(i) + f * at(i + 1.0);
                assert!((got - want).abs() < 1e-4, "{offset} {t}: {got} vs {want}");
            }
        }
    }
}
