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
//! Exact weights: colours enter as 8-bit levels, their squared distances are whole
//! numbers (computed in `f32` lanes, where they are exact), the weights come from a
//! 256-entry table of 16-bit values built once per call, and sums and selection are
//! integer, so no result depends on the order of operations. A pixel's result depends
//! only on the input within `radius + 1` pixels, so bands are independent and the map is
//! bit-identical for any banding. How most pixels are settled without weighing their
//! whole window: `pixel.rs`; how later passes skip what did not change:
//! [`filter_rows_again`].

use core::ops::Range;

mod gate;
mod passes;
mod pixel;
mod ring;
mod select;
mod support;
mod weights;

use crate::error::{check_scratch, Error, Result};
use crate::lightfield::{Sample, View};
use crate::setup::{Setup, StageParams};

use gate::{ColumnCounts, LastFlagged, QuarterRowCounts};
use pixel::{RowIndices, RowOrder, Window};
use ring::RowRing;
use weights::Weights;

pub use passes::{band_scratch_len, filter_band, halo};

/// Progress stage name.
pub const STAGE: &str = "median";
/// Most passes.
pub const MAX_PASSES: usize = 4;
/// Largest window radius (px).
pub const MAX_RADIUS: usize = 7;
const MAX_TAPS: usize = (2 * MAX_RADIUS + 1) * (2 * MAX_RADIUS + 1);
/// Most columns (and rows) of a window.
const SPAN: usize = 2 * MAX_RADIUS + 1;
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
    /// Thin structures: a pixel the median would move keeps its value when the
    /// neighbours whose votes lie within `snap` of it, joined to it 8-connected, cross
    /// its window from side to side with a mean width of at most this (px): a pole or a
    /// wire that the EPI stage and the refinement found, which fills too small a part
    /// of any window to hold its median (`support.rs`). 0 switches the test off.
    pub thin: f32,
}

impl Default for MedianParams {
    fn default() -> Self {
        // Chosen by measurement (docs/stages/median.md) on the HCI scenes and the seven
        // synthetic ones, where it lowers BadPix0.07 on every scene: four passes before
        // TV move fattened bands of up to ~5 px back onto their colour edges; σ = 0.04
        // (10 levels) separates the sides of soft edges; the 0.2 px step gate skips
        // smooth regions; planar votes and the 0.2 px snap keep curved surfaces (sphere
        // rims) as the refinement measured them; the thin-structure test (3 px) keeps
        // poles and wires, chosen on the realistic suite and HCI together.
        MedianParams {
            enabled: true,
            before_tv: true,
            passes: 4,
            radius: 7,
            color_sigma: 0.04,
            gate: 0.2,
            snap: 0.2,
            planar: true,
            thin: 3.0,
        }
    }
}

impl StageParams for MedianParams {
    fn validate(&self) -> Result<()> {
        MedianParams::validate(self)
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
        if !(self.thin.is_finite() && (0.0..=16.0).contains(&self.thin)) {
            return bad(
                "median.thin",
                "must be in [0, 16] pixels (0 switches the thin-structure test off)",
            );
        }
        Ok(())
    }
}

fn check<S: Sample>(
    setup: Setup<'_, MedianParams>,
    guide: &View<'_, S>,
    input: &[f32],
) -> Result<(usize, usize)> {
    setup.params().validate()?;
    let (w, h) = (setup.layout().width, setup.layout().height);
    if guide.width() != w || guide.height() != h {
        return Err(Error::InvalidParameter {
            name: "guide",
            reason: "must be the centre view of the planned light field (same width and height)",
        });
    }
    if input.len() != setup.pixels() {
        return Err(Error::OutputSize {
            what: "the median input disparity",
            needed: setup.pixels(),
            got: input.len(),
        });
    }
    Ok((w, h))
}

/// Scratch (`f32` elements) of [`filter_rows`], [`filter_rows_again`], [`filter_pass`]
/// and [`filter`]: three counts per column (window rows with a step, rows changed since
/// the previous pass within the window's reach and near its quarter rows) plus every window row's values, slopes and colour levels, padded by 22 columns:
/// `3 · width + 90 · (width + 22)`.
pub fn scratch_len(setup: Setup<'_, MedianParams>) -> usize {
    let width = setup.layout().width;
    width
        .saturating_mul(3)
        .saturating_add(ring::ring_len(width))
}

/// Filters the image rows `rows` of `input` (row-major, `setup.pixels()`) into `out`
/// (`rows.len() · width`, row-major) with the weighted median guided by `guide`.
/// `scratch` needs [`scratch_len`] elements. Non-finite input values are passed through
/// untouched and never enter a neighbour's median.
pub fn filter_rows<S: Sample>(
    setup: Setup<'_, MedianParams>,
    guide: &View<'_, S>,
    input: &[f32],
    rows: Range<usize>,
    out: &mut [f32],
    scratch: &mut [f32],
) -> Result<()> {
    let reads = PassInput {
        guide,
        input,
        previous: None,
    };
    run(setup, reads, rows, out, None, scratch)
}

