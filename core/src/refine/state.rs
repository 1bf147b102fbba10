//! The state of one band: the region of rows it computes on and the planes of the
//! scratch it works in, with the meaning of each plane's values.

use core::ops::Range;

use crate::scalar::Scalar;

/// The rows a band computes on: its own rows and a halo of rows on each side, clipped
/// at the image (see [`super::halo`]).
pub(super) struct Region {
    /// Pixels per row.
    pub(super) width: usize,
    /// The band's own image rows.
    pub(super) rows: Range<usize>,
    /// The region's first image row.
    pub(super) first: usize,
    /// One past the region's last image row.
    pub(super) last: usize,
}

impl Region {
    /// Rows of the region.
    pub(super) fn len(&self) -> usize {
        self.last - self.first
    }

    /// Region rows (relative to `first`) within `reach` rows of the band.
    pub(super) fn near(&self, reach: usize) -> Range<usize> {
        let lo = self.rows.start.saturating_sub(reach).max(self.first) - self.first;
        let hi = (self.rows.end + reach).min(self.last) - self.first;
        lo..hi
    }
}

/// A band's planes in the scratch, row-major over its [`Region`] (relative to its first
/// row).
pub(super) struct Planes<'a, T> {
    /// Each pixel's disparity now.
    pub(super) current: &'a mut [T],
    /// Each pixel's disparity before the current round or iteration.
    pub(super) previous: &'a mut [T],
    /// [`super::STATS`] Gauss–Newton statistics per pixel (`A`, `B`, `E` per group),
    /// measured at its disparity in `previous`.
    pub(super) stats: &'a mut [T],
    /// [`super::MEMORY`] values per pixel. During the propagation, pixel `i`'s
    /// [`OwnCost`] at `i · MEMORY` and the last candidates it rejected after it (`MAX`
    /// for none). From the iterations on (with `RefineParams::skip_settled`), three
    /// planes of one value per pixel instead: how far each pixel moved in the iteration
    /// before, and each pixel's last `E` and `A` + damping.
    pub(super) memory: &'a mut [T],
}

/// What the propagation knows of a pixel's cost at its current disparity, kept in the
/// first of its [`Planes::memory`] values: a cost is non-negative, the two states are
/// encoded as the negative values `−1` and `−2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum OwnCost<T> {
    /// Not measured.
    Unknown,
    /// Its statistics were measured there: the cost is their residual energy, and the
    /// first iteration need not measure them again.
    Fresh,
    /// The cost itself (a candidate's, accepted).
    Known(T),
}

impl<T: Scalar> OwnCost<T> {
    /// The state a stored value encodes.
    #[inline(always)]
    pub(super) fn read(value: T) -> Self {
        if value == -T::ONE {
            OwnCost::Unknown
        } else if value == -(T::ONE + T::ONE) {
            OwnCost::Fresh
        } else {
            OwnCost::Known(value)
        }
    }

    /// The value that stores the state.
    #[inline(always)]
    pub(super) fn value(self) -> T {
        match self {
            OwnCost::Unknown => -T::ONE,
            OwnCost::Fresh => -(T::ONE + T::ONE),
            OwnCost::Known(cost) => cost,
        }
    }
}
