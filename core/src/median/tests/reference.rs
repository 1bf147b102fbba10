//! The direct reference implementation: every pixel weighs and selects its whole
//! window, as the stage did before the exact early test.

use core::ops::Range;

use super::*;
use crate::error::check_scratch;
use crate::median::select::weighted_median;
use crate::median::weights::Weights;

const SLOPE_ROWS: usize = 2 * MAX_RADIUS + 1;

/// The median as first written: per pixel, every neighbour of the window is weighed
/// and voted, and the snap test decides on the sums.
pub(super) fn reference_rows<S: Sample>(
    stage: Setup<'_, MedianParams>,
    guide: &View<'_, S>,
    input: &[f32],
    rows: Range<usize>,
    out: &mut [f32],
    scratch: &mut [f32],
) -> Result<()> {
    let (width, height) = check(stage, guide, input)?;
    if rows.start > rows.end || rows.end > height {
        return Err(Error::OutOfRange {
            what: "median band end row",
            index: rows.end,
            len: height,
        });
    }
    let needed = rows.len() * width;
    if out.len() != needed {
        return Err(Error::OutputSize {
            what: "the median band",
            needed,
            got: out.len(),
        });
    }
    let needed = scratch_len(stage);
    check_scratch(needed, scratch.len())?;
    let (column_steps, slopes) = scratch[..needed].split_at_mut(width);
    // Slopes of image row `yy` live in slot `yy % SLOPE_ROWS` (x then y, `width` each),
    // computed when the row first enters a window: each row once per call.
    let mut slot_row = [usize::MAX; SLOPE_ROWS];
    let p = stage.params();
    let weights = Weights::new(p.color_sigma);
    let channels = guide.channels();
    let used = channels.min(3);
    let r = p.radius;
    let mut values = [0.0f32; MAX_TAPS];
    let mut taps = [0u32; MAX_TAPS];
    for (o, y) in out.chunks_exact_mut(width).zip(rows) {
        let ys = y.saturating_sub(r)..(y + r + 1).min(height);
        if p.gate > 0.0 {
            steps_by_column(input, width, ys.clone(), column_steps);
        }
        if p.planar {
            for yy in ys.clone() {
                let slot = yy % SLOPE_ROWS;
                if slot_row[slot] != yy {
                    let row = &mut slopes[2 * slot * width..2 * (slot + 1) * width];
                    let (sx, sy) = row.split_at_mut(width);
                    for (xx, (gx, gy)) in sx.iter_mut().zip(sy.iter_mut()).enumerate() {
                        (*gx, *gy) = slope(input, width, height, xx, yy, p.gate);
                    }
                    slot_row[slot] = yy;
                }
            }
        }
        let guide_row = guide.row(y).ok_or(Error::OutOfRange {
            what: "guide row",
            index: y,
            len: guide.height(),
        })?;
        for (x, o) in o.iter_mut().enumerate() {
            let own = input[y * width + x];
            *o = own;
            if !own.is_finite() {
                continue;
            }
            let xs = x.saturating_sub(r)..(x + r + 1).min(width);
            if p.gate > 0.0 && !column_steps[xs.clone()].iter().any(|&s| s > p.gate) {
                continue;
            }
            let mut centre = [0i32; 3];
            for (k, c) in centre.iter_mut().enumerate().take(used) {
                *c = i32::from(guide_row[x * channels + k].level());
            }
            let mut n = 0;
            let (mut total, mut below, mut above) = (0u64, 0u64, 0u64);
            // The same sums over the rows at a distance from the pixel's divisible by 4
            // and by 2.
            let mut quarter_sums = [0u64; 3];
            let mut even_sums = [0u64; 3];
            for yy in ys.clone() {
                let (quarter, even) = (y.abs_diff(yy) % 4 == 0, y.abs_diff(yy) % 2 == 0);
                let row = &input[yy * width..(yy + 1) * width];
                let colours = guide.row(yy).unwrap_or(&[]);
                for xx in xs.clone() {
                    let v = row[xx];
                    let Some(pixel) = colours.get(xx * channels..xx * channels + used) else {
                        continue;
                    };
                    if !v.is_finite() {
                        continue;
                    }
                    let mut d2 = 0u32;
                    for (s, c) in pixel.iter().zip(&centre) {
                        let d = i32::from(s.level()) - c;
                        d2 += (d * d) as u32;
                    }
                    let w = weights.get(d2);
                    if w > 0 {
                        let v = if p.planar {
                            let base = 2 * (yy % SLOPE_ROWS) * width;
                            let (gx, gy) = (slopes[base + xx], slopes[base + width + xx]);
                            v + gx * (x as f32 - xx as f32) + gy * (y as f32 - yy as f32)
                        } else {
                            v
                        };
                        values[n] = v;
                        taps[n] = w;
                        let w = u64::from(w);
                        let (b, a) = (
                            if v < own - p.snap { w } else { 0 },
                            if v > own + p.snap { w } else { 0 },
                        );
                        (total, below, above) = (total + w, below + b, above + a);
                        for (sums, add) in [(&mut quarter_sums, quarter), (&mut even_sums, even)] {
                            if add {
                                sums[0] += w;
                                sums[1] += b;
                                sums[2] += a;
                            }
                        }
                        n += 1;
                    }
                }
            }
            // Outside votes weighing less than a ninth of the quarter rows, or a third of
            // the even rows, on either side keep the pixel without the rest of the window.
            let clear = |[total, below, above]: [u64; 3], parts: u64| {
                parts * below < total && parts * above < total
            };
            if clear(quarter_sums, 9) || clear(even_sums, 3) {
                continue;
            }
            // The median lies within `snap` of the pixel's value (which then stays)
            // unless the weight beyond `own ± snap` on one side reaches half: a linear
            // test that spares most pixels the selection.
            let half = total.div_ceil(2);
            if n > 0 && (below >= half || total - above < half) {
                let m = weighted_median(&mut values[..n], &mut taps[..n], half);
                if (m - own).abs() > p.snap {
                    let vote = |xx: usize, yy: usize| {
                        let v = input[yy * width + xx];
                        if p.planar {
                            let base = 2 * (yy % SLOPE_ROWS) * width;
                            let (gx, gy) = (slopes[base + xx], slopes[base + width + xx]);
                            v + gx * (x as f32 - xx as f32) + gy * (y as f32 - yy as f32)
                        } else {
                            v
                        }
                    };
                    let d2 = |xx: usize, yy: usize| {
                        let colours = guide.row(yy).unwrap_or(&[]);
                        let pixel = &colours[xx * channels..xx * channels + used];
                        let mut d2 = 0u32;
                        for (s, c) in pixel.iter().zip(&centre) {
                            let d = i32::from(s.level()) - c;
                            d2 += (d * d) as u32;
                        }
                        d2
                    };
                    let window = (ys.clone(), xs.clone());
                    let weight = |xx, yy| u64::from(weights.get(d2(xx, yy)));
                    let keeps =
                        reference_keeps_structure(p, window, (x, y), (own, m), vote, weight);
                    if !keeps {
                        *o = m;
                    }
                }
            }
        }
    }
    Ok(())
}

