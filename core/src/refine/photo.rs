//! Photo-consistency of one centre-view pixel against the other views at a disparity:
//! per view the residual `r = I_v(x − d·u, y − d·v) − I_c(x, y)` and its derivative
//! `g = ∂r/∂d`, accumulated as Gauss–Newton normal equations in four half-plane groups
//! of views (left, right, up, down) so that occluded halves can be dropped.
//!
//! The views in the centre row and column (all of the default `ViewSet::Cross`) move
//! along one image axis: their samples are gathered in chunks of [`CHUNK`] views into
//! structure-of-arrays buffers and go through one loop of fixed length that the compiler
//! vectorises. Other views take three bilinear samples each.
//!
//! Everything is computed in the scalar type `T`; see [the module](super) for the scale
//! that keeps Q16.16 precise.

use core::any::{Any, TypeId};

use crate::align::Interpolation;
use crate::geometry::Homography;
use crate::lightfield::{Layout, Sample, GRID_MAX};
use crate::scalar::Scalar;

use super::params::ViewSet;

/// Half-plane groups of views: left (`c < c0`), right, up (`r < r0`), down.
pub(crate) const GROUPS: usize = 4;
/// Statistics per group: `A = Σ g²`, `B = Σ g·(g·d − r)`, `E = Σ r²`.
pub(crate) const STATS: usize = 3 * GROUPS;
const MAX_VIEWS: usize = GRID_MAX * GRID_MAX;

/// Intensities enter as `sample · INTENSITY_SCALE` (full scale 16, one 8-bit level
/// 0.063). Why: in Q16.16 the squared residual of one level, `(1/255)² ≈ 1.5e-5`, would
/// be a single LSB, so the Cauchy weights and the error `E` would be noise; scaled it is
/// 256 LSB. The largest per-view products, `g² ≤ (reach · 16)²` ≤ 4096 on a 9×9 grid
/// (16384 on 17×17), still fit below 32768. A power of two: `f32` results only scale
/// exactly, bit for bit.
pub(crate) const INTENSITY_SCALE: f32 = 16.0;

/// The power of two by which [`Views::cost`] scales its terms, as `scale · robust`
/// (`robust` the squared residual scale times the channels, scaled intensity²;
/// `memberships` the views counted once per group they belong to): each view's weighted
/// energy is at most `robust`, so the cost stays below `2^13` while its terms use the
/// bits of Q16.16 (at the default scale one term is at most 0.077 unscaled, 5033 LSB;
/// a propagation decision compares costs to a share of 0.7, which the rounding of small
/// terms flipped). Powers of two scale `f32` exactly: its decisions do not change.
/// One (no scaling) without a robust scale (`robust` = `MAX`).
pub(crate) fn cost_scale(robust: f32, memberships: f32) -> f32 {
    if !(robust > 0.0 && robust < f32::MAX && memberships > 0.0) {
        return 1.0;
    }
    let room = libm::floorf(libm::log2f(8192.0 / (robust * memberships)));
    libm::ldexpf(1.0, room.clamp(0.0, 16.0) as i32)
}

/// A compared view off the centre row and column (the diagonal and full view sets).
#[derive(Clone, Copy, Debug, Default)]
struct Tap<T> {
    /// Index of the view's first sample.
    start: usize,
    /// Camera offset from the centre (columns, rows).
    du: T,
    dv: T,
    /// Half the disparity step of the central difference: one pixel of image motion.
    h: T,
    /// `1 / (2h)`: the central difference's divisor (the view's reach, an integer).
    inv: T,
    /// The groups the view belongs to: one or (off the centre row and column) two,
    /// each below [`GROUPS`].
    group: usize,
    second_group: Option<usize>,
}

impl<T: Scalar> Tap<T> {
    /// One view's Cauchy-weighted residual energy over the first `n` channels,
    /// `scaled · e / (robust + e)`.
    fn weighted_cost<const L: usize>(
        &self,
        at: &[T; L],
        centre: &[T; L],
        n: usize,
        (robust, scaled): (T, T),
        slack: Option<&Interval<T, L>>,
    ) -> T {
        let mut e = T::ZERO;
        for c in 0..n.min(L) {
            let mut r = at[c] - centre[c];
            if let Some(s) = slack {
                r = s.outside(r, c);
            }
            e += r * r;
        }
        scaled / (robust + e) * e
    }

    /// Adds one view's normal-equation terms `(a, b, e)` to the sums of its groups
    /// (`out[3g..3g + 3]`), Cauchy-weighted by its residual energy `e`:
    /// `w = scaled / (robust + e)`.
    fn add_weighted(&self, out: &mut [T], (a, b, e): (T, T, T), (robust, scaled): (T, T)) {
        let w = scaled / (robust + e);
        let (a, b, e) = (w * a, w * b, w * e);
        let mut add = |g: usize| {
            if let Some(sums) = out.get_mut(3 * g..3 * g + 3) {
                sums[0] += a;
                sums[1] += b;
                sums[2] += e;
            }
        };
        add(self.group);
        if let Some(g) = self.second_group {
            add(g);
        }
    }
}

/// An oblique view as [`Views`] keeps it, expanded to a [`Tap`] where it is used: 16
/// bytes on 32-bit targets instead of the tap's 32 (a table of `MAX_VIEWS` full taps
/// was the largest part of the whole-frame firmware's deepest stack frame).
#[derive(Clone, Copy, Debug, Default)]
struct StoredTap {
    /// Index of the view's first sample.
    start: usize,
    /// Camera offset from the centre (columns, rows), at most `GRID_MAX / 2`.
    du: i8,
    dv: i8,
    /// Distance from the centre view (grid steps): the index of its `(h, 1 / (2h))`
    /// in [`Views::steps`].
    reach: u8,
    /// The groups the view belongs to (below [`GROUPS`]; `GROUPS` for no second one).
    group: u8,
    second_group: u8,
}

/// Entries of [`Views::steps`]: reaches 0…`GRID_MAX / 2`.
const STEPS: usize = GRID_MAX / 2 + 1;

/// A compared view in the centre row or column of the grid: its samples move along one
/// image axis, and it belongs to one group.
#[derive(Clone, Copy, Debug, Default)]
struct AxisTap<T> {
    /// Index of the view's first sample.
    start: usize,
    /// Camera offset along the axis of motion (columns in the centre row, rows in the
    /// centre column).
    offset: T,
    /// In the centre row (motion along x), else in the centre column (along y).
    in_row: bool,
    /// The group (left, right, up, down) the view belongs to.
    group: usize,
    /// Distance from the centre view (grid steps).
    reach: usize,
}

/// `1.5 · 2^23`: added to an `f32` of magnitude below `2^22`, it leaves the value
/// rounded to an integer in the low bits of the sum.
const MAGIC: f32 = 12_582_912.0;

/// Most views in the centre row and column of a grid.
const MAX_AXIS: usize = 2 * (GRID_MAX - 1);

/// Axis taps are sampled in chunks of this many: the gathered samples then go through
/// one loop of fixed length that the compiler vectorises (the weights' divisions too).
const CHUNK: usize = 16;

/// How [`Views::fill_regular`] gathered the regular axis taps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Gathered {
    /// Every tap sees the pixel, none needs the border's clamped samples.
    Every,
    /// Each tap in its lane; the lanes of the taps that do not see the pixel (flagged
    /// false) add zero to the sums instead of being left out: the sums start at +0 and
    /// never become −0, so adding +0 leaves them unchanged, bit for bit.
    Masked([bool; CHUNK]),
    /// Not gathered: `fill` takes the taps one by one.
    Not,
}

/// The gathered samples of up to [`CHUNK`] axis taps for one pixel, structure of
/// arrays: sample `j` of a tap (see [`Views::fill`]), channel, tap.
struct Chunk<T, S, const N: usize> {
    raw: [[[S; CHUNK]; N]; 3],
    /// Fraction of the position within its cell.
    fraction: [T; CHUNK],
    /// The tap's offset along its axis: the derivative's factor.
    offset: [T; CHUNK],
    /// Each tap's group (below [`GROUPS`]).
    group: [u8; CHUNK],
}

impl<T: Scalar, S: Sample, const N: usize> Chunk<T, S, N> {
    fn new() -> Self {
        Chunk {
            raw: [[[S::default(); CHUNK]; N]; 3],
            fraction: [T::ZERO; CHUNK],
            offset: [T::ZERO; CHUNK],
            group: [0; CHUNK],
        }
    }

    /// The scaled intensities of the first `J` samples (the others zero).
    #[inline(always)]
    fn scaled<const J: usize>(&self, levels: &[T; 256]) -> [[[T; CHUNK]; N]; 3] {
        let mut out = [[[T::ZERO; CHUNK]; N]; 3];
        for (to, from) in out.iter_mut().zip(&self.raw).take(J) {
            for (to, from) in to.iter_mut().zip(from) {
                *to = convert(from, levels);
            }
        }
        out
    }

    /// Adds the Gauss–Newton statistics of the first `n` taps (gathered with `J` = 3)
    /// at `d` to their groups in `out`: [`statistics`] of the chunk's scaled texels.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn statistics(
        &self,
        n: usize,
        levels: &[T; 256],
        centre: &[T; N],
        d: T,
        half: T,
        robust: (T, T),
        regular: Option<(&[usize; GROUPS], Option<&[bool; CHUNK]>)>,
        slack: Option<&LaneSlack<T, N>>,
        out: &mut [T; STATS],
    ) {
        let [t0, t1, t2] = self.scaled::<3>(levels);
        let lanes = Lanes {
            // `j` < 3 (`statistics`).
            texel: |j: usize, c: usize, v: usize| match j {
                0 => t0[c][v],
                1 => t1[c][v],
                _ => t2[c][v],
            },
            fraction: &self.fraction,
            offset: &self.offset,
            group: &self.group,
        };
        statistics(&lanes, n, centre, d, half, robust, regular, slack, out);
    }

    /// The weighted energies `scaled / (robust + e) · e` of the taps (gathered with
    /// `J` = 2), `e = Σ r²` at `p`; lanes past those gathered hold any value.
    #[inline(always)]
    fn energies(
        &self,
        levels: &[T; 256],
        centre: &[T; N],
        robust: (T, T),
        slack: Option<&LaneSlack<T, N>>,
    ) -> [T; CHUNK] {
        let [t0, t1, _] = self.scaled::<2>(levels);
        // `j` < 2 (`energies`).
        let texel = |j: usize, c: usize, v: usize| if j == 0 { t0[c][v] } else { t1[c][v] };
        energies(&texel, &self.fraction, centre, robust, slack)
    }

    /// Per lane, the slack of its axis (row taps are in the left and right groups).
    #[inline(always)]
    fn slack<const L: usize>(&self, slack: &Interval<T, L>) -> LaneSlack<T, N> {
        LaneSlack::new(slack, |v| self.group.get(v).is_some_and(|&g| g < 2))
    }
}

