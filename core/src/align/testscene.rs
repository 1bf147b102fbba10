//! Test light fields with exact parallax and known misalignment: textured planes
//! rendered by solving the rectified-array equation exactly, then warped by per-view
//! homographies. The core's tests use them, and the fuzz targets through the
//! `testscene` feature (host only: it needs the standard library).

extern crate std;
use std::vec::Vec;

use crate::geometry::Homography;
use crate::lightfield::{Grid, Layout};

/// Smooth value noise in about [0, 1].
pub fn texture(x: f32, y: f32, seed: u32) -> f32 {
    let mut v = 0.0;
    let mut amp = 0.5;
    let mut freq = 1.0 / 24.0;
    for octave in 0..3u32 {
        v += amp * value_noise(x * freq, y * freq, seed.wrapping_add(octave * 7919));
        amp *= 0.5;
        freq *= 2.0;
    }
    v / 0.875
}

/// A pseudo-random value in [0, 1] of the lattice point `(x, y)` for `seed`.
pub fn hash(x: i32, y: i32, seed: u32) -> f32 {
    let mut h = (x as u32).wrapping_mul(0x8da6_b343)
        ^ (y as u32).wrapping_mul(0xd816_3841)
        ^ seed.wrapping_mul(0xcb1a_b31f);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5bd1_e995);
    h ^= h >> 15;
    (h & 0xffff) as f32 / 65535.0
}

/// The lattice's [`hash`] values interpolated at `(x, y)` (lattice units), each axis's
/// fraction `t` weighted by `weight(t)`.
fn lattice_noise(x: f32, y: f32, seed: u32, weight: impl Fn(f32) -> f32) -> f32 {
    let (fx, fy) = (libm::floorf(x), libm::floorf(y));
    let (ix, iy) = (fx as i32, fy as i32);
    let (tx, ty) = (weight(x - fx), weight(y - fy));
    let a = hash(ix, iy, seed) + tx * (hash(ix + 1, iy, seed) - hash(ix, iy, seed));
    let b = hash(ix, iy + 1, seed) + tx * (hash(ix + 1, iy + 1, seed) - hash(ix, iy + 1, seed));
    a + ty * (b - a)
}

/// Value noise with smoothstep weights (continuous slopes), in [0, 1].
fn value_noise(x: f32, y: f32, seed: u32) -> f32 {
    lattice_noise(x, y, seed, |t| t * t * (3.0 - 2.0 * t))
}

/// Bilinear value noise of cell `cell` px at `(x, y)`, in [0, 1].
pub fn bilinear_noise(x: f32, y: f32, cell: f32, seed: u32) -> f32 {
    lattice_noise(x / cell, y / cell, seed, |t| t)
}

/// A plane of disparity `d(X) = a·(X − o) + c` over the centre-view region `support`.
#[derive(Clone, Copy)]
pub struct Plane {
    pub slope: (f32, f32),
    pub offset: f32,
    pub support: (f32, f32, f32, f32),
    pub seed: u32,
}

/// The scene: a slanted background and two nearer planes.
pub fn planes(width: usize, height: usize, near: f32) -> [Plane; 3] {
    let (w, h) = (width as f32, height as f32);
    [
        Plane {
            slope: (0.6 / w, -0.4 / h),
            offset: -0.8,
            support: (-1e9, -1e9, 1e9, 1e9),
            seed: 1,
        },
        Plane {
            slope: (0.0, 0.0),
            offset: near,
            support: (0.2 * w, 0.25 * h, 0.55 * w, 0.6 * h),
            seed: 2,
        },
        Plane {
            slope: (0.5 / w, 0.5 / h),
            offset: 0.4,
            support: (0.6 * w, 0.55 * h, 0.9 * w, 0.9 * h),
            seed: 3,
        },
    ]
}