/// [`filter_rows`] for a pass after the first, `previous` being the previous pass's
/// input (so that `input` is its output): the same result, faster. A pixel's value
/// depends only on the input within `radius + 1` pixels of it (the window, and the
/// neighbours its slopes and steps read), so where that holds the same values as in
/// `previous`, the previous pass computed this pixel from the same values, and it keeps
/// its value; after the first pass only pixels near the ones that moved are filtered.
pub fn filter_rows_again<S: Sample>(
    setup: Setup<'_, MedianParams>,
    guide: &View<'_, S>,
    input: &[f32],
    previous: &[f32],
    rows: Range<usize>,
    out: &mut [f32],
    scratch: &mut [f32],
) -> Result<()> {
    let reads = PassInput {
        guide,
        input,
        previous: Some(previous),
    };
    run(setup, reads, rows, out, None, scratch)
}

/// What one pass of the median reads.
#[derive(Clone, Copy, Debug)]
pub struct PassInput<'a, 'g, S: Sample> {
    /// The colour guide (the centre view).
    pub guide: &'a View<'g, S>,
    /// The map the pass filters (row-major, `setup.pixels()`).
    pub input: &'a [f32],
    /// The previous pass's input (so that `input` is its output), or `None` in the first
    /// pass.
    pub previous: Option<&'a [f32]>,
}

/// One pass of [`filter_rows`] (`reads.previous: None`, the first pass) or
/// [`filter_rows_again`] (`reads.previous`: the previous pass's input) that also
/// remembers, per pixel, whether the first phase of its decision settled it: the rows of
/// its window at a distance from its own divisible by 4 kept its value (`pixel.rs`). The
/// same output, faster again in later passes: a pixel so settled in the previous pass
/// keeps its value when the rows that first phase reads (those rows and the rows next
/// to them, whose values enter their slopes, over the window's columns and one more on
/// either side) hold the same values as in `previous`, because the phase then sees the
/// same votes and weights and keeps it again.
///
/// `settled` holds one byte per pixel of `rows` (row-major, `rows.len() · width`): the
/// pass writes it, and with `previous` it first reads what the previous pass's call
/// for the same pixels wrote there (any banding; each pixel's byte is its own). Bytes
/// not written by the previous pass make the output wrong, not an error.
pub fn filter_pass<S: Sample>(
    setup: Setup<'_, MedianParams>,
    reads: PassInput<'_, '_, S>,
    rows: Range<usize>,
    out: &mut [f32],
    settled: &mut [u8],
    scratch: &mut [f32],
) -> Result<()> {
    if settled.len() != out.len() {
        return Err(Error::OutputSize {
            what: "the median's settled pixels (one byte per pixel of the band)",
            needed: out.len(),
            got: settled.len(),
        });
    }
    run(setup, reads, rows, out, Some(settled), scratch)
}

