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

use crate::align::Interpolation;
use crate::geometry::Homography;
use crate::lightfield::{Layout, Sample, GRID_MAX};
use crate::scalar::Scalar;

use super::params::ViewSet;
use taps::{AxisTap, StoredTap, STEPS};

mod gather;
mod mapped;
mod rectified;
mod sampling;
mod statistics;
mod taps;

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

/// Most views in the centre row and column of a grid.
const MAX_AXIS: usize = 2 * (GRID_MAX - 1);

/// Axis taps are sampled in chunks of this many: the gathered samples then go through
/// one loop of fixed length that the compiler vectorises (the weights' divisions too).
const CHUNK: usize = 16;

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

impl<T: Scalar> Views<T> {
    /// The views of `set`.
    pub(crate) fn new(layout: &Layout, set: ViewSet) -> Self {
        let mut views = Self::empty();
        views.init(layout, set);
        views
    }

    /// [`Views::EMPTY`], written straight into the caller's place (not inlined: a
    /// constant this large is otherwise copied through a temporary on the stack).
    #[inline(never)]
    pub(crate) fn empty() -> Self {
        Self::EMPTY
    }

    /// Tables of no views, to [`Views::init`] where they lie.
    pub(crate) const EMPTY: Self = Views {
        axis: [AxisTap::EMPTY; MAX_AXIS],
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
        taps: [StoredTap::EMPTY; MAX_VIEWS],
        len: 0,
        steps: [(T::ZERO, T::ZERO); STEPS],
        terms: [0.0; GROUPS],
        centre: 0,
        channels: 0,
        row_stride: 0,
        view_stride: 0,
        x_max: T::ZERO,
        y_max: T::ZERO,
        x_last: 0,
        y_last: 0,
        x_cell: T::ZERO,
        y_cell: T::ZERO,
        half: T::ZERO,
        levels: [T::ZERO; 256],
        slack: None,
    };

    /// Makes these the views of `set`, field by field where they lie: built as a new
    /// value and moved, the tables (≈ 5.7 KB on 32-bit targets) were twice on the
    /// refinement's stack (docs/EMBEDDED.md, "Stack").
    pub(crate) fn init(&mut self, layout: &Layout, set: ViewSet) {
        let views = self;
        let grid = layout.grid;
        let (r0, c0) = grid.center();
        let used = layout.channels.min(3);
        let coordinate = |v: usize| T::from_i32(i32::try_from(v).unwrap_or(i32::MAX));
        let unit = T::from_f32(INTENSITY_SCALE / 255.0);
        let x_last = layout.width.saturating_sub(2);
        let y_last = layout.height.saturating_sub(2);
        views.axis.fill(AxisTap::EMPTY);
        views.axis_len = 0;
        views.regular = false;
        views.regular_groups.fill(0);
        views.regular_offset.fill(T::ZERO);
        views.regular_start.fill(0);
        views.regular_in_row.fill(false);
        views.regular_x.fill(T::ZERO);
        views.regular_y.fill(T::ZERO);
        views.regular_max.fill(T::ZERO);
        views.regular_samples.fill(0);
        views.taps.fill(StoredTap::EMPTY);
        views.len = 0;
        views.steps = core::array::from_fn(|reach| {
            let h = 0.5 / (reach.max(1) as f32);
            (T::from_f32(h), T::from_f32(0.5 / h))
        });
        views.terms.fill(0.0);
        views.centre = grid.index(r0, c0) * layout.view_stride;
        views.channels = layout.channels;
        views.row_stride = layout.row_stride;
        views.view_stride = layout.view_stride;
        views.x_max = coordinate(layout.width.saturating_sub(1));
        views.y_max = coordinate(layout.height.saturating_sub(1));
        views.x_last = x_last;
        views.y_last = y_last;
        views.x_cell = coordinate(x_last);
        views.y_cell = coordinate(y_last);
        views.half = T::from_f32(0.5);
        for (level, l) in (0i32..).zip(views.levels.iter_mut()) {
            *l = T::from_i32(level) * unit;
        }
        views.slack = None;
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

    /// These views with a sampling slack of `slack` px (`RefineParams::sampling_slack`;
    /// zero or less: none).
    #[cfg(test)]
    pub(crate) fn with_slack(mut self, slack: f32) -> Self {
        self.set_slack(slack);
        self
    }

    /// [`Views::with_slack`] in place.
    pub(crate) fn set_slack(&mut self, slack: f32) {
        self.slack = (slack > 0.0).then(|| T::from_f32(slack));
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
    /// Borrowed: the tables are large, and a firmware's stack is small.
    pub views: &'a Views<T>,
    pub data: &'a [S],
}

impl<T: Scalar, S: Sample> Photometric<T> for Rectified<'_, T, S> {
    #[inline(always)]
    fn views(&self) -> &Views<T> {
        self.views
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
mod tests;
