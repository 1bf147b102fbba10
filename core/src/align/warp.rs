//! Resampling views into the rectified array (bilinear or Catmull–Rom bicubic), a band
//! of rows at a time so the caller decides how much memory a warp holds.

use core::ops::Range;

use crate::error::{checked_product, Error, Result};
use crate::geometry::Homography;
use crate::lightfield::{LightField, Sample};

mod sealed {
    pub trait Sealed {}
    impl Sealed for u8 {}
    impl Sealed for f32 {}
}

/// A type rectified views can be written as: `u8` (0…255, rounded) or `f32` (0…1).
pub trait WarpSample: sealed::Sealed + Copy + Default + 'static {
    /// From intensity in nominal `[0, 1]`.
    fn from_unit(v: f32) -> Self;
}

impl WarpSample for u8 {
    #[inline(always)]
    fn from_unit(v: f32) -> Self {
        // `as` saturates and maps NaN to 0.
        (v * 255.0 + 0.5) as u8
    }
}

impl WarpSample for f32 {
    #[inline(always)]
    fn from_unit(v: f32) -> Self {
        v
    }
}

/// How a warp samples between pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Interpolation {
    /// 2 × 2 taps: cheap, but it low-passes the texture by a shift-dependent amount
    /// (a half-pixel shift averages two pixels), which the EPI stage sees as noise in
    /// the slopes and the photometric refinement as a mismatch with the unwarped centre
    /// view at occlusion edges (synthetic arrays, docs/stages/align.md: the final
    /// disparity +53 % / +39 % BadPix0.07 against the rectified array, where
    /// [`Interpolation::SharpenedBilinear`] gives +29 % / +27 %). The fastest: 55 ms for
    /// the 17 cross views of a 9×9×512² array, one thread.
    Bilinear,
    /// 4 × 4 taps of the Catmull–Rom cubic: keeps the texture's contrast at every shift.
    CatmullRom,
    /// Bilinear, then a 3-tap sharpening `[a, 1 − 2a, a]` along each axis of the output
    /// grid whose `a = −t(1 − t)/2` undoes the variance `t(1 − t)` that bilinear
    /// interpolation at phase `t` adds (so a sample at an integer position is copied, as
    /// by the other kernels). With the output's neighbours one source pixel apart (the
    /// near-identity maps of alignment) this is Catmull–Rom's kernel (its outer weights
    /// are exactly `a·(1 − t)` and `a·t`), computed separably: 4 + 3 + 3 taps instead of
    /// 16. The horizontal pass runs inside [`warp_rows_with`]; the vertical one needs
    /// the rows above and below, so a caller warping rows must finish each view with
    /// [`sharpen_columns`] once all its rows are written (`pipeline::warp_views` and the
    /// CLI do). The default: 93 ms for the 17 cross views of a 9×9×512² array, one
    /// thread (Catmull–Rom 125 ms, bilinear 55 ms); the final disparity scores like
    /// Catmull–Rom's (docs/stages/align.md).
    #[default]
    SharpenedBilinear,
}

/// Writes rows `rows` of rectified view `view` (row-major grid index) into `out`:
/// `rows.len() · width · channels` samples, rows packed, channels as in the light field.
/// Rectified pixel `(x, y)` takes the view's bilinear sample at `homographies[view]`
/// applied to `(x, y)`; positions outside the view take the nearest border pixel.
pub fn warp_rows<S: Sample, O: WarpSample>(
    lf: &LightField<'_, S>,
    homographies: &[Homography],
    view: usize,
    rows: Range<usize>,
    out: &mut [O],
) -> Result<()> {
    warp_rows_with(lf, homographies, view, rows, Interpolation::Bilinear, out)
}

