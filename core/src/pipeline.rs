//! The core entry point: runs the [`Schedule`] of a plan over a light field into
//! caller-owned maps, one part after another, with progress reports that can cancel
//! (core's serial driver; the firmware's whole-frame path), and the alignment prelude
//! that comes before it ([`run_aligned`]).

use core::ops::ControlFlow;

use crate::error::{check_map_lengths, check_scratch, Error, Result};
use crate::lightfield::{Grid, LightField, Sample};
use crate::plan::{Params, Plan};
use crate::progress::report;
pub use crate::progress::Progress;
use crate::scalar::Scalar;
pub use crate::schedule::Stages;
use crate::schedule::{PartOutput, PartScratch, Schedule, State};
use crate::setup::DisparityOut;

mod aligned;

pub use aligned::{
    align_params, align_params_for, align_scratch_len, align_views, aligned_len,
    alignment_reads_view, resampled_plan, run_aligned, run_aligned_into, warp_views, AlignBuffers,
    Prelude, STAGE_ALIGN, STAGE_WARP,
};

/// The serial schedule of `stages` (one part at a time).
fn serial(plan: &Plan, stages: Stages) -> Result<Schedule> {
    Schedule::new(plan, stages, 1)
}

/// Scratch (elements of `T`) [`run`] needs for [`Stages::Full`] (every kernel, one part
/// at a time).
pub fn scratch_len(plan: &Plan) -> usize {
    stage_scratch_len(plan, Stages::Full)
}

/// Scratch (elements of `T`) [`run`] needs for `stages`.
pub fn stage_scratch_len(plan: &Plan, stages: Stages) -> usize {
    serial(plan, stages).map_or(usize::MAX, |s| s.max_scratch_len().kernel)
}

/// Scratch (`f32` elements) [`run`] needs for [`Stages::Full`]: the run's state
/// ([`Schedule::state_len`]), one part's outputs and one part's map scratch.
pub fn map_scratch_len(plan: &Plan) -> usize {
    stage_map_scratch_len(plan, Stages::Full)
}

/// [`map_scratch_len`] for `stages`.
pub fn stage_map_scratch_len(plan: &Plan, stages: Stages) -> usize {
    let Ok(schedule) = serial(plan, stages) else {
        return usize::MAX;
    };
    let Ok(part) = schedule.max_part_len() else {
        return usize::MAX;
    };
    schedule
        .state_len()
        .saturating_add(part.total())
        .saturating_add(schedule.max_scratch_len().maps)
}

/// Where [`run`] writes its results.
#[derive(Debug)]
pub struct RunOutput<'a> {
    /// The disparity (`f32`, row-major, `plan.pixels()`) of the centre view.
    pub disparity: &'a mut [f32],
    /// Its confidence in `[0, 1]` (`plan.pixels()`).
    pub confidence: &'a mut [f32],
    /// The TV residual norm per iteration (an empty slice skips it).
    pub history: &'a mut [f32],
}

impl<'a> From<DisparityOut<'a>> for RunOutput<'a> {
    /// The disparity and confidence alone, without the TV history.
    fn from(out: DisparityOut<'a>) -> Self {
        RunOutput {
            disparity: out.disparity,
            confidence: out.confidence,
            history: &mut [],
        }
    }
}

/// The caller-owned scratch [`run`] works in.
#[derive(Debug)]
pub struct RunScratch<'a, T> {
    /// Kernel scalars: [`stage_scratch_len`] elements.
    pub kernel: &'a mut [T],
    /// `f32` maps (the run's state, one part's outputs and its map scratch):
    /// [`stage_map_scratch_len`] elements.
    pub maps: &'a mut [f32],
}

