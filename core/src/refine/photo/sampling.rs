//! Reading a view: samples as scaled intensities in `T`, bilinear cells, the centre
//! view and the oblique views' bilinear samples.

use crate::lightfield::Sample;
use crate::scalar::Scalar;

use super::taps::Tap;
use super::{Views, INTENSITY_SCALE};

/// The scaled intensity of a sample in `T`. 8-bit samples read the table of levels, so
/// fixed point does no `f32` arithmetic in the sampling loop; `f32` samples cross the
/// `f32 → T` boundary here. (For `T = f32` both equal `to_unit() · INTENSITY_SCALE` bit
/// for bit.)
#[inline(always)]
pub(super) fn texel<T: Scalar, S: Sample>(sample: S, levels: &[T; 256]) -> T {
    // Resolved at compile time for each sample type.
    match sample.as_u8() {
        Some(level) => levels[usize::from(level)],
        None => T::from_f32(sample.to_unit() * INTENSITY_SCALE),
    }
}

/// [`INTENSITY_SCALE`] per 8-bit level in `f32`: the factor of the table of levels.
const UNIT: f32 = INTENSITY_SCALE / 255.0;

/// The scaled intensities of `L` samples. 8-bit samples into `f32` take one vector
/// conversion and product (the same bits as the table, `level as f32 · UNIT`); every
/// other pair of types converts each sample with [`texel`].
#[inline(always)]
pub(super) fn convert<T: Scalar, S: Sample, const L: usize>(
    s: &[S; L],
    levels: &[T; 256],
) -> [T; L] {
    let mut out = [T::ZERO; L];
    // Resolved at compile time for each pair of types.
    if let (Some(bytes), Some(to)) = (S::as_u8_lanes(s), T::as_f32_lanes_mut(&mut out)) {
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
pub(super) fn unpack<T: Scalar>(word: u32, c: usize, levels: &[T; 256]) -> T {
    let level = (word >> (8 * (c as u32 & 3))) & 0xff;
    // Resolved at compile time for each scalar type.
    let mut out = T::ZERO;
    if let Some(to) = out.as_f32_mut() {
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
pub(super) fn split<T: Scalar>(p: T) -> (usize, T) {
    // Resolved at compile time for each scalar type.
    match p.as_f32() {
        Some(v) => {
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
pub(super) fn cell<T: Scalar>(p: T, last: usize, last_t: T) -> (usize, T) {
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
pub(super) fn lanes<T: Scalar, S: Sample, const CH: usize, const L: usize>(
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
pub(super) fn samples<S: Sample, const N: usize>(data: &[S], at: usize) -> Option<&[S; N]> {
    // Indices stay far below `usize::MAX`; a wrapped end would only fail the lookup.
    data.get(at..at.wrapping_add(N))?.try_into().ok()
}

impl<T: Scalar> Views<T> {
    /// The centre view's samples of pixel `(x, y)` and its coordinates in `T`.
    #[inline(always)]
    pub(super) fn centre<S: Sample, const CH: usize, const N: usize>(
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

    /// The samples of an oblique view: bilinear at `d + h`, `d − h` and `d`, with the
    /// central difference's factor `1 / (2h)`. `None` when a sample leaves the image.
    #[inline(always)]
    pub(super) fn oblique<S: Sample, const CH: usize, const L: usize>(
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
    pub(super) fn bilinear<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        tap: &Tap<T>,
        position: (T, T),
    ) -> Option<[T; L]> {
        self.bilinear_at::<S, CH, L>(data, tap.start, position)
    }

    /// [`Self::bilinear`] in the view whose first sample is `start`.
    #[inline(always)]
    pub(super) fn bilinear_at<S: Sample, const CH: usize, const L: usize>(
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