/// The weighted energies `scaled / (robust + e) · e` of [`CHUNK`] taps
/// (`texel(j, c, v)`: sample `j` < 2 of tap `v`, channel `c`), `e = Σ r²` at `p`.
#[inline(always)]
fn energies<T: Scalar, F: Fn(usize, usize, usize) -> T, const N: usize>(
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
/// (see [`Chunk`]).
struct Lanes<'a, T, F> {
    texel: F,
    fraction: &'a [T; CHUNK],
    offset: &'a [T; CHUNK],
    group: &'a [u8; CHUNK],
}

/// Adds the Gauss–Newton statistics of the first `n` taps of `lanes` at `d` to their
/// groups in `out` (see [`Views::pixel`]). Every lane is computed
/// (the loop has a fixed length); lanes from `n` on are not added. `regular`: all
/// [`CHUNK`] lanes are taken and lane `v` belongs to group `regular[v % GROUPS]`;
/// with a mask, the lanes it leaves out add zero (see [`Gathered::Masked`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn statistics<T: Scalar, F: Fn(usize, usize, usize) -> T, const N: usize>(
    lanes: &Lanes<'_, T, F>,
    n: usize,
    centre: &[T; N],
    d: T,
    half: T,
    (robust, scaled): (T, T),
    regular: Option<(&[usize; GROUPS], Option<&[bool; CHUNK]>)>,
    slack: Option<&LaneSlack<T, N>>,
    out: &mut [T; STATS],
) {
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
fn used<T: Scalar, const L: usize, const N: usize>(lanes: &[T; L]) -> [T; N] {
    core::array::from_fn(|c| lanes.get(c).copied().unwrap_or(T::ZERO))
}

/// The centre view's values over `±slack` px around a pixel (its linear interpolation
/// towards each neighbour), per axis of image motion (along x, along y, both: oblique
/// views), as offsets `lo ≤ 0 ≤ hi` from the pixel's value, per lane: a residual within
/// them costs nothing (`RefineParams::sampling_slack`, after Birchfield and Tomasi).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Interval<T, const L: usize> {
    lo: [[T; L]; 3],
    hi: [[T; L]; 3],
}

