//! The core entry point: runs the [`Schedule`] of a plan over a light field into
//! caller-owned maps, one part after another, with progress reports that can cancel
//! (core's serial driver; the firmware's whole-frame path), and the alignment prelude
//! that comes before it ([`run_aligned`]).

use core::ops::ControlFlow;

use crate::align::{self, AlignMode, AlignParams, AlignReport, AlignedViews, WarpSample};
use crate::error::{check_map_lengths, check_scratch, Error, Result};
use crate::geometry::Homography;
use crate::lightfield::{Grid, LightField, Sample};
use crate::plan::{Params, Plan};
use crate::progress::report;
pub use crate::progress::Progress;
use crate::scalar::Scalar;
pub use crate::schedule::Stages;
use crate::schedule::{PartOutput, PartScratch, Schedule, State};
use crate::setup::DisparityOut;

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

/// Name of the alignment estimate in progress reports.
pub const STAGE_ALIGN: &str = "align";
/// Name of the warp into the rectified array in progress reports.
pub const STAGE_WARP: &str = "warp";

/// Whether `stages` read view `view` (row-major grid index): the EPI stage reads the
/// centre row and column of the grid, the refinement (when enabled and `stages` is
/// [`Stages::Full`]) also its `views`; TV reads only the centre view. Only these views
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
    stages == Stages::Full
        && refine.enabled
        && refine
            .views
            .contains(r as isize - r0 as isize, c as isize - c0 as isize)
}

/// Whether the alignment prelude of `params` ([`align_views`], with
/// [`align_params_for`]) may read view `view` of a `grid` before `stages` run: see
/// [`align::reads_view`]. A view neither this nor [`stages_read_view`] accepts is never
/// read and may be absent.
pub fn alignment_reads_view(grid: Grid, params: &Params, stages: Stages, view: usize) -> bool {
    align::reads_view(grid, &align_params_for(grid, params, stages), view)
}

/// The alignment parameters of `plan` for `stages`: [`AlignedViews::Read`] becomes
/// [`AlignedViews::Cross`] when the stages read no view off the centre row and column,
/// else [`AlignedViews::All`].
pub fn align_params(plan: &Plan, stages: Stages) -> AlignParams {
    align_params_for(plan.layout().grid, plan.params(), stages)
}

/// [`align_params`] before there is a plan.
pub fn align_params_for(grid: Grid, params: &Params, stages: Stages) -> AlignParams {
    let mut align = params.align;
    if align.views == AlignedViews::Read {
        let (r0, c0) = grid.center();
        let off_cross = (0..grid.len()).any(|v| {
            v.checked_div(grid.cols) != Some(r0)
                && v.checked_rem(grid.cols) != Some(c0)
                && stages_read_view(grid, params, stages, v)
        });
        align.views = if off_cross {
            AlignedViews::All
        } else {
            AlignedViews::Cross
        };
    }
    align
}

/// The plan the stages run with on views that were warped (aligned): `plan` with the
/// refinement's [`crate::refine::RefineParams::sampling_slack`] at [`crate::refine::RESAMPLED_SLACK`]
/// unless it sets one itself. Interpolated views do not reproduce the rendered or
/// photographed occlusion edges of the centre view, and the refinement, comparing them
/// sample by sample, otherwise chooses differently there (docs/stages/align.md).
/// Rectified arrays (alignment off or skipped) keep `plan` itself.
pub fn resampled_plan(plan: &Plan) -> Result<Plan> {
    let mut params = *plan.params();
    params.refine = params.refine.for_resampled_views();
    Plan::new(*plan.layout(), params)
}

/// Elements of the rectified light field buffer of [`align_views`] / [`run_aligned`]:
/// the plan's layout (same strides as the input).
pub fn aligned_len(plan: &Plan) -> Result<usize> {
    plan.layout().validate()
}

