//! Tiny analytic light fields for the unit tests: fronto-parallel textured planes in
//! vertical strips over a background plane, rendered exactly (no sampling error).

extern crate std;
use std::vec::Vec;

use crate::lightfield::{Grid, Layout};

/// A rendered light field and the exact disparity of its centre view.
pub(crate) struct Scene {
    pub data: Vec<f32>,
    pub layout: Layout,
    pub gt: Vec<f32>,
}

/// Smooth band-limited texture (frequencies ≤ 1.1 rad/px), distinct per plane and channel.
fn texture(x: f32, y: f32, plane: usize, channel: usize) -> f32 {
    let p = plane as f32 * 1.7 + channel as f32 * 0.9;
    0.5 + 0.18 * libm::sinf(0.83 * x + 0.31 * y + p)
        + 0.12 * libm::sinf(0.29 * x - 0.67 * y + 2.0 * p)
        + 0.08 * libm::sinf(1.1 * x + 0.9 * y - p)
        + 0.07 * libm::sinf(0.17 * x + 1.05 * y + 0.5 * p)
}

/// `background` disparity everywhere; strip `i` of `strips` (equal widths) in front with
/// disparity `strips[i]` when it is larger than the background (nearer).
pub(crate) fn strips(
    grid: Grid,
    width: usize,
    height: usize,
    channels: usize,
    background: f32,
    strips: &[f32],
) -> Scene {
    let layout = Layout::packed(grid, width, height, channels);
    let (r0, c0) = grid.center();
    let strip_w = width as f32 / strips.len().max(1) as f32;
    // Planes by decreasing disparity: the nearest visible one wins.
    let surface = |u: f32, v: f32, dr: f32, dc: f32| -> (f32, usize, f32, f32) {
        let mut best: Option<(f32, usize, f32, f32)> = None;
        for (i, &d) in strips.iter().enumerate() {
            if d <= background {
                continue;
            }
            let (x, y) = (u + d * dc, v + d * dr);
            let inside = x >= i as f32 * strip_w && x < (i + 1) as f32 * strip_w;
            if inside && best.is_none_or(|b| d > b.0) {
                best = Some((d, i + 1, x, y));
            }
        }
        best.unwrap_or((background, 0, u + background * dc, v + background * dr))
    };
    let mut data = Vec::with_capacity(grid.len() * width * height * channels);
    for r in 0..grid.rows {
        for c in 0..grid.cols {
            let (dr, dc) = (r as f32 - r0 as f32, c as f32 - c0 as f32);
            for v in 0..height {
                for u in 0..width {
                    let (_, plane, x, y) = surface(u as f32, v as f32, dr, dc);
                    for ch in 0..channels {
                        data.push(texture(x, y, plane, ch));
                    }
                }
            }
        }
    }
    let mut gt = Vec::with_capacity(width * height);
    for v in 0..height {
        for u in 0..width {
            gt.push(surface(u as f32, v as f32, 0.0, 0.0).0);
        }
    }
    Scene { data, layout, gt }
}

/// One textured plane slanted across the whole view: disparity
/// `centre + slope.0 · (x − cx) + slope.1 · (y − cy)` about the image centre `(cx, cy)`.
pub(crate) fn slanted(
    grid: Grid,
    (width, height, channels): (usize, usize, usize),
    centre: f32,
    slope: (f32, f32),
) -> Scene {
    let layout = Layout::packed(grid, width, height, channels);
    let (r0, c0) = grid.center();
    let (cx, cy) = (width as f32 / 2.0, height as f32 / 2.0);
    let (gx, gy) = slope;
    let disparity = |x: f32, y: f32| centre + gx * (x - cx) + gy * (y - cy);
    let mut data = Vec::with_capacity(grid.len() * width * height * channels);
    for r in 0..grid.rows {
        for c in 0..grid.cols {
            let (dr, dc) = (r as f32 - r0 as f32, c as f32 - c0 as f32);
            for v in 0..height {
                for u in 0..width {
                    // The centre-view point (x, y) seen at (u, v): u = x − d(x, y)·dc,
                    // v = y − d(x, y)·dr, linear in (x, y).
                    let k = centre - gx * cx - gy * cy;
                    let (a, b, e) = (1.0 - gx * dc, -gy * dc, u as f32 + k * dc);
                    let (c2, d2, f) = (-gx * dr, 1.0 - gy * dr, v as f32 + k * dr);
                    let det = a * d2 - b * c2;
                    let (x, y) = ((e * d2 - b * f) / det, (a * f - e * c2) / det);
                    for ch in 0..channels {
                        data.push(texture(x, y, 0, ch));
                    }
                }
            }
        }
    }
    let mut gt = Vec::with_capacity(width * height);
    for v in 0..height {
        for u in 0..width {
            gt.push(disparity(u as f32, v as f32));
        }
    }
    Scene { data, layout, gt }
}

/// Deterministic pseudo-random samples in [0, 1) (xorshift).
pub(crate) fn noise(len: usize, seed: u64) -> Vec<f32> {
    let mut s = seed | 1;
    (0..len)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32
        })
        .collect()
}