/// [`warp_rows`] with the given interpolation. With
/// [`Interpolation::SharpenedBilinear`] this writes the bilinear samples sharpened along
/// the rows only; [`finish_view`] completes the view once all its rows are written.
pub fn warp_rows_with<S: Sample, O: WarpSample>(
    lf: &LightField<'_, S>,
    homographies: &[Homography],
    view: usize,
    rows: Range<usize>,
    interpolation: Interpolation,
    out: &mut [O],
) -> Result<()> {
    let grid = lf.grid();
    if homographies.len() != grid.len() {
        return Err(Error::OutputSize {
            what: "the homography slice (one per view)",
            needed: grid.len(),
            got: homographies.len(),
        });
    }
    if view >= grid.len() {
        return Err(Error::OutOfRange {
            what: "view",
            index: view,
            len: grid.len(),
        });
    }
    if rows.start > rows.end || rows.end > lf.height() {
        return Err(Error::OutOfRange {
            what: "band end row",
            index: rows.end,
            len: lf.height(),
        });
    }
    let (width, channels) = (lf.width(), lf.channels());
    let row_len = width * channels;
    let needed = checked_product(&[rows.len(), row_len], "the warped band")?;
    if out.len() != needed {
        return Err(Error::OutputSize {
            what: "the warped band",
            needed,
            got: out.len(),
        });
    }
    let h = homographies.get(view).ok_or(Error::OutOfRange {
        what: "view",
        index: view,
        len: homographies.len(),
    })?;
    if row_len == 0 || channels == 0 {
        // An empty band (validated layouts have pixels and channels): nothing to write.
        return Ok(());
    }
    if !h.m.iter().all(|v| v.is_finite()) {
        return Err(Error::NonFinite {
            what: "the homography",
        });
    }
    let layout = lf.layout();
    // The view's samples; validation proved they lie inside the buffer.
    let start = view * layout.view_stride;
    let src = Source {
        data: lf.data().get(start..).unwrap_or(&[]),
        width,
        height: lf.height(),
        channels,
        row_stride: layout.row_stride,
    };
    let m = h.m;
    for (y, out_row) in rows.zip(out.chunks_exact_mut(row_len)) {
        let yf = y as f32;
        if interpolation == Interpolation::SharpenedBilinear {
            src.sharpened_row(&m, yf, out_row);
            continue;
        }
        // Homogeneous coordinates advance linearly along the row.
        let (mut nx, mut ny, mut w) = (m[1] * yf + m[2], m[4] * yf + m[5], m[7] * yf + m[8]);
        for px in out_row.chunks_exact_mut(channels.max(1)) {
            match interpolation {
                Interpolation::Bilinear => src.bilinear(nx / w, ny / w, px),
                Interpolation::CatmullRom => src.catmull_rom(nx / w, ny / w, px),
                Interpolation::SharpenedBilinear => {}
            }
            nx += m[0];
            ny += m[3];
            w += m[6];
        }
    }
    Ok(())
}

/// One view's samples with its strides.
struct Source<'a, S> {
    data: &'a [S],
    width: usize,
    height: usize,
    channels: usize,
    row_stride: usize,
}

impl<S: Sample> Source<'_, S> {
    /// Bilinear sample of every channel at `(u, v)`, clamped to the view.
    #[inline(always)]
    fn bilinear<O: WarpSample>(&self, u: f32, v: f32, px: &mut [O]) {
        let cell = self.cell(u, v);
        for (c, o) in px.iter_mut().enumerate() {
            *o = O::from_unit(self.lerp(&cell, c));
        }
    }

    /// The bilinear cell of `(u, v)` clamped to the view: its first sample's index, the
    /// index steps to the right and lower neighbours (0 on the last column / row), and
    /// the phases `(fx, fy)`.
    #[inline(always)]
    fn cell(&self, u: f32, v: f32) -> Cell {
        let (w, h, ch) = (self.width, self.height, self.channels);
        // NaN (a point at infinity) clamps to the origin: `max` returns the other operand.
        let u = u.max(0.0).min((w - 1) as f32);
        let v = v.max(0.0).min((h - 1) as f32);
        let (x0, y0) = (u as usize, v as usize);
        Cell {
            index: y0 * self.row_stride + x0 * ch,
            dx: if x0 + 1 < w { ch } else { 0 },
            dy: if y0 + 1 < h { self.row_stride } else { 0 },
            fx: u - x0 as f32,
            fy: v - y0 as f32,
        }
    }

    /// Channel `c` of the bilinear sample in `cell`.
    #[inline(always)]
    fn lerp(&self, cell: &Cell, c: usize) -> f32 {
        let Cell {
            index: i,
            dx,
            dy,
            fx,
            fy,
        } = *cell;
        let at = |k: usize| self.data.get(k).map_or(0.0, |s| s.to_unit());
        let (a, b) = (at(i + c), at(i + c + dx));
        let top = a + fx * (b - a);
        let (a, b) = (at(i + c + dy), at(i + c + dy + dx));
        let bottom = a + fx * (b - a);
        top + fy * (bottom - top)
    }
}