/// Scratch (`f32` elements) the alignment estimate needs.
pub fn align_scratch_len(plan: &Plan) -> Result<usize> {
    align::scratch_len(plan.layout(), &plan.params().align)
}

fn same_layout<S: Sample>(plan: &Plan, lf: &LightField<'_, S>) -> Result<()> {
    if lf.layout() == plan.layout() {
        return Ok(());
    }
    Err(Error::InvalidParameter {
        name: "light field",
        reason:
            "has a different layout than the plan: make the plan from this light field's layout",
    })
}

/// Caller-owned buffers of the alignment prelude.
pub struct AlignBuffers<'a, A> {
    /// One homography per view (row-major grid order), written by the estimate
    /// (identities when alignment was skipped).
    pub homographies: &'a mut [Homography],
    /// [`align_scratch_len`] elements.
    pub scratch: &'a mut [f32],
    /// [`aligned_len`] elements (the input's layout): receives the rectified views the
    /// stages read (see [`reads_view`]); the other views are left as they were.
    pub aligned: &'a mut [A],
}

/// The alignment prelude: estimates the homographies of `lf` with `plan`'s
/// `params.align` and, unless the estimate was skipped (mode off, or auto found the
/// array rectified or could not align it: see [`AlignReport::warning`]), warps the views
/// `stages` read into `buffers.aligned`. Returns the report; when it says
/// `skipped`, `buffers.aligned` is untouched and the stages should read `lf` itself.
/// Mode on returns [`Error::Alignment`] for textureless or too different views.
pub fn align_views<S: Sample, A: WarpSample + Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    stages: Stages,
    buffers: &mut AlignBuffers<'_, A>,
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<AlignReport> {
    let mut report = AlignReport::default();
    align_views_into(plan, lf, stages, buffers, progress, &mut report)?;
    Ok(report)
}

/// [`align_views`] into `report` (see [`align::estimate_into`]).
fn align_views_into<S: Sample, A: WarpSample + Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    stages: Stages,
    buffers: &mut AlignBuffers<'_, A>,
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
    out: &mut AlignReport,
) -> Result<()> {
    same_layout(plan, lf)?;
    let params = &align_params(plan, stages);
    if params.mode == AlignMode::Off {
        buffers.homographies.fill(Homography::IDENTITY);
        out.start(0);
        out.skipped = true;
        return Ok(());
    }
    let needed = aligned_len(plan)?;
    if buffers.aligned.len() < needed {
        return Err(Error::OutputSize {
            what: "the aligned light field",
            needed,
            got: buffers.aligned.len(),
        });
    }
    report(progress, STAGE_ALIGN, 0, 1)?;
    align::estimate_into(
        lf,
        params,
        &|_| true,
        buffers.homographies,
        buffers.scratch,
        &mut align::Serial,
        out,
    )?;
    report(progress, STAGE_ALIGN, 1, 1)?;
    if !out.skipped {
        warp_views(
            plan,
            lf,
            stages,
            buffers.homographies,
            buffers.aligned,
            progress,
        )?;
    }
    Ok(())
}

/// Warps the views `stages` read ([`reads_view`]) of `lf` by `homographies` (rectified →
/// view pixels, one per view) into `aligned` ([`aligned_len`] elements, the plan's
/// layout) with `params.align.interpolation`; the other views of `aligned` are left as
/// they were.
pub fn warp_views<S: Sample, A: WarpSample + Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    stages: Stages,
    homographies: &[Homography],
    aligned: &mut [A],
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<()> {
    same_layout(plan, lf)?;
    let needed = aligned_len(plan)?;
    if aligned.len() < needed {
        return Err(Error::OutputSize {
            what: "the aligned light field",
            needed,
            got: aligned.len(),
        });
    }
    let layout = *plan.layout();
    let views = layout.grid.len();
    let row_len = layout.width * layout.channels;
    for view in 0..views {
        report(progress, STAGE_WARP, view, views)?;
        if !reads_view(plan, stages, view) {
            continue;
        }
        for y in 0..layout.height {
            let start = view * layout.view_stride + y * layout.row_stride;
            let out = aligned
                .get_mut(start..start.saturating_add(row_len))
                .ok_or(Error::SizeOverflow {
                    what: "the aligned light field",
                })?;
            align::warp_rows_with(
                lf,
                homographies,
                view,
                y..y + 1,
                plan.params().align.interpolation,
                out,
            )?;
        }
        let start = view * layout.view_stride;
        let out = aligned.get_mut(start..).ok_or(Error::SizeOverflow {
            what: "the aligned light field",
        })?;
        align::finish_view(
            &layout,
            homographies,
            view,
            plan.params().align.interpolation,
            out,
        )?;
    }
    report(progress, STAGE_WARP, views, views)
}

