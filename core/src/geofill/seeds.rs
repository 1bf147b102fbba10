//! The values the band takes from its seeds.

use super::access::{at, put};

/// Writes into `out` the value of each band pixel's seed (`field` = the distance and the
/// offsets `(x, y)` to the seed of every pixel), extrapolated along the seed's slope when
/// `planar`, where the path cost is positive and at most `max_cost` and the input finite.
pub(super) fn refill_from_seeds(
    input: &[f32],
    (dist, off_x, off_y): (&[f32], &[f32], &[f32]),
    (width, height): (usize, usize),
    (max_cost, planar): (f32, bool),
    out: &mut [f32],
) {
    for y in 0..height {
        for x in 0..width {
            let i = y * width + x;
            let di = at(dist, i);
            if !(di > 0.0 && di <= max_cost && at(input, i).is_finite()) {
                continue;
            }
            let (ox, oy) = (at(off_x, i), at(off_y, i));
            // Offsets are small integers held exactly in f32.
            let sx = x as i64 + ox as i64;
            let sy = y as i64 + oy as i64;
            let (Ok(sx), Ok(sy)) = (usize::try_from(sx), usize::try_from(sy)) else {
                continue;
            };
            if sx >= width || sy >= height {
                continue;
            }
            let s = sy * width + sx;
            let mut v = at(input, s);
            if planar {
                let seed = |xx: usize, yy: usize| {
                    let j = yy * width + xx;
                    (at(dist, j) == 0.0).then(|| at(input, j))
                };
                let gx = seed_slope(|k| {
                    let xx = sx as i64 + k;
                    usize::try_from(xx)
                        .ok()
                        .filter(|&xx| xx < width)
                        .and_then(|xx| seed(xx, sy))
                });
                let gy = seed_slope(|k| {
                    let yy = sy as i64 + k;
                    usize::try_from(yy)
                        .ok()
                        .filter(|&yy| yy < height)
                        .and_then(|yy| seed(sx, yy))
                });
                v -= gx * ox + gy * oy;
            }
            put(out, i, v);
        }
    }
}

/// The slope at a seed from `at(k)`, the seed value `k` pixels away (`None` where there
/// is no seed): the difference across the longest run of seeds within ±2 that contains
/// the seed itself, 0 where it has no seed neighbour on the line.
fn seed_slope(at: impl Fn(i64) -> Option<f32>) -> f32 {
    let Some(centre) = at(0) else {
        return 0.0;
    };
    let mut hi = (0i64, centre);
    for k in 1..=2 {
        match at(k) {
            Some(v) => hi = (k, v),
            None => break,
        }
    }
    let mut lo = (0i64, centre);
    for k in 1..=2 {
        match at(-k) {
            Some(v) => lo = (-k, v),
            None => break,
        }
    }
    let span = hi.0 - lo.0;
    if span == 0 {
        0.0
    } else {
        (hi.1 - lo.1) / span as f32
    }
}
