//! The core entry point: runs the stages over a light field into caller-owned maps,
//! with progress reports that can cancel. For now the pipeline is the EPI stage.

use core::ops::ControlFlow;

use crate::epi;
use crate::error::Result;
use crate::lightfield::{LightField, Sample};
use crate::plan::Plan;
use crate::scalar::Scalar;

/// A progress report: `done` of `total` units of `stage` are finished.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    /// Name of the running stage (e.g. [`epi::STAGE_HORIZONTAL`]).
    pub stage: &'static str,
    /// Units finished.
    pub done: u64,
    /// Units in the stage.
    pub total: u64,
}

/// Scratch (elements of `T`) [`estimate`] needs.
pub fn scratch_len(plan: &Plan) -> usize {
    epi::scratch_len(plan)
}

/// Estimates the disparity (`f32`, row-major, `plan.pixels()`) and its confidence in
/// `[0, 1]` for the centre view of `lf`, computing in `T`. `progress` is called as work
/// completes; returning `ControlFlow::Break(())` stops with [`crate::Error::Cancelled`].
pub fn estimate<T: Scalar, S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    disparity: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<()> {
    epi::estimate_with_progress(plan, lf, disparity, confidence, scratch, progress)?;
    Ok(())
}