/// [`run`] after the alignment prelude ([`align_views`]): the stages read the rectified
/// views in `buffers.aligned` with the [`resampled_plan`] when the array was aligned,
/// `lf` itself with `plan` when alignment was skipped (so mode off, and auto on a
/// rectified array, give exactly `run`'s output).
pub fn run_aligned<T: Scalar, S: Sample, A: WarpSample + Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    stages: Stages,
    buffers: &mut AlignBuffers<'_, A>,
    out: RunOutput<'_>,
    scratch: RunScratch<'_, T>,
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<AlignReport> {
    let mut report = AlignReport::default();
    let prelude = Prelude {
        buffers,
        report: &mut report,
    };
    run_aligned_into(plan, lf, stages, prelude, out, scratch, progress)?;
    Ok(report)
}

/// Where [`run_aligned_into`]'s alignment prelude works and reports.
pub struct Prelude<'a, 'b, A> {
    /// The alignment's buffers.
    pub buffers: &'a mut AlignBuffers<'b, A>,
    /// Receives the alignment's report.
    pub report: &'a mut AlignReport,
}

/// [`run_aligned`] with the alignment's report written to `prelude.report` instead of
/// returned: a firmware keeps it in static memory, off its stack (it holds a
/// `ViewReport` per view of the largest grid, ≈ 2.4 KB on 32-bit targets).
pub fn run_aligned_into<T: Scalar, S: Sample, A: WarpSample + Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    stages: Stages,
    prelude: Prelude<'_, '_, A>,
    out: RunOutput<'_>,
    scratch: RunScratch<'_, T>,
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<()> {
    let Prelude { buffers, report } = prelude;
    align_alone(plan, lf, stages, buffers, progress, report)?;
    if report.skipped {
        run(plan, lf, stages, out, scratch, progress)?;
    } else {
        let aligned = LightField::new(&*buffers.aligned, *plan.layout())?;
        let plan = &resampled_plan(plan)?;
        run(plan, &aligned, stages, out, scratch, progress)?;
    }
    Ok(())
}

/// [`align_views`] in a frame of its own: the alignment's locals are not on the stack
/// while the stages run (docs/EMBEDDED.md, "Stack").
#[inline(never)]
fn align_alone<S: Sample, A: WarpSample + Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    stages: Stages,
    buffers: &mut AlignBuffers<'_, A>,
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
    out: &mut AlignReport,
) -> Result<()> {
    align_views_into(plan, lf, stages, buffers, progress, out)
}

