//! Edge-snapping weighted median of the disparity, guided by the centre view.
//!
//! Both the structure tensor and the photometric refinement measure disparity over a
//! window. Next to a depth edge whose background is weakly textured, the foreground's
//! disparity fits the background pixels just as well (a flat background matches at any
//! disparity) while the true background disparity is half occluded, so the foreground
//! "fattens" by a few pixels into the background. Nothing in the views can undo that;
//! the centre view's colour edges can: depth edges of real scenes sit on colour edges.
//!
//! Each pixel takes the weighted median of the disparities in a `(2r+1)²` window, each
//! neighbour weighted by its colour similarity `exp(−‖I_p − I_q‖² / 2σ²)` to the pixel
//! (Ma et al., "Constant time weighted median filtering for stereo matching and
//! beyond", ICCV 2013, use the same weights). A pixel separated from the foreground by a
//! colour edge gathers almost all its weight from its own side of that edge, so the
//! fattened band returns to the background's disparity; on a smooth surface the median
//! of a symmetric window is the pixel's own disparity, so slants are kept.
//!
//! Integers only in the inner loop: colours enter as 8-bit levels, the weights come from
//! a 256-entry table of 16-bit values built once per call, so the stage is exact and
//! runs alike on a microcontroller without FPU. The result of a pixel depends only on
//! its window, so bands are independent and the map is bit-identical for any banding.

use core::ops::Range;

use crate::error::{Error, Result};
use crate::lightfield::{Sample, View};
use crate::plan::Plan;

/// Progress stage name.
pub const STAGE: &str = "median";
/// Most passes.
pub const MAX_PASSES: usize = 4;
/// Largest window radius (px).
pub const MAX_RADIUS: usize = 7;
const MAX_TAPS: usize = (2 * MAX_RADIUS + 1) * (2 * MAX_RADIUS + 1);
const TABLE: usize = 256;

/// Parameters of the weighted median.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MedianParams {
    /// Run the stage.
    pub enabled: bool,
    /// Where it runs: between the refinement and TV (`true`) or after TV.
    pub before_tv: bool,
    /// Passes of the filter, 1…[`MAX_PASSES`]: each pass moves a fattened band a
    /// window further back onto its colour edge.
    pub passes: usize,
    /// Window radius (px), 1…[`MAX_RADIUS`].
    pub radius: usize,
    /// Colour scale σ of the weights (unit intensity, per channel), 0.005…0.5.
    pub color_sigma: f32,
    /// Pixels whose window holds no step between adjacent pixels larger than this (px)
    /// are left as they are: the median only matters at depth edges, and a smooth slant
    /// (small steps, however long) keeps its exact values. 0 filters every pixel.
    pub gate: f32,
    /// A pixel takes the median only when it differs from its own value by more than
    /// this (px): fattened bands differ by a depth jump, while on curved surfaces the
    /// median of a window is off by a few hundredths and the pixel's own value is better.
    pub snap: f32,
    /// Each neighbour votes for its value extrapolated to the pixel along the map's
    /// local slope (central differences, zero across steps above the gate), so the
    /// median of a slanted or curved surface is unbiased.
    pub planar: bool,
}

impl Default for MedianParams {
    fn default() -> Self {
        // Chosen by measurement (docs/bench-median.md) on the HCI scenes and the seven
        // synthetic ones, where it lowers BadPix0.07 on every scene: four passes before
        // TV move fattened bands of up to ~5 px back onto their colour edges; σ = 0.04
        // (10 levels) separates the sides of soft edges; the 0.2 px step gate skips
        // smooth regions; planar votes and the 0.2 px snap keep curved surfaces (sphere
        // rims) as the refinement measured them.
        MedianParams {
            enabled: true,
            before_tv: true,
            passes: 4,
            radius: 7,
            color_sigma: 0.04,
            gate: 0.2,
            snap: 0.2,
            planar: true,
        }
    }
}

