//! Tests of the median: behaviour on small scenes, and equality, bit for bit, with a
//! direct reference implementation (every pixel weighs and selects its whole window, as
//! the stage did before the exact early test) on random maps and guides.

use core::ops::Range;

use super::select::weighted_median;
use super::weights::Weights;
use super::*;
use crate::error::check_scratch;
use crate::lightfield::{Grid, Layout, LightField};
use crate::setup::TestSetup;

const SLOPE_ROWS: usize = 2 * MAX_RADIUS + 1;

/// The median as first written: per pixel, every neighbour of the window is weighed
/// and voted, and the snap test decides on the sums.
fn reference_rows<S: Sample>(
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

fn stage_for(width: usize, height: usize, params: MedianParams) -> TestSetup<MedianParams> {
    let layout = Layout::packed(Grid::new(3, 3), width, height, 1);
    TestSetup::new(layout, params)
}

/// A vertical colour edge at x = 16 (dark left, bright right) and a disparity edge
/// fattened 3 px into the dark side: the median moves the depth edge onto the colour
/// edge and leaves everything else alone.
#[test]
fn fattened_depth_edge_snaps_to_colour_edge() {
    let (w, h) = (32usize, 24usize);
    let stage = stage_for(w, h, MedianParams::default());
    let mut views = [0u8; 9 * 32 * 24];
    let centre = 4 * w * h;
    for y in 0..h {
        for x in 0..w {
            views[centre + y * w + x] = if x < 16 { 40 } else { 200 };
        }
    }
    let lf = LightField::new(&views, *stage.layout()).unwrap();
    let mut input = [0.0f32; 32 * 24];
    for y in 0..h {
        for x in 0..w {
            input[y * w + x] = if x >= 13 { 1.5 } else { -0.5 };
        }
    }
    let mut out = [0.0f32; 32 * 24];
    filter(
        stage.setup(),
        &lf.center_view(),
        &input,
        &mut out,
        &mut vec![0.0; scratch_len(stage.setup())],
    )
    .unwrap();
    for y in 0..h {
        for x in 0..w {
            let want = if x >= 16 { 1.5 } else { -0.5 };
            assert_eq!(out[y * w + x], want, "({x}, {y})");
        }
    }
}

/// A two-pixel pole 16 levels brighter than the background (colour weight ≈ 0.29: the
/// background's 195 pixels of a window outweigh the pole's 30) and a short blotch of
/// the same colour and disparity: without the thin-structure test the median erases
/// both; with it the pole, long and narrow and of its own colour, keeps its disparity
/// and the blotch (4 rows, shorter than r + 1) is still erased.
#[test]
fn thin_structures_keep_their_value_and_short_blotches_do_not() {
    let (w, h) = (32usize, 24usize);
    let mut views = [0u8; 9 * 32 * 24];
    let centre = 4 * w * h;
    let mut input = [-1.0f32; 32 * 24];
    let pole = |x: usize| x == 10 || x == 11;
    let blotch = |x: usize, y: usize| (23..25).contains(&x) && (10..14).contains(&y);
    for y in 0..h {
        for x in 0..w {
            let on = pole(x) || blotch(x, y);
            views[centre + y * w + x] = if on { 76 } else { 60 } + (x * 7 + y * 3) as u8 % 3;
            if on {
                input[y * w + x] = 1.0;
            }
        }
    }
    let run = |params: MedianParams| {
        let stage = stage_for(w, h, params);
        let lf = LightField::new(&views, *stage.layout()).unwrap();
        let mut out = [0.0f32; 32 * 24];
        filter(
            stage.setup(),
            &lf.center_view(),
            &input,
            &mut out,
            &mut vec![0.0; scratch_len(stage.setup())],
        )
        .unwrap();
        out
    };
    let without = run(MedianParams {
        thin: 0.0,
        ..MedianParams::default()
    });
    let with = run(MedianParams::default());
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            assert_eq!(without[i], -1.0, "without the test ({x}, {y})");
            let want = if pole(x) { 1.0 } else { -1.0 };
            assert_eq!(with[i], want, "with the test ({x}, {y})");
        }
    }
}

