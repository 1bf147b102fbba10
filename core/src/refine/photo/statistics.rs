//! Gauss–Newton statistics and weighted energies of a chunk of axis taps, lane by lane,
//! and the sampling slack's intervals.

use crate::scalar::Scalar;

use super::{CHUNK, GROUPS, STATS};

/// The weighted energies `scaled / (robust + e) · e` of [`CHUNK`] taps
/// (`texel(j, c, v)`: sample `j` < 2 of tap `v`, channel `c`), `e = Σ r²` at `p`.
#[inline(always)]
pub(super) fn energies<T: Scalar, F: Fn(usize, usize, usize) -> T, const N: usize>(
    texel: &F,
    fraction: &[T; CHUNK],
    centre: &[T; N],
    (robust, scaled): (T, T),
    slack: Option<&LaneSlack<T, N>>,
) -> [T; CHUNK] {
    // With a slack, each residual's part inside the centre's interval is taken out
    // (`RefineParams::sampling_slack`); the loop is instantiated once per case so the
    // plain residual's code carries no test of it.
    match slack {
        Some(slack) => energies_of(texel, fraction, centre, (robust, scaled), |r, c, v| {
            slack.outside(r, c, v)
        }),
        None => energies_of(texel, fraction, centre, (robust, scaled), |r, _, _| r),
    }
}

/// [`energies`] with `counted(r, c, v)`, the part of residual `r` (channel `c`, tap
/// `v`) that counts.
#[inline(always)]
fn energies_of<T: Scalar, F: Fn(usize, usize, usize) -> T, const N: usize>(
    texel: &F,
    fraction: &[T; CHUNK],
    centre: &[T; N],
    (robust, scaled): (T, T),
    counted: impl Fn(T, usize, usize) -> T,
) -> [T; CHUNK] {
    let mut out = [T::ZERO; CHUNK];
    for (v, o) in out.iter_mut().enumerate() {
        let f = fraction[v];
        let mut e = T::ZERO;
        for (c, &centre) in centre.iter().enumerate() {
            let (t0, t1) = (texel(0, c, v), texel(1, c, v));
            let r = counted(t0 + f * (t1 - t0) - centre, c, v);
            e += r * r;
        }
        *o = scaled / (robust + e) * e;
    }
    out
}

/// The scaled texels of up to [`CHUNK`] axis taps (`texel(j, c, v)`: sample `j` of tap
/// `v`, channel `c`) with the fractions of their positions, their offsets and groups
/// (see [`Chunk`](super::gather::Chunk)).
pub(super) struct Lanes<'a, T, F> {
    pub(super) texel: F,
    pub(super) fraction: &'a [T; CHUNK],
    pub(super) offset: &'a [T; CHUNK],
    pub(super) group: &'a [u8; CHUNK],
}

/// The pixel whose statistics are gathered: the centre view's values there, the
/// disparity `d` tested, `½` (in `T`), and the robust weight's `(robust, scaled)`.
#[derive(Clone, Copy)]
pub(super) struct PixelProbe<'a, T, const N: usize> {
    pub(super) centre: &'a [T; N],
    pub(super) d: T,
    pub(super) half: T,
    pub(super) robust: (T, T),
}

/// Adds the Gauss–Newton statistics of the first `n` taps of `lanes` at `probe.d` to their
/// groups in `out` (see [`Views::pixel`](super::Views::pixel)). Every lane is computed
/// (the loop has a fixed length); lanes from `n` on are not added. `regular`: all
/// [`CHUNK`] lanes are taken and lane `v` belongs to group `regular[v % GROUPS]`;
/// with a mask, the lanes it leaves out add zero (see [`Gathered::Masked`](super::gather::Gathered::Masked)).
#[inline(always)]
pub(super) fn statistics<T: Scalar, F: Fn(usize, usize, usize) -> T, const N: usize>(
    lanes: &Lanes<'_, T, F>,
    n: usize,
    probe: &PixelProbe<'_, T, N>,
    regular: Option<(&[usize; GROUPS], Option<&[bool; CHUNK]>)>,
    slack: Option<&LaneSlack<T, N>>,
    out: &mut [T; STATS],
) {
    let PixelProbe {
        centre,
        d,
        half,
        robust: (robust, scaled),
    } = *probe;
    // With a slack, the weight and the energy come from the residual outside the
    // centre's interval (`RefineParams::sampling_slack`) and the step from the residual
    // itself (from the part outside, the interval would be a dead zone of ±slack px of
    // image motion around every match: measured, BadPix0.07 +74 … +97 % on the
    // synthetic scenes, docs/stages/refine.md). The loop is instantiated once
    // per case so the plain residual's code carries no test of it.
    let [sa, sb, se] = match slack {
        Some(slack) => lane_statistics(lanes, centre, d, half, (robust, scaled), |r, c, v| {
            slack.outside(r, c, v)
        }),
        None => lane_statistics(lanes, centre, d, half, (robust, scaled), |r, _, _| r),
    };
    if let Some((groups, seen)) = regular {
        // Lane `v` belongs to group `groups[v % GROUPS]`: each group's sums take its
        // lanes in the same order as the loop below, four groups side by side.
        // The regular chunk is a pixel's first: its sums start at zero as `out` does.
        let mut sums = [[T::ZERO; 3]; GROUPS];
        for (v, ((&a, &b), &e)) in sa.iter().zip(&sb).zip(&se).enumerate() {
            let keep = seen.is_none_or(|seen| seen.get(v).copied().unwrap_or(false));
            let (a, b, e) = if keep {
                (a, b, e)
            } else {
                (T::ZERO, T::ZERO, T::ZERO)
            };
            if let Some([sa, sb, se]) = sums.get_mut(v % GROUPS) {
                *sa += a;
                *sb += b;
                *se += e;
            }
        }
        for (sum, &g) in sums.iter().zip(groups) {
            if let Some(s) = out.get_mut(3 * g..).and_then(|s| s.first_chunk_mut::<3>()) {
                *s = *sum;
            }
        }
        return;
    }
    for v in 0..n.min(CHUNK) {
        let g = usize::from(lanes.group[v]);
        if let Some(sums) = out.get_mut(3 * g..3 * g + 3) {
            sums[0] += sa[v];
            sums[1] += sb[v];
            sums[2] += se[v];
        }
    }
}

