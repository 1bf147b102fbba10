//! An independent reference of the median, written from the stage's definition
//! (docs/stages/median.md, the module docs of `median`) and sharing nothing with the
//! stage but its parameters: for every pixel, every vote of its window is weighed and
//! classified, the gate and the two sampled phases are applied to the sums, the votes
//! are sorted and the weighted median read off, and the thin-structure test searches
//! the window breadth first. Slow and plain: no ring, no lanes, no early exit, no
//! quickselect.
//!
//! The one freedom the definition leaves is the sign of a median of zero: `−0` and `+0`
//! are the same vote (they compare equal), and which of the two the stage's selection
//! returns depends on where its pivots fall. [`same`] accepts either.

use core::ops::Range;

use super::*;

/// A window's vote: its value, its colour weight and its row distance from the pixel.
#[derive(Clone, Copy)]
struct Vote {
    value: f32,
    weight: u64,
    distance: usize,
}

/// Whether the stage's value `got` is the reference's `expected`: the same bits, or
/// both zero (the sign of a median of zero is not defined; see the module docs).
pub(super) fn same(got: f32, expected: f32) -> bool {
    got.to_bits() == expected.to_bits() || (got == 0.0 && expected == 0.0)
}

/// Every pass of the median (`params.passes`, none when the stage is off) over the
/// whole map `input` (row-major, `width · height`), guided by `guide`.
pub(super) fn reference_passes<S: Sample>(
    params: &MedianParams,
    guide: &View<'_, S>,
    input: &[f32],
) -> Vec<f32> {
    let passes = if params.enabled { params.passes } else { 0 };
    let mut map = input.to_vec();
    for _ in 0..passes {
        map = reference_pass(params, guide, &map);
    }
    map
}

/// One pass of the median over the whole map `input`, guided by `guide` (of the map's
/// width and height).
pub(super) fn reference_pass<S: Sample>(
    params: &MedianParams,
    guide: &View<'_, S>,
    input: &[f32],
) -> Vec<f32> {
    let (width, height) = (guide.width(), guide.height());
    assert_eq!(input.len(), width * height, "the map is the guide's size");
    let weights = ColourWeights::new(params.color_sigma);
    let mut out = input.to_vec();
    for y in 0..height {
        for x in 0..width {
            out[y * width + x] = pixel(params, guide, &weights, input, (width, height), x, y);
        }
    }
    out
}

/// The median's value at `(x, y)`.
fn pixel<S: Sample>(
    p: &MedianParams,
    guide: &View<'_, S>,
    weights: &ColourWeights,
    map: &[f32],
    (width, height): (usize, usize),
    x: usize,
    y: usize,
) -> f32 {
    let at = |xx: usize, yy: usize| map[yy * width + xx];
    let own = at(x, y);
    // Non-finite values are kept and never vote.
    if !own.is_finite() {
        return own;
    }
    let r = p.radius;
    let ys = y.saturating_sub(r)..(y + r + 1).min(height);
    let xs = x.saturating_sub(r)..(x + r + 1).min(width);
    if p.gate > 0.0 && !window_has_step(map, width, height, &ys, &xs, p.gate) {
        return own;
    }
    let centre = colour(guide, x, y);
    // Each finite neighbour votes: its value, extrapolated to the pixel along the map's
    // slope at the neighbour with planar votes.
    let vote_at = |xx: usize, yy: usize| -> Option<f32> {
        let v = at(xx, yy);
        if !v.is_finite() {
            return None;
        }
        Some(if p.planar {
            let (gx, gy) = slope(map, width, height, xx, yy, p.gate);
            v + gx * (x as f32 - xx as f32) + gy * (y as f32 - yy as f32)
        } else {
            v
        })
    };
    let weight_at = |xx: usize, yy: usize| weights.of(distance2(&centre, &colour(guide, xx, yy)));
    let mut votes = Vec::new();
    for yy in ys.clone() {
        for xx in xs.clone() {
            if let Some(value) = vote_at(xx, yy) {
                votes.push(Vote {
                    value,
                    weight: weight_at(xx, yy),
                    distance: y.abs_diff(yy),
                });
            }
        }
    }
    // Below, inside and above `own ± snap`, over the votes of the rows `rows` selects.
    let sums = |rows: &dyn Fn(usize) -> bool| {
        let (mut below, mut inside, mut above) = (0u64, 0u64, 0u64);
        for v in votes.iter().filter(|v| rows(v.distance)) {
            if v.value < own - p.snap {
                below += v.weight;
            } else if v.value > own + p.snap {
                above += v.weight;
            } else {
                inside += v.weight;
            }
        }
        (below, inside, above)
    };
    // The two sampled phases: on the rows at a distance divisible by 4, then on those at
    // an even distance, the pixel keeps its value when the votes outside `own ± snap`
    // weigh less than a ninth, then a third, of those rows on either side.
    for (rows, q) in [
        (&(|d: usize| d % 4 == 0) as &dyn Fn(usize) -> bool, 8),
        (&|d: usize| d % 2 == 0, 2),
    ] {
        let (below, inside, above) = sums(rows);
        if q * below < inside + above && q * above < inside + below {
            return own;
        }
    }
    // The weighted median: the smallest vote whose weight of votes at or below it
    // reaches half the window's weight.
    let mut weighed: Vec<Vote> = votes.iter().copied().filter(|v| v.weight > 0).collect();
    weighed.sort_by(|a, b| a.value.total_cmp(&b.value));
    let total: u64 = weighed.iter().map(|v| v.weight).sum();
    let half = total.div_ceil(2);
    let mut sum = 0;
    let m = weighed
        .iter()
        .find(|v| {
            sum += v.weight;
            sum >= half
        })
        .map_or(own, |v| v.value);
    // The snap: only a median further than `snap` from the pixel's value moves it.
    if (m - own).abs() <= p.snap {
        return own;
    }
    if p.thin > 0.0 && thin_structure(p, (&ys, &xs), (x, y), (own, m), vote_at, weight_at) {
        return own;
    }
    m
}