fn run<S: Sample>(
    setup: Setup<'_, MedianParams>,
    reads: PassInput<'_, '_, S>,
    rows: Range<usize>,
    out: &mut [f32],
    mut settled: Option<&mut [u8]>,
    scratch: &mut [f32],
) -> Result<()> {
    let PassInput {
        guide,
        input,
        previous,
    } = reads;
    if let Some(previous) = previous {
        if previous.len() != input.len() {
            return Err(Error::OutputSize {
                what: "the median's previous input",
                needed: input.len(),
                got: previous.len(),
            });
        }
    }
    let (width, height) = check(setup, guide, input)?;
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
    let needed = scratch_len(setup);
    check_scratch(needed, scratch.len())?;
    let too_small = Error::ScratchTooSmall {
        needed,
        got: scratch.len(),
    };
    let (step_counts, rest) = scratch[..needed]
        .split_at_mut_checked(width)
        .ok_or(too_small)?;
    let (change_counts, rest) = rest.split_at_mut_checked(width).ok_or(too_small)?;
    let (quarter_counts, ring) = rest.split_at_mut_checked(width).ok_or(too_small)?;
    let p = *setup.params();
    let weights = Weights::new(p.color_sigma);
    let r = p.radius;
    let gated = p.gate > 0.0;
    let mut steps = ColumnCounts::new(step_counts);
    let mut changes = ColumnCounts::new(change_counts);
    let mut quarter_changes = QuarterRowCounts::new(quarter_counts, r, height);
    // Pixels settled in the previous pass stay settled while their rows do not change.
    let recheck = previous.is_some() && settled.is_some();
    let mut ring = RowRing::new(ring, width);
    let offsets = pixel::lane_offsets(r);
    let mut indices: RowIndices = [[0; ring::LANES]; SPAN];
    // The window's row order for (rows, the pixels' row in it).
    let mut order = ((0, 0), RowOrder::new(0, 0));
    let count_steps = |yy: usize, counts: &mut [f32], delta: f32| {
        gate::count_steps(input, width, p.gate, yy, counts, delta);
    };
    // `max(1)`: a layout has pixels (`check`); an empty row would have nothing to cut.
    for (i, (o, y)) in out.chunks_exact_mut(width.max(1)).zip(rows).enumerate() {
        let mut settled_row = settled
            .as_deref_mut()
            .and_then(|s| s.get_mut(i * width..(i + 1) * width));
        let row = input
            .get(y * width..(y + 1) * width)
            .ok_or(Error::OutOfRange {
                what: "median input row",
                index: y,
                len: height,
            })?;
        for (o, &v) in o.iter_mut().zip(row) {
            *o = v;
        }
        let ys = y.saturating_sub(r)..(y + r + 1).min(height);
        let last = ys.end - 1;
        // Rows whose step below lies inside the window, and the last one's right steps.
        if gated {
            steps.slide_to(ys.start..last, count_steps);
        }
        let last_row = input.get(last * width..(last + 1) * width).unwrap_or(&[]);
        let column_has_step = |c: usize| steps.any(c) || gate::right_step(last_row, c, p.gate);
        // What the pixel's value depends on: radius + 1 around it.
        let reach = r + 1;
        if let Some(previous) = previous {
            let count_changes = |yy: usize, counts: &mut [f32], delta: f32| {
                gate::count_changes(input, previous, width, yy, counts, delta);
            };
            changes.slide_to(
                y.saturating_sub(reach)..(y + reach + 1).min(height),
                count_changes,
            );
            if recheck {
                quarter_changes.move_to(y, count_changes);
            }
        }
        let mut loaded = false;
        // Per window row: where it lives in the ring, and `y − yy`; the order of the
        // rows is that of the row before unless the window meets the image's edge.
        let shape = (ys.len(), y - ys.start);
        if order.0 != shape {
            order = (shape, RowOrder::new(shape.0, shape.1));
        }
        let mut bases = [0usize; SPAN];
        let mut dys = [0.0f32; SPAN];
        for ((base, dy), yy) in bases.iter_mut().zip(dys.iter_mut()).zip(ys.clone()) {
            *base = ring.base(yy);
            *dy = y as f32 - yy as f32;
        }
        // What every pixel of the row shares (the ring is passed to each decision, as
        // the row's window rows enter it only when a pixel first needs them).
        let window = Window {
            input,
            width,
            height,
            guide,
            bases: &bases,
            dys: &dys,
            offsets,
            weights: &weights,
            params: p,
            order: &order.1,
        };
        // The runs of pixels with a change within their reach (all of them in a first
        // pass); the others keep their value and their `settled` byte.
        let mut from = 0;
        while from < width {
            let span = match previous {
                Some(_) => match gate::changed_span(|c| changes.any(c), from, reach, width) {
                    Some(span) => span,
                    None => break,
                },
                None => 0..width,
            };
            from = span.end;
            let mut step_column =
                LastFlagged::at(span.start, r, width, |c| gated && column_has_step(c));
            let mut quarter_column =
                LastFlagged::at(span.start, reach, width, |c| quarter_changes.any(c));
            let (Some(o), Some(row)) = (o.get_mut(span.clone()), row.get(span.clone())) else {
                break;
            };
            for (x, (o, &own)) in span.zip(o.iter_mut().zip(row)) {
                let has_step = step_column.step(x, width, |c| gated && column_has_step(c));
                let quarter_changed =
                    recheck && quarter_column.step(x, width, |c| quarter_changes.any(c));
                let flag = settled_row.as_deref_mut().and_then(|s| s.get_mut(x));
                if recheck && !quarter_changed && flag.as_deref() == Some(&1) {
                    continue;
                }
                if !own.is_finite() || (gated && !has_step) {
                    // A non-finite value is always kept; a window without a step may gain one.
                    if let Some(flag) = flag {
                        *flag = u8::from(!own.is_finite());
                    }
                    continue;
                }
                // The window rows enter the ring when a pixel of this row first needs them.
                if !loaded {
                    for yy in ys.clone() {
                        ring.load(input, guide, yy, p.gate, p.planar);
                    }
                    loaded = true;
                }
                let by_quarter_rows;
                (*o, by_quarter_rows) = window.value(&ring, x, y, own, &mut indices);
                if let Some(flag) = flag {
                    *flag = u8::from(by_quarter_rows);
                }
            }
        }
    }
    Ok(())
}

/// The whole map: `out` (row-major, `setup.pixels()`) from `input`.
pub fn filter<S: Sample>(
    setup: Setup<'_, MedianParams>,
    guide: &View<'_, S>,
    input: &[f32],
    out: &mut [f32],
    scratch: &mut [f32],
) -> Result<()> {
    filter_rows(setup, guide, input, 0..setup.layout().height, out, scratch)
}

#[cfg(test)]
mod tests;
