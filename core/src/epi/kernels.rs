//! 1-D correlation kernels (Gaussian, Gaussian-smoothed derivative and Scharr smoothing)
//! and their application along a line with clamped ("nearest") borders.

use core::ops::Range;

use crate::scalar::Scalar;

/// Largest kernel radius: `ceil(3σ) + 1` for the largest σ `EpiParams::validate` accepts.
pub(crate) const MAX_RADIUS: usize = 16;
/// Taps of the largest kernel.
pub(crate) const MAX_TAPS: usize = 2 * MAX_RADIUS + 1;

/// Taps of the along-line prefilter kernels below this fraction of their largest are
/// dropped (the same threshold as the across-view bands', `band::PRUNE`).
const PRUNE: f32 = 1e-3;

/// Radius of a Gaussian of standard deviation `sigma` truncated at 3σ (0 for σ ≤ 0).
pub(crate) fn gaussian_radius(sigma: f32) -> usize {
    if sigma > 0.0 {
        libm::ceilf(3.0 * sigma) as usize
    } else {
        0
    }
}

/// Normalised Gaussian taps at offsets `-r..=r`, `r = gaussian_radius(sigma)`.
fn gaussian_f32(sigma: f32, taps: &mut [f32; MAX_TAPS]) -> usize {
    let r = gaussian_radius(sigma).min(MAX_RADIUS - 1);
    *taps = [0.0; MAX_TAPS];
    if r == 0 {
        taps[0] = 1.0;
        return 0;
    }
    let mut sum = 0.0f32;
    for (i, t) in taps.iter_mut().take(2 * r + 1).enumerate() {
        let x = i as f32 - r as f32;
        *t = libm::expf(-0.5 * x * x / (sigma * sigma));
        sum += *t;
    }
    for t in taps.iter_mut().take(2 * r + 1) {
        *t /= sum;
    }
    r
}

/// A symmetric or antisymmetric correlation kernel: `out[t] = Σ_j taps[j]·in[t + j − radius]`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Kernel<T: Scalar> {
    taps: [T; MAX_TAPS],
    radius: usize,
    symmetry: Symmetry,
}

/// Mirror symmetry of the taps about the centre: the interior then multiplies each pair
/// of mirrored samples once (half the multiplications).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Symmetry {
    /// `taps[r + j] == taps[r − j]` (smoothing).
    Even,
    /// `taps[r + j] == −taps[r − j]`, zero centre (derivative).
    Odd,
}

impl<T: Scalar> Kernel<T> {
    /// Kernel from `2·radius + 1` taps that are mirror-symmetric up to rounding; the upper
    /// half is mirrored from the lower one so that the symmetry is exact.
    fn from_f32(taps: &[f32; MAX_TAPS], radius: usize, symmetry: Symmetry) -> Self {
        let radius = radius.min(MAX_RADIUS);
        let mut out = [T::ZERO; MAX_TAPS];
        for (o, &t) in out.iter_mut().zip(taps.iter()).take(radius + 1) {
            *o = T::from_f32(t);
        }
        // `radius ≤ MAX_RADIUS`: the centre and the `radius` taps above it exist.
        let (lower, upper) = out.split_at_mut(radius);
        if let Some((centre, upper)) = upper.split_first_mut() {
            if symmetry == Symmetry::Odd {
                *centre = T::ZERO;
            }
            for (u, &l) in upper.iter_mut().zip(lower.iter().rev()) {
                *u = match symmetry {
                    Symmetry::Even => l,
                    Symmetry::Odd => -l,
                };
            }
        }
        Kernel {
            taps: out,
            radius,
            symmetry,
        }
    }

    /// Gaussian smoothing of standard deviation `sigma` (identity for σ ≤ 0).
    pub(crate) fn gaussian(sigma: f32) -> Self {
        let mut g = [0.0; MAX_TAPS];
        let r = gaussian_f32(sigma, &mut g);
        Self::from_f32(&g, r, Symmetry::Even)
    }