/// Intensity of rectified view with baseline `b` at pixel `y`, and the disparity seen.
pub fn rectified(scene: &[Plane], o: (f32, f32), b: (f32, f32), y: (f32, f32)) -> (f32, f32) {
    let mut best: Option<(f32, f32)> = None;
    for p in scene {
        // y = X − (a·(X − o) + c)·b  ⇒  X = y' + b·(a·(y' − o))/(1 − a·b), y' = y + c·b.
        let yp = (y.0 + p.offset * b.0, y.1 + p.offset * b.1);
        let ab = p.slope.0 * b.0 + p.slope.1 * b.1;
        let k = (p.slope.0 * (yp.0 - o.0) + p.slope.1 * (yp.1 - o.1)) / (1.0 - ab);
        let x = (yp.0 + b.0 * k, yp.1 + b.1 * k);
        let d = p.slope.0 * (x.0 - o.0) + p.slope.1 * (x.1 - o.1) + p.offset;
        let (x0, y0, x1, y1) = p.support;
        if x.0 >= x0 && x.0 < x1 && x.1 >= y0 && x.1 < y1 && best.is_none_or(|b| d > b.1) {
            best = Some((texture(x.0, x.1, p.seed), d));
        }
    }
    best.unwrap_or((0.0, 0.0))
}

/// A misalignment: rotation, translation, scale and perspective about the image centre,
/// mapping rectified pixel coordinates to misaligned view pixel coordinates.
pub fn misalignment(
    o: (f32, f32),
    deg: f32,
    t: (f32, f32),
    scale: f32,
    persp: (f32, f32),
) -> Homography {
    let (s, c) = libm::sincosf(deg.to_radians());
    let k = 1.0 + scale;
    // q = o + t + k·R·(x − o) / (1 + p·(x − o))
    let a = [k * c, -k * s, k * s, k * c];
    let (px, py) = persp;
    let m = [
        a[0] + (o.0 + t.0) * px,
        a[1] + (o.0 + t.0) * py,
        0.0,
        a[2] + (o.1 + t.1) * px,
        a[3] + (o.1 + t.1) * py,
        0.0,
        px,
        py,
        1.0,
    ];
    // Translate the origin to o: H · T(−o).
    let h = Homography { m };
    let shift = Homography {
        m: [1.0, 0.0, -o.0, 0.0, 1.0, -o.1, 0.0, 0.0, 1.0],
    };
    let mut out = h.compose(&shift);
    out.m[2] += o.0 + t.0;
    out.m[5] += o.1 + t.1;
    let s = out.m[8];
    Homography {
        m: out.m.map(|v| v / s),
    }
}

/// Deterministic pseudo-random in [−1, 1].
pub fn unit(seed: u32, k: u32) -> f32 {
    2.0 * hash(seed as i32, k as i32, 99) - 1.0
}

/// Renders a gray u8 light field; per view a random misalignment up to the given bounds
/// (`deg`, `px`, `scale`, `persp` per pixel) when `misalign` is set.
pub fn render(
    grid: Grid,
    width: usize,
    height: usize,
    misalign: Option<(f32, f32, f32, f32)>,
    seed: u32,
) -> (Vec<u8>, Layout, Vec<Homography>) {
    let layout = Layout::packed(grid, width, height, 1);
    let scene = planes(width, height, 1.5);
    let o = ((width as f32 - 1.0) * 0.5, (height as f32 - 1.0) * 0.5);
    let (r0, c0) = grid.center();
    let mut data = std::vec![0u8; layout.validate().unwrap()];
    let mut hs = Vec::new();
    for v in 0..grid.len() {
        let (r, c) = (v / grid.cols, v % grid.cols);
        let b = (c as f32 - c0 as f32, r as f32 - r0 as f32);
        let h = match misalign {
            None => Homography::IDENTITY,
            Some((deg, px, scale, persp)) => {
                let k = v as u32 * 8 + seed * 1000;
                misalignment(
                    o,
                    deg * unit(k, 0),
                    (px * unit(k, 1), px * unit(k, 2)),
                    scale * unit(k, 3),
                    (persp * unit(k, 4), persp * unit(k, 5)),
                )
            }
        };
        let inv = h.inverse().unwrap();
        for y in 0..height {
            for x in 0..width {
                let (u, w) = inv.apply(x as f32, y as f32).unwrap();
                let (i, _) = rectified(&scene, o, b, (u, w));
                data[v * layout.view_stride + y * width + x] = (i * 255.0 + 0.5) as u8;
            }
        }
        hs.push(h);
    }
    (data, layout, hs)
}
