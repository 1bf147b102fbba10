//! The serial stage: both directions over every line of the light field, fused into
//! row-major maps, with progress reports and cancellation.

use core::ops::ControlFlow;

use super::band_estimator::{write_line, BandEstimator};
use super::{
    check_layout, fuse, hypotheses, scratch_len, Direction, EpiParams, Hypotheses, VERTICAL_TILE,
};
use crate::error::{check_scratch, Error, Result};
use crate::float::clamp_f32;
use crate::lightfield::{LightField, Sample};
use crate::progress::Progress;
use crate::scalar::Scalar;
use crate::setup::Setup;

/// Lines per progress report.
const PROGRESS_LINES: usize = 32;

type ProgressFn<'f> = dyn FnMut(Progress) -> ControlFlow<()> + 'f;

fn report(
    progress: &mut ProgressFn<'_>,
    stage: &'static str,
    done: usize,
    total: usize,
) -> Result<()> {
    match progress(Progress {
        stage,
        done: done as u64,
        total: total as u64,
    }) {
        ControlFlow::Continue(()) => Ok(()),
        ControlFlow::Break(()) => Err(Error::Cancelled),
    }
}

/// The serial stage with progress: both directions over every line, fused into
/// `disparity` / `confidence` (row-major, `setup.pixels()` each); a linear array's one
/// direction alone. Returns the hypotheses.
pub(crate) fn estimate_with_progress<T: Scalar, S: Sample>(
    setup: Setup<'_, EpiParams>,
    lf: &LightField<'_, S>,
    disparity: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
    progress: &mut ProgressFn<'_>,
) -> Result<Hypotheses> {
    check_layout(setup, lf)?;
    if setup.params().half_resolution {
        return Err(Error::InvalidParameter {
            name: "half_resolution",
            reason:
                "runs through the schedule (its upsampling is a step of its own): use pipeline::run",
        });
    }
    let pixels = setup.pixels();
    if disparity.len() != pixels || confidence.len() != pixels {
        return Err(Error::OutputSize {
            what: "the disparity/confidence map",
            needed: pixels,
            got: disparity.len().min(confidence.len()),
        });
    }
    let needed = scratch_len(setup);
    check_scratch(needed, scratch.len())?;
    report(progress, STAGE_RANGE, 0, 1)?;
    let hyps = hypotheses(setup, lf, scratch)?;
    report(progress, STAGE_RANGE, 1, 1)?;
    let horizontal = Direction::Horizontal.exists(setup.layout());
    if horizontal {
        estimate_rows(setup, &hyps, lf, disparity, confidence, scratch, progress)?;
    }
    if Direction::Vertical.exists(setup.layout()) {
        let maps = (disparity, confidence);
        estimate_columns(setup, &hyps, lf, horizontal, maps, scratch, progress)?;
    }
    Ok(hyps)
}

/// The horizontal lines of [`estimate_with_progress`], written into the maps.
fn estimate_rows<T: Scalar, S: Sample>(
    setup: Setup<'_, EpiParams>,
    hyps: &Hypotheses,
    lf: &LightField<'_, S>,
    disparity: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
    progress: &mut ProgressFn<'_>,
) -> Result<()> {
    let width = setup.layout().width;
    let height = setup.layout().height;
    let band = BandEstimator::new(setup, *hyps, lf, Direction::Horizontal);
    let (d_line, c_line, work) = band.split_scratch(scratch)?;
    for y in 0..height {
        if y % PROGRESS_LINES == 0 {
            report(progress, STAGE_HORIZONTAL, y, height)?;
        }
        band.line(y, work, d_line, c_line)?;
        let row = y * width..(y + 1) * width;
        // Both maps hold `pixels` values (checked by the caller): the skip never happens.
        let (Some(out_d), Some(out_c)) = (disparity.get_mut(row.clone()), confidence.get_mut(row))
        else {
            continue;
        };
        write_line(hyps, d_line, c_line, out_d, out_c);
    }
    report(progress, STAGE_HORIZONTAL, height, height)
}