    /// Gaussian of `sigma` followed by a 3-tap kernel `three` (offsets −1, 0, +1) of the
    /// given symmetry.
    fn gaussian_then(sigma: f32, three: [f32; 3], symmetry: Symmetry) -> Self {
        let mut g = [0.0; MAX_TAPS];
        let r = gaussian_f32(sigma, &mut g);
        let mut c = [0.0f32; MAX_TAPS];
        // Correlations compose by adding offsets: c[m] = Σ_{i + j = m} g[i]·three[j].
        for (i, &gi) in g.iter().take(2 * r + 1).enumerate() {
            for (j, &tj) in three.iter().enumerate() {
                c[i + j] += gi * tj;
            }
        }
        // Outer taps below `PRUNE` of the largest are dropped (at σ = 0.5 the last pair,
        // 3·10⁻⁴ / 10⁻⁴ of the largest, from the Gaussian's 3σ tail: 5 taps instead of 7,
        // a third of the prefilter's work), the rest rescaled so that the kernel keeps its
        // gain on a constant (smoothing) or a ramp (derivative).
        let full = r + 1;
        let largest = c
            .iter()
            .take(2 * full + 1)
            .fold(0.0f32, |m, &v| m.max(libm::fabsf(v)));
        let mut kept = full;
        while kept > 1 && libm::fabsf(c[full - kept]) < PRUNE * largest {
            kept -= 1;
        }
        let moment = |taps: &[f32], radius: usize| -> f32 {
            taps.iter()
                .take(2 * radius + 1)
                .enumerate()
                .map(|(i, &v)| match symmetry {
                    Symmetry::Even => v,
                    Symmetry::Odd => v * (i as f32 - radius as f32),
                })
                .sum()
        };
        let mut pruned = [0.0f32; MAX_TAPS];
        for (o, &v) in pruned
            .iter_mut()
            .zip(c.iter().skip(full - kept))
            .take(2 * kept + 1)
        {
            *o = v;
        }
        let (before, after) = (moment(&c, full), moment(&pruned, kept));
        if after != 0.0 {
            for o in pruned.iter_mut().take(2 * kept + 1) {
                *o *= before / after;
            }
        }
        Self::from_f32(&pruned, kept, symmetry)
    }

    /// Gaussian-smoothed central difference `(in[t+1] − in[t−1]) / 2`.
    pub(crate) fn derivative(sigma: f32) -> Self {
        Self::gaussian_then(sigma, [-0.5, 0.0, 0.5], Symmetry::Odd)
    }

    /// Gaussian-smoothed Scharr cross smoothing `[3, 10, 3] / 16`.
    pub(crate) fn scharr_smoothing(sigma: f32) -> Self {
        Self::gaussian_then(sigma, [3.0 / 16.0, 10.0 / 16.0, 3.0 / 16.0], Symmetry::Even)
    }

    /// Kernel radius.
    pub(crate) fn radius(&self) -> usize {
        self.radius
    }

    /// Correlates `input` with the kernel into `out` (same length), clamping indices at
    /// the borders. The summation order of a sample depends only on its position and the
    /// line length, so results never depend on how lines are grouped into bands.
    pub(crate) fn apply(&self, input: &[T], out: &mut [T]) {
        let n = input.len().min(out.len());
        self.apply_range(input, out, 0..n);
    }