/// Runs `stages`: the disparity and its confidence for the centre view of `lf` into
/// `out`, every stage computing in `T` (the maps between the stages are `f32`).
/// `progress` is called as work completes; returning `ControlFlow::Break(())` stops with
/// [`crate::Error::Cancelled`].
pub fn run<T: Scalar, S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    stages: Stages,
    out: RunOutput<'_>,
    scratch: RunScratch<'_, T>,
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<()> {
    let RunOutput {
        disparity,
        confidence,
        history,
    } = out;
    let RunScratch {
        kernel: scratch,
        maps,
    } = scratch;
    let pixels = plan.pixels();
    check_map_lengths(
        pixels,
        &[
            ("the disparity", disparity.len()),
            ("the confidence", confidence.len()),
        ],
    )?;
    let schedule = serial(plan, stages)?;
    let most = schedule.max_scratch_len();
    check_scratch(most.kernel, scratch.len())?;
    let needed = stage_map_scratch_len(plan, stages);
    check_scratch(needed, maps.len())?;
    let too_small = Error::ScratchTooSmall {
        needed,
        got: maps.len(),
    };
    let (state_maps, rest) = maps
        .split_at_mut_checked(schedule.state_len())
        .ok_or(too_small)?;
    let (part_buffer, map_scratch) = rest
        .split_at_mut_checked(schedule.max_part_len()?.total())
        .ok_or(too_small)?;
    let mut state = State::new(&schedule, state_maps)?;
    for &step in schedule.steps() {
        let parts = schedule.parts(step);
        for index in 0..parts {
            report(progress, step.stage(), index, parts)?;
            let mut out = PartOutput::split(part_buffer, schedule.part_len(step, index)?)?;
            let scratch = PartScratch {
                kernel: &mut *scratch,
                maps: &mut *map_scratch,
                flags: &mut [],
            };
            schedule.run_part(step, index, lf, &state, &mut out, scratch)?;
            schedule.place(step, index, &out, &mut state)?;
        }
        report(progress, step.stage(), parts, parts)?;
        schedule.finish(step, &mut state);
    }
    if stages == Stages::Full {
        let curve = state.history();
        for (i, h) in history.iter_mut().enumerate() {
            *h = curve.get(i).copied().unwrap_or(0.0);
        }
    }
    for (out, result) in [
        (disparity, state.disparity()),
        (confidence, state.confidence()),
    ] {
        // Both hold `pixels` values (checked above); the zip keeps `copy_from_slice`'s
        // panic path out of the firmware image.
        for (o, r) in out.iter_mut().zip(result) {
            *o = *r;
        }
    }
    Ok(())
}

/// The EPI stage alone (`run` with [`Stages::Epi`]): disparity and confidence of the
/// centre view. `scratch` needs [`stage_scratch_len`] and [`stage_map_scratch_len`] of
/// [`Stages::Epi`].
pub fn estimate<T: Scalar, S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    out: DisparityOut<'_>,
    scratch: RunScratch<'_, T>,
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<()> {
    run(plan, lf, Stages::Epi, out.into(), scratch, progress)
}

/// Whether `stages` read view `view` (row-major grid index): the EPI stage reads the
/// centre row and column of the grid, the refinement (when enabled and `stages` is
/// [`Stages::Full`], or in the fused start) also its `views`; TV reads only the centre
/// view. Only these views
/// need warping.
pub fn reads_view(plan: &Plan, stages: Stages, view: usize) -> bool {
    stages_read_view(plan.layout().grid, plan.params(), stages, view)
}

/// [`reads_view`] before there is a plan: whether `stages` with `params` on a `grid`
/// read view `view` (what a loader needs to know before it decodes any view).
pub fn stages_read_view(grid: Grid, params: &Params, stages: Stages, view: usize) -> bool {
    if view >= grid.len() {
        return false;
    }
    let (r0, c0) = grid.center();
    // `grid.cols > 0` here (`view < grid.len()`); the checked forms keep the division's
    // panic path out of the image.
    let (r, c) = (
        view.checked_div(grid.cols).unwrap_or_default(),
        view.checked_rem(grid.cols).unwrap_or_default(),
    );
    if r == r0 || c == c0 {
        return true;
    }
    let refine = &params.refine;
    (stages == Stages::Full || params.fused)
        && refine.enabled
        && refine
            .views
            .contains(r as isize - r0 as isize, c as isize - c0 as isize)
}

#[cfg(test)]
mod fixed_tests;
#[cfg(test)]
mod half_tests;

#[cfg(test)]
mod tests;