#[test]
fn smooth_ramp_is_kept_and_bands_are_bit_identical() {
    let (w, h) = (24usize, 20usize);
    // No gate: every pixel goes through the median.
    let stage = stage_for(
        w,
        h,
        MedianParams {
            gate: 0.0,
            ..MedianParams::default()
        },
    );
    let mut views = [0u8; 9 * 24 * 20];
    for (i, v) in views.iter_mut().enumerate() {
        *v = (i * 7 % 13) as u8 + 100;
    }
    let lf = LightField::new(&views, *stage.layout()).unwrap();
    let mut input = [0.0f32; 24 * 20];
    for y in 0..h {
        for x in 0..w {
            input[y * w + x] = 0.01 * x as f32 + 0.02 * y as f32;
        }
    }
    let mut whole = [0.0f32; 24 * 20];
    filter(
        stage.setup(),
        &lf.center_view(),
        &input,
        &mut whole,
        &mut vec![0.0; scratch_len(stage.setup())],
    )
    .unwrap();
    // Interior pixels (full symmetric window) keep their value on a plane.
    let r = MedianParams::default().radius;
    for y in r..h - r {
        for x in r..w - r {
            assert!((whole[y * w + x] - input[y * w + x]).abs() < 1e-6);
        }
    }
    let mut banded = [0.0f32; 24 * 20];
    for start in (0..h).step_by(3) {
        let end = (start + 3).min(h);
        filter_rows(
            stage.setup(),
            &lf.center_view(),
            &input,
            start..end,
            &mut banded[start * w..end * w],
            &mut vec![0.0; scratch_len(stage.setup())],
        )
        .unwrap();
    }
    assert_eq!(whole, banded);
}

#[test]
fn bad_parameters_and_sizes_are_errors() {
    let layout = Layout::packed(Grid::new(3, 3), 16, 16, 1);
    for bad in [
        MedianParams {
            radius: 0,
            ..MedianParams::default()
        },
        MedianParams {
            radius: 8,
            ..MedianParams::default()
        },
        MedianParams {
            color_sigma: f32::NAN,
            ..MedianParams::default()
        },
        MedianParams {
            gate: -1.0,
            ..MedianParams::default()
        },
    ] {
        assert!(matches!(
            Setup::new(&layout, &bad),
            Err(Error::InvalidParameter { .. })
        ));
    }
    let stage = stage_for(16, 16, MedianParams::default());
    let views = [0u8; 9 * 256];
    let lf = LightField::new(&views, *stage.layout()).unwrap();
    let input = [0.0f32; 256];
    let mut out = [0.0f32; 255];
    assert!(filter(
        stage.setup(),
        &lf.center_view(),
        &input,
        &mut out,
        &mut vec![0.0; scratch_len(stage.setup())]
    )
    .is_err());
    let mut out = [0.0f32; 256];
    assert!(filter(
        stage.setup(),
        &lf.center_view(),
        &input[..10],
        &mut out,
        &mut vec![0.0; scratch_len(stage.setup())]
    )
    .is_err());
    assert!(matches!(
        filter(
            stage.setup(),
            &lf.center_view(),
            &input,
            &mut out,
            &mut vec![0.0; scratch_len(stage.setup()) - 1]
        ),
        Err(Error::ScratchTooSmall { .. })
    ));
    assert!(filter_rows(
        stage.setup(),
        &lf.center_view(),
        &input,
        10..17,
        &mut out[..112],
        &mut vec![0.0; scratch_len(stage.setup())]
    )
    .is_err());
}

#[test]
fn non_finite_values_pass_through_and_stay_out_of_neighbours() {
    let stage = stage_for(16, 16, MedianParams::default());
    let views = [128u8; 9 * 256];
    let lf = LightField::new(&views, *stage.layout()).unwrap();
    let mut input = [0.25f32; 256];
    input[17] = f32::NAN;
    input[40] = f32::INFINITY;
    let mut out = [0.0f32; 256];
    filter(
        stage.setup(),
        &lf.center_view(),
        &input,
        &mut out,
        &mut vec![0.0; scratch_len(stage.setup())],
    )
    .unwrap();
    assert!(out[17].is_nan());
    assert_eq!(out[40], f32::INFINITY);
    for (i, v) in out.iter().enumerate() {
        if i != 17 && i != 40 {
            assert_eq!(*v, 0.25);
        }
    }
}
/// A small xorshift generator: the tests are reproducible without a dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
}

const MAX_SIDE: usize = 40;

/// A random side from the smallest a stage takes to `MAX_SIDE`.
fn side(rng: &mut Rng) -> usize {
    let min = crate::lightfield::VIEW_MIN;
    min + rng.below(MAX_SIDE - min + 1)
}