    /// [`Kernel::apply`] for the outputs `range` only (bit-identical to the full call there;
    /// the rest of `out` is left alone).
    pub(crate) fn apply_range(&self, input: &[T], out: &mut [T], range: Range<usize>) {
        let n = input.len().min(out.len());
        let r = self.radius;
        let Some(taps) = self.taps.get(..2 * r + 1) else {
            return; // radius ≤ MAX_RADIUS by construction
        };
        let (a, b) = (range.start.min(n), range.end.min(n));
        if a >= b {
            return;
        }
        let last = n - 1;
        let clamped = |t: usize, out: &mut T| {
            let mut acc = T::ZERO;
            for (j, &k) in taps.iter().enumerate() {
                let i = (t + j).saturating_sub(r).min(last);
                acc += k * input[i];
            }
            *out = acc;
        };
        if n <= 2 * r {
            for (t, o) in out.iter_mut().enumerate().take(b).skip(a) {
                clamped(t, o);
            }
            return;
        }
        // Clamped edges, then the interior samples of the range.
        for (t, o) in out.iter_mut().enumerate().take(b.min(r)).skip(a) {
            clamped(t, o);
        }
        for (t, o) in out.iter_mut().enumerate().take(b).skip(a.max(n - r)) {
            clamped(t, o);
        }
        let (lo, hi) = (a.max(r), b.min(n - r));
        if lo >= hi {
            return;
        }
        // Interior: tap-major sums over contiguous slices (vectorises for f32), in blocks
        // of constant length held in registers; the last block overlaps its predecessor
        // (overlapping samples are computed again, identically). Input index of output t
        // is t − r + tap, so block starts are counted from t − r.
        let inner_len = hi - lo;
        let inner = &mut out[lo..hi];
        let base = lo - r;
        let mut done = 0;
        while done < inner_len {
            let mut acc = [T::ZERO; BLOCK];
            let (t0, len) = if inner_len >= BLOCK {
                let t0 = done.min(inner_len - BLOCK);
                // The outer smoothing's radii (σ 2, the default, and 1.5) fixed at compile
                // time: unrolled taps, no checks per window.
                match (self.symmetry, r) {
                    (Symmetry::Even, 6) => self.even_block::<6>(input, base + t0, &mut acc),
                    (Symmetry::Even, 5) => self.even_block::<5>(input, base + t0, &mut acc),
                    _ => self.interior_block(input, base + t0, BLOCK, &mut acc),
                }
                (t0, BLOCK)
            } else {
                self.interior_block(input, base, inner_len, &mut acc);
                (0, inner_len)
            };
            // An element loop, not `copy_from_slice`: the length varies, and a library
            // `memmove` call per block cost more than the copy.
            if let (Some(dst), Some(src)) = (inner.get_mut(done..t0 + len), acc.get(done - t0..len))
            {
                for (o, &v) in dst.iter_mut().zip(src) {
                    *o = v;
                }
            }
            done = t0 + len;
        }
    }
}

impl<T: Scalar> Kernel<T> {
    /// The even outputs of [`Kernel::apply`] on a line of `n` samples, bit-identical:
    /// `out[m]` = `apply(input)[2m]` for `m < ⌈n/2⌉`, where `split` holds the input as
    /// [`deinterleave`] writes it (its even samples, then its odd ones). Each output sums
    /// the same products in the same order as `apply_range` (clamped edges tap by tap, the
    /// interior centre first, then the symmetric pairs), over contiguous slices of the
    /// two halves, so the interior vectorises at half the products of the full line.
    pub(crate) fn apply_even(&self, split: &[T], n: usize, out: &mut [T]) {
        let n = n.min(split.len());
        let half = n.div_ceil(2);
        let (Some(even), Some(odd), Some(out)) =
            (split.get(..half), split.get(half..n), out.get_mut(..half))
        else {
            return;
        };
        let r = self.radius;
        let Some(taps) = self.taps.get(..2 * r + 1) else {
            return; // radius ≤ MAX_RADIUS by construction
        };
        if n == 0 {
            return;
        }
        let last = n - 1;
        let sample = |i: usize| {
            let half = if i % 2 == 0 { even } else { odd };
            half.get(i / 2).copied().unwrap_or(T::ZERO)
        };
        let clamped = |t: usize| {
            let mut acc = T::ZERO;
            for (j, &k) in taps.iter().enumerate() {
                acc += k * sample((t + j).saturating_sub(r).min(last));
            }
            acc
        };
        // Outputs `lo..hi` (samples r ≤ 2m < n − r) are `apply_range`'s interior.
        let (lo, hi) = if n > 2 * r {
            (r.div_ceil(2), (n - r).div_ceil(2))
        } else {
            (half, half)
        };
        for m in (0..lo).chain(hi..half) {
            if let Some(o) = out.get_mut(m) {
                *o = clamped(2 * m);
            }
        }
        let (Some(interior), Some((&centre, upper))) = (
            out.get_mut(lo..hi),
            self.taps.get(r..).and_then(|t| t.split_first()),
        ) else {
            return;
        };
        let len = interior.len();
        fn window<T>(half: &[T], from: usize, len: usize) -> Option<&[T]> {
            half.get(from..).and_then(|s| s.get(..len))
        }
        match (self.symmetry, window(even, lo, len)) {
            (Symmetry::Even, Some(middle)) => {
                for (o, &v) in interior.iter_mut().zip(middle) {
                    *o = centre * v;
                }
            }
            _ => interior.fill(T::ZERO),
        }
        for (j, &k) in (1..r + 1).zip(upper) {
            // Input 2m − j and 2m + j: even halves for even j, odd halves for odd j.
            let (half, down) = if j % 2 == 0 {
                (even, j / 2)
            } else {
                (odd, j.div_ceil(2))
            };
            let below = lo
                .checked_sub(down)
                .and_then(|from| window(half, from, len));
            let above = window(half, lo + j / 2, len);
            let (Some(below), Some(above)) = (below, above) else {
                continue;
            };
            match self.symmetry {
                Symmetry::Even => {
                    for ((o, &x), &y) in interior.iter_mut().zip(below).zip(above) {
                        *o += k * (x + y);
                    }
                }
                Symmetry::Odd => {
                    for ((o, &x), &y) in interior.iter_mut().zip(below).zip(above) {
                        *o += k * (y - x);
                    }
                }
            }
        }
    }
}