impl<T: Scalar, const L: usize> Interval<T, L> {
    /// The part of residual `r` of lane `c` outside the oblique interval.
    #[inline(always)]
    fn outside(&self, r: T, c: usize) -> T {
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
    fn new<const L: usize>(slack: &Interval<T, L>, in_row: impl Fn(usize) -> bool) -> Self {
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
    fn outside(&self, r: T, c: usize, v: usize) -> T {
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

/// The compared views of a light field.
pub(crate) struct Views<T> {
    /// The views in the centre row and column, the farthest first (they tell
    /// disparities apart best, so a propagation candidate's cost reaches its bar
    /// sooner), in grid order (up, left, right, down) among equally far ones.
    axis: [AxisTap<T>; MAX_AXIS],
    axis_len: usize,
    /// There are [`CHUNK`] axis taps and tap `i` belongs to the group of tap
    /// `i % GROUPS`, the first [`GROUPS`] taps to the four groups (the 9×9 cross: up,
    /// left, right, down at each distance).
    regular: bool,
    /// For a regular set: the group of taps `i` with `i % GROUPS = s`, per `s`.
    regular_groups: [usize; GROUPS],
    /// For a regular set, per axis tap: offset, first sample, whether it lies in the
    /// centre row, the position's factors of `x` and `y` (one of them one, the other
    /// zero), its largest value and the number of samples along the axis (an `i32`, as
    /// the cells are: compared side by side).
    regular_offset: [T; CHUNK],
    regular_start: [usize; CHUNK],
    regular_in_row: [bool; CHUNK],
    regular_x: [T; CHUNK],
    regular_y: [T; CHUNK],
    regular_max: [T; CHUNK],
    regular_samples: [i32; CHUNK],
    /// The other views.
    taps: [StoredTap; MAX_VIEWS],
    len: usize,
    /// Per reach, the oblique taps' `h` (half the disparity step of the central
    /// difference) and `1 / (2h)`.
    steps: [(T, T); STEPS],
    /// Views per group times channels: the number of terms of each group per pixel.
    pub terms: [f32; GROUPS],
    centre: usize,
    channels: usize,
    row_stride: usize,
    view_stride: usize,
    /// Largest sample position along x and y.
    x_max: T,
    y_max: T,
    /// The last bilinear cell's origin along x and y, as an index and in `T`.
    x_last: usize,
    y_last: usize,
    x_cell: T,
    y_cell: T,
    /// One half in `T`.
    half: T,
    /// The scaled intensity of each 8-bit level: `level · INTENSITY_SCALE / 255`,
    /// computed in `T` as `T::from_i32(level) · unit` (a table lookup costs less than
    /// the conversion and the product, with the same bits).
    levels: [T; 256],
    /// `RefineParams::sampling_slack` (px), when not zero.
    slack: Option<T>,
}

/// The scaled intensity of a sample in `T`. 8-bit samples read the table of levels, so
/// fixed point does no `f32` arithmetic in the sampling loop; `f32` samples cross the
/// `f32 → T` boundary here. (For `T = f32` both equal `to_unit() · INTENSITY_SCALE` bit
/// for bit.)
#[inline(always)]
fn texel<T: Scalar, S: Sample>(sample: S, levels: &[T; 256]) -> T {
    // Resolved at compile time for each sample type.
    match (&sample as &dyn Any).downcast_ref::<u8>() {
        Some(&level) => levels[usize::from(level)],
        None => T::from_f32(sample.to_unit() * INTENSITY_SCALE),
    }
}

/// [`INTENSITY_SCALE`] per 8-bit level in `f32`: the factor of the table of levels.
const UNIT: f32 = INTENSITY_SCALE / 255.0;

/// The scaled intensities of `L` samples. 8-bit samples into `f32` take one vector
/// conversion and product (the same bits as the table, `level as f32 · UNIT`); every
/// other pair of types converts each sample with [`texel`].
#[inline(always)]
fn convert<T: Scalar, S: Sample, const L: usize>(s: &[S; L], levels: &[T; 256]) -> [T; L] {
    let mut out = [T::ZERO; L];
    // Resolved at compile time for each pair of types.
    if let (Some(bytes), Some(to)) = (
        (s as &dyn Any).downcast_ref::<[u8; L]>(),
        (&mut out as &mut dyn Any).downcast_mut::<[f32; L]>(),
    ) {
        for (o, &b) in to.iter_mut().zip(bytes) {
            *o = f32::from(b) * UNIT;
        }
        return out;
    }
    for (o, &v) in out.iter_mut().zip(s) {
        *o = texel(v, levels);
    }
    out
}

/// The scaled intensity of channel `c` (byte `c`, little-endian) of a 32-bit word
/// holding a texel's 8-bit channels: the same value as [`convert`] of the byte.
#[inline(always)]
fn unpack<T: Scalar>(word: u32, c: usize, levels: &[T; 256]) -> T {
    let level = (word >> (8 * (c as u32 & 3))) & 0xff;
    // Resolved at compile time for each scalar type.
    let mut out = T::ZERO;
    if let Some(to) = (&mut out as &mut dyn Any).downcast_mut::<f32>() {
        // Below 256: exact in `i32` and `f32` (`f32::from` of the byte).
        *to = level as i32 as f32 * UNIT;
        return out;
    }
    levels[level as usize]
}

/// `(⌊p⌋, p − ⌊p⌋)` of a position `p ≥ 0` inside the image. For `f32` the truncating
/// conversion is the floor of a non-negative value (and the fraction is exact below
/// 2^24), without the out-of-line `floorf`; fixed point splits its bits.
#[inline(always)]
fn split<T: Scalar>(p: T) -> (usize, T) {
    // Resolved at compile time for each scalar type.
    match (&p as &dyn Any).downcast_ref::<f32>() {
        Some(&v) => {
            // `as` saturates (and maps NaN to 0); positions are below the image size.
            let whole = (v as i32).max(0);
            (whole as usize, T::from_f32(v - whole as f32))
        }
        None => {
            let (whole, fraction) = p.floor_fract();
            (whole.max(0) as usize, fraction)
        }
    }
}

/// The bilinear cell (origin, fraction) of position `p` in `[0, last + 1]`, `last` the
/// last cell's origin (`last_t` in `T`).
#[inline(always)]
fn cell<T: Scalar>(p: T, last: usize, last_t: T) -> (usize, T) {
    let (whole, fraction) = split(p);
    if whole > last {
        // The last row or column itself: the last cell at fraction 1.
        (last, p - last_t)
    } else {
        (whole, fraction)
    }
}

/// The scaled intensities of `L` consecutive samples from `at`: a pixel's `CH` samples
/// and, when `L > CH`, the next pixel's first (zero past the end of the data), a lane
/// that keeps three channels in four SIMD lanes and that no sum reads (`None` when the
/// pixel itself lies past the end).
#[inline(always)]
fn lanes<T: Scalar, S: Sample, const CH: usize, const L: usize>(
    data: &[S],
    at: usize,
    levels: &[T; 256],
) -> Option<[T; L]> {
    if let Some(s) = samples::<S, L>(data, at) {
        return Some(convert(s, levels));
    }
    let s = data.get(at..at.wrapping_add(CH.min(L)))?;
    let mut out = [T::ZERO; L];
    for (o, &v) in out.iter_mut().zip(s) {
        *o = texel(v, levels);
    }
    Some(out)
}

/// `N` consecutive samples from `at` (`None` past the end of the data).
#[inline(always)]
fn samples<S: Sample, const N: usize>(data: &[S], at: usize) -> Option<&[S; N]> {
    // Indices stay far below `usize::MAX`; a wrapped end would only fail the lookup.
    data.get(at..at.wrapping_add(N))?.try_into().ok()
}

impl<T: Scalar> Views<T> {
    /// The views of `set`.
    pub(crate) fn new(layout: &Layout, set: ViewSet) -> Self {
        let grid = layout.grid;
        let (r0, c0) = grid.center();
        let used = layout.channels.min(3);
        let coordinate = |v: usize| T::from_i32(i32::try_from(v).unwrap_or(i32::MAX));
        let unit = T::from_f32(INTENSITY_SCALE / 255.0);
        let mut levels = [T::ZERO; 256];
        for (level, l) in (0i32..).zip(levels.iter_mut()) {
            *l = T::from_i32(level) * unit;
        }
        let x_last = layout.width.saturating_sub(2);
        let y_last = layout.height.saturating_sub(2);
        let mut views = Views {
            axis: [AxisTap::default(); MAX_AXIS],
            axis_len: 0,
            regular: false,
            regular_groups: [0; GROUPS],
            regular_offset: [T::ZERO; CHUNK],
            regular_start: [0; CHUNK],
            regular_in_row: [false; CHUNK],
            regular_x: [T::ZERO; CHUNK],
            regular_y: [T::ZERO; CHUNK],
            regular_max: [T::ZERO; CHUNK],
            regular_samples: [0; CHUNK],
            taps: [StoredTap::default(); MAX_VIEWS],
            len: 0,
            steps: core::array::from_fn(|reach| {
                let h = 0.5 / (reach.max(1) as f32);
                (T::from_f32(h), T::from_f32(0.5 / h))
            }),
            terms: [0.0; GROUPS],
            centre: grid.index(r0, c0) * layout.view_stride,
            channels: layout.channels,
            row_stride: layout.row_stride,
            view_stride: layout.view_stride,
            x_max: coordinate(layout.width.saturating_sub(1)),
            y_max: coordinate(layout.height.saturating_sub(1)),
            x_last,
            y_last,
            x_cell: coordinate(x_last),
            y_cell: coordinate(y_last),
            half: T::from_f32(0.5),
            levels,
            slack: None,
        };
        for r in 0..grid.rows {
            for c in 0..grid.cols {
                let (dr, dc) = (r as isize - r0 as isize, c as isize - c0 as isize);
                if !set.contains(dr, dc) || views.len >= MAX_VIEWS {
                    continue;
                }
                // Left, right, up, down.
                let horizontal = (dc != 0).then_some(usize::from(dc > 0));
                let vertical = (dr != 0).then_some(2 + usize::from(dr > 0));
                let (group, second_group) = match (horizontal, vertical) {
                    (Some(h), v) => (h, v),
                    (None, Some(v)) => (v, None),
                    (None, None) => continue,
                };
                for g in [Some(group), second_group].into_iter().flatten() {
                    if let Some(terms) = views.terms.get_mut(g) {
                        *terms += used as f32;
                    }
                }
                let start = grid.index(r, c) * layout.view_stride;
                if dr == 0 || dc == 0 {
                    if let Some(tap) = views.axis.get_mut(views.axis_len) {
                        *tap = AxisTap {
                            start,
                            offset: T::from_f32(if dr == 0 { dc } else { dr } as f32),
                            in_row: dr == 0,
                            group,
                            reach: dr.unsigned_abs().max(dc.unsigned_abs()),
                        };
                        views.axis_len += 1;
                    }
                    continue;
                }
                // Offsets and reach are at most GRID_MAX / 2, groups below GROUPS: the
                // defaults never happen.
                let small = |v: usize| u8::try_from(v).unwrap_or(u8::MAX);
                let offset = |v: isize| i8::try_from(v).unwrap_or(0);
                views.taps[views.len] = StoredTap {
                    start,
                    du: offset(dc),
                    dv: offset(dr),
                    reach: small(dr.unsigned_abs().max(dc.unsigned_abs())),
                    group: small(group),
                    second_group: small(second_group.unwrap_or(GROUPS)),
                };
                views.len += 1;
            }
        }
        // Farthest first, stable (insertion sort: no allocation).
        let axis = views.axis.get_mut(..views.axis_len).unwrap_or_default();
        for i in 1..axis.len() {
            let mut j = i;
            while j > 0 && axis[j - 1].reach < axis[j].reach {
                axis.swap(j - 1, j);
                j -= 1;
            }
        }
        let first = views
            .axis
            .first_chunk::<GROUPS>()
            .map(|t| t.map(|t| t.group));
        if let (Some(groups), true) = (first, views.axis_len == CHUNK) {
            let mut seen = [false; GROUPS];
            for &g in &groups {
                if let Some(s) = seen.get_mut(g) {
                    *s = true;
                }
            }
            views.regular = seen == [true; GROUPS]
                && (views.axis.iter().take(CHUNK).enumerate())
                    .all(|(i, tap)| Some(&tap.group) == groups.get(i % GROUPS));
            views.regular_groups = groups;
        }
        let (along, across) = (T::ONE, T::ZERO);
        // `refine_band` takes only images whose sides convert to `i32`.
        let samples = |n: usize| i32::try_from(n).unwrap_or(i32::MAX);
        let (row_frame, column_frame) = (
            (along, across, views.x_max, samples(views.x_last + 2)),
            (across, along, views.y_max, samples(views.y_last + 2)),
        );
        for (i, tap) in views.axis.iter().take(CHUNK).enumerate() {
            let frame = if tap.in_row { row_frame } else { column_frame };
            if let (Some(o), Some(s), Some(r), Some(x), Some(y), Some(m), Some(n)) = (
                views.regular_offset.get_mut(i),
                views.regular_start.get_mut(i),
                views.regular_in_row.get_mut(i),
                views.regular_x.get_mut(i),
                views.regular_y.get_mut(i),
                views.regular_max.get_mut(i),
                views.regular_samples.get_mut(i),
            ) {
                (*o, *s, *r) = (tap.offset, tap.start, tap.in_row);
                (*x, *y, *m, *n) = frame;
            }
        }
        views
    }

    /// Accumulates the statistics of pixel `(x, y)` at disparity `d` into `out`
    /// (zeroed first), each view weighted by `scaled / (robust + Σ r²)` (`robust` the
    /// squared residual scale times the channels, in scaled intensity²; `scaled` the
    /// same times the statistics' power-of-two scale). Views whose
    /// samples leave the image are skipped.
    #[inline]
    pub(crate) fn pixel<S: Sample>(
        &self,
        data: &[S],
        x: usize,
        y: usize,
        d: T,
        robust: (T, T),
        out: &mut [T; STATS],
    ) {
        // A layout has 1, 3 or 4 channels (`Layout::validate`): one or three are used.
        // Without a sampling slack the code is that of the plain residual alone.
        match (self.channels, self.slack.is_some()) {
            (1, false) => self.pixel_channels::<S, 1, 1, 1, false>(data, x, y, d, robust, out),
            (3, false) => self.pixel_channels::<S, 3, 3, 4, false>(data, x, y, d, robust, out),
            (4, false) => self.pixel_channels::<S, 4, 3, 4, false>(data, x, y, d, robust, out),
            (1, true) => self.pixel_channels::<S, 1, 1, 1, true>(data, x, y, d, robust, out),
            (3, true) => self.pixel_channels::<S, 3, 3, 4, true>(data, x, y, d, robust, out),
            (4, true) => self.pixel_channels::<S, 4, 3, 4, true>(data, x, y, d, robust, out),
            _ => *out = [T::ZERO; STATS],
        }
    }

    /// The robust photometric cost of pixel `(x, y)` at disparity `d`: the sum over the
    /// views (an oblique one once per group it belongs to, as the statistics count it)
    /// of their weighted residual energy times `scale / robust` (`scaled` = `scale`: a
    /// power of two, see [`cost_scale`]), one sample per view from two texels (the
    /// statistics read three: the derivative is not needed). `None` when the cost is not
    /// below `bar`, as soon as that is known after a chunk: every term is non-negative
    /// and rounded sums are monotonic, so the running sum is a lower bound of the cost.
    #[inline]
    pub(crate) fn cost<S: Sample>(
        &self,
        data: &[S],
        x: usize,
        y: usize,
        d: T,
        robust: (T, T),
        bar: Option<T>,
    ) -> Option<T> {
        match (self.channels, self.slack.is_some()) {
            (1, false) => self.cost_channels::<S, 1, 1, 1, false>(data, x, y, d, robust, bar),
            (3, false) => self.cost_channels::<S, 3, 3, 4, false>(data, x, y, d, robust, bar),
            (4, false) => self.cost_channels::<S, 4, 3, 4, false>(data, x, y, d, robust, bar),
            (1, true) => self.cost_channels::<S, 1, 1, 1, true>(data, x, y, d, robust, bar),
            (3, true) => self.cost_channels::<S, 3, 3, 4, true>(data, x, y, d, robust, bar),
            (4, true) => self.cost_channels::<S, 4, 3, 4, true>(data, x, y, d, robust, bar),
            _ => None,
        }
    }

    /// The centre view's samples of pixel `(x, y)` and its coordinates in `T`.
    #[inline(always)]
    fn centre<S: Sample, const CH: usize, const N: usize>(
        &self,
        data: &[S],
        x: usize,
        y: usize,
    ) -> Option<([T; N], T, T)> {
        let base = self.centre + y * self.row_stride + x * CH;
        let centre = lanes::<T, S, CH, N>(data, base, &self.levels)?;
        // `refine_band` checked that every coordinate converts without saturating.
        Some((centre, T::from_i32(x as i32), T::from_i32(y as i32)))
    }

    /// The oblique taps.
    #[inline(always)]
    fn oblique_taps(&self) -> impl Iterator<Item = Tap<T>> + '_ {
        // `len` ≤ MAX_VIEWS (`new` stops there): the default never happens.
        let stored = self.taps.get(..self.len).unwrap_or_default();
        stored.iter().map(|t| {
            // `reach` < STEPS (`new`): the default never happens.
            let (h, inv) = self
                .steps
                .get(usize::from(t.reach))
                .copied()
                .unwrap_or((T::ZERO, T::ZERO));
            let second = usize::from(t.second_group);
            Tap {
                start: t.start,
                // The same values as `T::from_f32` of the offsets (small integers).
                du: T::from_i32(i32::from(t.du)),
                dv: T::from_i32(i32::from(t.dv)),
                h,
                inv,
                group: usize::from(t.group),
                second_group: (second < GROUPS).then_some(second),
            }
        })
    }

    /// Where the samples of an axis tap lie for pixel `(x, y)`: the position along the
    /// axis, its largest value, the index of the last sample along it, the sample index
    /// of position 0 and the stride between positions (in samples).
    #[inline(always)]
    fn axis_frame(
        &self,
        tap: &AxisTap<T>,
        (x, y): (usize, usize),
        (xf, yf): (T, T),
        d: T,
    ) -> (T, T, usize, usize, usize) {
        if tap.in_row {
            (
                xf - d * tap.offset,
                self.x_max,
                self.x_last + 1,
                tap.start + y * self.row_stride,
                self.channels,
            )
        } else {
            (
                yf - d * tap.offset,
                self.y_max,
                self.y_last + 1,
                tap.start + x * self.channels,
                self.row_stride,
            )
        }
    }

    /// Whether the derivative's samples of an oblique `tap` (at `d ± h`) lie inside the
    /// image. Both the statistics and the cost skip the views where they do not (for an
    /// axis tap: where the position at `d` is not half a pixel inside the image).
    #[inline(always)]
    fn sees(&self, tap: &Tap<T>, xf: T, yf: T, d: T) -> bool {
        let (dp, dm) = (d + tap.h, d - tap.h);
        let inside = |dd: T| {
            let (px, py) = (xf - dd * tap.du, yf - dd * tap.dv);
            px >= T::ZERO && px <= self.x_max && py >= T::ZERO && py <= self.y_max
        };
        inside(dp) && inside(dm)
    }

    /// The pixel's sampling-slack interval and the regular taps' lanes of it; `None`
    /// unless `SLACK` (a constant, so that the plain residual's code has no trace of
    /// it).
    #[inline(always)]
    fn slacks<S: Sample, const CH: usize, const N: usize, const L: usize, const SLACK: bool>(
        &self,
        data: &[S],
        (x, y): (usize, usize),
        centre: &[T; L],
    ) -> (Option<Interval<T, L>>, Option<LaneSlack<T, N>>) {
        let slack = if SLACK {
            self.interval::<S, CH, L>(data, (x, y), centre)
        } else {
            None
        };
        let regular_slack = slack
            .as_ref()
            .map(|s| LaneSlack::<T, N>::new(s, |v| self.regular_in_row[v % CHUNK]));
        (slack, regular_slack)
    }

    fn pixel_channels<
        S: Sample,
        const CH: usize,
        const N: usize,
        const L: usize,
        const SLACK: bool,
    >(
        &self,
        data: &[S],
        x: usize,
        y: usize,
        d: T,
        (robust, scaled): (T, T),
        out: &mut [T; STATS],
    ) {
        *out = [T::ZERO; STATS];
        let Some((centre, xf, yf)) = self.centre::<S, CH, L>(data, x, y) else {
            return;
        };
        let (slack, regular_slack) = self.slacks::<S, CH, N, L, SLACK>(data, (x, y), &centre);
        // The common case first: every regular tap sees the pixel, and none needs the
        // border's clamped samples.
        let mut cursor = 0;
        if self.regular {
            let (mut cells, mut fractions) = ([0i32; CHUNK], [T::ZERO; CHUNK]);
            if self.regular_cells::<3>((xf, yf), d, &mut cells, &mut fractions)
                && self.regular_statistics::<S, CH, N>(
                    data,
                    (x, y),
                    (&cells, &fractions),
                    &used::<T, L, N>(&centre),
                    d,
                    (robust, scaled),
                    regular_slack.as_ref(),
                    out,
                )
            {
                cursor = CHUNK;
            }
        }
        // The other axis taps, or those of a regular set near the image's sides, from
        // a chunk (zeroed: not needed when the regular taps are done).
        if cursor < self.axis_len {
            let mut chunk = Chunk::<T, S, N>::new();
            let centre_used = used::<T, L, N>(&centre);
            let gathered = if self.regular {
                self.fill_regular::<S, CH, N, 3>(data, (x, y), (xf, yf), d, &mut chunk)
            } else {
                Gathered::Not
            };
            // Two calls rather than one with the mask as an option: the common one keeps no
            // mask in its loop.
            let groups = &self.regular_groups;
            match gathered {
                Gathered::Every => chunk.statistics(
                    CHUNK,
                    &self.levels,
                    &centre_used,
                    d,
                    self.half,
                    (robust, scaled),
                    Some((groups, None)),
                    regular_slack.as_ref(),
                    out,
                ),
                Gathered::Masked(seen) => chunk.statistics(
                    CHUNK,
                    &self.levels,
                    &centre_used,
                    d,
                    self.half,
                    (robust, scaled),
                    Some((groups, Some(&seen))),
                    regular_slack.as_ref(),
                    out,
                ),
                Gathered::Not => {}
            }
            if gathered != Gathered::Not {
                cursor = CHUNK;
            }
            loop {
                let n =
                    self.fill::<S, CH, N, 3>(data, &mut cursor, (x, y), (xf, yf), d, &mut chunk);
                if n == 0 {
                    break;
                }
                let lane_slack = slack.as_ref().map(|s| chunk.slack(s));
                chunk.statistics(
                    n,
                    &self.levels,
                    &centre_used,
                    d,
                    self.half,
                    (robust, scaled),
                    None,
                    lane_slack.as_ref(),
                    out,
                );
            }
        }
        for tap in self.oblique_taps() {
            let tap = &tap;
            let Some(([first, second, at], factor)) =
                self.oblique::<S, CH, L>(data, tap, (xf, yf), d)
            else {
                continue;
            };
            let (mut gg, mut gr, mut rr) = ([T::ZERO; L], [T::ZERO; L], [T::ZERO; L]);
            for c in 0..L {
                let g = (first[c] - second[c]) * factor;
                let r = at[c] - centre[c];
                gg[c] = g * g;
                match &slack {
                    // See `statistics`.
                    Some(s) => {
                        let outside = s.outside(r, c);
                        rr[c] = outside * outside;
                    }
                    None => rr[c] = r * r,
                }
                gr[c] = g * (g * d - r);
            }
            let (mut a, mut b, mut e) = (T::ZERO, T::ZERO, T::ZERO);
            for c in 0..N.min(L) {
                a += gg[c];
                b += gr[c];
                e += rr[c];
            }
            tap.add_weighted(out, (a, b, e), (robust, scaled));
        }
    }

    fn cost_channels<
        S: Sample,
        const CH: usize,
        const N: usize,
        const L: usize,
        const SLACK: bool,
    >(
        &self,
        data: &[S],
        x: usize,
        y: usize,
        d: T,
        (robust, scaled): (T, T),
        bar: Option<T>,
    ) -> Option<T> {
        let below = |c: T| bar.is_none_or(|bar| c < bar);
        let Some((centre, xf, yf)) = self.centre::<S, CH, L>(data, x, y) else {
            return below(T::ZERO).then_some(T::ZERO);
        };
        let (slack, regular_slack) = self.slacks::<S, CH, N, L, SLACK>(data, (x, y), &centre);
        // The views' weighted energies in a fixed order: a running sum of non-negative
        // terms, so a partial sum at or above the bar decides.
        let mut cost = T::ZERO;
        let mut cursor = 0;
        let centre_used = used::<T, L, N>(&centre);
        // The common case first, as in `pixel_channels`: the same energies as from the
        // chunk `fill_regular` gathers (the same bits).
        if self.regular {
            let (mut cells, mut fractions) = ([0i32; CHUNK], [T::ZERO; CHUNK]);
            let mut words = [[0u32; CHUNK]; 2];
            if self.regular_cells::<2>((xf, yf), d, &mut cells, &mut fractions)
                && self
                    .regular_words::<S, CH, 2>(data, (x, y), &cells, &mut words)
                    .is_some()
            {
                let levels = &self.levels;
                // `j` < 2, `c` < N ≤ 3 (`energies`).
                let texel = |j: usize, c: usize, v: usize| unpack(words[j][v], c, levels);
                let slack = regular_slack.as_ref();
                for e in energies(&texel, &fractions, &centre_used, (robust, scaled), slack) {
                    cost += e;
                }
                if !below(cost) {
                    return None;
                }
                cursor = CHUNK;
            }
        }
        // The other axis taps (see `pixel_channels`).
        if cursor < self.axis_len {
            let mut chunk = Chunk::<T, S, N>::new();
            let gathered = if self.regular {
                self.fill_regular::<S, CH, N, 2>(data, (x, y), (xf, yf), d, &mut chunk)
            } else {
                Gathered::Not
            };
            match gathered {
                Gathered::Every => {
                    let slack = regular_slack.as_ref();
                    for e in chunk.energies(&self.levels, &centre_used, (robust, scaled), slack) {
                        cost += e;
                    }
                }
                Gathered::Masked(seen) => {
                    let slack = regular_slack.as_ref();
                    let energies =
                        chunk.energies(&self.levels, &centre_used, (robust, scaled), slack);
                    for (e, keep) in energies.into_iter().zip(seen) {
                        cost += if keep { e } else { T::ZERO };
                    }
                }
                Gathered::Not => {}
            }
            if gathered != Gathered::Not {
                if !below(cost) {
                    return None;
                }
                cursor = CHUNK;
            }
            loop {
                let n =
                    self.fill::<S, CH, N, 2>(data, &mut cursor, (x, y), (xf, yf), d, &mut chunk);
                if n == 0 {
                    break;
                }
                let lane_slack = slack.as_ref().map(|s| chunk.slack(s));
                let energies = chunk.energies(
                    &self.levels,
                    &centre_used,
                    (robust, scaled),
                    lane_slack.as_ref(),
                );
                for &e in energies.get(..n).unwrap_or_default() {
                    cost += e;
                    if !below(cost) {
                        return None;
                    }
                }
            }
        }
        for tap in self.oblique_taps() {
            let tap = &tap;
            if !self.sees(tap, xf, yf, d) {
                continue;
            }
            let Some(at) = self.bilinear::<S, CH, L>(data, tap, (xf - d * tap.du, yf - d * tap.dv))
            else {
                continue;
            };
            // Counted once per group the view belongs to (two separate sums, so the
            // rounding matches summing each group on its own).
            let e = tap.weighted_cost(&at, &centre, N, (robust, scaled), slack.as_ref());
            cost += e;
            if tap.second_group.is_some() {
                cost += e;
            }
            if !below(cost) {
                return None;
            }
        }
        below(cost).then_some(cost)
    }

    /// With a sampling slack ([`Views::with_slack`]), the centre view's [`Interval`] at
    /// pixel `(x, y)` (value `centre`): along x and y, the values of its linear
    /// interpolation at `±slack` px (neighbours past the image's side repeat the
    /// pixel), and for oblique views both. `None` without a slack.
    #[inline(always)]
    fn interval<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        (x, y): (usize, usize),
        centre: &[T; L],
    ) -> Option<Interval<T, L>> {
        let slack = self.slack?;
        let base = self.centre + y * self.row_stride + x * CH;
        let at = |i: usize| lanes::<T, S, CH, L>(data, i, &self.levels);
        let left = if x > 0 { at(base - CH)? } else { *centre };
        let right = if x <= self.x_last {
            at(base + CH)?
        } else {
            *centre
        };
        let up = if y > 0 {
            at(base - self.row_stride)?
        } else {
            *centre
        };
        let down = if y <= self.y_last {
            at(base + self.row_stride)?
        } else {
            *centre
        };
        let mut out = Interval {
            lo: [[T::ZERO; L]; 3],
            hi: [[T::ZERO; L]; 3],
        };
        // Compare and select (the samples are finite: no NaN tests).
        let lower = |a: T, b: T| if b < a { b } else { a };
        let upper = |a: T, b: T| if b > a { b } else { a };
        for (axis, (a, b)) in [(left, right), (up, down)].into_iter().enumerate() {
            for c in 0..L {
                let (ea, eb) = (slack * (a[c] - centre[c]), slack * (b[c] - centre[c]));
                out.lo[axis][c] = lower(lower(ea, eb), T::ZERO);
                out.hi[axis][c] = upper(upper(ea, eb), T::ZERO);
            }
        }
        for c in 0..L {
            out.lo[2][c] = lower(out.lo[0][c], out.lo[1][c]);
            out.hi[2][c] = upper(out.hi[0][c], out.hi[1][c]);
        }
        Some(out)
    }

    /// These views with a sampling slack of `slack` px (`RefineParams::sampling_slack`;
    /// zero or less: none).
    pub(crate) fn with_slack(mut self, slack: f32) -> Self {
        self.slack = (slack > 0.0).then(|| T::from_f32(slack));
        self
    }

    /// The statistics of the [`CHUNK`] regular axis taps when every one sees pixel
    /// `(x, y)` and none needs the border's clamped samples (`cells`, `fractions` from
    /// [`Self::regular_cells`] with `J` = 3), written to the groups' slots of `out`
    /// (zeroed), for 8-bit samples: [`statistics`] of the same scaled texels as the
    /// chunk `fill_regular` gathers (the same bits), but each texel's channels moved as
    /// one 32-bit word, then split into channels for all taps side by side (the byte
    /// by byte gather was a third of a call). `false` (and `out` unchanged) for other
    /// sample types and when a texel's four bytes reach past the end of the data.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn regular_statistics<S: Sample, const CH: usize, const N: usize>(
        &self,
        data: &[S],
        (x, y): (usize, usize),
        (cells, fractions): (&[i32; CHUNK], &[T; CHUNK]),
        centre: &[T; N],
        d: T,
        robust: (T, T),
        slack: Option<&LaneSlack<T, N>>,
        out: &mut [T; STATS],
    ) -> bool {
        let mut words = [[0u32; CHUNK]; 3];
        if self
            .regular_words::<S, CH, 3>(data, (x, y), cells, &mut words)
            .is_none()
        {
            return false;
        }
        let levels = &self.levels;
        let lanes = Lanes {
            // `j` < 3, `c` < N ≤ 4 (`statistics`).
            texel: |j: usize, c: usize, v: usize| unpack(words[j][v], c, levels),
            fraction: fractions,
            offset: &self.regular_offset,
            group: &[0; CHUNK],
        };
        let regular = Some((&self.regular_groups, None));
        statistics(
            &lanes, CHUNK, centre, d, self.half, robust, regular, slack, out,
        );
        true
    }

    /// The texels `k`, …, `k + J − 1` (`k` the tap's cell) of the [`CHUNK`] regular
    /// axis taps for pixel `(x, y)` into `words`, each as one 32-bit word of its first
    /// four 8-bit samples (the channels, little-endian; see [`unpack`]). `None` for
    /// other sample types and when a word reaches past the end of the data. (An output
    /// argument: a returned array was copied by `memcpy`.)
    #[inline(always)]
    fn regular_words<S: Sample, const CH: usize, const J: usize>(
        &self,
        data: &[S],
        (x, y): (usize, usize),
        cells: &[i32; CHUNK],
        words: &mut [[u32; CHUNK]; J],
    ) -> Option<()> {
        // Resolved at compile time for each sample type. A pixel's used channels (at
        // most three) fit a word; a row tap's `J` ≤ 3 texels lie within twelve bytes.
        if TypeId::of::<S>() != TypeId::of::<u8>() || CH > 4 || J > 3 {
            return None;
        }
        let word = |bytes: Option<&[S; 4]>| {
            let bytes = bytes.and_then(|b| (b as &dyn Any).downcast_ref::<[u8; 4]>())?;
            Some(u32::from_le_bytes(*bytes))
        };
        let (row, column, rs) = (y * self.row_stride, x * CH, self.row_stride);
        for v in 0..CHUNK {
            // Cells are non-negative (`regular_cells`).
            let k = cells[v] as usize;
            if self.regular_in_row[v] {
                // Side by side in the row: one bounds check.
                let first = self.regular_start[v] + row + k * CH;
                let run = data.get(first..)?.first_chunk::<12>()?;
                for (j, words) in words.iter_mut().enumerate() {
                    words[v] = word(run.get(j * CH..).and_then(|s| s.first_chunk::<4>()))?;
                }
            } else {
                // One row apart: one bounds check for the span from the first word to
                // the end of the last (the sums do not wrap, so the nearer words lie
                // inside it).
                let first = self.regular_start[v] + column + k * rs;
                let last = rs.checked_mul(J.saturating_sub(1))?.checked_add(4)?;
                let run = data.get(first..first.checked_add(last)?)?;
                let mut at = 0usize;
                for words in words.iter_mut() {
                    words[v] = word(run.get(at..).and_then(|s| s.first_chunk::<4>()))?;
                    at = at.checked_add(rs)?;
                }
            }
        }
        Some(())
    }

    /// The next axis tap.
    #[inline(always)]
    fn next_axis(&self, cursor: &mut usize) -> Option<&AxisTap<T>> {
        let tap = self.axis.get(..self.axis_len)?.get(*cursor)?;
        *cursor += 1;
        Some(tap)
    }

    /// Gathers the samples of the next axis taps (from index `cursor`) that see pixel
    /// `(x, y)` at `d` into `chunk`, at most [`CHUNK`]; returns how many. `J` = 3: the
    /// samples `k`, `k + 1`, `k + 2` around the position `p` with `p − ½ = k + f` (for
    /// the derivative); `J` = 2: `k`, `k + 1` with `p = k + f`. A sample past the
    /// image takes the one before it (it has weight zero). A tap sees the pixel when
    /// `p ± ½` lies inside the image (the statistics and the cost skip the same taps).
    #[inline(always)]
    fn fill<S: Sample, const CH: usize, const N: usize, const J: usize>(
        &self,
        data: &[S],
        cursor: &mut usize,
        pixel: (usize, usize),
        position: (T, T),
        d: T,
        chunk: &mut Chunk<T, S, N>,
    ) -> usize {
        let half = self.half;
        let mut n = 0;
        while n < CHUNK {
            let Some(tap) = self.next_axis(cursor) else {
                break;
            };
            let (p, max, last, base, stride) = self.axis_frame(tap, pixel, position, d);
            if !(p - half >= T::ZERO && p + half <= max) {
                continue;
            }
            let (k, f) = split(if J == 3 { p - half } else { p });
            let start = base + k * stride;
            let inside = if tap.in_row && k + J <= last + 1 {
                // The samples lie side by side in the row: one bounds check.
                match data.get(start..start.wrapping_add((J - 1) * CH + N)) {
                    Some(run) => {
                        for (j, texel) in chunk.raw.iter_mut().take(J).enumerate() {
                            for (c, channel) in texel.iter_mut().enumerate() {
                                channel[n] = run[j * CH + c];
                            }
                        }
                        true
                    }
                    None => false,
                }
            } else if k + J <= last + 1 {
                // Down a column: one bounds check for the span.
                match data.get(start..start.wrapping_add((J - 1) * stride + N)) {
                    Some(run) => {
                        for (j, texel) in chunk.raw.iter_mut().take(J).enumerate() {
                            for (c, channel) in texel.iter_mut().enumerate() {
                                channel[n] = run.get(j * stride + c).copied().unwrap_or_default();
                            }
                        }
                        true
                    }
                    None => false,
                }
            } else {
                let mut inside = true;
                for (j, texel) in chunk.raw.iter_mut().take(J).enumerate() {
                    let i = base + (k + j).min(last) * stride;
                    match data.get(i..i.wrapping_add(N)) {
                        Some(samples) => {
                            for (channel, &sample) in texel.iter_mut().zip(samples) {
                                channel[n] = sample;
                            }
                        }
                        None => inside = false,
                    }
                }
                inside
            };
            if !inside {
                continue;
            }
            if let (Some(fraction), Some(offset), Some(to)) = (
                chunk.fraction.get_mut(n),
                chunk.offset.get_mut(n),
                chunk.group.get_mut(n),
            ) {
                // Groups are below `GROUPS`: the default never happens.
                let group = u8::try_from(tap.group).unwrap_or(u8::MAX);
                (*fraction, *offset, *to) = (f, tap.offset, group);
            }
            n += 1;
        }
        n
    }

    /// [`Self::fill`] of all [`CHUNK`] axis taps of a regular set at once (the positions
    /// and cells of the sixteen taps in fixed-length loops, then the copies): when every
    /// tap sees the pixel and none needs the border's clamped samples, the same chunk
    /// as `fill` from cursor 0 ([`Gathered::Every`]); near the image's sides each tap in
    /// its lane with the clamped samples `fill` takes, and a mask of the taps that see
    /// the pixel ([`Gathered::Masked`]). [`Gathered::Not`] when a sample lies outside
    /// the data (the chunk is then partly written; `fill` rewrites every lane it
    /// returns).
    #[inline(always)]
    fn fill_regular<S: Sample, const CH: usize, const N: usize, const J: usize>(
        &self,
        data: &[S],
        (x, y): (usize, usize),
        (xf, yf): (T, T),
        d: T,
        chunk: &mut Chunk<T, S, N>,
    ) -> Gathered {
        let mut cells = [0i32; CHUNK];
        let every = self.regular_cells::<J>((xf, yf), d, &mut cells, &mut chunk.fraction);
        // Cells are non-negative (`regular_cells`).
        let cells = cells.map(|k| k as usize);
        let (row, column) = (y * self.row_stride, x * CH);
        let rs = self.row_stride;
        chunk.offset = self.regular_offset;
        if every {
            for (v, (&k, &start)) in cells.iter().zip(&self.regular_start).enumerate() {
                if self.regular_in_row[v] {
                    // The J texels lie side by side in the row.
                    let start = start + row + k * CH;
                    let Some(run) = data.get(start..start.wrapping_add((J - 1) * CH + N)) else {
                        return Gathered::Not;
                    };
                    for (j, texel) in chunk.raw.iter_mut().take(J).enumerate() {
                        let texel_run = run.get(j * CH..).unwrap_or_default();
                        for (channel, &sample) in texel.iter_mut().zip(texel_run) {
                            if let Some(lane) = channel.get_mut(v) {
                                *lane = sample;
                            }
                        }
                    }
                } else {
                    // One texel per row, `rs` apart.
                    let start = start + column + k * rs;
                    for (j, texel) in chunk.raw.iter_mut().take(J).enumerate() {
                        let at = start.wrapping_add(j * rs);
                        let Some(run) = data.get(at..at.wrapping_add(N)) else {
                            return Gathered::Not;
                        };
                        for (channel, &sample) in texel.iter_mut().zip(run) {
                            if let Some(lane) = channel.get_mut(v) {
                                *lane = sample;
                            }
                        }
                    }
                }
            }
            return Gathered::Every;
        }
        // Near the sides: texel `k + j` clamped to the last sample along the axis, as
        // `fill` takes a tap that sees the pixel (`p ± ½` inside the image, the same
        // position as `regular_cells`); a tap that does not see it reads any texel
        // inside the view (its lane adds zero).
        let mut seen = [false; CHUNK];
        for (v, (&k, &start)) in cells.iter().zip(&self.regular_start).enumerate() {
            let p = (xf * self.regular_x[v] + yf * self.regular_y[v]) - d * self.regular_offset[v];
            seen[v] = p - self.half >= T::ZERO && p + self.half <= self.regular_max[v];
            let last = (self.regular_samples[v] as usize).saturating_sub(1);
            let (base, stride) = if self.regular_in_row[v] {
                (start + row, CH)
            } else {
                (start + column, rs)
            };
            for (j, texel) in chunk.raw.iter_mut().take(J).enumerate() {
                let at = base.wrapping_add(k.saturating_add(j).min(last).wrapping_mul(stride));
                let Some(run) = data.get(at..at.wrapping_add(N)) else {
                    return Gathered::Not;
                };
                for (channel, &sample) in texel.iter_mut().zip(run) {
                    if let Some(lane) = channel.get_mut(v) {
                        *lane = sample;
                    }
                }
            }
        }
        Gathered::Masked(seen)
    }

    /// The cells (first texel index along the axis) and fractions of the regular axis
    /// taps at `d`, as [`Self::fill`] splits them (`J` = 3: of `p − ½`, `J` = 2: of
    /// `p`); whether every tap sees the pixel and none needs the border's clamped
    /// samples. For `f32` in one loop without branches, which the compiler vectorises
    /// (the cells as `i32`, non-negative, so that they stay in vector lanes too).
    #[inline(always)]
    fn regular_cells<const J: usize>(
        &self,
        (xf, yf): (T, T),
        d: T,
        cells: &mut [i32; CHUNK],
        fractions: &mut [T; CHUNK],
    ) -> bool {
        let half = self.half;
        // Resolved at compile time for each scalar type.
        let f32s = (
            (&xf as &dyn Any).downcast_ref::<f32>(),
            (&yf as &dyn Any).downcast_ref::<f32>(),
            (&d as &dyn Any).downcast_ref::<f32>(),
            (&self.regular_x as &dyn Any).downcast_ref::<[f32; CHUNK]>(),
            (&self.regular_y as &dyn Any).downcast_ref::<[f32; CHUNK]>(),
            (&self.regular_offset as &dyn Any).downcast_ref::<[f32; CHUNK]>(),
            (&self.regular_max as &dyn Any).downcast_ref::<[f32; CHUNK]>(),
            (fractions as &mut dyn Any).downcast_mut::<[f32; CHUNK]>(),
        );
        if let (Some(&xf), Some(&yf), Some(&d), Some(rx), Some(ry), Some(off), Some(max), Some(f)) =
            f32s
        {
            let mut inside = [false; CHUNK];
            let mut whole = [0i32; CHUNK];
            for v in 0..CHUNK {
                // `xf · 1 + yf · 0` is `xf` exactly (and the other way round).
                let p = (xf * rx[v] + yf * ry[v]) - d * off[v];
                let q = if J == 3 { p - 0.5 } else { p };
                // The floor of `0 ≤ q < 2^22` (a position inside the image) without a
                // saturating conversion: `q + 1.5·2^23` rounds `q` to an integer in
                // the low bits of the sum; one less where that rounded up. The same
                // cell and fraction as `split`. (Outside that range the cell is wrong,
                // and `inside` is false.)
                let rounded = q + MAGIC;
                let mut k = (rounded.to_bits() as i32).wrapping_sub(MAGIC.to_bits() as i32);
                k -= i32::from(rounded - MAGIC > q);
                whole[v] = k;
                f[v] = q - k as f32;
                inside[v] = (p - 0.5 >= 0.0) & (p + 0.5 <= max[v]) & (q < 4194304.0);
            }
            // In `i32` side by side (the cells are below 2^22).
            let mut fits = [false; CHUNK];
            for v in 0..CHUNK {
                let k = whole[v].max(0);
                cells[v] = k;
                fits[v] = inside[v] & (k + J as i32 <= self.regular_samples[v]);
            }
            return fits.iter().fold(true, |all, &fits| all & fits);
        }
        let mut all = true;
        for v in 0..CHUNK {
            let p = (xf * self.regular_x[v] + yf * self.regular_y[v]) - d * self.regular_offset[v];
            let (k, f) = split(if J == 3 { p - half } else { p });
            // A cell that does not fit `i32` lies outside the image: not `all`, and the
            // border path clamps it to the last cell either way.
            let cell = i32::try_from(k).unwrap_or(i32::MAX);
            all &= p - half >= T::ZERO
                && p + half <= self.regular_max[v]
                && cell
                    .checked_add(J as i32)
                    .is_some_and(|end| end <= self.regular_samples[v]);
            cells[v] = cell;
            fractions[v] = f;
        }
        all
    }

    /// The samples of an oblique view: bilinear at `d + h`, `d − h` and `d`, with the
    /// central difference's factor `1 / (2h)`. `None` when a sample leaves the image.
    #[inline(always)]
    fn oblique<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        tap: &Tap<T>,
        (xf, yf): (T, T),
        d: T,
    ) -> Option<([[T; L]; 3], T)> {
        if !self.sees(tap, xf, yf, d) {
            return None;
        }
        let (dp, dm) = (d + tap.h, d - tap.h);
        let sample =
            |dd: T| self.bilinear::<S, CH, L>(data, tap, (xf - dd * tap.du, yf - dd * tap.dv));
        Some(([sample(dp)?, sample(dm)?, sample(d)?], tap.inv))
    }

