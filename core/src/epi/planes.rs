//! Where a line's filtered samples live: edge-padded planes per view and channel, read at
//! an offset by every shear hypothesis, and the interpolating shift for other fractions.

use super::hypotheses::MAX_DISPARITY;
use crate::lightfield::GRID_MAX;
use crate::scalar::Scalar;

/// Samples per register block of the tensor sums: the gradients and sums of a block are
/// accumulated over every channel and view before they are stored (8: 123–124 ms,
/// 16: 114–121 ms, 32: 128–134 ms CPU per bench estimate, docs/stages/epi.md). A line's
/// planes hold whole blocks.
pub(super) const BLOCK: usize = 16;

/// Where the sheared samples of one hypothesis are read: sample `t` of view `j`, channel
/// `c` is `bank[d[c][j] + t]` (along-line derivative) and `bank[s[c][j] + t]` (along-line
/// smoothing).
pub(super) struct Sources {
    pub(super) d: [[usize; GRID_MAX]; 3],
    pub(super) s: [[usize; GRID_MAX]; 3],
    /// Channels read.
    pub(super) slots: usize,
    /// Views whose tensor enters the sum.
    pub(super) active: [bool; GRID_MAX],
}

/// Layout of the stored planes of one line. Every view and channel has two planes of
/// `len` samples — derivative and smoothing — holding samples `−lead ≤ u < n_blocks +
/// reach` (edge-replicated outside the line); the views some hypothesis shifts by half a
/// sample also have both shifted by half a sample; when some hypothesis shifts by another
/// fraction (or further than `reach`), one fallback plane pair per view and channel
/// follows, interpolated per hypothesis.
#[derive(Clone, Copy, Debug)]
pub(super) struct Planes {
    pub(super) n: usize,
    /// `n` rounded up to whole blocks.
    pub(super) n_blocks: usize,
    /// Largest whole shift read from the stored planes.
    pub(super) reach: usize,
    pub(super) lead: usize,
    pub(super) len: usize,
    views: usize,
    channels: usize,
    /// Per view, its index among the views with half-shifted planes (`NO_HALF`: none).
    half_slot: [usize; GRID_MAX],
    halves: usize,
    fallback: bool,
}

/// `half_slot` of a view without half-shifted planes.
const NO_HALF: usize = usize::MAX;
/// Start returned for a plane the layout does not hold: past any bank, and far enough
/// from `usize::MAX` that the offsets added to it never overflow.
const ABSENT: usize = usize::MAX / 4;

impl Planes {
    /// `half[k]`: view `k` has half-shifted planes; `fallback`: the fallback planes exist.
    pub(super) fn new(
        views: usize,
        centre: usize,
        channels: usize,
        n: usize,
        half: &[bool; GRID_MAX],
        fallback: bool,
    ) -> Self {
        let far = centre.max(views.saturating_sub(1).saturating_sub(centre));
        let reach = Self::reach_for(far);
        let n_blocks = n.div_ceil(BLOCK) * BLOCK;
        let lead = reach + 1;
        let mut half_slot = [NO_HALF; GRID_MAX];
        let mut halves = 0;
        for (slot, &h) in half_slot.iter_mut().zip(half).take(views) {
            if h {
                *slot = halves;
                halves += 1;
            }
        }
        Planes {
            n,
            n_blocks,
            reach,
            lead,
            len: lead + n_blocks + reach,
            views,
            channels,
            half_slot,
            halves,
            fallback,
        }
    }

    /// Largest whole shift stored for views at most `far` from the centre: shears never
    /// exceed MAX_DISPARITY + 1 (multiples of a step ≤ 2 nearest the range).
    pub(super) fn reach_for(far: usize) -> usize {
        libm::ceilf(far as f32 * (MAX_DISPARITY + 1.0)) as usize + 1
    }

    /// Start of plane `kind` (0 derivative, 1 smoothing, 2 and 3 the same shifted by half a
    /// sample) of view `k`, channel `c`; [`ABSENT`] for a half-shifted plane the view
    /// does not have.
    pub(super) fn plane(&self, kind: usize, k: usize, c: usize) -> usize {
        if kind < 2 {
            return ((kind * self.views + k) * self.channels + c) * self.len;
        }
        match self.half_slot.get(k) {
            Some(&slot) if slot != NO_HALF => {
                let whole = 2 * self.views * self.channels;
                (whole + ((kind - 2) * self.halves + slot) * self.channels + c) * self.len
            }
            _ => ABSENT,
        }
    }

    /// Start of the fallback plane `kind` (0 derivative, 1 smoothing) of view `k`,
    /// channel `c` ([`ABSENT`] without fallback planes).
    pub(super) fn fallback(&self, kind: usize, k: usize, c: usize) -> usize {
        if !self.fallback {
            return ABSENT;
        }
        self.stored_len() + ((kind * self.views + k) * self.channels + c) * self.n_blocks
    }

    pub(super) fn stored_len(&self) -> usize {
        2 * (self.views + self.halves) * self.channels * self.len
    }

    pub(super) fn bank_len(&self) -> usize {
        let fallback = if self.fallback {
            2 * self.views * self.channels * self.n_blocks
        } else {
            0
        };
        self.stored_len() + fallback
    }
}

/// `out[t] = input(t − offset)`, linear interpolation, clamped at the ends. Integer offsets
/// are exact copies (no interpolation blur).
pub(super) fn shift<T: Scalar>(input: &[T], out: &mut [T], offset: f32) {
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
    // `max`/`min` rather than `clamp`: the same values here (the bounds are ordered) without
    // `clamp`'s assertion.
    let at = |i: isize| {
        input
            .get(i.max(0).min(last) as usize)
            .copied()
            .unwrap_or(T::ZERO)
    };
    // Interior: every index in range, t ∈ [whole + lag, last + whole].
    let lo = (whole + lag as isize).max(0).min(n as isize) as usize;
    let hi = (last + whole + 1).max(lo as isize).min(n as isize) as usize;
    if frac == 0.0 {
        for (t, o) in out.iter_mut().enumerate().take(lo) {
            *o = at(t as isize - whole);
        }
        if hi > lo {
            let src = (lo as isize - whole) as usize;
            if let Some(dst) = out.get_mut(lo..hi) {
                if let Some(from) = input.get(src..).and_then(|i| i.get(..dst.len())) {
                    dst.copy_from_slice(from);
                }
            }
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
        // src ≥ 1 (lo ≥ whole + 1): both windows lie inside the input.
        let below = src.wrapping_sub(1);
        if let (Some(dst), Some(a), Some(b)) = (
            out.get_mut(lo..hi),
            input.get(src..src + (hi - lo)),
            input.get(below..below.wrapping_add(hi - lo)),
        ) {
            for ((o, &x), &y) in dst.iter_mut().zip(a).zip(b) {
                *o = wa * x + wb * y;
            }
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
