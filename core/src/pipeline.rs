//! The core entry point: runs the stages over a light field into caller-owned maps,
//! serially, with progress reports that can cancel:
//! (alignment, [`run_aligned`] only) → EPI → photometric refinement (when
//! `params.refine.enabled`) → geodesic refill of the band around depth steps (when
//! `params.geofill.enabled`) → edge-snapping weighted median (when
//! `params.median.enabled`, before or after TV) → TV.

use core::ops::ControlFlow;

use crate::align::{self, AlignMode, AlignParams, AlignReport, AlignedViews, WarpSample};
use crate::epi;
use crate::error::{check_map_lengths, check_scratch, Error, Result};
use crate::geofill;
use crate::geometry::Homography;
use crate::lightfield::{LightField, Sample};
use crate::median;
use crate::plan::Plan;
use crate::refine;
use crate::scalar::Scalar;
use crate::tv::{self, Guide, Maps};

/// A progress report: `done` of `total` units of `stage` are finished.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    /// Name of the running stage (e.g. [`epi::STAGE_HORIZONTAL`], [`refine::STAGE`],
    /// [`tv::STAGE`]).
    pub stage: &'static str,
    /// Units finished.
    pub done: u64,
    /// Units in the stage.
    pub total: u64,
}

/// How far [`run`] goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stages {
    /// The initial EPI disparity only.
    Epi,
    /// EPI → refinement (when enabled) → TV.
    Full,
}

/// Scratch (elements of `T`) [`run`] needs for the EPI, refinement and TV kernels
/// ([`Stages::Epi`] and [`estimate`] need only `epi::scratch_len`).
pub fn scratch_len(plan: &Plan) -> usize {
    epi::scratch_len(plan)
        .max(tv::scratch_len(plan))
        .max(refine::scratch_len(plan))
}

/// Scratch (elements of `T`) [`run`] needs for `stages`: the EPI kernels alone for
/// [`Stages::Epi`], the larger of EPI and TV for [`Stages::Full`].
pub fn stage_scratch_len(plan: &Plan, stages: Stages) -> usize {
    match stages {
        Stages::Epi => epi::scratch_len(plan),
        Stages::Full => scratch_len(plan),
    }
}

/// Scratch (`f32` elements) [`run`] needs for the intermediate maps (disparity and
/// confidence between the stages), the TV duals and the weighted median's rows (which
/// the geodesic refill, running before both, borrows when enabled).
pub fn map_scratch_len(plan: &Plan) -> usize {
    let tail = tv::dual_len(plan)
        .saturating_add(median_map_len(plan))
        .saturating_add(median::scratch_len(plan));
    let tail = if plan.params().geofill.enabled {
        tail.max(geofill::scratch_len(plan))
    } else {
        tail
    };
    plan.pixels().saturating_mul(2).saturating_add(tail)
}

/// The weighted median's copy of the map two passes back (see
/// [`median::filter_rows_again`]), or nothing when the median is off.
fn median_map_len(plan: &Plan) -> usize {
    if plan.params().median.enabled {
        plan.pixels()
    } else {
        0
    }
}

/// Every pass of the weighted median: `input` holds the map and receives the result, as
/// does `output`; `previous` keeps each pass's input for the next, which then filters
/// only near the pixels that moved (the same bits as a full pass).
fn median_passes<S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    input: &mut [f32],
    output: &mut [f32],
    previous: &mut [f32],
    scratch: &mut [f32],
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<()> {
    let passes = plan.params().median.passes;
    let guide = lf.center_view();
    let rows = 0..plan.layout().height;
    // One length check up front lets the copies below go without their own.
    if output.len() != input.len() || previous.len() != input.len() {
        return Err(Error::OutputSize {
            what: "the median maps",
            needed: input.len(),
            got: output.len().min(previous.len()),
        });
    }
    for pass in 0..passes {
        report(progress, median::STAGE, pass, passes)?;
        if pass == 0 {
            median::filter(plan, &guide, input, output, scratch)?;
        } else {
            median::filter_rows_again(
                plan,
                &guide,
                input,
                previous,
                rows.clone(),
                output,
                scratch,
            )?;
        }
        previous.copy_from_slice(input);
        input.copy_from_slice(output);
    }
    report(progress, median::STAGE, passes, passes)
}

