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
    /// the slopes. The default: Catmull–Rom costs 2.6× the warp time (53 → 140 ms for
    /// the 17 cross views of a 9×9×512² array, one thread). Measured gain of
    /// Catmull–Rom (docs/bench-align.md): 0.5–4 % relative BadPix0.07 in the EPI stage,
    /// but on the final disparity the photometric refinement loses about half as much
    /// to the warp (synthetic arrays, true homographies: +20…23 % instead of
    /// +42…51 % against the rectified array).
    #[default]
    Bilinear,
    /// 4 × 4 taps of the Catmull–Rom cubic: keeps the texture's contrast at every shift.
    CatmullRom,
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

/// [`warp_rows`] with the given interpolation.
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
        // Homogeneous coordinates advance linearly along the row.
        let (mut nx, mut ny, mut w) = (m[1] * yf + m[2], m[4] * yf + m[5], m[7] * yf + m[8]);
        for px in out_row.chunks_exact_mut(channels.max(1)) {
            match interpolation {
                Interpolation::Bilinear => src.bilinear(nx / w, ny / w, px),
                Interpolation::CatmullRom => src.catmull_rom(nx / w, ny / w, px),
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
        let (w, h, ch) = (self.width, self.height, self.channels);
        // NaN (a point at infinity) clamps to the origin: `max` returns the other operand.
        let u = u.max(0.0).min((w - 1) as f32);
        let v = v.max(0.0).min((h - 1) as f32);
        let (x0, y0) = (u as usize, v as usize);
        let (fx, fy) = (u - x0 as f32, v - y0 as f32);
        let dx = if x0 + 1 < w { ch } else { 0 };
        let dy = if y0 + 1 < h { self.row_stride } else { 0 };
        let i = y0 * self.row_stride + x0 * ch;
        for (c, o) in px.iter_mut().enumerate() {
            let at = |k: usize| self.data.get(k).map_or(0.0, |s| s.to_unit());
            let (a, b) = (at(i + c), at(i + c + dx));
            let top = a + fx * (b - a);
            let (a, b) = (at(i + c + dy), at(i + c + dy + dx));
            let bottom = a + fx * (b - a);
            *o = O::from_unit(top + fy * (bottom - top));
        }
    }
}

/// The 4 × 4 Catmull–Rom taps of `C` channels (rows of 4 pixels): a constant channel
/// count lets the compiler unroll and drop the bounds checks.
#[inline(always)]
fn taps<S: Sample, O: WarpSample, const C: usize>(
    rows: [&[S]; 4],
    wx: [f32; 4],
    wy: [f32; 4],
    px: &mut [O],
) {
    let mut acc = [0.0f32; C];
    for (row, wyk) in rows.into_iter().zip(wy) {
        let mut line = [0.0f32; C];
        for (pixel, wxk) in row.chunks_exact(C).zip(wx) {
            for c in 0..C {
                line[c] += wxk * pixel[c].to_unit();
            }
        }
        for c in 0..C {
            acc[c] += wyk * line[c];
        }
    }
    for (o, a) in px.iter_mut().zip(acc) {
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
                    1 => taps::<S, O, 1>(rows, wx, wy, px),
                    3 => taps::<S, O, 3>(rows, wx, wy, px),
                    _ => taps::<S, O, 4>(rows, wx, wy, px),
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
