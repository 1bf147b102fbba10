//! Gathering the samples of axis taps into structure-of-arrays chunks: tap by tap, or
//! all [`CHUNK`] taps of a regular set at once.

use crate::lightfield::Sample;
use crate::scalar::Scalar;

use super::sampling::{convert, split, unpack};
use super::statistics::{energies, statistics, Interval, LaneSlack, Lanes, PixelProbe};
use super::taps::AxisTap;
use super::{Views, CHUNK, GROUPS, STATS};

/// `1.5 · 2^23`: added to an `f32` of magnitude below `2^22`, it leaves the value
/// rounded to an integer in the low bits of the sum.
const MAGIC: f32 = 12_582_912.0;

/// How [`Views::fill_regular`] gathered the regular axis taps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Gathered {
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
pub(super) struct Chunk<T, S, const N: usize> {
    pub(super) raw: [[[S; CHUNK]; N]; 3],
    /// Fraction of the position within its cell.
    pub(super) fraction: [T; CHUNK],
    /// The tap's offset along its axis: the derivative's factor.
    pub(super) offset: [T; CHUNK],
    /// Each tap's group (below [`GROUPS`]).
    pub(super) group: [u8; CHUNK],
}

impl<T: Scalar, S: Sample, const N: usize> Chunk<T, S, N> {
    pub(super) fn new() -> Self {
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
    /// at `probe.d` to their groups in `out`: [`statistics`] of the chunk's scaled
    /// texels.
    #[inline(always)]
    pub(super) fn statistics(
        &self,
        n: usize,
        levels: &[T; 256],
        probe: &PixelProbe<'_, T, N>,
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
        statistics(&lanes, n, probe, regular, slack, out);
    }

    /// The weighted energies `scaled / (robust + e) · e` of the taps (gathered with
    /// `J` = 2), `e = Σ r²` at `p`; lanes past those gathered hold any value.
    #[inline(always)]
    pub(super) fn energies(
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
    pub(super) fn slack<const L: usize>(&self, slack: &Interval<T, L>) -> LaneSlack<T, N> {
        LaneSlack::new(slack, |v| self.group.get(v).is_some_and(|&g| g < 2))
    }
}

impl<T: Scalar> Views<T> {
    /// The statistics of the [`CHUNK`] regular axis taps when every one sees pixel
    /// `(x, y)` and none needs the border's clamped samples (`cells`, `fractions` from
    /// [`Self::regular_cells`] with `J` = 3), written to the groups' slots of `out`
    /// (zeroed), for 8-bit samples: [`statistics`] of the same scaled texels as the
    /// chunk `fill_regular` gathers (the same bits), but each texel's channels moved as
    /// one 32-bit word, then split into channels for all taps side by side (the byte
    /// by byte gather was a third of a call). `false` (and `out` unchanged) for other
    /// sample types and when a texel's four bytes reach past the end of the data.
    #[inline(always)]
    pub(super) fn regular_statistics<S: Sample, const CH: usize, const N: usize>(
        &self,
        data: &[S],
        (x, y): (usize, usize),
        (cells, fractions): (&[i32; CHUNK], &[T; CHUNK]),
        probe: &PixelProbe<'_, T, N>,
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
        statistics(&lanes, CHUNK, probe, regular, slack, out);
        true
    }

    /// The texels `k`, …, `k + J − 1` (`k` the tap's cell) of the [`CHUNK`] regular
    /// axis taps for pixel `(x, y)` into `words`, each as one 32-bit word of its first
    /// four 8-bit samples (the channels, little-endian; see [`unpack`]). `None` for
    /// other sample types and when a word reaches past the end of the data. (An output
    /// argument: a returned array was copied by `memcpy`.)
    #[inline(always)]
    pub(super) fn regular_words<S: Sample, const CH: usize, const J: usize>(
        &self,
        data: &[S],
        (x, y): (usize, usize),
        cells: &[i32; CHUNK],
        words: &mut [[u32; CHUNK]; J],
    ) -> Option<()> {
        // Resolved at compile time for each sample type. A pixel's used channels (at
        // most three) fit a word; a row tap's `J` ≤ 3 texels lie within twelve bytes.
        if S::as_u8(S::default()).is_none() || CH > 4 || J > 3 {
            return None;
        }
        let word = |bytes: Option<&[S; 4]>| {
            let bytes = bytes.and_then(S::as_u8_lanes)?;
            Some(u32::from_le_bytes(*bytes))
        };
        let (row, column, rs) = (y * self.row_stride, x * CH, self.row_stride);
        // A column tap's span: from its first word to the end of its last.
        let span = rs.checked_mul(J.saturating_sub(1))?.checked_add(4)?;
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
                let run = data.get(first..first.checked_add(span)?)?;
                for (j, words) in words.iter_mut().enumerate() {
                    words[v] = word(run.get(j * rs..).and_then(|s| s.first_chunk::<4>()))?;
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
    pub(super) fn fill<S: Sample, const CH: usize, const N: usize, const J: usize>(
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
    pub(super) fn fill_regular<S: Sample, const CH: usize, const N: usize, const J: usize>(
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
    pub(super) fn regular_cells<const J: usize>(
        &self,
        (xf, yf): (T, T),
        d: T,
        cells: &mut [i32; CHUNK],
        fractions: &mut [T; CHUNK],
    ) -> bool {
        let half = self.half;
        // Resolved at compile time for each scalar type.
        let f32s = (
            xf.as_f32(),
            yf.as_f32(),
            d.as_f32(),
            T::as_f32_lanes(&self.regular_x),
            T::as_f32_lanes(&self.regular_y),
            T::as_f32_lanes(&self.regular_offset),
            T::as_f32_lanes(&self.regular_max),
            T::as_f32_lanes_mut(fractions),
        );
        if let (Some(xf), Some(yf), Some(d), Some(rx), Some(ry), Some(off), Some(max), Some(f)) =
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
}