/// `split` = the even samples of `input`, then its odd ones (`input.len()` of them; for
/// [`Kernel::apply_even`]).
pub(crate) fn deinterleave<T: Copy>(input: &[T], split: &mut [T]) {
    let n = input.len();
    let Some((even, odd)) = split
        .get_mut(..n)
        .and_then(|s| s.split_at_mut_checked(n.div_ceil(2)))
    else {
        return;
    };
    for (e, pair) in even.iter_mut().zip(input.chunks(2)) {
        if let Some(&v) = pair.first() {
            *e = v;
        }
    }
    for (o, pair) in odd.iter_mut().zip(input.chunks_exact(2)) {
        if let [_, v] = *pair {
            *o = v;
        }
    }
}

/// Samples per register block of [`apply_pair`]'s interior (two accumulators).
const PAIR_BLOCK: usize = 16;

/// `odd.apply(input, out_odd)` and `even.apply(input, out_even)` in one pass over the
/// input (each window of samples loaded once for both kernels), bit-identical to the two
/// calls: every output sums the same products in the same order. Kernels of other
/// symmetries or of different radii take the two calls.
pub(crate) fn apply_pair<T: Scalar>(
    odd: &Kernel<T>,
    even: &Kernel<T>,
    input: &[T],
    out_odd: &mut [T],
    out_even: &mut [T],
) {
    let n = input.len().min(out_odd.len()).min(out_even.len());
    let r = odd.radius;
    if odd.symmetry != Symmetry::Odd
        || even.symmetry != Symmetry::Even
        || even.radius != r
        || n <= 2 * r + PAIR_BLOCK
    {
        odd.apply(input, out_odd);
        even.apply(input, out_even);
        return;
    }
    // Clamped edges (the first and last `r` samples) as `apply_range` computes them (the
    // same sums in the same order), both kernels in one loop.
    let (Some(all_odd), Some(all_even)) = (odd.taps.get(..2 * r + 1), even.taps.get(..2 * r + 1))
    else {
        return;
    };
    let last = n - 1;
    for t in (0..r).chain(n - r..n) {
        let (mut acc_odd, mut acc_even) = (T::ZERO, T::ZERO);
        for (j, (&ko, &ke)) in all_odd.iter().zip(all_even).enumerate() {
            let v = input
                .get((t + j).saturating_sub(r).min(last))
                .copied()
                .unwrap_or(T::ZERO);
            acc_odd += ko * v;
            acc_even += ke * v;
        }
        if let (Some(o), Some(e)) = (out_odd.get_mut(t), out_even.get_mut(t)) {
            (*o, *e) = (acc_odd, acc_even);
        }
    }
    let (Some(&centre), Some(odd_taps), Some(even_taps)) = (
        even.taps.get(r),
        odd.taps.get(r + 1..2 * r + 1),
        even.taps.get(r + 1..2 * r + 1),
    ) else {
        return;
    };
    let taps = HalfTaps {
        centre,
        odd: odd_taps,
        even: even_taps,
    };
    // The default prefilters (inner σ 0.5) have radius 2: a fixed radius unrolls the
    // taps and keeps both blocks of sums in registers.
    match r {
        1 => pair_interior::<T, 1>(taps, input, out_odd, out_even, n),
        2 => pair_interior::<T, 2>(taps, input, out_odd, out_even, n),
        3 => pair_interior::<T, 3>(taps, input, out_odd, out_even, n),
        _ => pair_interior::<T, 0>(taps, input, out_odd, out_even, n),
    }
}