/// The reference's thin-structure test: a breadth-first search over the window from
/// the pixel through 8-neighbours whose vote lies within `own ± max(snap, |m − own| / 2)`
/// (`m` the median), then the
/// bounding box of the pixels reached: at least `radius + 1` long along the rows or the
/// columns, with at most `thin` pixels per pixel of that length; and their mean colour
/// weight at least twice that of the window's other finite votes outside the band.
fn reference_keeps_structure(
    p: &MedianParams,
    (ys, xs): (Range<usize>, Range<usize>),
    (x, y): (usize, usize),
    (own, m): (f32, f32),
    vote: impl Fn(usize, usize) -> f32,
    weight: impl Fn(usize, usize) -> u64,
) -> bool {
    if p.thin <= 0.0 {
        return false;
    }
    let reach = p.snap.max(0.5 * (m - own).abs());
    let joinable = |xx: usize, yy: usize| {
        let v = vote(xx, yy);
        v.is_finite() && v >= own - reach && v <= own + reach
    };
    let mut seen = [[false; 2 * MAX_RADIUS + 1]; 2 * MAX_RADIUS + 1];
    let mut queue = vec![(x, y)];
    seen[y - ys.start][x - xs.start] = true;
    let mut head = 0;
    while let Some(&(cx, cy)) = queue.get(head) {
        head += 1;
        for ny in cy.saturating_sub(1)..=cy + 1 {
            for nx in cx.saturating_sub(1)..=cx + 1 {
                if !ys.contains(&ny) || !xs.contains(&nx) || seen[ny - ys.start][nx - xs.start] {
                    continue;
                }
                if joinable(nx, ny) {
                    seen[ny - ys.start][nx - xs.start] = true;
                    queue.push((nx, ny));
                }
            }
        }
    }
    let span = |of: fn(&(usize, usize)) -> usize| {
        let (lo, hi) = (queue.iter().map(of).min(), queue.iter().map(of).max());
        hi.zip(lo).map_or(0, |(hi, lo)| hi - lo + 1)
    };
    let span = span(|q| q.0).max(span(|q| q.1));
    if span <= p.radius || queue.len() as f32 > p.thin * span as f32 {
        return false;
    }
    // Contrast: the mean weight of the pixels reached at least twice that of the
    // window's finite votes outside the band.
    let joined = queue.iter().map(|&(xx, yy)| weight(xx, yy)).sum::<u64>();
    let (mut others, mut others_weight) = (0u64, 0u64);
    for yy in ys.clone() {
        for xx in xs.clone() {
            let v = vote(xx, yy);
            if v.is_finite() && (v < own - reach || v > own + reach) {
                others += 1;
                others_weight += weight(xx, yy);
            }
        }
    }
    joined * others >= 2 * others_weight * queue.len() as u64
}