/// The thin-structure test of a pixel `(x, y)` of value `own` that the median would move
/// to `m`: the window's votes within `reach = max(snap, |m − own| / 2)` of `own`
/// joined to the pixel 8-connected (set J) are at least `r + 1` long (rows or columns
/// of their bounding box, L), number at most `thin · L`, and weigh on average at least
/// twice as much as the window's other votes (set O).
fn thin_structure(
    p: &MedianParams,
    (ys, xs): (&Range<usize>, &Range<usize>),
    (x, y): (usize, usize),
    (own, m): (f32, f32),
    vote_at: impl Fn(usize, usize) -> Option<f32>,
    weight_at: impl Fn(usize, usize) -> u64,
) -> bool {
    let reach = p.snap.max(0.5 * (m - own).abs());
    let near = |v: f32| v >= own - reach && v <= own + reach;
    let in_band = |xx: usize, yy: usize| vote_at(xx, yy).is_some_and(near);
    // Breadth first from the pixel through 8-neighbours in the band, inside the window.
    let mut joined = vec![(x, y)];
    let mut head = 0;
    while head < joined.len() {
        let (cx, cy) = joined[head];
        head += 1;
        for ny in cy.saturating_sub(1)..=cy + 1 {
            for nx in cx.saturating_sub(1)..=cx + 1 {
                if ys.contains(&ny)
                    && xs.contains(&nx)
                    && in_band(nx, ny)
                    && !joined.contains(&(nx, ny))
                {
                    joined.push((nx, ny));
                }
            }
        }
    }
    let extent = |coordinate: fn(&(usize, usize)) -> usize| {
        let lo = joined.iter().map(coordinate).min().unwrap();
        let hi = joined.iter().map(coordinate).max().unwrap();
        hi - lo + 1
    };
    let length = extent(|q| q.0).max(extent(|q| q.1));
    if length < p.radius + 1 || joined.len() as f32 > p.thin * length as f32 {
        return false;
    }
    let joined_weight: u64 = joined.iter().map(|&(xx, yy)| weight_at(xx, yy)).sum();
    let (mut others, mut others_weight) = (0u64, 0u64);
    for yy in ys.clone() {
        for xx in xs.clone() {
            if vote_at(xx, yy).is_some_and(|v| !near(v)) {
                others += 1;
                others_weight += weight_at(xx, yy);
            }
        }
    }
    // mean_J w ≥ 2 · mean_O w, without division.
    joined_weight * others >= 2 * others_weight * joined.len() as u64
}