    /// Bilinear sample of the `L` lanes at `(px, py)` (see [`lanes`]), inside the image
    /// (`None` only for a layout the samples do not fill).
    #[inline(always)]
    fn bilinear<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        tap: &Tap<T>,
        position: (T, T),
    ) -> Option<[T; L]> {
        self.bilinear_at::<S, CH, L>(data, tap.start, position)
    }

    /// [`Self::bilinear`] in the view whose first sample is `start`.
    #[inline(always)]
    fn bilinear_at<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        start: usize,
        (px, py): (T, T),
    ) -> Option<[T; L]> {
        let levels = &self.levels;
        let lerp = |s0: [T; L], s1: [T; L], a: T| {
            let mut out = [T::ZERO; L];
            for c in 0..L {
                out[c] = s0[c] + a * (s1[c] - s0[c]);
            }
            out
        };
        let at = |i: usize| lanes::<T, S, CH, L>(data, i, levels);
        let (x0, ax) = cell(px, self.x_last, self.x_cell);
        let (y0, ay) = cell(py, self.y_last, self.y_cell);
        let i00 = start + y0 * self.row_stride + x0 * CH;
        let i10 = i00 + self.row_stride;
        let top = lerp(at(i00)?, at(i00 + CH)?, ax);
        let bottom = lerp(at(i10)?, at(i10 + CH)?, ax);
        Some(lerp(top, bottom, ay))
    }
}