/// Where a bilinear sample reads (see [`Source::cell`]).
#[derive(Clone, Copy)]
struct Cell {
    index: usize,
    dx: usize,
    dy: usize,
    fx: f32,
    fy: f32,
}

/// Weight `a` of the two neighbours in the sharpening of a bilinear sample at phase `t`
/// (see [`Interpolation::SharpenedBilinear`]): `−t(1 − t)/2`, 0 at integer positions.
#[inline(always)]
fn sharpening(t: f32) -> f32 {
    -0.5 * t * (1.0 - t)
}

impl<S: Sample> Source<'_, S> {
    /// Bilinear sample of `C` channels at `(u, v)` (as [`Source::bilinear`], kept in
    /// `f32`; `C` is the view's channel count) and the phase of `u`.
    #[inline(always)]
    fn bilinear_lanes<const C: usize>(&self, u: f32, v: f32) -> ([f32; C], f32) {
        let cell = self.cell(u, v);
        let mut value = [0.0f32; C];
        for (c, o) in value.iter_mut().enumerate() {
            *o = self.lerp(&cell, c);
        }
        (value, cell.fx)
    }

    /// One output row of [`Interpolation::SharpenedBilinear`]'s horizontal pass.
    fn sharpened_row<O: WarpSample>(&self, m: &[f32; 9], yf: f32, out_row: &mut [O]) {
        match self.channels {
            1 => self.sharpened_row_of::<O, 1>(m, yf, out_row),
            3 => self.sharpened_row_of::<O, 3>(m, yf, out_row),
            _ => self.sharpened_row_of::<O, 4>(m, yf, out_row),
        }
    }

    /// [`Source::sharpened_row`] for `C` channels: the bilinear samples slide through a
    /// window of three (left, centre, right; the row's ends repeat), each output the
    /// sharpening of the centre by its own phase.
    #[inline(always)]
    fn sharpened_row_of<O: WarpSample, const C: usize>(
        &self,
        m: &[f32; 9],
        yf: f32,
        out_row: &mut [O],
    ) {
        // Homogeneous coordinates of the next sample to take, advancing along the row.
        let mut at = [m[1] * yf + m[2], m[4] * yf + m[5], m[7] * yf + m[8]];
        let (mut centre, mut phase) = self.bilinear_lanes::<C>(at[0] / at[2], at[1] / at[2]);
        let mut left = centre;
        let pixels = out_row.len() / C;
        for (x, px) in out_row.chunks_exact_mut(C).enumerate() {
            let (right, next_phase) = if x + 1 < pixels {
                at = [at[0] + m[0], at[1] + m[3], at[2] + m[6]];
                self.bilinear_lanes::<C>(at[0] / at[2], at[1] / at[2])
            } else {
                (centre, phase)
            };
            let a = sharpening(phase);
            let b = 1.0 - 2.0 * a;
            for (((o, l), c), r) in px.iter_mut().zip(left).zip(centre).zip(right) {
                *o = O::from_unit(a * l + b * c + a * r);
            }
            left = centre;
            centre = right;
            phase = next_phase;
        }
    }
}

/// Completes view `view` once [`warp_rows_with`] has written all its rows into `out`
/// with `interpolation`: the column pass of [`Interpolation::SharpenedBilinear`]
/// ([`sharpen_columns`]); the other kernels are complete after their rows, so nothing.
pub fn finish_view<O: WarpSample + Sample>(
    layout: &crate::lightfield::Layout,
    homographies: &[Homography],
    view: usize,
    interpolation: Interpolation,
    out: &mut [O],
) -> Result<()> {
    match interpolation {
        Interpolation::SharpenedBilinear => sharpen_columns(layout, homographies, view, out),
        Interpolation::Bilinear | Interpolation::CatmullRom => Ok(()),
    }
}

/// Pixels per column block of [`sharpen_columns`] (its carried row lives on the stack).
const COLUMN_BLOCK: usize = 64;