/// The taps of [`apply_pair`]'s two kernels past their centre (`odd`, `even`: taps
/// `r + 1..=2r`), and the even kernel's centre tap (the odd kernel's is zero).
#[derive(Clone, Copy)]
struct HalfTaps<'a, T> {
    centre: T,
    odd: &'a [T],
    even: &'a [T],
}

/// The interior outputs `r..n − r` of [`apply_pair`] (`r` the taps' count, `n > 2·r +
/// PAIR_BLOCK`) in blocks of `PAIR_BLOCK`, the last one overlapping: `R` the radius when
/// it is fixed at compile time (`R = r`), 0 for any.
#[inline(always)]
fn pair_interior<T: Scalar, const R: usize>(
    taps: HalfTaps<'_, T>,
    input: &[T],
    out_odd: &mut [T],
    out_even: &mut [T],
    n: usize,
) {
    let HalfTaps {
        centre,
        odd: odd_taps,
        even: even_taps,
    } = taps;
    let r = if R > 0 { R } else { odd_taps.len() };
    let (Some(odd_taps), Some(even_taps)) = (odd_taps.get(..r), even_taps.get(..r)) else {
        return;
    };
    // Interior outputs r..n − r in blocks of constant length, the last one overlapping.
    let inner_len = n - 2 * r;
    let mut done = 0;
    while done < inner_len {
        let t0 = done.min(inner_len - PAIR_BLOCK);
        // Output r + t0 + i reads input t0 + i + r ± j: all within `block` (whose length
        // is a constant for a fixed radius, so the windows need no checks).
        let Some(block) = input.get(t0..t0 + PAIR_BLOCK + 2 * r) else {
            break;
        };
        let window = |from: usize| {
            block
                .get(from..)
                .and_then(|s| s.first_chunk::<PAIR_BLOCK>())
        };
        let mut acc_odd = [T::ZERO; PAIR_BLOCK];
        let mut acc_even = [T::ZERO; PAIR_BLOCK];
        if let Some(middle) = window(r) {
            for (a, &v) in acc_even.iter_mut().zip(middle) {
                *a = centre * v;
            }
        }
        for (j, (&ko, &ke)) in (1..r + 1).zip(odd_taps.iter().zip(even_taps)) {
            let (Some(below), Some(above)) = (window(r - j), window(r + j)) else {
                continue;
            };
            for (((ao, ae), &x), &y) in acc_odd
                .iter_mut()
                .zip(acc_even.iter_mut())
                .zip(below)
                .zip(above)
            {
                *ao += ko * (y - x);
                *ae += ke * (x + y);
            }
        }
        let at = r + t0;
        let skip = done - t0;
        if skip == 0 {
            // Whole blocks as fixed-size stores (a slice copy became a `memcpy` call).
            if let (Some(o), Some(e)) = (
                out_odd
                    .get_mut(at..)
                    .and_then(|o| o.first_chunk_mut::<PAIR_BLOCK>()),
                out_even
                    .get_mut(at..)
                    .and_then(|e| e.first_chunk_mut::<PAIR_BLOCK>()),
            ) {
                *o = acc_odd;
                *e = acc_even;
            }
        } else if let (Some(o), Some(e)) = (
            out_odd.get_mut(at + skip..at + PAIR_BLOCK),
            out_even.get_mut(at + skip..at + PAIR_BLOCK),
        ) {
            for ((o, e), (&vo, &ve)) in o
                .iter_mut()
                .zip(e.iter_mut())
                .zip(acc_odd.iter().zip(&acc_even).skip(skip))
            {
                *o = vo;
                *e = ve;
            }
        }
        done = t0 + PAIR_BLOCK;
    }
}

/// Samples per register block of the interior correlation.
const BLOCK: usize = 32;