impl MedianParams {
    /// The stage switched off (the paper's pipeline has no such step).
    pub fn off() -> Self {
        MedianParams {
            enabled: false,
            ..Self::default()
        }
    }

    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, reason| Err(Error::InvalidParameter { name, reason });
        if !(1..=MAX_PASSES).contains(&self.passes) {
            return bad("median.passes", "must be in 1..=4");
        }
        if !(1..=MAX_RADIUS).contains(&self.radius) {
            return bad("median.radius", "must be in 1..=7 pixels");
        }
        if !(self.color_sigma.is_finite() && (0.005..=0.5).contains(&self.color_sigma)) {
            return bad(
                "median.color_sigma",
                "must be in [0.005, 0.5] (unit intensity)",
            );
        }
        if !(self.snap.is_finite() && (0.0..=16.0).contains(&self.snap)) {
            return bad("median.snap", "must be in [0, 16] pixels");
        }
        if !(self.gate.is_finite() && (0.0..=16.0).contains(&self.gate)) {
            return bad("median.gate", "must be in [0, 16] pixels");
        }
        Ok(())
    }
}

/// Colour-distance weights: `table[d² >> shift]` for the squared 8-bit colour distance
/// `d²`, in units of 1/65535.
struct Weights {
    table: [u16; TABLE],
    shift: u32,
}

impl Weights {
    fn new(color_sigma: f32) -> Self {
        let sigma = color_sigma * 255.0;
        let two_sigma2 = 2.0 * sigma * sigma;
        // The table reaches 12·2σ², where the weight (e^−12 ≈ 6e−6) rounds to zero.
        let reach = 12.0 * two_sigma2;
        let mut shift = 0u32;
        while ((TABLE as f32) * (1u32 << shift) as f32) < reach && shift < 20 {
            shift += 1;
        }
        let mut table = [0u16; TABLE];
        for (i, w) in table.iter_mut().enumerate() {
            // The bin's mid value, so the table is unbiased within a bin.
            let d2 = if shift == 0 {
                i as f32
            } else {
                (i as f32 + 0.5) * (1u32 << shift) as f32
            };
            let v = libm::expf(-d2 / two_sigma2) * 65535.0;
            *w = libm::roundf(v) as u16;
        }
        // The pixel itself always counts fully.
        table[0] = table[0].max(1);
        Weights { table, shift }
    }

    #[inline(always)]
    fn get(&self, d2: u32) -> u32 {
        self.table
            .get((d2 >> self.shift) as usize)
            .map_or(0, |&w| u32::from(w))
    }
}

fn check<S: Sample>(plan: &Plan, guide: &View<'_, S>, input: &[f32]) -> Result<(usize, usize)> {
    plan.params().median.validate()?;
    let (w, h) = (plan.layout().width, plan.layout().height);
    if guide.width() != w || guide.height() != h {
        return Err(Error::InvalidParameter {
            name: "guide",
            reason: "must be the centre view of the planned light field (same width and height)",
        });
    }
    if input.len() != plan.pixels() {
        return Err(Error::OutputSize {
            what: "the median input disparity",
            needed: plan.pixels(),
            got: input.len(),
        });
    }
    Ok((w, h))
}

/// Rows of slopes kept: one per window row.
const SLOPE_ROWS: usize = 2 * MAX_RADIUS + 1;

/// Scratch (`f32` elements) of [`filter_rows`] and [`filter`]: the steps of one row plus
/// the slopes (x and y) of every window row, `(1 + 2 · SLOPE_ROWS) · width`.
pub fn scratch_len(plan: &Plan) -> usize {
    plan.layout().width.saturating_mul(1 + 2 * SLOPE_ROWS)
}

/// Filters the image rows `rows` of `input` (row-major, `plan.pixels()`) into `out`
/// (`rows.len() · width`, row-major) with the weighted median guided by `guide`.
/// `scratch` needs [`scratch_len`] elements. Non-finite input values are passed through
/// untouched and never enter a neighbour's median.
pub fn filter_rows<S: Sample>(
    plan: &Plan,
    guide: &View<'_, S>,
    input: &[f32],
    rows: Range<usize>,
    out: &mut [f32],
    scratch: &mut [f32],
) -> Result<()> {
    let (width, height) = check(plan, guide, input)?;
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
    let needed = scratch_len(plan);
    if scratch.len() < needed {
        return Err(Error::ScratchTooSmall {
            needed,
            got: scratch.len(),
        });
    }
    let (column_steps, slopes) = scratch[..needed].split_at_mut(width);
    // Slopes of image row `yy` live in slot `yy % SLOPE_ROWS` (x then y, `width` each),
    // computed when the row first enters a window: each row once per call.
    let mut slot_row = [usize::MAX; SLOPE_ROWS];
    let p = plan.params().median;
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
            for yy in ys.clone() {
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
                        total += u64::from(w);
                        if v < own - p.snap {
                            below += u64::from(w);
                        } else if v > own + p.snap {
                            above += u64::from(w);
                        }
                        n += 1;
                    }
                }
            }
            // The median lies within `snap` of the pixel's value (which then stays)
            // unless the weight beyond `own ± snap` on one side reaches half: a linear
            // test that spares most pixels the selection.
            let half = total.div_ceil(2);
            if n > 0 && (below >= half || total - above < half) {
                let m = weighted_median(&mut values[..n], &mut taps[..n], half);
                if (m - own).abs() > p.snap {
                    *o = m;
                }
            }
        }
    }
    Ok(())
}

