//! Gray image pyramids (2×2 box reduction) stored in caller scratch.

use crate::error::{checked_product, Error, Result};
use crate::lightfield::{Sample, View};

/// Most pyramid levels (level 0 = full resolution); 1/8 resolution lets the tracker
/// follow displacements of a few tens of pixels.
pub const MAX_LEVELS: usize = 4;
/// Levels are added while the smaller side stays at least this long.
const MIN_SIDE: usize = 24;

/// Sizes and offsets of the levels of one pyramid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pyramid {
    pub levels: usize,
    pub width: [usize; MAX_LEVELS],
    pub height: [usize; MAX_LEVELS],
    pub offset: [usize; MAX_LEVELS],
    pub len: usize,
}

impl Pyramid {
    /// The level layout for a `width` × `height` view.
    pub fn new(width: usize, height: usize) -> Result<Self> {
        let mut p = Pyramid {
            levels: 0,
            width: [0; MAX_LEVELS],
            height: [0; MAX_LEVELS],
            offset: [0; MAX_LEVELS],
            len: 0,
        };
        let (mut w, mut h) = (width, height);
        while p.levels < MAX_LEVELS && (p.levels == 0 || w.min(h) >= MIN_SIDE) {
            let l = p.levels;
            p.width[l] = w;
            p.height[l] = h;
            p.offset[l] = p.len;
            p.len = p
                .len
                .checked_add(checked_product(&[w, h], "an image pyramid")?)
                .ok_or(Error::SizeOverflow {
                    what: "an image pyramid",
                })?;
            p.levels += 1;
            w /= 2;
            h /= 2;
        }
        Ok(p)
    }

    /// Elements one pyramid of a `width` × `height` view occupies.
    pub fn len_for(width: usize, height: usize) -> Result<usize> {
        Ok(Pyramid::new(width, height)?.len)
    }

    /// Level `l` of a pyramid stored in `data`.
    pub fn level<'d>(&self, data: &'d [f32], l: usize) -> Image<'d> {
        let (Some(&start), Some(&width), Some(&height)) =
            (self.offset.get(l), self.width.get(l), self.height.get(l))
        else {
            return Image {
                data: &[],
                width: 0,
                height: 0,
            };
        };
        Image {
            data: data.get(start..start + width * height).unwrap_or(&[]),
            width,
            height,
        }
    }

    /// Fills `data` (at least `self.len` long) with the gray pyramid of `view`.
    pub fn build<S: Sample>(&self, view: &View<'_, S>, data: &mut [f32]) {
        self.build_base(view, data);
        self.reduce(data);
    }

    /// Fills only level 0 (full resolution, gray) of `data` from `view`.
    pub fn build_base<S: Sample>(&self, view: &View<'_, S>, data: &mut [f32]) {
        let (w, h) = (self.width[0], self.height[0]);
        let channels = view.channels().min(3);
        let scale = 1.0 / channels as f32;
        for y in 0..h {
            let Some(row) = view.row(y) else { continue };
            // `data` holds the whole pyramid and `row` the whole view row: no skips.
            let Some(out) = data.get_mut(y * w..(y + 1) * w) else {
                continue;
            };
            // Pixel by pixel through `chunks_exact` (no index checks): the same sums,
            // in the same order, as indexing each pixel's channels.
            for (o, px) in out.iter_mut().zip(row.chunks_exact(view.channels().max(1))) {
                let sum: f32 = px.iter().take(channels).map(|s| s.to_unit()).sum();
                // Non-finite input samples become black rather than poisoning the fit.
                *o = if sum.is_finite() { sum * scale } else { 0.0 };
            }
        }
    }

    /// Fills levels 1… from level 0.
    pub fn reduce(&self, data: &mut [f32]) {
        for l in 1..self.levels.min(MAX_LEVELS) {
            let (pw, nw, nh) = (self.width[l - 1], self.width[l], self.height[l]);
            // `data` holds the whole pyramid (`self.len`): the returns never happen.
            let Some((src, dst)) = data.split_at_mut_checked(self.offset[l]) else {
                return;
            };
            let Some(src) = src.get(self.offset[l - 1]..) else {
                return;
            };
            for y in 0..nh {
                let (Some(r0), Some(r1), Some(out)) = (
                    src.get(2 * y * pw..),
                    src.get((2 * y + 1) * pw..),
                    dst.get_mut(y * nw..(y + 1) * nw),
                ) else {
                    return;
                };
                let (mut r0, mut r1) = (r0.iter(), r1.iter());
                for o in out.iter_mut() {
                    let (Some(a0), Some(a1), Some(b0), Some(b1)) =
                        (r0.next(), r0.next(), r1.next(), r1.next())
                    else {
                        break;
                    };
                    *o = 0.25 * (a0 + a1 + b0 + b1);
                }
            }
        }
    }
}