/// Every compared view as an oblique tap (axis views included): the simple path of
/// [`Mapped`], which samples each view through its homography.
impl<T: Scalar> Views<T> {
    fn all_taps(&self) -> impl Iterator<Item = Tap<T>> + '_ {
        let axis = self.axis.get(..self.axis_len).unwrap_or_default();
        axis.iter()
            .map(|a| {
                let h = 0.5 / (a.reach.max(1) as f32);
                let (du, dv) = if a.in_row {
                    (a.offset, T::ZERO)
                } else {
                    (T::ZERO, a.offset)
                };
                Tap {
                    start: a.start,
                    du,
                    dv,
                    h: T::from_f32(h),
                    inv: T::from_f32(0.5 / h),
                    group: a.group,
                    second_group: None,
                }
            })
            .chain(self.oblique_taps())
    }

    /// The sample of the raw view at `start` at rectified position `(px, py)` mapped by
    /// `map` (rectified → view pixels, as the warp), bilinear or (`cubic`) Catmull–Rom:
    /// one interpolation of the input. `None` outside the view.
    #[inline(always)]
    fn mapped<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        start: usize,
        map: &Homography,
        cubic: bool,
        (px, py): (T, T),
    ) -> Option<[T; L]> {
        let (u, v) = map.apply(px.to_f32(), py.to_f32())?;
        let (xm, ym) = (self.x_max.to_f32(), self.y_max.to_f32());
        if !(u >= 0.0 && u <= xm && v >= 0.0 && v <= ym) {
            return None;
        }
        if cubic {
            return self.catmull_rom_at::<S, CH, L>(data, start, u, v);
        }
        self.bilinear_at::<S, CH, L>(data, start, (T::from_f32(u), T::from_f32(v)))
    }

    /// Catmull–Rom sample of the `L` lanes at `(u, v)` inside the view; taps past the
    /// border repeat the border pixel.
    #[inline(always)]
    fn catmull_rom_at<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        start: usize,
        u: f32,
        v: f32,
    ) -> Option<[T; L]> {
        let weights = |t: f32| {
            let (t2, t3) = (t * t, t * t * t);
            [
                0.5 * (-t3 + 2.0 * t2 - t),
                0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
                0.5 * (-3.0 * t3 + 4.0 * t2 + t),
                0.5 * (t3 - t2),
            ]
        };
        let (x0, y0) = ((u as i32).max(0), (v as i32).max(0));
        let (wx, wy) = (weights(u - x0 as f32), weights(v - y0 as f32));
        let xl = self.x_last as i32 + 1;
        let yl = self.y_last as i32 + 1;
        let mut out = [T::ZERO; L];
        for (j, &wyj) in wy.iter().enumerate() {
            let yy = (y0 + j as i32 - 1).clamp(0, yl) as usize;
            let mut row = [T::ZERO; L];
            for (i, &wxi) in wx.iter().enumerate() {
                let xx = (x0 + i as i32 - 1).clamp(0, xl) as usize;
                let at = lanes::<T, S, CH, L>(
                    data,
                    start + yy * self.row_stride + xx * CH,
                    &self.levels,
                )?;
                let w = T::from_f32(wxi);
                for c in 0..L {
                    row[c] += w * at[c];
                }
            }
            let w = T::from_f32(wyj);
            for c in 0..L {
                out[c] += w * row[c];
            }
        }
        Some(out)
    }

    /// The homography of the view whose first sample is `start`.
    #[inline(always)]
    fn map_of<'m>(&self, maps: &'m [Homography], start: usize) -> Option<&'m Homography> {
        maps.get(start.checked_div(self.view_stride)?)
    }

    /// The centre view's samples at `(x, y)` through its homography.
    #[inline(always)]
    fn mapped_centre<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        (maps, cubic): (&[Homography], bool),
        (xf, yf): (T, T),
    ) -> Option<[T; L]> {
        let map = self.map_of(maps, self.centre)?;
        self.mapped::<S, CH, L>(data, self.centre, map, cubic, (xf, yf))
    }

    /// The samples of a view through its homography at `d + h`, `d − h` and `d`.
    #[inline(always)]
    fn mapped_three<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        (maps, cubic): (&[Homography], bool),
        tap: &Tap<T>,
        (xf, yf): (T, T),
        d: T,
    ) -> Option<[[T; L]; 3]> {
        let map = self.map_of(maps, tap.start)?;
        let sample = |dd: T| {
            let at = (xf - dd * tap.du, yf - dd * tap.dv);
            self.mapped::<S, CH, L>(data, tap.start, map, cubic, at)
        };
        Some([sample(d + tap.h)?, sample(d - tap.h)?, sample(d)?])
    }

    fn pixel_mapped_channels<S: Sample, const CH: usize, const N: usize, const L: usize>(
        &self,
        data: &[S],
        maps: (&[Homography], bool),
        (x, y): (usize, usize),
        d: T,
        (robust, scaled): (T, T),
        out: &mut [T; STATS],
    ) {
        *out = [T::ZERO; STATS];
        let (xf, yf) = (T::from_i32(x as i32), T::from_i32(y as i32));
        let Some(centre) = self.mapped_centre::<S, CH, L>(data, maps, (xf, yf)) else {
            return;
        };
        for tap in self.all_taps() {
            let Some([first, second, at]) =
                self.mapped_three::<S, CH, L>(data, maps, &tap, (xf, yf), d)
            else {
                continue;
            };
            let (mut a, mut b, mut e) = (T::ZERO, T::ZERO, T::ZERO);
            for c in 0..N.min(L) {
                let g = (first[c] - second[c]) * tap.inv;
                let r = at[c] - centre[c];
                a += g * g;
                b += g * (g * d - r);
                e += r * r;
            }
            tap.add_weighted(out, (a, b, e), (robust, scaled));
        }
    }

    fn cost_mapped_channels<S: Sample, const CH: usize, const N: usize, const L: usize>(
        &self,
        data: &[S],
        maps: (&[Homography], bool),
        (x, y): (usize, usize),
        d: T,
        (robust, scaled): (T, T),
        bar: Option<T>,
    ) -> Option<T> {
        let below = |c: T| bar.is_none_or(|bar| c < bar);
        let (xf, yf) = (T::from_i32(x as i32), T::from_i32(y as i32));
        let Some(centre) = self.mapped_centre::<S, CH, L>(data, maps, (xf, yf)) else {
            return below(T::ZERO).then_some(T::ZERO);
        };
        let mut cost = T::ZERO;
        for tap in self.all_taps() {
            // The same views as the statistics: those whose three samples lie inside.
            let Some([_, _, at]) = self.mapped_three::<S, CH, L>(data, maps, &tap, (xf, yf), d)
            else {
                continue;
            };
            // Counted once per group the view belongs to (two separate sums, so the
            // rounding matches summing each group on its own).
            let e = tap.weighted_cost(&at, &centre, N, (robust, scaled), None);
            cost += e;
            if tap.second_group.is_some() {
                cost += e;
            }
            if !below(cost) {
                return None;
            }
        }
        below(cost).then_some(cost)
    }
}