/// A disparity map of slanted regions split by a few straight depth edges, fattened or
/// not against the guide's colour edges, with noise, quantised ties and non-finite
/// values; and a guide whose colour edges follow the true depth edges.
struct Scene {
    map: [f32; MAX_SIDE * MAX_SIDE],
    colours: [u8; 4 * MAX_SIDE * MAX_SIDE],
}

fn scene(rng: &mut Rng, width: usize, height: usize, channels: usize) -> Scene {
    let mut map = [0.0f32; MAX_SIDE * MAX_SIDE];
    let mut colours = [0u8; 4 * MAX_SIDE * MAX_SIDE];
    // Up to three edges a·x + b·y = c; each region (side pattern) gets a plane and a colour.
    let edges = 1 + rng.below(3);
    let mut lines = [(0.0f32, 0.0f32, 0.0f32); 3];
    for line in lines.iter_mut().take(edges) {
        let angle = rng.unit() * core::f32::consts::PI;
        let (a, b) = (libm::cosf(angle), libm::sinf(angle));
        let c = a * rng.unit() * width as f32 + b * rng.unit() * height as f32;
        *line = (a, b, c);
    }
    let fatten = rng.below(4) as f32;
    let noise = [0.0, 0.002, 0.05][rng.below(3)];
    let colour_noise = rng.below(12) as i32;
    let quantum = [0.0, 0.25, 0.01][rng.below(3)];
    let mut planes = [(0.0f32, 0.0f32, 0.0f32); 8];
    let mut tints = [[0u8; 4]; 8];
    for (plane, tint) in planes.iter_mut().zip(tints.iter_mut()) {
        let slant = [0.0, 0.02, 0.3][rng.below(3)];
        *plane = (
            rng.unit() * 3.0 - 1.5,
            (rng.unit() - 0.5) * slant,
            (rng.unit() - 0.5) * slant,
        );
        for t in tint.iter_mut() {
            *t = rng.below(256) as u8;
        }
    }
    let region = |x: f32, y: f32, shift: f32| {
        let mut index = 0;
        for (k, (a, b, c)) in lines.iter().take(edges).enumerate() {
            if a * x + b * y > c + shift {
                index |= 1 << k;
            }
        }
        index
    };
    for y in 0..height {
        for x in 0..width {
            let (fx, fy) = (x as f32, y as f32);
            // The map's edges sit `fatten` pixels off the colour edges.
            let (d0, dx, dy) = planes[region(fx, fy, -fatten)];
            let mut d = d0 + dx * fx + dy * fy + (rng.unit() - 0.5) * noise;
            if quantum > 0.0 {
                d = libm::roundf(d / quantum) * quantum;
            }
            d = match rng.below(200) {
                0 => f32::NAN,
                1 => f32::INFINITY,
                2 => f32::NEG_INFINITY,
                3 => -0.0,
                _ => d,
            };
            map[y * width + x] = d;
            let tint = tints[region(fx, fy, 0.0)];
            for k in 0..channels {
                let jitter = rng.below(2 * colour_noise as usize + 1) as i32 - colour_noise;
                colours[(y * width + x) * channels + k] =
                    (i32::from(tint[k]) + jitter).clamp(0, 255) as u8;
            }
        }
    }
    Scene { map, colours }
}

fn random_params(rng: &mut Rng) -> MedianParams {
    MedianParams {
        radius: 1 + rng.below(MAX_RADIUS),
        color_sigma: [0.005, 0.02, 0.04, 0.1, 0.5][rng.below(5)],
        gate: [0.0, 0.05, 0.2, 1.0][rng.below(4)],
        snap: [0.0, 0.05, 0.2, 1.0][rng.below(4)],
        planar: rng.below(3) != 0,
        thin: [0.0, 1.0, 2.5, 4.0, 16.0][rng.below(5)],
        ..MedianParams::default()
    }
}