/// The vertical pass of [`Interpolation::SharpenedBilinear`], in place: `out` holds
/// every row of rectified view `view` (`height` rows `row_stride` samples apart, as
/// written by [`warp_rows_with`] with that interpolation), each sample is replaced by
/// `a·above + (1 − 2a)·itself + a·below` with `a` from the phase of the view's vertical
/// coordinate at that pixel (the top and bottom rows repeat). Blocks of columns walk
/// down the view carrying the previous row's original samples, so it needs no scratch.
pub fn sharpen_columns<O: WarpSample + Sample>(
    layout: &crate::lightfield::Layout,
    homographies: &[Homography],
    view: usize,
    out: &mut [O],
) -> Result<()> {
    let (width, height, ch, stride) = (
        layout.width,
        layout.height,
        layout.channels,
        layout.row_stride,
    );
    let h = homographies.get(view).ok_or(Error::OutOfRange {
        what: "view",
        index: view,
        len: homographies.len(),
    })?;
    if width == 0 || height == 0 || ch == 0 {
        return Ok(());
    }
    let row_len = checked_product(&[width, ch], "the warped view")?;
    let needed = checked_product(&[height - 1, stride], "the warped view")?
        .checked_add(row_len)
        .ok_or(Error::SizeOverflow {
            what: "the warped view",
        })?;
    if out.len() < needed || ch > 4 || stride < row_len {
        return Err(Error::OutputSize {
            what: "the warped view",
            needed,
            got: out.len(),
        });
    }
    if !h.m.iter().all(|v| v.is_finite()) {
        return Err(Error::NonFinite {
            what: "the homography",
        });
    }
    let m = h.m;
    let last = (height - 1) as f32;
    let mut first_pixel = 0;
    let mut weight = [0.0f32; COLUMN_BLOCK];
    while first_pixel < width {
        let pixels = COLUMN_BLOCK.min(width - first_pixel);
        let (start, span) = (first_pixel * ch, pixels * ch);
        // The original samples of the row above (the top row repeats itself).
        let mut above = [0.0f32; COLUMN_BLOCK * 4];
        for (a, s) in above
            .iter_mut()
            .zip(out.get(start..start + span).unwrap_or(&[]))
        {
            *a = s.to_unit();
        }
        let x0 = first_pixel as f32;
        for y in 0..height {
            let yf = y as f32;
            // The view's vertical coordinate along the block: numerator and
            // denominator advance linearly with x.
            let (mut num, mut den) = (m[3] * x0 + m[4] * yf + m[5], m[6] * x0 + m[7] * yf + m[8]);
            for w in weight.iter_mut().take(pixels) {
                let v = (num / den).max(0.0).min(last);
                *w = sharpening(v - (v as usize) as f32);
                num += m[3];
                den += m[6];
            }
            let row = y * stride + start;
            // The row and the one below it (the bottom row is its own below).
            let (head, tail) = out.split_at_mut((row + stride).min(out.len()));
            let Some(current) = head.get_mut(row..row + span) else {
                break;
            };
            let below = if y + 1 < height {
                tail.get(..span)
            } else {
                None
            };
            let weight = &weight[..pixels];
            match ch {
                1 => sharpen_block::<O, 1>(current, below, &mut above, weight),
                3 => sharpen_block::<O, 3>(current, below, &mut above, weight),
                _ => sharpen_block::<O, 4>(current, below, &mut above, weight),
            }
        }
        first_pixel += pixels;
    }
    Ok(())
}

/// One row of a column block of [`sharpen_columns`] with `C` channels: `current`
/// sharpened in place from `above` (the row above's original samples, replaced by
/// `current`'s) and `below` (`None` on the bottom row: the row is its own below), one
/// neighbour weight per pixel.
#[inline(always)]
fn sharpen_block<O: WarpSample + Sample, const C: usize>(
    current: &mut [O],
    below: Option<&[O]>,
    above: &mut [f32],
    weight: &[f32],
) {
    let rows = current.chunks_exact_mut(C).zip(above.chunks_exact_mut(C));
    match below {
        Some(below) => {
            for (((cur, up), down), &a) in rows.zip(below.chunks_exact(C)).zip(weight) {
                let b = 1.0 - 2.0 * a;
                for ((slot, up), down) in cur.iter_mut().zip(up.iter_mut()).zip(down) {
                    let centre = slot.to_unit();
                    *slot = O::from_unit(a * *up + b * centre + a * down.to_unit());
                    *up = centre;
                }
            }
        }
        None => {
            for ((cur, up), &a) in rows.zip(weight) {
                let b = 1.0 - 2.0 * a;
                for (slot, up) in cur.iter_mut().zip(up.iter_mut()) {
                    let centre = slot.to_unit();
                    *slot = O::from_unit(a * *up + b * centre + a * centre);
                    *up = centre;
                }
            }
        }
    }
}