/// For every column `x`, the largest step inside the rows `ys` from a pixel to its right
/// and lower neighbour (the lower one only inside `ys`): a window holds a step larger than
/// the gate exactly when one of its columns does (up to steps leaving it to the right).
/// Non-finite values are no steps.
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

/// The map's slope at `(x, y)` by central differences; a side whose step exceeds `gate`
/// (a depth edge) is left out, and a slope with both sides out is zero.
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

/// The whole map: `out` (row-major, `plan.pixels()`) from `input`.
pub fn filter<S: Sample>(
    plan: &Plan,
    guide: &View<'_, S>,
    input: &[f32],
    out: &mut [f32],
    scratch: &mut [f32],
) -> Result<()> {
    filter_rows(plan, guide, input, 0..plan.layout().height, out, scratch)
}

/// The smallest value `v` whose weight of values `≤ v` reaches `half` (weighted
/// quickselect with three-way partitions; `values` and `weights` are reordered).
/// `half` must be at most the total weight and the slices non-empty and equally long.
fn weighted_median(values: &mut [f32], weights: &mut [u32], half: u64) -> f32 {
    let (mut lo, mut hi) = (0usize, values.len());
    let mut below = 0u64;
    while hi > lo {
        let slice = lo..hi;
        let pivot = median_of_three(
            values[slice.start],
            values[slice.start + slice.len() / 2],
            values[slice.end - 1],
        );
        // Dutch-flag partition of [lo, hi): < pivot | == pivot | > pivot.
        let (mut lt, mut i, mut gt) = (lo, lo, hi);
        while i < gt {
            let v = values[i];
            if v < pivot {
                values.swap(i, lt);
                weights.swap(i, lt);
                lt += 1;
                i += 1;
            } else if v > pivot {
                gt -= 1;
                values.swap(i, gt);
                weights.swap(i, gt);
            } else {
                i += 1;
            }
        }
        let w_less: u64 = weights[lo..lt].iter().map(|&w| u64::from(w)).sum();
        let w_equal: u64 = weights[lt..gt].iter().map(|&w| u64::from(w)).sum();
        if below + w_less >= half {
            hi = lt;
        } else if below + w_less + w_equal >= half {
            return pivot;
        } else {
            below += w_less + w_equal;
            lo = gt;
        }
    }
    // Only reached when `half` exceeds the total weight: the largest value.
    values.iter().copied().fold(f32::MIN, f32::max)
}