/// `filter_rows` over the whole map and in random bands, checked bit for bit against
/// the reference; returns how many pixels the median moved.
fn check_against_reference<S: Sample>(
    rng: &mut Rng,
    stage: Setup<'_, MedianParams>,
    guide: &View<'_, S>,
    map: &[f32],
    trial: usize,
) -> usize {
    let (w, h) = (stage.layout().width, stage.layout().height);
    let pixels = w * h;
    let mut scratch = vec![0.0f32; scratch_len(stage)];
    let scratch = &mut scratch[..];
    let mut expected = [0.0f32; MAX_SIDE * MAX_SIDE];
    reference_rows(stage, guide, map, 0..h, &mut expected[..pixels], scratch).unwrap();
    let mut got = [0.0f32; MAX_SIDE * MAX_SIDE];
    filter(stage, guide, map, &mut got[..pixels], scratch).unwrap();
    let mut banded = [0.0f32; MAX_SIDE * MAX_SIDE];
    let mut start = 0;
    while start < h {
        let end = (start + 1 + rng.below(h)).min(h);
        // Scratch left over from another call must not matter.
        scratch.fill(f32::NAN);
        filter_rows(
            stage,
            guide,
            map,
            start..end,
            &mut banded[start * w..end * w],
            scratch,
        )
        .unwrap();
        start = end;
    }
    for i in 0..pixels {
        let (x, y) = (i % w, i / w);
        assert_eq!(
            got[i].to_bits(),
            expected[i].to_bits(),
            "trial {trial}, ({x}, {y}): {} vs reference {}",
            got[i],
            expected[i]
        );
        assert_eq!(
            banded[i].to_bits(),
            expected[i].to_bits(),
            "trial {trial}, banded ({x}, {y})"
        );
    }
    (0..pixels)
        .filter(|&i| expected[i].to_bits() != map[i].to_bits())
        .count()
}

#[test]
fn equals_the_reference_bit_for_bit_on_random_scenes() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut moved = 0;
    for trial in 0..60 {
        let (w, h) = (side(&mut rng), side(&mut rng));
        let channels = [1, 3, 4][rng.below(3)];
        let s = scene(&mut rng, w, h, channels);
        let stage = stage_for(w, h, random_params(&mut rng));
        let guide =
            View::new(&s.colours[..w * h * channels], w, h, channels, w * channels).unwrap();
        moved += check_against_reference(&mut rng, stage.setup(), &guide, &s.map[..w * h], trial);
    }
    // The comparison means something only if the selection ran and moved pixels.
    assert!(moved > 200, "only {moved} pixels moved");
}

#[test]
fn equals_the_reference_with_a_float_guide() {
    let mut rng = Rng(0x0123_4567_89AB_CDEF);
    let mut moved = 0;
    for trial in 0..20 {
        let (w, h) = (side(&mut rng), side(&mut rng));
        let s = scene(&mut rng, w, h, 3);
        let mut colours = [0.0f32; 3 * MAX_SIDE * MAX_SIDE];
        for (c, &level) in colours.iter_mut().zip(&s.colours[..3 * w * h]) {
            // Levels beyond [0, 1] and NaN clamp to the ends.
            *c = match rng.below(100) {
                0 => f32::NAN,
                1 => 1.5,
                2 => -0.5,
                _ => f32::from(level) / 255.0 + (rng.unit() - 0.5) / 255.0,
            };
        }
        let stage = stage_for(w, h, random_params(&mut rng));
        let guide = View::new(&colours[..3 * w * h], w, h, 3, 3 * w).unwrap();
        moved += check_against_reference(&mut rng, stage.setup(), &guide, &s.map[..w * h], trial);
    }
    assert!(moved > 50, "only {moved} pixels moved");
}

#[test]
fn later_passes_skip_unchanged_windows_with_the_same_result() {
    let mut rng = Rng(0x5DEE_CE66_D1CE_4E5B);
    let mut skipped_some = 0;
    for trial in 0..30 {
        let (w, h) = (side(&mut rng), side(&mut rng));
        let channels = [1, 3, 4][rng.below(3)];
        let s = scene(&mut rng, w, h, channels);
        let stage = stage_for(w, h, random_params(&mut rng));
        let guide =
            View::new(&s.colours[..w * h * channels], w, h, channels, w * channels).unwrap();
        let pixels = w * h;
        let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
        let mut previous = s.map[..pixels].to_vec();
        let mut input = vec![0.0f32; pixels];
        filter(stage.setup(), &guide, &previous, &mut input, &mut scratch).unwrap();
        for pass in 1..4 {
            let mut expected = vec![0.0f32; pixels];
            filter(stage.setup(), &guide, &input, &mut expected, &mut scratch).unwrap();
            let mut got = vec![0.0f32; pixels];
            let mut start = 0;
            while start < h {
                let end = (start + 1 + rng.below(h)).min(h);
                scratch.fill(f32::NAN);
                filter_rows_again(
                    stage.setup(),
                    &guide,
                    &input,
                    &previous,
                    start..end,
                    &mut got[start * w..end * w],
                    &mut scratch,
                )
                .unwrap();
                start = end;
            }
            for i in 0..pixels {
                assert_eq!(
                    got[i].to_bits(),
                    expected[i].to_bits(),
                    "trial {trial}, pass {pass}, ({}, {})",
                    i % w,
                    i / w
                );
            }
            if input != previous {
                skipped_some += 1;
            }
            previous = core::mem::replace(&mut input, expected);
        }
    }
    assert!(
        skipped_some > 10,
        "too few passes where something moved: {skipped_some}"
    );
    let stage = stage_for(16, 16, MedianParams::default());
    let views = [0u8; 256];
    let guide = View::new(&views, 16, 16, 1, 16).unwrap();
    let mut out = [0.0f32; 256];
    assert!(matches!(
        filter_rows_again(
            stage.setup(),
            &guide,
            &[0.0; 256],
            &[0.0; 255],
            0..16,
            &mut out,
            &mut vec![0.0; scratch_len(stage.setup())]
        ),
        Err(Error::OutputSize { .. })
    ));
}