/// Whether the window `ys` × `xs` holds a step above `gate` between adjacent pixels:
/// from each of its pixels to the right neighbour (also when that lies right of the
/// window) and to the lower neighbour when that is in the window too. A step is
/// `|b − a| > gate`: a NaN makes none (nor ∞ next to ∞), an infinite value next to a
/// finite one does.
fn window_has_step(
    map: &[f32],
    width: usize,
    height: usize,
    ys: &Range<usize>,
    xs: &Range<usize>,
    gate: f32,
) -> bool {
    let at = |xx: usize, yy: usize| map[yy * width + xx];
    let step = |a: f32, b: f32| (b - a).abs() > gate;
    ys.clone().any(|yy| {
        xs.clone().any(|xx| {
            (xx + 1 < width && step(at(xx, yy), at(xx + 1, yy)))
                || (yy + 1 < ys.end && yy + 1 < height && step(at(xx, yy), at(xx, yy + 1)))
        })
    })
}

/// The map's slope at `(x, y)`: per axis the mean of the backward and forward
/// differences, each left out when its neighbour is missing or non-finite or the step
/// exceeds `gate` (at least 1e-6, so that a gate of 0 still lets a flat map have
/// slope 0 from its equal neighbours); zero when both are out.
fn slope(map: &[f32], width: usize, height: usize, x: usize, y: usize, gate: f32) -> (f32, f32) {
    let at = |xx: usize, yy: usize| map[yy * width + xx];
    let v = at(x, y);
    let limit = gate.max(1e-6);
    let usable = |d: f32| d.is_finite() && d.abs() <= limit;
    let axis = |back: Option<f32>, forward: Option<f32>| {
        let back = back.map(|b| v - b).filter(|&d| usable(d));
        let forward = forward.map(|f| f - v).filter(|&d| usable(d));
        match (back, forward) {
            (Some(b), Some(f)) => (b + f) / 2.0,
            (Some(d), None) | (None, Some(d)) => d,
            (None, None) => 0.0,
        }
    };
    let gx = axis(
        (x > 0).then(|| at(x - 1, y)),
        (x + 1 < width).then(|| at(x + 1, y)),
    );
    let gy = axis(
        (y > 0).then(|| at(x, y - 1)),
        (y + 1 < height).then(|| at(x, y + 1)),
    );
    (gx, gy)
}

/// The guide's 8-bit levels at `(x, y)`: its first three channels (fewer when it has
/// fewer; the others are ignored).
fn colour<S: Sample>(guide: &View<'_, S>, x: usize, y: usize) -> Vec<i32> {
    let channels = guide.channels();
    let row = guide.row(y).expect("a guide row of the map");
    row[x * channels..x * channels + channels.min(3)]
        .iter()
        .map(|s| i32::from(s.level()))
        .collect()
}

/// The squared distance of two colours in 8-bit levels: a whole number.
fn distance2(a: &[i32], b: &[i32]) -> u32 {
    a.iter()
        .zip(b)
        .map(|(a, b)| ((a - b) * (a - b)) as u32)
        .sum()
}

/// The colour weights `exp(−d² / 2σ²)` (σ in 8-bit levels) as 16-bit values (units of
/// 1/65535) from a table of 256 bins of squared distance: bins one level² wide while 256
/// of them reach 12 · 2σ² (where the weight rounds to zero), else the narrowest
/// power-of-two width (at most 2²⁰) that reaches it, each bin's weight taken at its
/// middle; zero beyond the table, and at least 1 for the pixel's own colour.
struct ColourWeights {
    table: Vec<u64>,
    shift: u32,
}

impl ColourWeights {
    fn new(color_sigma: f32) -> Self {
        let sigma = color_sigma * 255.0;
        let two_sigma2 = 2.0 * sigma * sigma;
        let shift = (0..=20)
            .find(|&s| 256.0 * (1u32 << s) as f32 >= 12.0 * two_sigma2)
            .unwrap_or(20);
        let table = (0..256)
            .map(|bin| {
                let middle = if shift == 0 {
                    bin as f32
                } else {
                    (bin as f32 + 0.5) * (1u32 << shift) as f32
                };
                let w = libm::roundf(libm::expf(-middle / two_sigma2) * 65535.0) as u64;
                if bin == 0 {
                    w.max(1)
                } else {
                    w
                }
            })
            .collect();
        ColourWeights { table, shift }
    }

    fn of(&self, d2: u32) -> u64 {
        self.table
            .get((d2 >> self.shift) as usize)
            .copied()
            .unwrap_or(0)
    }
}