impl<T: Scalar> Kernel<T> {
    /// [`Self::interior_block`] of a whole block for an even kernel of radius `R`
    /// (`self.radius == R`): the same products and sums in the same order, over one
    /// checked window of constant length.
    #[inline(always)]
    fn even_block<const R: usize>(&self, input: &[T], t0: usize, acc: &mut [T; BLOCK]) {
        let (Some(block), Some((&centre, upper))) = (
            input.get(t0..t0 + BLOCK + 2 * R),
            self.taps.get(R..).and_then(|t| t.split_first()),
        ) else {
            return;
        };
        let (Some(upper), Some(middle)) = (
            upper.first_chunk::<R>(),
            block.get(R..).and_then(|b| b.first_chunk::<BLOCK>()),
        ) else {
            return;
        };
        for (a, &v) in acc.iter_mut().zip(middle) {
            *a = centre * v;
        }
        for (j, &k) in (1..R + 1).zip(upper) {
            let window = |from: usize| block.get(from..).and_then(|s| s.first_chunk::<BLOCK>());
            let (Some(below), Some(above)) = (window(R - j), window(R + j)) else {
                continue;
            };
            for ((a, &x), &y) in acc.iter_mut().zip(below).zip(above) {
                *a += k * (x + y);
            }
        }
    }

    /// `acc[i] = Σ_j taps[j]·input[t0 + i + j]` for `i < len` (`len ≤ BLOCK`): the centre
    /// tap, then each mirrored pair of samples times its shared tap, outermost last.
    #[inline(always)]
    fn interior_block(&self, input: &[T], t0: usize, len: usize, acc: &mut [T; BLOCK]) {
        // The callers keep every window inside `input` and `radius ≤ MAX_RADIUS`; the
        // checked accesses only keep panics out of the image (a miss leaves zeros).
        let r = self.radius;
        let len = len.min(BLOCK);
        let window = |from: usize| input.get(from..).and_then(|s| s.get(..len));
        let Some((&centre, upper)) = self.taps.get(r..).and_then(|t| t.split_first()) else {
            return;
        };
        if self.symmetry == Symmetry::Even {
            if let Some(middle) = window(t0 + r) {
                for (a, &v) in acc.iter_mut().zip(middle) {
                    *a = centre * v;
                }
            }
        }
        for (j, &k) in (1..r + 1).zip(upper) {
            let (Some(below), Some(above)) = (window(t0 + r - j), window(t0 + r + j)) else {
                continue;
            };
            match self.symmetry {
                Symmetry::Even => {
                    for ((a, &x), &y) in acc.iter_mut().zip(below).zip(above) {
                        *a += k * (x + y);
                    }
                }
                Symmetry::Odd => {
                    for ((a, &x), &y) in acc.iter_mut().zip(below).zip(above) {
                        *a += k * (y - x);
                    }
                }
            }
        }
    }
}

/// Weights `w[k]` such that Gaussian smoothing (σ = `sigma`, nearest borders) of a column of
/// `len` values, evaluated at row `centre`, equals `Σ_k w[k]·value[k]`.
pub(crate) fn centre_weights<T: Scalar>(sigma: f32, len: usize, centre: usize, out: &mut [T]) {
    let mut g = [0.0; MAX_TAPS];
    let r = gaussian_f32(sigma, &mut g);
    let mut w = [0.0f32; MAX_TAPS];
    let last = len.saturating_sub(1).min(MAX_TAPS - 1);
    for (j, &gj) in g.iter().take(2 * r + 1).enumerate() {
        let k = (centre + j).saturating_sub(r).min(last);
        w[k] += gj;
    }
    for (o, &v) in out.iter_mut().zip(w.iter()).take(len) {
        *o = T::from_f32(v);
    }
}

/// Gaussian weights (σ = `sigma`) centred on row `centre` of `len` rows, truncated to the
/// rows that exist and renormalised to sum to one.
pub(crate) fn truncated_gaussian(sigma: f32, len: usize, centre: usize, out: &mut [f32]) {
    let mut g = [0.0; MAX_TAPS];
    let r = gaussian_f32(sigma, &mut g);
    let mut sum = 0.0;
    for (j, o) in out.iter_mut().enumerate().take(len) {
        let offset = j as isize - centre as isize + r as isize;
        *o = if (0..=2 * r as isize).contains(&offset) {
            g[offset as usize]
        } else {
            0.0
        };
        sum += *o;
    }
    if sum > 0.0 {
        for o in out.iter_mut().take(len) {
            *o /= sum;
        }
    }
}

#[cfg(test)]
mod tests;