/// What the refinement compares: the statistics and the cost of a pixel at a disparity.
pub(crate) trait Photometric<T> {
    /// The compared views.
    fn views(&self) -> &Views<T>;
    /// See [`Views::pixel`].
    fn pixel(&self, x: usize, y: usize, d: T, robust: (T, T), out: &mut [T; STATS]);
    /// See [`Views::cost`].
    fn cost(&self, x: usize, y: usize, d: T, robust: (T, T), bar: Option<T>) -> Option<T>;
}

/// Rectified views, read where they lie.
pub(crate) struct Rectified<'a, T, S> {
    pub views: Views<T>,
    pub data: &'a [S],
}

impl<T: Scalar, S: Sample> Photometric<T> for Rectified<'_, T, S> {
    #[inline(always)]
    fn views(&self) -> &Views<T> {
        &self.views
    }
    #[inline(always)]
    fn pixel(&self, x: usize, y: usize, d: T, robust: (T, T), out: &mut [T; STATS]) {
        self.views.pixel(self.data, x, y, d, robust, out);
    }
    #[inline(always)]
    fn cost(&self, x: usize, y: usize, d: T, robust: (T, T), bar: Option<T>) -> Option<T> {
        self.views.cost(self.data, x, y, d, robust, bar)
    }
}

