//! The band: the pixels near depth steps that no colour edge supports.

use crate::lightfield::{Sample, View};

use super::access::{at, put};

/// City-block distance (px, as `f32`) of every pixel to the nearest pixel of an
/// *unsupported* step where it is at most `band`, a value above `band` elsewhere (see
/// [`within_band`]; `row_scratch` holds one row). A step is a difference above `step` between finite
/// 4-neighbours; it is unsupported when no colour step of `edge` or more lies on the
/// line through the pair within 2 px of it: depth edges of real scenes sit on colour
/// edges, so a step inside uniform colour is a misplaced (fattened) one, while a
/// step on a colour edge is where it belongs and is left alone.
pub(super) fn band_distance<S: Sample>(
    guide: &View<'_, S>,
    input: &[f32],
    (width, height): (usize, usize),
    (step, edge, band): (f32, f32, usize),
    dist: &mut [f32],
    row_scratch: &mut [f32],
) {
    // False next to a NaN; a finite value next to ±∞ is a step.
    let jump = |a: f32, b: f32| (a - b).abs() > step;
    // Whether the colour steps between consecutive pixels along the line through
    // (x, y) and (x + dx, y + dy), from 2 px before to 2 px after the pair, all stay
    // below `edge`.
    let flat = |x: usize, y: usize, dx: usize, dy: usize| {
        (-2i64..=2).all(|k| {
            let at = |t: i64| {
                let xx = usize::try_from(x as i64 + t * dx as i64).ok()?;
                let yy = usize::try_from(y as i64 + t * dy as i64).ok()?;
                (xx < width && yy < height).then_some((xx, yy))
            };
            match (at(k), at(k + 1)) {
                (Some(a), Some(b)) => colour_step(guide, a, b) < edge,
                _ => true,
            }
        })
    };
    dist.fill(f32::INFINITY);
    for y in 0..height {
        for x in 0..width {
            let i = y * width + x;
            let v = at(input, i);
            if !v.is_finite() {
                continue;
            }
            if x + 1 < width && jump(v, at(input, i + 1)) && flat(x, y, 1, 0) {
                put(dist, i, 0.0);
                put(dist, i + 1, 0.0);
            }
            if y + 1 < height && jump(v, at(input, i + width)) && flat(x, y, 0, 1) {
                put(dist, i, 0.0);
                put(dist, i + width, 0.0);
            }
        }
    }
    within_band(dist, width, band, row_scratch);
}

/// Turns `dist` (0 on the step pixels, `+∞` elsewhere) into the city-block distance to
/// the nearest step pixel where it is at most `band`, and a value above `band` elsewhere
/// (the caller only asks which pixels lie within the band). The L1 distance is separable:
/// the vertical distance by a downward and an upward pass over whole rows, then the
/// horizontal step as a minimum over a window of `±band` columns. Every loop walks whole
/// rows with no dependence between neighbouring columns, so it vectorises (a raster
/// two-pass transform chains every pixel on its left neighbour). `row` is room for one
/// row (`width` long). Compare-and-select, not `f32::min`, which wasm lowers slowly.
pub(super) fn within_band(dist: &mut [f32], width: usize, band: usize, row: &mut [f32]) {
    let width = width.max(1);
    let near = |a: f32, b: f32| if b < a { b } else { a };
    let pixels = dist.len() - dist.len() % width;
    // Checked splits and copies: the firmware links with no panic path (a plain
    // `split_at_mut` or `copy_from_slice` keeps one the compiler cannot rule out).
    for y in 1..pixels / width {
        let Some((done, rest)) = dist.split_at_mut_checked(y * width) else {
            break;
        };
        let above = done.get((y - 1) * width..).unwrap_or_default();
        for (d, &a) in rest.iter_mut().zip(above) {
            *d = near(*d, a + 1.0);
        }
    }
    for y in (1..pixels / width).rev() {
        let Some((done, rest)) = dist.split_at_mut_checked(y * width) else {
            continue;
        };
        let above = done.get_mut((y - 1) * width..).unwrap_or_default();
        for (a, &d) in above.iter_mut().zip(rest.iter()) {
            *a = near(*a, d + 1.0);
        }
    }
    let Some(row) = row.get_mut(..width) else {
        return;
    };
    for line in dist.chunks_exact_mut(width) {
        for (r, &l) in row.iter_mut().zip(line.iter()) {
            *r = l;
        }
        for k in 1..=band.min(width - 1) {
            let step = k as f32;
            let (Some(right), Some(later)) = (row.get(k..), line.get_mut(k..)) else {
                break;
            };
            // Pixel x sees column x − k on its left, then x + k on its right.
            for (d, &l) in later.iter_mut().zip(row.iter()) {
                *d = near(*d, l + step);
            }
            for (d, &r) in line.iter_mut().zip(right) {
                *d = near(*d, r + step);
            }
        }
    }
}

/// Largest channel difference (unit intensity) between the guide's pixels `a` and `b`
/// (0 where either is outside the view).
fn colour_step<S: Sample>(guide: &View<'_, S>, a: (usize, usize), b: (usize, usize)) -> f32 {
    let stride = guide.channels();
    let used = stride.min(3);
    let pixel = |(x, y): (usize, usize)| {
        guide
            .row(y)
            .and_then(|r| r.get(x * stride..x * stride + used))
            .unwrap_or(&[])
    };
    let mut most = 0u8;
    for (sa, sb) in pixel(a).iter().zip(pixel(b)) {
        most = most.max(sa.level().abs_diff(sb.level()));
    }
    f32::from(most) * (1.0 / 255.0)
}