/// Per lane of `lanes` at `d`, the Cauchy-weighted `Σ g²`, `Σ g·(g·d − r)` and energy
/// `Σ e²` over the channels, `e = counted(r, c, v)` the part of residual `r` that counts
/// (see [`statistics`]).
#[inline(always)]
fn lane_statistics<T: Scalar, F: Fn(usize, usize, usize) -> T, const N: usize>(
    lanes: &Lanes<'_, T, F>,
    centre: &[T; N],
    d: T,
    half: T,
    (robust, scaled): (T, T),
    counted: impl Fn(T, usize, usize) -> T,
) -> [[T; CHUNK]; 3] {
    let texel = &lanes.texel;
    let (mut sa, mut sb, mut se) = ([T::ZERO; CHUNK], [T::ZERO; CHUNK], [T::ZERO; CHUNK]);
    for v in 0..CHUNK {
        let (f, offset) = (lanes.fraction[v], lanes.offset[v]);
        // The image at `p − ½` and `p + ½` (`t0 + f·(t1 − t0)`, `t1 + f·(t2 − t1)`)
        // and at `p` (between t0 and t1 for f < ½, t1 and t2 above: the weights
        // without a branch): `g = (I(p − ½) − I(p + ½)) · offset`,
        // `r = I(p) − centre`.
        let (w0, w2) = ((half - f).max(T::ZERO), (f - half).max(T::ZERO));
        let (mut gg, mut gr, mut rr) = (T::ZERO, T::ZERO, T::ZERO);
        for (c, &centre) in centre.iter().enumerate() {
            let (a0, a1, a2) = (texel(0, c, v), texel(1, c, v), texel(2, c, v));
            let (d01, d12) = (a1 - a0, a2 - a1);
            let g = (f * (d01 - d12) - d01) * offset;
            let r = a1 - w0 * d01 + w2 * d12 - centre;
            let e = counted(r, c, v);
            gg += g * g;
            gr += g * (g * d - r);
            rr += e * e;
        }
        // Cauchy weight of the view (iteratively reweighted least squares): a view
        // that disagrees by much more than the noise (an occluder, a highlight)
        // hardly counts.
        let w = scaled / (robust + rr);
        (sa[v], sb[v], se[v]) = (w * gg, w * gr, w * rr);
    }
    [sa, sb, se]
}

/// The first `N` lanes of `lanes`.
#[inline(always)]
pub(super) fn used<T: Scalar, const L: usize, const N: usize>(lanes: &[T; L]) -> [T; N] {
    core::array::from_fn(|c| lanes.get(c).copied().unwrap_or(T::ZERO))
}

/// The centre view's values over `±slack` px around a pixel (its linear interpolation
/// towards each neighbour), per axis of image motion (along x, along y, both: oblique
/// views), as offsets `lo ≤ 0 ≤ hi` from the pixel's value, per lane: a residual within
/// them costs nothing (`RefineParams::sampling_slack`, after Birchfield and Tomasi).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Interval<T, const L: usize> {
    pub(super) lo: [[T; L]; 3],
    pub(super) hi: [[T; L]; 3],
}

impl<T: Scalar, const L: usize> Interval<T, L> {
    /// The part of residual `r` of lane `c` outside the oblique interval.
    #[inline(always)]
    pub(super) fn outside(&self, r: T, c: usize) -> T {
        match (self.lo[2].get(c), self.hi[2].get(c)) {
            (Some(&lo), Some(&hi)) => outside(r, lo, hi),
            _ => r,
        }
    }
}

/// [`Interval`] per tap of a chunk: the interval of its axis, channel, tap.
pub(crate) struct LaneSlack<T, const N: usize> {
    lo: [[T; CHUNK]; N],
    hi: [[T; CHUNK]; N],
}

impl<T: Scalar, const N: usize> LaneSlack<T, N> {
    /// The lanes' intervals: tap `v` moves along x when `in_row(v)`.
    #[inline(always)]
    pub(super) fn new<const L: usize>(
        slack: &Interval<T, L>,
        in_row: impl Fn(usize) -> bool,
    ) -> Self {
        let mut out = LaneSlack {
            lo: [[T::ZERO; CHUNK]; N],
            hi: [[T::ZERO; CHUNK]; N],
        };
        for v in 0..CHUNK {
            let axis = usize::from(!in_row(v));
            for c in 0..N.min(L) {
                out.lo[c][v] = slack.lo[axis][c];
                out.hi[c][v] = slack.hi[axis][c];
            }
        }
        out
    }

    /// The part of residual `r` (channel `c`, tap `v`) outside the tap's interval.
    #[inline(always)]
    pub(super) fn outside(&self, r: T, c: usize, v: usize) -> T {
        outside(r, self.lo[c][v], self.hi[c][v])
    }
}

/// `r − clamp(r, lo, hi)` (`lo ≤ 0 ≤ hi`), the same bits, by compare and select
/// without the NaN tests of `Scalar::clamp` (residuals are finite): vector lanes.
#[inline(always)]
fn outside<T: Scalar>(r: T, lo: T, hi: T) -> T {
    let at_most = if r > hi { hi } else { r };
    r - if at_most < lo { lo } else { at_most }
}