#[inline(always)]
fn median_of_three(a: f32, b: f32, c: f32) -> f32 {
    a.max(b).min(a.min(b).max(c))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::{Grid, Layout, LightField};
    use crate::plan::Params;

    fn brute(values: &[f32], weights: &[u32]) -> f32 {
        let mut pairs: [(f32, u32); 64] = [(0.0, 0); 64];
        let n = values.len();
        for i in 0..n {
            pairs[i] = (values[i], weights[i]);
        }
        pairs[..n].sort_by(|a, b| a.0.total_cmp(&b.0));
        let total: u64 = weights.iter().map(|&w| u64::from(w)).sum();
        let half = total.div_ceil(2);
        let mut acc = 0u64;
        for (v, w) in &pairs[..n] {
            acc += u64::from(*w);
            if acc >= half {
                return *v;
            }
        }
        unreachable!()
    }

    #[test]
    fn weighted_median_matches_sorting() {
        let mut state = 12345u32;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            state >> 8
        };
        for trial in 0..500 {
            let n = 1 + trial % 40;
            let mut v = [0.0f32; 64];
            let mut w = [0u32; 64];
            for i in 0..n {
                // Few distinct values, so ties are common.
                v[i] = (next() % 7) as f32 * 0.25 - 0.5;
                w[i] = 1 + next() % 1000;
            }
            let expected = brute(&v[..n], &w[..n]);
            let total: u64 = w[..n].iter().map(|&x| u64::from(x)).sum();
            let got = weighted_median(&mut v[..n], &mut w[..n], total.div_ceil(2));
            assert_eq!(got, expected, "trial {trial}");
        }
    }

    fn plan_for(width: usize, height: usize, params: MedianParams) -> Plan {
        let layout = Layout::packed(Grid::new(3, 3), width, height, 1);
        let p = Params {
            median: params,
            ..Params::default()
        };
        Plan::new(layout, p).unwrap()
    }

    /// A vertical colour edge at x = 16 (dark left, bright right) and a disparity edge
    /// fattened 3 px into the dark side: the median moves the depth edge onto the colour
    /// edge and leaves everything else alone.
    #[test]
    fn fattened_depth_edge_snaps_to_colour_edge() {
        let (w, h) = (32usize, 24usize);
        let plan = plan_for(w, h, MedianParams::default());
        let mut views = [0u8; 9 * 32 * 24];
        let centre = 4 * w * h;
        for y in 0..h {
            for x in 0..w {
                views[centre + y * w + x] = if x < 16 { 40 } else { 200 };
            }
        }
        let lf = LightField::new(&views, *plan.layout()).unwrap();
        let mut input = [0.0f32; 32 * 24];
        for y in 0..h {
            for x in 0..w {
                input[y * w + x] = if x >= 13 { 1.5 } else { -0.5 };
            }
        }
        let mut out = [0.0f32; 32 * 24];
        filter(
            &plan,
            &lf.center_view(),
            &input,
            &mut out,
            &mut [0.0; 32 * 31],
        )
        .unwrap();
        for y in 0..h {
            for x in 0..w {
                let want = if x >= 16 { 1.5 } else { -0.5 };
                assert_eq!(out[y * w + x], want, "({x}, {y})");
            }
        }
    }

    #[test]
    fn smooth_ramp_is_kept_and_bands_are_bit_identical() {
        let (w, h) = (24usize, 20usize);
        // No gate: every pixel goes through the median.
        let plan = plan_for(
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
        let lf = LightField::new(&views, *plan.layout()).unwrap();
        let mut input = [0.0f32; 24 * 20];
        for y in 0..h {
            for x in 0..w {
                input[y * w + x] = 0.01 * x as f32 + 0.02 * y as f32;
            }
        }
        let mut whole = [0.0f32; 24 * 20];
        filter(
            &plan,
            &lf.center_view(),
            &input,
            &mut whole,
            &mut [0.0; 24 * 31],
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
                &plan,
                &lf.center_view(),
                &input,
                start..end,
                &mut banded[start * w..end * w],
                &mut [0.0; 24 * 31],
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
            let p = Params {
                median: bad,
                ..Params::default()
            };
            assert!(matches!(
                Plan::new(layout, p),
                Err(Error::InvalidParameter { .. })
            ));
        }
        let plan = plan_for(16, 16, MedianParams::default());
        let views = [0u8; 9 * 256];
        let lf = LightField::new(&views, *plan.layout()).unwrap();
        let input = [0.0f32; 256];
        let mut out = [0.0f32; 255];
        assert!(filter(
            &plan,
            &lf.center_view(),
            &input,
            &mut out,
            &mut [0.0; 16 * 31]
        )
        .is_err());
        let mut out = [0.0f32; 256];
        assert!(filter(
            &plan,
            &lf.center_view(),
            &input[..10],
            &mut out,
            &mut [0.0; 16 * 31]
        )
        .is_err());
        assert!(matches!(
            filter(
                &plan,
                &lf.center_view(),
                &input,
                &mut out,
                &mut [0.0; 16 * 31 - 1]
            ),
            Err(Error::ScratchTooSmall { .. })
        ));
        assert!(filter_rows(
            &plan,
            &lf.center_view(),
            &input,
            10..17,
            &mut out[..112],
            &mut [0.0; 16 * 31]
        )
        .is_err());
    }

    #[test]
    fn non_finite_values_pass_through_and_stay_out_of_neighbours() {
        let plan = plan_for(16, 16, MedianParams::default());
        let views = [128u8; 9 * 256];
        let lf = LightField::new(&views, *plan.layout()).unwrap();
        let mut input = [0.25f32; 256];
        input[17] = f32::NAN;
        input[40] = f32::INFINITY;
        let mut out = [0.0f32; 256];
        filter(
            &plan,
            &lf.center_view(),
            &input,
            &mut out,
            &mut [0.0; 32 * 31],
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
}