#[cfg(test)]
mod fixed_tests;
#[cfg(test)]
mod half_tests;

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec;
    use std::vec::Vec;

    use super::*;
    use crate::align::{testscene, AlignParams};
    use crate::epi::test_scenes::strips;
    use crate::lightfield::Grid;
    use crate::plan::Params;
    use crate::refine::{self, RefineParams, ViewSet};
    use crate::tv;

    #[test]
    fn full_pipeline_runs_every_stage_and_can_be_cancelled() {
        let scene = strips(Grid::new(5, 5), 40, 32, 3, -0.4, &[0.0, 0.9]);
        let params = Params {
            refine: RefineParams::on(),
            ..Params::default()
        };
        let plan = Plan::new(scene.layout, params).unwrap();
        let lf = LightField::new(&scene.data, scene.layout).unwrap();
        let mut d = vec![0.0; plan.pixels()];
        let mut c = vec![0.0; plan.pixels()];
        let mut scratch = vec![0.0f32; scratch_len(&plan)];
        let mut maps = vec![0.0f32; map_scratch_len(&plan)];
        let mut history = vec![0.0f32; 20];
        let mut stages: Vec<&str> = Vec::new();
        run(
            &plan,
            &lf,
            Stages::Full,
            RunOutput {
                disparity: &mut d,
                confidence: &mut c,
                history: &mut history,
            },
            RunScratch {
                kernel: &mut scratch,
                maps: &mut maps,
            },
            &mut |p| {
                if stages.last() != Some(&p.stage) {
                    stages.push(p.stage);
                }
                ControlFlow::Continue(())
            },
        )
        .unwrap();
        assert!(stages.contains(&refine::STAGE) && stages.last() == Some(&tv::STAGE));
        assert!(d.iter().all(|v| v.is_finite()) && c.iter().all(|v| (0.0..=1.0).contains(v)));
        assert!(history[0] > 0.0);
        let mut cancel = |p: Progress| {
            if p.stage == tv::STAGE {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        };
        let short = map_scratch_len(&plan) - 1;
        assert!(matches!(
            run(
                &plan,
                &lf,
                Stages::Full,
                RunOutput {
                    disparity: &mut d,
                    confidence: &mut c,
                    history: &mut history
                },
                RunScratch {
                    kernel: &mut scratch,
                    maps: &mut maps[..short]
                },
                &mut cancel
            ),
            Err(Error::ScratchTooSmall { .. })
        ));
        assert_eq!(
            run(
                &plan,
                &lf,
                Stages::Full,
                RunOutput {
                    disparity: &mut d,
                    confidence: &mut c,
                    history: &mut history
                },
                RunScratch {
                    kernel: &mut scratch,
                    maps: &mut maps
                },
                &mut cancel
            ),
            Err(Error::Cancelled)
        );
    }

    /// EPI disparity of `data` through `run_aligned` with `mode`, and the report.
    fn epi_aligned(
        data: &[u8],
        layout: crate::Layout,
        mode: AlignMode,
    ) -> (Result<AlignReport>, Vec<f32>) {
        let params = Params {
            align: AlignParams {
                mode,
                ..AlignParams::default()
            },
            ..Params::default()
        };
        let plan = Plan::new(layout, params).unwrap();
        let lf = LightField::new(data, layout).unwrap();
        let mut hs = vec![Homography::IDENTITY; layout.grid.len()];
        let mut align_scratch = vec![0.0f32; align_scratch_len(&plan).unwrap()];
        let mut aligned = vec![0u8; aligned_len(&plan).unwrap()];
        let mut buffers = AlignBuffers {
            homographies: &mut hs,
            scratch: &mut align_scratch,
            aligned: &mut aligned,
        };
        let mut d = vec![0.0; plan.pixels()];
        let mut c = vec![0.0; plan.pixels()];
        let mut scratch = vec![0.0f32; scratch_len(&plan)];
        let mut maps = vec![0.0f32; stage_map_scratch_len(&plan, Stages::Epi)];
        let r = run_aligned(
            &plan,
            &lf,
            Stages::Epi,
            &mut buffers,
            RunOutput {
                disparity: &mut d,
                confidence: &mut c,
                history: &mut [],
            },
            RunScratch {
                kernel: &mut scratch,
                maps: &mut maps,
            },
            &mut |_| ControlFlow::Continue(()),
        );
        (r, d)
    }

    fn epi_plain(data: &[u8], layout: crate::Layout) -> Vec<f32> {
        let plan = Plan::new(layout, Params::default()).unwrap();
        let lf = LightField::new(data, layout).unwrap();
        let mut d = vec![0.0; plan.pixels()];
        let mut c = vec![0.0; plan.pixels()];
        let mut scratch = vec![0.0f32; scratch_len(&plan)];
        let mut maps = vec![0.0f32; stage_map_scratch_len(&plan, Stages::Epi)];
        estimate(
            &plan,
            &lf,
            DisparityOut {
                disparity: &mut d,
                confidence: &mut c,
            },
            RunScratch {
                kernel: &mut scratch,
                maps: &mut maps,
            },
            &mut |_| ControlFlow::Continue(()),
        )
        .unwrap();
        d
    }

    fn median_abs_diff(a: &[f32], b: &[f32], width: usize, border: usize) -> f32 {
        let height = a.len() / width;
        let mut diffs: Vec<f32> = (border..height - border)
            .flat_map(|y| (border..width - border).map(move |x| y * width + x))
            .map(|i| (a[i] - b[i]).abs())
            .collect();
        diffs.sort_by(f32::total_cmp);
        diffs[diffs.len() / 2]
    }

    #[test]
    fn warped_views_get_the_refinements_sampling_slack_unless_the_plan_sets_one() {
        let layout = crate::Layout::packed(Grid::new(5, 5), 32, 32, 1);
        let plan = Plan::new(layout, Params::default()).unwrap();
        assert_eq!(plan.params().refine.sampling_slack, 0.0);
        let resampled = resampled_plan(&plan).unwrap();
        assert_eq!(
            resampled.params().refine.sampling_slack,
            refine::RESAMPLED_SLACK
        );
        let mut params = Params::default();
        params.refine.sampling_slack = 0.25;
        let own = Plan::new(layout, params).unwrap();
        assert_eq!(resampled_plan(&own).unwrap(), own);
        // Nothing else changes.
        let mut back = *resampled.params();
        back.refine.sampling_slack = 0.0;
        assert_eq!(back, *plan.params());
    }

    #[test]
    fn off_and_auto_on_a_rectified_array_are_bit_identical_to_run() {
        let (data, layout, _) = testscene::render(Grid::new(5, 5), 96, 96, None, 2);
        let plain = epi_plain(&data, layout);
        for mode in [AlignMode::Off, AlignMode::Auto] {
            let (report, d) = epi_aligned(&data, layout, mode);
            let report = report.unwrap();
            assert!(report.skipped && report.warning.is_none(), "{report:?}");
            assert!(
                d.iter()
                    .zip(&plain)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "{mode:?}"
            );
        }
    }

    #[test]
    fn aligning_a_misaligned_array_brings_its_disparity_back() {
        let grid = Grid::new(5, 5);
        let (ideal, layout, _) = testscene::render(grid, 128, 128, None, 3);
        let (bent, _, _) = testscene::render(grid, 128, 128, Some((1.0, 2.0, 0.005, 0.0)), 3);
        let truth = epi_plain(&ideal, layout);
        let unaligned = median_abs_diff(&epi_plain(&bent, layout), &truth, 128, 16);
        for mode in [AlignMode::On, AlignMode::Auto] {
            let (report, d) = epi_aligned(&bent, layout, mode);
            let report = report.unwrap();
            assert!(!report.skipped, "{report:?}");
            let aligned = median_abs_diff(&d, &truth, 128, 16);
            std::eprintln!("{mode:?}: median abs diff aligned {aligned} unaligned {unaligned}");
            assert!(
                aligned < 0.1 && aligned < 0.25 * unaligned,
                "{mode:?}: aligned {aligned} unaligned {unaligned}"
            );
        }
    }

    #[test]
    fn textureless_arrays_fail_when_on_and_fall_back_when_auto() {
        let layout = crate::Layout::packed(Grid::new(3, 3), 64, 64, 1);
        let flat = vec![128u8; layout.validate().unwrap()];
        let (r, _) = epi_aligned(&flat, layout, AlignMode::On);
        assert!(matches!(r, Err(Error::Alignment { view: 4, .. })), "{r:?}");
        let (r, d) = epi_aligned(&flat, layout, AlignMode::Auto);
        let r = r.unwrap();
        assert!(r.skipped && matches!(r.warning, Some(Error::Alignment { .. })));
        let plain = epi_plain(&flat, layout);
        assert!(d
            .iter()
            .zip(&plain)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
    }

    #[test]
    fn only_the_views_the_stages_read_are_warped() {
        let layout = crate::Layout::packed(Grid::new(5, 5), 32, 32, 1);
        let mut params = Params::default();
        let plan = Plan::new(layout, params).unwrap();
        let cross = |plan: &Plan, stages| (0..25).filter(|&v| reads_view(plan, stages, v)).count();
        assert_eq!(cross(&plan, Stages::Full), 9);
        assert_eq!(align_params(&plan, Stages::Full).views, AlignedViews::Cross);
        params.refine = RefineParams {
            views: ViewSet::CrossDiagonals,
            ..RefineParams::on()
        };
        let plan = Plan::new(layout, params).unwrap();
        assert_eq!(cross(&plan, Stages::Epi), 9);
        assert_eq!(cross(&plan, Stages::Full), 17);
        assert_eq!(align_params(&plan, Stages::Epi).views, AlignedViews::Cross);
        assert_eq!(align_params(&plan, Stages::Full).views, AlignedViews::All);
        assert!(!reads_view(&plan, Stages::Full, 25));

        // Unread views keep what the buffer held; a wrong-sized buffer is an error.
        let data: Vec<u8> = (0..layout.validate().unwrap())
            .map(|i| (i % 251) as u8)
            .collect();
        let lf = LightField::new(&data[..], layout).unwrap();
        let hs = [Homography::IDENTITY; 25];
        let mut out = vec![7u8; data.len()];
        warp_views(&plan, &lf, Stages::Full, &hs, &mut out, &mut |_| {
            ControlFlow::Continue(())
        })
        .unwrap();
        for v in 0..25 {
            let range = v * 1024..(v + 1) * 1024;
            if reads_view(&plan, Stages::Full, v) {
                assert_eq!(out[range.clone()], data[range]);
            } else {
                assert!(out[range].iter().all(|&s| s == 7));
            }
        }
        assert!(matches!(
            warp_views(&plan, &lf, Stages::Full, &hs, &mut out[1..], &mut |_| {
                ControlFlow::Continue(())
            }),
            Err(Error::OutputSize { .. })
        ));
    }

    #[test]
    fn views_read_before_a_plan() {
        let grid = Grid::new(9, 9);
        let layout = crate::Layout::packed(grid, 32, 32, 1);
        let mut params = Params::default();
        for views in [ViewSet::Cross, ViewSet::CrossDiagonals] {
            params.refine.views = views;
            let plan = Plan::new(layout, params).unwrap();
            for stages in [Stages::Epi, Stages::Full] {
                for v in 0..90 {
                    assert_eq!(
                        stages_read_view(grid, &params, stages, v),
                        reads_view(&plan, stages, v)
                    );
                }
            }
        }
        let count = |params: &Params, stages| {
            (0..81)
                .filter(|&v| alignment_reads_view(grid, params, stages, v))
                .count()
        };
        params.refine.views = ViewSet::Cross;
        assert_eq!(count(&params, Stages::Full), 0, "alignment off");
        params.align.mode = AlignMode::Auto;
        // The cross, and the probe's four corners.
        assert_eq!(count(&params, Stages::Full), 21);
        params.align.mode = AlignMode::On;
        assert_eq!(count(&params, Stages::Full), 17);
        params.refine.views = ViewSet::CrossDiagonals;
        assert_eq!(count(&params, Stages::Full), 81);
        assert_eq!(count(&params, Stages::Epi), 17);
    }
}
