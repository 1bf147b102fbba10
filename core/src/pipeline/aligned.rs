//! The alignment prelude: estimates the views' homographies and warps them into a
//! rectified array before the stages run ([`run_aligned`]).

use core::ops::ControlFlow;

use super::{reads_view, run, stages_read_view, Progress, RunOutput, RunScratch, Stages};
use crate::align::{self, AlignMode, AlignParams, AlignReport, AlignedViews, WarpSample};
use crate::error::{Error, Result};
use crate::geometry::Homography;
use crate::lightfield::{Grid, LightField, Sample};
use crate::plan::{Params, Plan};
use crate::progress::report;
use crate::scalar::Scalar;

/// Name of the alignment estimate in progress reports.
pub const STAGE_ALIGN: &str = "align";
/// Name of the warp into the rectified array in progress reports.
pub const STAGE_WARP: &str = "warp";

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
