//! Corner detection in the centre view: the smaller eigenvalue of the structure tensor
//! (Shi–Tomasi, the trackability measure of Lucas–Kanade), best corner per grid cell so
//! that corners cover the whole image — a homography is best conditioned by spread-out
//! points.

use super::pyramid::Image;
use super::MAX_FEATURES;

/// A corner in full-resolution pixel coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corner {
    pub x: f32,
    pub y: f32,
    pub strength: f32,
}

/// Smallest structure-tensor eigenvalue accepted (5×5 window, intensities in [0, 1]):
/// gradients of about half an 8-bit level per pixel in every direction. Weaker corners
/// are noise; a view without stronger ones is textureless.
const MIN_STRENGTH: f32 = 25.0 * 4.0e-6;
/// Half-size of the structure-tensor window.
const WINDOW: usize = 2;

/// Smaller eigenvalue of the 5×5 structure tensor at `(x, y)`; `x, y` at least 3 pixels
/// inside the image.
fn min_eigenvalue(img: &Image<'_>, x: usize, y: usize) -> f32 {
    let (mut sxx, mut sxy, mut syy) = (0.0f32, 0.0f32, 0.0f32);
    for v in y - WINDOW..=y + WINDOW {
        for u in x - WINDOW..=x + WINDOW {
            let gx = 0.5 * (img.at(u + 1, v) - img.at(u - 1, v));
            let gy = 0.5 * (img.at(u, v + 1) - img.at(u, v - 1));
            sxx += gx * gx;
            sxy += gx * gy;
            syy += gy * gy;
        }
    }
    let half_trace = 0.5 * (sxx + syy);
    let diff = 0.5 * (sxx - syy);
    half_trace - crate::float::sqrtf(diff * diff + sxy * sxy)
}

/// Up to `count` corners of `img` (a pyramid level `level`, scale `2^level`), at most one
/// per cell of a grid of about `count` cells, keeping `margin` full-resolution pixels
/// from the border, handed to `keep` one by one (it returns `false` when it holds no
/// more).
pub fn detect(
    img: &Image<'_>,
    level: usize,
    count: usize,
    margin: usize,
    mut keep: impl FnMut(Corner) -> bool,
) {
    let scale = 1usize << level;
    let border = (margin / scale).max(WINDOW + 2);
    if img.width <= 2 * border + 1 || img.height <= 2 * border + 1 {
        return;
    }
    let (w, h) = (img.width - 2 * border, img.height - 2 * border);
    let count = count.clamp(1, MAX_FEATURES);
    // Grid of roughly square cells, `gx · gy ≤ count`.
    let aspect = w as f32 / h as f32;
    let gx = (crate::float::sqrtf(count as f32 * aspect) as usize).clamp(1, w);
    let gy = (count / gx).clamp(1, h);
    for cy in 0..gy {
        let (y0, y1) = (border + cy * h / gy, border + (cy + 1) * h / gy);
        for cx in 0..gx {
            let (x0, x1) = (border + cx * w / gx, border + (cx + 1) * w / gx);
            let mut best = Corner {
                x: 0.0,
                y: 0.0,
                strength: MIN_STRENGTH,
            };
            for y in y0..y1 {
                for x in x0..x1 {
                    let s = min_eigenvalue(img, x, y);
                    if s > best.strength {
                        best = Corner {
                            x: (x * scale) as f32 + 0.5 * (scale as f32 - 1.0),
                            y: (y * scale) as f32 + 0.5 * (scale as f32 - 1.0),
                            strength: s,
                        };
                    }
                }
            }
            if best.strength > MIN_STRENGTH && !keep(best) {
                return;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use heapless::Vec as FixedVec;

    use super::*;

    #[test]
    fn finds_checkerboard_corners_and_nothing_on_flat_images() {
        let (w, h) = (64usize, 64usize);
        let mut data = [0.0f32; 64 * 64];
        for y in 0..h {
            for x in 0..w {
                data[y * w + x] = if ((x / 8) + (y / 8)) % 2 == 0 {
                    0.8
                } else {
                    0.2
                };
            }
        }
        let img = Image {
            data: &data,
            width: w,
            height: h,
        };
        let mut out: FixedVec<Corner, MAX_FEATURES> = FixedVec::new();
        detect(&img, 0, 16, 4, |c| out.push(c).is_ok());
        assert!(out.len() >= 12, "{}", out.len());
        for c in &out {
            // Checkerboard corners sit between pixels 8k − 1 and 8k.
            let near = |v: f32| (v + 0.5 - 8.0 * libm::roundf((v + 0.5) / 8.0)).abs() <= 1.5;
            assert!(near(c.x) && near(c.y), "{c:?}");
        }
        let flat = [0.5f32; 64 * 64];
        let img = Image {
            data: &flat,
            width: w,
            height: h,
        };
        out.clear();
        detect(&img, 0, 16, 4, |c| out.push(c).is_ok());
        assert!(out.is_empty());
    }
}