/// Largest step per column in the rows `ys` (the reference's gate).
fn steps_by_column(map: &[f32], width: usize, ys: Range<usize>, out: &mut [f32]) {
    out.fill(0.0);
    let last = ys.end.saturating_sub(1);
    for yy in ys {
        let row = &map[yy * width..(yy + 1) * width];
        for (x, o) in out.iter_mut().enumerate() {
            let v = row[x];
            let mut step = 0.0f32;
            if let Some(&right) = row.get(x + 1) {
                step = (right - v).abs();
            }
            if yy < last {
                step = step.max((map[(yy + 1) * width + x] - v).abs());
            }
            // NaN steps compare false and are ignored by `max`.
            *o = o.max(step);
        }
    }
}

/// The reference's slope.
#[inline(always)]
fn slope(map: &[f32], width: usize, height: usize, x: usize, y: usize, gate: f32) -> (f32, f32) {
    let at = |xx: usize, yy: usize| map[yy * width + xx];
    let v = at(x, y);
    let diff = |prev: Option<f32>, next: Option<f32>| -> f32 {
        let ok = |d: f32| d.is_finite() && d.abs() <= gate.max(1e-6);
        let back = prev.map(|p| v - p).filter(|&d| ok(d));
        let fwd = next.map(|n| n - v).filter(|&d| ok(d));
        match (back, fwd) {
            (Some(b), Some(f)) => 0.5 * (b + f),
            (Some(b), None) => b,
            (None, Some(f)) => f,
            (None, None) => 0.0,
        }
    };
    let gx = diff(
        x.checked_sub(1).map(|xx| at(xx, y)),
        (x + 1 < width).then(|| at(x + 1, y)),
    );
    let gy = diff(
        y.checked_sub(1).map(|yy| at(x, yy)),
        (y + 1 < height).then(|| at(x, y + 1)),
    );
    (gx, gy)
}