/// Input views of an aligned array, each read through its homography (rectified → view
/// pixels, as the warp) at the disparity-shifted position: one interpolation of the
/// input, where the warped copy would be interpolated a second time (its occlusion
/// edges spread by a different amount in every view; docs/stages/align.md). Every view
/// takes three samples (the derivative by a central difference) with `interpolation`.
pub(crate) struct Mapped<'a, T, S> {
    pub views: Views<T>,
    pub data: &'a [S],
    pub maps: &'a [Homography],
    pub interpolation: Interpolation,
}

impl<T: Scalar, S: Sample> Photometric<T> for Mapped<'_, T, S> {
    fn views(&self) -> &Views<T> {
        &self.views
    }
    fn pixel(&self, x: usize, y: usize, d: T, robust: (T, T), out: &mut [T; STATS]) {
        let v = &self.views;
        let m = (self.maps, self.interpolation == Interpolation::CatmullRom);
        match v.channels {
            1 => v.pixel_mapped_channels::<S, 1, 1, 1>(self.data, m, (x, y), d, robust, out),
            3 => v.pixel_mapped_channels::<S, 3, 3, 4>(self.data, m, (x, y), d, robust, out),
            4 => v.pixel_mapped_channels::<S, 4, 3, 4>(self.data, m, (x, y), d, robust, out),
            _ => *out = [T::ZERO; STATS],
        }
    }
    fn cost(&self, x: usize, y: usize, d: T, robust: (T, T), bar: Option<T>) -> Option<T> {
        let v = &self.views;
        let m = (self.maps, self.interpolation == Interpolation::CatmullRom);
        match v.channels {
            1 => v.cost_mapped_channels::<S, 1, 1, 1>(self.data, m, (x, y), d, robust, bar),
            3 => v.cost_mapped_channels::<S, 3, 3, 4>(self.data, m, (x, y), d, robust, bar),
            4 => v.cost_mapped_channels::<S, 4, 3, 4>(self.data, m, (x, y), d, robust, bar),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::*;
    use crate::epi::test_scenes::{noise, strips};
    use crate::lightfield::Grid;
    use crate::scalar::Q16;

    /// The 9×9 cross's taps in one pass (`fill_regular`, the group sums side by side)
    /// against tap by tap (`fill`): the same bits for every pixel, disparity and bar,
    /// borders (where the one pass masks the taps that do not see the pixel and clamps
    /// the last samples) included.
    fn regular_matches_tap_by_tap<T: Scalar>(slack: f32) {
        let scene = strips(Grid::new(9, 9), 40, 36, 3, 0.6, &[1.8]);
        let regular = Views::<T>::new(&scene.layout, ViewSet::Cross).with_slack(slack);
        assert!(regular.regular, "the 9×9 cross is regular");
        let mut by_tap = Views::<T>::new(&scene.layout, ViewSet::Cross).with_slack(slack);
        by_tap.regular = false;
        let robust = 0.01f32 * 0.01 * 3.0 * INTENSITY_SCALE * INTENSITY_SCALE;
        let stat_robust = (T::from_f32(robust), T::from_f32(4.0 * robust));
        let cost_robust = (T::from_f32(robust), T::from_f32(4096.0 * robust));
        let (w, h) = (scene.layout.width, scene.layout.height);
        let shifts = noise(w * h, 11);
        let mut costs = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let d = T::from_f32(6.0 * shifts[y * w + x] - 3.0);
                let (mut a, mut b) = ([T::ZERO; STATS], [T::ZERO; STATS]);
                regular.pixel(&scene.data, x, y, d, stat_robust, &mut a);
                by_tap.pixel(&scene.data, x, y, d, stat_robust, &mut b);
                assert!(a == b, "statistics differ at ({x}, {y}): {a:?} vs {b:?}");
                let full = regular.cost(&scene.data, x, y, d, cost_robust, None);
                assert_eq!(full, by_tap.cost(&scene.data, x, y, d, cost_robust, None));
                let full = full.unwrap_or(T::ZERO);
                costs.push(full);
                for bar in [full, full + T::from_f32(1.0e-3), full * T::from_f32(0.5)] {
                    assert_eq!(
                        regular.cost(&scene.data, x, y, d, cost_robust, Some(bar)),
                        by_tap.cost(&scene.data, x, y, d, cost_robust, Some(bar)),
                        "cost below {bar:?} at ({x}, {y})"
                    );
                }
            }
        }
        // The comparison saw real costs, not only empty ones.
        assert!(costs.iter().filter(|&&c| c > T::ZERO).count() > w * h / 2);
    }

    /// The compact stored oblique taps expand to the values a full tap held: offsets,
    /// `h = ½ / reach`, `1 / (2h)` and the groups, in grid order (every view of the
    /// largest grid, and a small one).
    fn stored_taps_expand_to_full_taps<T: Scalar>() {
        for grid in [Grid::new(GRID_MAX, GRID_MAX), Grid::new(5, 7)] {
            let layout = crate::lightfield::Layout::packed(grid, 8, 6, 3);
            let views = Views::<T>::new(&layout, ViewSet::All);
            let (r0, c0) = grid.center();
            let mut expected = Vec::new();
            for r in 0..grid.rows {
                for c in 0..grid.cols {
                    let (dr, dc) = (r as isize - r0 as isize, c as isize - c0 as isize);
                    if dr == 0 || dc == 0 {
                        continue;
                    }
                    let h = 0.5 / (dr.unsigned_abs().max(dc.unsigned_abs()) as f32);
                    let vertical = 2 + usize::from(dr > 0);
                    expected.push((
                        grid.index(r, c) * layout.view_stride,
                        [dc as f32, dr as f32, h, 0.5 / h].map(T::from_f32),
                        usize::from(dc > 0),
                        Some(vertical),
                    ));
                }
            }
            let taps: Vec<_> = views
                .oblique_taps()
                .map(|t| (t.start, [t.du, t.dv, t.h, t.inv], t.group, t.second_group))
                .collect();
            assert_eq!(taps.len(), grid.len() - grid.rows - grid.cols + 1);
            assert!(taps == expected, "{grid:?}: {taps:?} vs {expected:?}");
        }
    }

    #[test]
    fn stored_f32_taps_expand_to_full_taps() {
        stored_taps_expand_to_full_taps::<f32>();
    }

    #[test]
    fn stored_q16_taps_expand_to_full_taps() {
        stored_taps_expand_to_full_taps::<Q16>();
    }

    #[test]
    fn the_regular_cross_gives_the_same_f32_statistics_and_costs_as_tap_by_tap() {
        regular_matches_tap_by_tap::<f32>(0.0);
        regular_matches_tap_by_tap::<f32>(0.5);
    }

    #[test]
    fn the_regular_cross_gives_the_same_q16_statistics_and_costs_as_tap_by_tap() {
        regular_matches_tap_by_tap::<Q16>(0.0);
        regular_matches_tap_by_tap::<Q16>(0.5);
    }

    /// The sampling slack only forgives: the cost and every group's residual energy
    /// with it are at most the plain ones, for the cross and every view; it forgives something on a textured scene; and a view that is the centre
    /// view shifted by less than the slack costs nothing at the true disparity (0) where
    /// the plain residual does not.
    fn slack_only_forgives<T: Scalar>() {
        let scene = strips(Grid::new(5, 5), 32, 28, 3, 0.6, &[1.2]);
        let robust = 0.01f32 * 0.01 * 3.0 * INTENSITY_SCALE * INTENSITY_SCALE;
        let stat_robust = (T::from_f32(robust), T::from_f32(4.0 * robust));
        let cost_robust = (T::from_f32(robust), T::from_f32(4096.0 * robust));
        let (w, h) = (scene.layout.width, scene.layout.height);
        let shifts = noise(w * h, 5);
        for set in [ViewSet::Cross, ViewSet::All] {
            let plain = Views::<T>::new(&scene.layout, set);
            let slack = Views::<T>::new(&scene.layout, set).with_slack(0.5);
            let mut forgiven = 0;
            for y in 0..h {
                for x in 0..w {
                    let d = T::from_f32(4.0 * shifts[y * w + x] - 2.0);
                    let (mut a, mut b) = ([T::ZERO; STATS], [T::ZERO; STATS]);
                    plain.pixel(&scene.data, x, y, d, stat_robust, &mut a);
                    slack.pixel(&scene.data, x, y, d, stat_robust, &mut b);
                    // Within the rounding of Q16.16's weights (the weight of a large
                    // residual is a few LSB, times that residual's energy).
                    for g in 0..GROUPS {
                        let (e0, e1) = (a[3 * g + 2], b[3 * g + 2]);
                        let tolerance = T::from_f32(1.0e-3) + e0 * T::from_f32(0.02);
                        assert!(
                            e1 <= e0 + tolerance,
                            "{set:?} energy at ({x}, {y}): {e1:?} > {e0:?}"
                        );
                    }
                    let c0 = plain.cost(&scene.data, x, y, d, cost_robust, None);
                    let c1 = slack.cost(&scene.data, x, y, d, cost_robust, None);
                    let (c0, c1) = (c0.unwrap_or(T::ZERO), c1.unwrap_or(T::ZERO));
                    let tolerance = T::from_f32(0.05);
                    assert!(
                        c1 <= c0 + tolerance,
                        "{set:?} cost at ({x}, {y}): {c1:?} > {c0:?}"
                    );
                    forgiven += usize::from(c1 + tolerance < c0);
                }
            }
            assert!(forgiven > w * h / 4, "{set:?}: {forgiven} pixels forgiven");
        }
        // Every view is the centre view moved by 0.2 px per grid step along x (linear interpolation
        // of a smooth ramp image): at disparity 0 each row view's sample lies within
        // the centre's values over ±0.5 px.
        let grid = Grid::new(3, 5);
        let layout = Layout::packed(grid, 24, 16, 1);
        let mut data = std::vec![0.0f32; layout.validate().unwrap()];
        for v in 0..grid.len() {
            for y in 0..16 {
                for x in 0..24 {
                    let p = x as f32 + 0.2 * ((v % 5) as f32 - 2.0);
                    data[v * layout.view_stride + y * 24 + x] = 0.2 + 0.02 * p;
                }
            }
        }
        let plain = Views::<T>::new(&layout, ViewSet::Cross);
        let slack = Views::<T>::new(&layout, ViewSet::Cross).with_slack(0.5);
        let c0 = plain
            .cost(&data, 12, 8, T::ZERO, cost_robust, None)
            .unwrap();
        let c1 = slack
            .cost(&data, 12, 8, T::ZERO, cost_robust, None)
            .unwrap();
        assert!(c0 > T::ZERO && c1 == T::ZERO, "{c0:?} {c1:?}");
    }

    #[test]
    fn the_f32_sampling_slack_only_forgives() {
        slack_only_forgives::<f32>();
    }

    #[test]
    fn the_q16_sampling_slack_only_forgives() {
        slack_only_forgives::<Q16>();
    }
}