/// One gray image borrowed from a pyramid.
#[derive(Clone, Copy, Debug)]
pub struct Image<'d> {
    pub data: &'d [f32],
    pub width: usize,
    pub height: usize,
}

impl Image<'_> {
    /// Pixel value, `x` and `y` in range.
    #[inline(always)]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.data.get(y * self.width + x).copied().unwrap_or(0.0)
    }

    /// Bilinear sample at `(x, y)` (pixel centres at integers); `None` outside
    /// `[0, w − 1] × [0, h − 1]`.
    #[inline(always)]
    pub fn sample(&self, x: f32, y: f32) -> Option<f32> {
        if !(x >= 0.0 && y >= 0.0) {
            return None;
        }
        let (x0, y0) = (x as usize, y as usize);
        if x0 + 1 >= self.width || y0 + 1 >= self.height {
            if x0 + 1 == self.width && x == x0 as f32 && y0 < self.height {
                return Some(self.at(x0, y0.min(self.height - 1)));
            }
            return None;
        }
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let i = y0 * self.width + x0;
        let &[t0, t1, ..] = self.data.get(i..)? else {
            return None;
        };
        let &[b0, b1, ..] = self.data.get(i + self.width..)? else {
            return None;
        };
        let top = t0 + fx * (t1 - t0);
        let bottom = b0 + fx * (b1 - b0);
        Some(top + fy * (bottom - top))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::{Grid, Layout, LightField};

    #[test]
    fn levels_halve_until_small() {
        let p = Pyramid::new(512, 512).unwrap();
        assert_eq!(p.levels, 4);
        assert_eq!(p.width, [512, 256, 128, 64]);
        assert_eq!(p.len, 512 * 512 + 256 * 256 + 128 * 128 + 64 * 64);
        let p = Pyramid::new(40, 30).unwrap();
        assert_eq!(p.levels, 1);
    }

    #[test]
    fn build_averages_channels_and_blocks() {
        let layout = Layout::packed(Grid::new(3, 3), 48, 48, 3);
        let mut data = [0u8; 9 * 48 * 48 * 3];
        for (i, v) in data.iter_mut().enumerate() {
            *v = ((i / 3) % 48 * 5) as u8;
        }
        let lf = LightField::new(&data[..], layout).unwrap();
        let p = Pyramid::new(48, 48).unwrap();
        assert_eq!(p.levels, 2);
        let mut buf = [0.0f32; 48 * 48 + 24 * 24];
        p.build(&lf.view(0, 0).unwrap(), &mut buf);
        let l0 = p.level(&buf, 0);
        let l1 = p.level(&buf, 1);
        assert!((l0.at(3, 7) - 15.0 / 255.0).abs() < 1e-6);
        assert!((l1.at(2, 5) - 22.5 / 255.0).abs() < 1e-6);
        let s = l0.sample(3.5, 2.25).unwrap();
        assert!((s - 17.5 / 255.0).abs() < 1e-6);
        assert!(l0.sample(47.5, 3.0).is_none());
        assert!(l0.sample(-0.1, 3.0).is_none());
    }
}