/// [`filter_pass`] over four passes in random bands (a new banding each pass, scratch
/// and the first pass's `settled` bytes garbage) equals full passes of [`filter`] bit
/// for bit, while pixels settled by their quarter rows are kept without a decision.
#[test]
fn passes_that_remember_settled_pixels_equal_full_passes() {
    let mut rng = Rng(0x2545_F491_4F6C_DD1D);
    let (mut settled_pixels, mut moved) = (0, 0);
    for trial in 0..30 {
        let (w, h) = (side(&mut rng), side(&mut rng));
        let channels = [1, 3, 4][rng.below(3)];
        let s = scene(&mut rng, w, h, channels);
        let stage = stage_for(w, h, random_params(&mut rng));
        let guide =
            View::new(&s.colours[..w * h * channels], w, h, channels, w * channels).unwrap();
        let pixels = w * h;
        let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
        let mut expected = s.map[..pixels].to_vec();
        let mut input = expected.clone();
        let mut previous: Option<Vec<f32>> = None;
        let mut settled = vec![7u8; pixels];
        for pass in 0..4 {
            let mut next = vec![0.0f32; pixels];
            filter(stage.setup(), &guide, &expected, &mut next, &mut scratch).unwrap();
            moved += (0..pixels)
                .filter(|&i| next[i].to_bits() != expected[i].to_bits())
                .count();
            expected = next;
            let mut got = vec![0.0f32; pixels];
            let mut start = 0;
            while start < h {
                let end = (start + 1 + rng.below(h)).min(h);
                scratch.fill(f32::NAN);
                filter_pass(
                    stage.setup(),
                    PassInput {
                        guide: &guide,
                        input: &input,
                        previous: previous.as_deref(),
                    },
                    start..end,
                    &mut got[start * w..end * w],
                    &mut settled[start * w..end * w],
                    &mut scratch,
                )
                .unwrap();
                start = end;
            }
            for i in 0..pixels {
                assert_eq!(
                    got[i].to_bits(),
                    expected[i].to_bits(),
                    "trial {trial}, pass {pass}, ({}, {})",
                    i % w,
                    i / w
                );
                assert!(
                    settled[i] <= 1,
                    "trial {trial}, pass {pass}: byte not written"
                );
            }
            settled_pixels += settled.iter().filter(|&&b| b == 1).count();
            previous = Some(core::mem::replace(&mut input, got));
        }
    }
    // Both the median and the settled shortcut must have had work to do.
    assert!(moved > 100, "only {moved} pixels moved");
    assert!(
        settled_pixels > 1000,
        "only {settled_pixels} settled pixels"
    );
    let stage = stage_for(16, 16, MedianParams::default());
    let views = [0u8; 256];
    let guide = View::new(&views, 16, 16, 1, 16).unwrap();
    let mut out = [0.0f32; 256];
    let mut scratch = vec![0.0; scratch_len(stage.setup())];
    let map = [0.0f32; 256];
    assert!(matches!(
        filter_pass(
            stage.setup(),
            PassInput {
                guide: &guide,
                input: &map,
                previous: None
            },
            0..16,
            &mut out,
            &mut [0; 255],
            &mut scratch
        ),
        Err(Error::OutputSize { .. })
    ));
    assert!(matches!(
        filter_pass(
            stage.setup(),
            PassInput {
                guide: &guide,
                input: &map,
                previous: Some(&[0.0; 255])
            },
            0..16,
            &mut out,
            &mut [0; 256],
            &mut scratch
        ),
        Err(Error::OutputSize { .. })
    ));
}