/// The vertical lines of [`estimate_with_progress`], fused into the maps' horizontal
/// estimate when `horizontal` (the grid has one), else written as they are.
fn estimate_columns<T: Scalar, S: Sample>(
    setup: Setup<'_, EpiParams>,
    hyps: &Hypotheses,
    lf: &LightField<'_, S>,
    horizontal: bool,
    (disparity, confidence): (&mut [f32], &mut [f32]),
    scratch: &mut [T],
    progress: &mut ProgressFn<'_>,
) -> Result<()> {
    let width = setup.layout().width;
    let height = setup.layout().height;
    let fusion = setup.params().fusion;
    // Vertical lines in tiles of `VERTICAL_TILE` columns (their disparity lines, then
    // their confidence lines, before the band's work), each tile fused row by row.
    let band = BandEstimator::new(setup, *hyps, lf, Direction::Vertical);
    let n = band.n;
    let tile_len = VERTICAL_TILE * n;
    let too_small = Error::ScratchTooSmall {
        needed: scratch_len(setup),
        got: scratch.len(),
    };
    let (tile_d, rest) = scratch.split_at_mut_checked(tile_len).ok_or(too_small)?;
    let (tile_c, work) = rest.split_at_mut_checked(tile_len).ok_or(too_small)?;
    let (lo, hi) = (hyps.min(), hyps.max());
    for x0 in (0..width).step_by(VERTICAL_TILE) {
        let columns = VERTICAL_TILE.min(width - x0);
        // Indexed slices, not zipped `chunks_exact_mut`: the zip's length (a division by
        // the chunk size) kept a panic path in the firmware image.
        let line_len = n.max(1);
        for g in 0..columns {
            let lines = g * line_len..(g + 1) * line_len;
            let (Some(d_line), Some(c_line)) =
                (tile_d.get_mut(lines.clone()), tile_c.get_mut(lines))
            else {
                break;
            };
            let x = x0 + g;
            if x % PROGRESS_LINES == 0 {
                report(progress, STAGE_VERTICAL, x, width)?;
            }
            band.line(x, work, d_line, c_line)?;
        }
        for y in 0..height {
            let row = y * width + x0..y * width + x0 + columns;
            // Both maps hold `pixels` values (checked by the caller): the skip never
            // happens.
            let (Some(out_d), Some(out_c)) =
                (disparity.get_mut(row.clone()), confidence.get_mut(row))
            else {
                continue;
            };
            for (g, (d, c)) in out_d.iter_mut().zip(out_c.iter_mut()).enumerate() {
                let (Some(&dv), Some(&cv)) = (tile_d.get(g * n + y), tile_c.get(g * n + y)) else {
                    continue;
                };
                let (dv, cv) = (clamp_f32(dv.to_f32(), lo, hi), cv.to_f32().clamp(0.0, 1.0));
                (*d, *c) = if horizontal {
                    fuse(fusion, *d, *c, dv, cv)
                } else {
                    (dv, cv)
                };
            }
        }
    }
    report(progress, STAGE_VERTICAL, width, width)
}

/// Progress stage names.
pub const STAGE_RANGE: &str = "epi range";
/// See [`STAGE_RANGE`].
pub const STAGE_HORIZONTAL: &str = "epi horizontal";
/// See [`STAGE_RANGE`].
pub const STAGE_VERTICAL: &str = "epi vertical";
/// See [`STAGE_RANGE`].
pub const STAGE_UPSAMPLE: &str = "epi upsample";

/// The serial stage: disparity and confidence of the centre view (row-major, `f32`,
/// `setup.pixels()` each), computed in `T`. `scratch` needs [`scratch_len`] elements.
pub fn estimate<T: Scalar, S: Sample>(
    setup: Setup<'_, EpiParams>,
    lf: &LightField<'_, S>,
    disparity: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
) -> Result<Hypotheses> {
    estimate_with_progress(setup, lf, disparity, confidence, scratch, &mut |_| {
        ControlFlow::Continue(())
    })
}