/// The 4 × 4 Catmull–Rom taps of `C` channels (rows of 4 pixels, `N` = 4·`C` samples):
/// the four rows are first combined sample by sample into one run of `N` (a lane loop
/// the compiler vectorises; 12 % less warp time than combining each row's pixels
/// first), then the run's 4 pixels by the horizontal weights.
#[inline(always)]
fn taps<S: Sample, O: WarpSample, const C: usize, const N: usize>(
    rows: [&[S]; 4],
    wx: [f32; 4],
    wy: [f32; 4],
    px: &mut [O],
) {
    let mut column = [0.0f32; N];
    for (row, wyk) in rows.into_iter().zip(wy) {
        for (acc, s) in column.iter_mut().zip(row) {
            *acc += wyk * s.to_unit();
        }
    }
    let mut out = [0.0f32; C];
    for (pixel, wxk) in column.chunks_exact(C).zip(wx) {
        for (o, s) in out.iter_mut().zip(pixel) {
            *o += wxk * s;
        }
    }
    for (o, a) in px.iter_mut().zip(out) {
        *o = O::from_unit(a);
    }
}

/// Catmull–Rom weights of the taps at −1, 0, 1, 2 for a fraction `t` in [0, 1).
#[inline(always)]
fn catmull_rom_weights(t: f32) -> [f32; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}

impl<S: Sample> Source<'_, S> {
    /// Catmull–Rom sample of every channel at `(u, v)`, clamped to the view; taps past
    /// the border repeat the border pixel.
    #[inline(always)]
    fn catmull_rom<O: WarpSample>(&self, u: f32, v: f32, px: &mut [O]) {
        let (w, h, ch) = (self.width, self.height, self.channels);
        let u = u.max(0.0).min((w - 1) as f32);
        let v = v.max(0.0).min((h - 1) as f32);
        let (x0, y0) = (u as usize, v as usize);
        let (wx, wy) = (
            catmull_rom_weights(u - x0 as f32),
            catmull_rom_weights(v - y0 as f32),
        );
        if x0 >= 1 && x0 + 2 < w && y0 >= 1 && y0 + 2 < h {
            // Inside: the 4 × 4 taps are four runs of 4 pixels, one slice per row.
            let base = (y0 - 1) * self.row_stride + (x0 - 1) * ch;
            let run = |k: usize| self.data.get(base + k * self.row_stride..)?.get(..4 * ch);
            if let (Some(r0), Some(r1), Some(r2), Some(r3)) = (run(0), run(1), run(2), run(3)) {
                let rows = [r0, r1, r2, r3];
                match ch {
                    1 => taps::<S, O, 1, 4>(rows, wx, wy, px),
                    3 => taps::<S, O, 3, 12>(rows, wx, wy, px),
                    _ => taps::<S, O, 4, 16>(rows, wx, wy, px),
                }
                return;
            }
        }
        let clamp = |i: usize, n: usize| i.min(n - 1);
        let xs = [
            x0.saturating_sub(1) * ch,
            x0 * ch,
            clamp(x0 + 1, w) * ch,
            clamp(x0 + 2, w) * ch,
        ];
        let ys = [
            y0.saturating_sub(1) * self.row_stride,
            y0 * self.row_stride,
            clamp(y0 + 1, h) * self.row_stride,
            clamp(y0 + 2, h) * self.row_stride,
        ];
        for (c, o) in px.iter_mut().enumerate() {
            let mut sum = 0.0;
            for (row, wyk) in ys.iter().zip(wy) {
                let mut line = 0.0;
                for (col, wxk) in xs.iter().zip(wx) {
                    let s = self.data.get(row + col + c).map_or(0.0, |s| s.to_unit());
                    line += wxk * s;
                }
                sum += wyk * line;
            }
            *o = O::from_unit(sum);
        }
    }
}

