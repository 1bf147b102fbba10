//! Automatic disparity range: probe every `RANGE_LINE_STEP`-th line of both directions (the
//! one of a linear array) with
//! integer shears over the whole supported range, histogram the confident estimates and
//! keep the outermost 0.3 px windows holding at least 1 % of them, padded.

use super::hypotheses::Hypotheses;
use super::{check_layout, scratch_len, BandEstimator, ColorMode, Direction, EpiParams};
use crate::error::{check_scratch, Result};
use crate::lightfield::{LightField, Sample};
use crate::scalar::Scalar;
use crate::setup::Setup;

/// Every how many lines the range probe looks (16 rather than 8: a third of the probe's
/// time; the HCI ranges moved by at most one 0.05 px bin, docs/stages/epi.md).
pub const RANGE_LINE_STEP: usize = 16;
/// Probed disparities (integer shears ±PROBE_REACH, each accepting ±1 px residuals).
const PROBE_REACH: f32 = 4.0;
/// Only estimates at least this coherent enter the histogram.
const MIN_COHERENCE: f32 = 0.8;
/// Histogram resolution (px).
const BIN: f32 = 0.05;
const BINS: usize = 2 * ((PROBE_REACH + 1.0) / BIN) as usize;
/// Share of confident samples left out on each side, and the padding added back.
const TAIL: f32 = 0.01;
const CLUSTER: usize = 6;
const PAD: f32 = 0.2;
/// Samples this close to a line end see clamped (constant) views and are not probed.
const MARGIN: usize = 16;

/// Estimates the disparity range of the scene. `scratch` needs [`scratch_len`] elements.
/// Returns the supported extremes when too few samples are confident to tell.
pub fn estimate_range<T: Scalar, S: Sample>(
    setup: Setup<'_, EpiParams>,
    lf: &LightField<'_, S>,
    scratch: &mut [T],
) -> Result<(f32, f32)> {
    check_layout(setup, lf)?;
    let needed = scratch_len(setup);
    check_scratch(needed, scratch.len())?;
    let reach = PROBE_REACH + 1.0;
    let probe = Hypotheses::sheared(-PROBE_REACH, PROBE_REACH, 1.0, 1.0)?;
    let mut histogram = [0u32; BINS];
    let mut total = 0u64;
    // The probe runs on the gray mean of the channels (a third of the work of the colour
    // tensor; the range ends are padded histogram windows, docs/stages/epi.md), on
    // full-resolution lines whatever resolution the EPI stage then runs at (its lines
    // and disparities are the frame's).
    let gray = EpiParams {
        color: ColorMode::Gray,
        half_resolution: false,
        ..*setup.params()
    };
    let gray = setup.with_params(&gray);
    for direction in Direction::BOTH {
        if !direction.exists(setup.layout()) {
            continue;
        }
        let band = BandEstimator::new(gray, probe, lf, direction);
        let (d, c, work) = band.split_scratch(scratch)?;
        let n = direction.line_len(setup.layout());
        let margin = if n > 4 * MARGIN { MARGIN } else { 0 };
        let mut line = RANGE_LINE_STEP / 2;
        while line < direction.lines(setup.layout()) {
            band.line(line, work, d, c)?;
            // `split_scratch` gave lines of `n` values and `margin` ≤ n / 4.
            let inner = margin..n - margin;
            let (d, c) = (
                d.get(inner.clone()).unwrap_or(&[]),
                c.get(inner).unwrap_or(&[]),
            );
            for (&dv, &cv) in d.iter().zip(c) {
                if cv.to_f32() >= MIN_COHERENCE {
                    let bin = ((dv.to_f32() + reach) / BIN) as usize;
                    histogram[bin.min(BINS - 1)] += 1;
                    total += 1;
                }
            }
            line += RANGE_LINE_STEP;
        }
    }
    let limit = PROBE_REACH;
    if total < 64 {
        return Ok((-limit, limit));
    }
    // Outliers scatter thinly over many bins while surfaces pile up: the range ends are
    // the outermost windows of CLUSTER bins that hold at least TAIL of the samples.
    let need = ((total as f32 * TAIL) as u64).max(1);
    let window_mass = |first: usize| -> u64 {
        histogram
            .get(first..(first + CLUSTER).min(BINS))
            .unwrap_or(&[])
            .iter()
            .map(|&h| h as u64)
            .sum()
    };
    let quantile = |from_low: bool| -> f32 {
        for i in 0..BINS {
            let first = if from_low {
                i
            } else {
                (BINS - 1 - i).saturating_sub(CLUSTER - 1)
            };
            if window_mass(first) >= need {
                let edge = if from_low { first } else { first + CLUSTER };
                return edge as f32 * BIN - reach;
            }
        }
        0.0
    };
    let lo = (quantile(true) - PAD).clamp(-limit, limit);
    let hi = (quantile(false) + PAD).clamp(-limit, limit);
    Ok((lo.min(hi), hi.max(lo)))
}