fn report(
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
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

/// Runs `stages`: the disparity (`f32`, row-major, `plan.pixels()`) and its confidence in
/// `[0, 1]` for the centre view of `lf`, every stage computing in `T` (the maps between
/// the stages are `f32`). `scratch` needs [`scratch_len`] elements, `maps`
/// [`map_scratch_len`]; `history` receives the TV residual norm per iteration (pass an
/// empty slice to skip it). `progress` is called as work completes; returning
/// `ControlFlow::Break(())` stops with [`crate::Error::Cancelled`].
#[allow(clippy::too_many_arguments)]
pub fn run<T: Scalar, S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    stages: Stages,
    disparity: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
    maps: &mut [f32],
    history: &mut [f32],
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<()> {
    let needed = stage_scratch_len(plan, stages);
    check_scratch(needed, scratch.len())?;
    let hyps = epi::estimate_with_progress(plan, lf, disparity, confidence, scratch, progress)?;
    if stages == Stages::Epi {
        return Ok(());
    }
    regularize(
        plan,
        lf,
        (hyps.min(), hyps.max()),
        disparity,
        confidence,
        scratch,
        maps,
        history,
        progress,
    )
}

/// Every stage after the EPI one, in place: `disparity` and `confidence` hold the EPI
/// result (from [`run`] with [`Stages::Epi`], or from EPI bands run elsewhere, e.g. in
/// other workers) measured over `range` (the hypothesis range), and receive the final
/// result. `scratch`, `maps` and `history` as in [`run`].
#[allow(clippy::too_many_arguments)]
pub fn regularize<T: Scalar, S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    disparity: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
    maps: &mut [f32],
    history: &mut [f32],
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<()> {
    let pixels = plan.pixels();
    check_map_lengths(
        pixels,
        &[
            ("the disparity", disparity.len()),
            ("the confidence", confidence.len()),
        ],
    )?;
    let needed = scratch_len(plan);
    check_scratch(needed, scratch.len())?;
    let needed = map_scratch_len(plan);
    check_scratch(needed, maps.len())?;
    let too_small = Error::ScratchTooSmall {
        needed,
        got: maps.len(),
    };
    let (mid_d, rest) = maps.split_at_mut_checked(pixels).ok_or(too_small)?;
    let (mid_c, rest) = rest.split_at_mut_checked(pixels).ok_or(too_small)?;
    if plan.params().refine.enabled {
        refine::refine_with_progress(plan, lf, range, disparity, mid_d, mid_c, scratch, progress)?;
    } else {
        mid_d.copy_from_slice(disparity);
        mid_c.copy_from_slice(confidence);
    }
    confidence.copy_from_slice(mid_c);
    if plan.params().geofill.enabled {
        // The refill writes through `disparity`, which TV overwrites next; its scratch
        // is the duals', the median's copy and the median's rows, all still unused.
        report(progress, geofill::STAGE, 0, 1)?;
        geofill::fill(plan, &lf.center_view(), mid_d, disparity, rest)?;
        mid_d.copy_from_slice(disparity);
        report(progress, geofill::STAGE, 1, 1)?;
    }
    let (duals, rest) = rest
        .split_at_mut_checked(tv::dual_len(plan))
        .ok_or(too_small)?;
    let (median_previous, median_scratch) = rest
        .split_at_mut_checked(median_map_len(plan))
        .ok_or(too_small)?;
    let median = plan.params().median;
    if median.enabled && median.before_tv {
        median_passes(
            plan,
            lf,
            mid_d,
            disparity,
            median_previous,
            median_scratch,
            progress,
        )?;
    }

    let layout = plan.layout();
    let tv_maps = Maps::new(layout.width, layout.height, mid_d, mid_c)?;
    let guide = Guide::View(lf.center_view());
    tv::refine_with_progress(
        plan, &tv_maps, &guide, disparity, history, scratch, duals, progress,
    )?;
    if median.enabled && !median.before_tv {
        mid_d.copy_from_slice(disparity);
        median_passes(
            plan,
            lf,
            mid_d,
            disparity,
            median_previous,
            median_scratch,
            progress,
        )?;
    }
    Ok(())
}

/// The EPI stage alone (`run` with [`Stages::Epi`], which needs no map scratch):
/// disparity and confidence of the centre view. `scratch` needs [`scratch_len`] elements.
pub fn estimate<T: Scalar, S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    disparity: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<()> {
    run(
        plan,
        lf,
        Stages::Epi,
        disparity,
        confidence,
        scratch,
        &mut [],
        &mut [],
        progress,
    )
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
    let grid = plan.layout().grid;
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
    let refine = &plan.params().refine;
    stages == Stages::Full
        && refine.enabled
        && refine
            .views
            .contains(r as isize - r0 as isize, c as isize - c0 as isize)
}

/// The alignment parameters of `plan` for `stages`: [`AlignedViews::Read`] becomes
/// [`AlignedViews::Cross`] when the stages read no view off the centre row and column,
/// else [`AlignedViews::All`].
pub fn align_params(plan: &Plan, stages: Stages) -> AlignParams {
    let mut params = plan.params().align;
    if params.views == AlignedViews::Read {
        let grid = plan.layout().grid;
        let (r0, c0) = grid.center();
        let off_cross = (0..grid.len()).any(|v| {
            v.checked_div(grid.cols) != Some(r0)
                && v.checked_rem(grid.cols) != Some(c0)
                && reads_view(plan, stages, v)
        });
        params.views = if off_cross {
            AlignedViews::All
        } else {
            AlignedViews::Cross
        };
    }
    params
}

/// The plan the stages run with on views that were warped (aligned): `plan` with the
/// refinement's [`refine::RefineParams::sampling_slack`] at [`refine::RESAMPLED_SLACK`]
/// unless it sets one itself. Interpolated views do not reproduce the rendered or
/// photographed occlusion edges of the centre view, and the refinement, comparing them
/// sample by sample, otherwise chooses differently there (docs/bench-align.md,
/// "Session 9"). Rectified arrays (alignment off or skipped) keep `plan` itself.
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
    same_layout(plan, lf)?;
    let params = &align_params(plan, stages);
    if params.mode == AlignMode::Off {
        buffers.homographies.fill(Homography::IDENTITY);
        return Ok(AlignReport {
            skipped: true,
            ..AlignReport::default()
        });
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
    let result = align::estimate(lf, params, buffers.homographies, buffers.scratch)?;
    report(progress, STAGE_ALIGN, 1, 1)?;
    if !result.skipped {
        warp_views(
            plan,
            lf,
            stages,
            buffers.homographies,
            buffers.aligned,
            progress,
        )?;
    }
    Ok(result)
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
#[allow(clippy::too_many_arguments)]
pub fn run_aligned<T: Scalar, S: Sample, A: WarpSample + Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    stages: Stages,
    buffers: &mut AlignBuffers<'_, A>,
    disparity: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [T],
    maps: &mut [f32],
    history: &mut [f32],
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<AlignReport> {
    let result = align_views(plan, lf, stages, buffers, progress)?;
    if result.skipped {
        run(
            plan, lf, stages, disparity, confidence, scratch, maps, history, progress,
        )?;
    } else {
        let aligned = LightField::new(&*buffers.aligned, *plan.layout())?;
        let plan = &resampled_plan(plan)?;
        run(
            plan, &aligned, stages, disparity, confidence, scratch, maps, history, progress,
        )?;
    }
    Ok(result)
}

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
    use crate::refine::{RefineParams, ViewSet};

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
            &mut d,
            &mut c,
            &mut scratch,
            &mut maps,
            &mut history,
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
                &mut d,
                &mut c,
                &mut scratch,
                &mut maps[..short],
                &mut history,
                &mut cancel
            ),
            Err(Error::ScratchTooSmall { .. })
        ));
        assert_eq!(
            run(
                &plan,
                &lf,
                Stages::Full,
                &mut d,
                &mut c,
                &mut scratch,
                &mut maps,
                &mut history,
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
        let r = run_aligned(
            &plan,
            &lf,
            Stages::Epi,
            &mut buffers,
            &mut d,
            &mut c,
            &mut scratch,
            &mut [],
            &mut [],
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
        estimate(&plan, &lf, &mut d, &mut c, &mut scratch, &mut |_| {
            ControlFlow::Continue(())
        })
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
}