/// Writes rows `rows` of every rectified view into `out`, view after view (row-major
/// grid order): `views · rows.len() · width · channels` samples.
pub fn warp_band<S: Sample, O: WarpSample>(
    lf: &LightField<'_, S>,
    homographies: &[Homography],
    rows: Range<usize>,
    out: &mut [O],
) -> Result<()> {
    let views = lf.grid().len();
    let band = checked_product(&[rows.len(), lf.width(), lf.channels()], "the warped band")?;
    let needed = checked_product(&[views, band], "the warped band")?;
    if out.len() != needed || band == 0 {
        if out.len() == needed {
            return Ok(());
        }
        return Err(Error::OutputSize {
            what: "the warped band of all views",
            needed,
            got: out.len(),
        });
    }
    for (v, chunk) in out.chunks_exact_mut(band).enumerate() {
        warp_rows(lf, homographies, v, rows.clone(), chunk)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::{Grid, Layout};

    fn field() -> (std::vec::Vec<u8>, Layout) {
        let layout = Layout::packed(Grid::new(3, 3), 20, 18, 3);
        let data = (0..layout.validate().unwrap())
            .map(|i| ((i * 7) % 251) as u8)
            .collect();
        (data, layout)
    }

    #[test]
    fn identity_copies_and_shift_moves() {
        let (data, layout) = field();
        let lf = LightField::new(&data[..], layout).unwrap();
        let mut hs = [Homography::IDENTITY; 9];
        let mut out = std::vec![0u8; 9 * 5 * 20 * 3];
        warp_band(&lf, &hs, 4..9, &mut out).unwrap();
        for v in 0..9 {
            for y in 4..9 {
                for x in 0..20 {
                    for c in 0..3 {
                        let got = out[((v * 5 + y - 4) * 20 + x) * 3 + c];
                        assert_eq!(Some(got), lf.pixel(v / 3, v % 3, x, y, c));
                    }
                }
            }
        }
        // Rectified (x, y) reads view (x + 2, y + 1).
        hs[4].m[2] = 2.0;
        hs[4].m[5] = 1.0;
        let mut row = std::vec![0.0f32; 20 * 3];
        warp_rows(&lf, &hs, 4, 3..4, &mut row).unwrap();
        let expect = lf.pixel(1, 1, 7, 4, 1).unwrap() as f32 / 255.0;
        assert!((row[5 * 3 + 1] - expect).abs() < 1e-6);
        // Past the right border the last column repeats.
        let edge = lf.pixel(1, 1, 19, 4, 0).unwrap() as f32 / 255.0;
        assert!((row[19 * 3] - edge).abs() < 1e-6);
    }

    #[test]
    fn catmull_rom_copies_at_integer_shifts_and_keeps_ramps_linear() {
        let (data, layout) = field();
        let lf = LightField::new(&data[..], layout).unwrap();
        let mut hs = [Homography::IDENTITY; 9];
        let mut out = std::vec![0u8; 18 * 20 * 3];
        warp_rows_with(&lf, &hs, 4, 0..18, Interpolation::CatmullRom, &mut out).unwrap();
        assert_eq!(out[..], data[4 * 18 * 20 * 3..5 * 18 * 20 * 3]);
        // A horizontal ramp, shifted by a fraction: cubic interpolation of a line is the
        // line wherever all four taps lie inside the view.
        let layout = Layout::packed(Grid::new(3, 3), 24, 20, 1);
        let ramp: std::vec::Vec<f32> = (0..layout.validate().unwrap())
            .map(|i| (i % 24) as f32 / 24.0)
            .collect();
        let lf = LightField::new(&ramp[..], layout).unwrap();
        hs[4].m[2] = 0.3;
        hs[4].m[5] = 0.6;
        let mut row = std::vec![0.0f32; 24];
        warp_rows_with(&lf, &hs, 4, 7..8, Interpolation::CatmullRom, &mut row).unwrap();
        for (x, v) in row.iter().enumerate().take(22).skip(1) {
            assert!((v - (x as f32 + 0.3) / 24.0).abs() < 1e-5, "{x}: {v}");
        }
    }

    /// Warps view 4 of `lf` completely with [`Interpolation::SharpenedBilinear`].
    fn sharpened(lf: &LightField<'_, f32>, hs: &[Homography]) -> std::vec::Vec<f32> {
        let l = lf.layout();
        let mut out = std::vec![0.0f32; l.width * l.height * l.channels];
        let how = Interpolation::SharpenedBilinear;
        warp_rows_with(lf, hs, 4, 0..l.height, how, &mut out).unwrap();
        sharpen_columns(l, hs, 4, &mut out).unwrap();
        out
    }

    #[test]
    fn sharpened_bilinear_copies_at_integer_shifts_and_is_catmull_rom_for_translations() {
        let layout = Layout::packed(Grid::new(3, 3), 24, 20, 3);
        let data: std::vec::Vec<f32> = (0..layout.validate().unwrap())
            .map(|i| ((i * 37) % 101) as f32 / 100.0)
            .collect();
        let lf = LightField::new(&data[..], layout).unwrap();
        let view = 24 * 20 * 3;
        let mut hs = [Homography::IDENTITY; 9];
        assert_eq!(sharpened(&lf, &hs)[..], data[4 * view..5 * view]);
        hs[4].m[2] = 2.0;
        hs[4].m[5] = -1.0;
        let mut bilinear = std::vec![0.0f32; view];
        warp_rows(&lf, &hs, 4, 0..20, &mut bilinear).unwrap();
        assert_eq!(sharpened(&lf, &hs), bilinear);
        // A fractional translation: the output's neighbours are one source pixel apart,
        // so the sharpened bilinear sample is the separable Catmull–Rom sample wherever
        // the taps lie inside the view.
        hs[4].m[2] = 0.3;
        hs[4].m[5] = 0.6;
        let got = sharpened(&lf, &hs);
        let mut cubic = std::vec![0.0f32; view];
        warp_rows_with(&lf, &hs, 4, 0..20, Interpolation::CatmullRom, &mut cubic).unwrap();
        for y in 2..18 {
            for x in 2..22 {
                for c in 0..3 {
                    let i = (y * 24 + x) * 3 + c;
                    assert!(
                        (got[i] - cubic[i]).abs() < 1e-5,
                        "{x} {y}: {} {}",
                        got[i],
                        cubic[i]
                    );
                }
            }
        }
        // And it is sharper than bilinear: further from it than Catmull–Rom is not.
        warp_rows(&lf, &hs, 4, 0..20, &mut bilinear).unwrap();
        assert!(got.iter().zip(&bilinear).any(|(a, b)| (a - b).abs() > 0.01));
    }

    #[test]
    fn sharpen_columns_rejects_what_does_not_fit() {
        let layout = Layout::packed(Grid::new(3, 3), 20, 18, 3);
        let hs = [Homography::IDENTITY; 9];
        let mut out = std::vec![0.5f32; 20 * 18 * 3];
        assert!(sharpen_columns(&layout, &hs, 9, &mut out).is_err());
        assert!(sharpen_columns(&layout, &hs, 0, &mut out[1..]).is_err());
        let mut nan = hs;
        nan[0].m[4] = f32::NAN;
        assert!(sharpen_columns(&layout, &nan, 0, &mut out).is_err());
        // u8 views too: a constant view stays constant.
        let mut levels = std::vec![77u8; 20 * 18 * 3];
        let mut shifted = hs;
        shifted[0].m[5] = 0.5;
        sharpen_columns(&layout, &shifted, 0, &mut levels).unwrap();
        assert!(levels.iter().all(|&v| v == 77));
    }

    #[test]
    fn bad_requests_are_errors() {
        let (data, layout) = field();
        let lf = LightField::new(&data[..], layout).unwrap();
        let hs = [Homography::IDENTITY; 9];
        let mut out = std::vec![0u8; 20 * 3];
        assert!(warp_rows(&lf, &hs, 9, 0..1, &mut out).is_err());
        assert!(warp_rows(&lf, &hs, 0, 17..19, &mut out).is_err());
        assert!(warp_rows(&lf, &hs, 0, 0..2, &mut out).is_err());
        assert!(warp_rows(&lf, &hs[..8], 0, 0..1, &mut out).is_err());
        let mut nan = hs;
        nan[0].m[0] = f32::NAN;
        assert!(warp_rows(&lf, &nan, 0, 0..1, &mut out).is_err());
        // A homography sending everything to infinity still writes defined values.
        let mut degenerate = hs;
        degenerate[0].m = [0.0; 9];
        warp_rows(&lf, &degenerate, 0, 0..1, &mut out).unwrap();
    }
}
