//! The core entry point: runs the stages over a light field into caller-owned maps,
//! serially, with progress reports that can cancel:
//! EPI → photometric refinement (when `params.refine.enabled`) → TV.

use core::ops::ControlFlow;

use crate::epi;
use crate::error::{checked_product, Error, Result};
use crate::lightfield::{LightField, Sample};
use crate::plan::Plan;
use crate::refine;
use crate::scalar::Scalar;
use crate::tv::{self, Guide, Maps, SolveOutput};

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

/// Scratch (`f32` elements) [`run`] needs for the intermediate maps (disparity and
/// confidence between the stages).
pub fn map_scratch_len(plan: &Plan) -> usize {
    plan.pixels().saturating_mul(2)
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
    let needed = match stages {
        Stages::Epi => epi::scratch_len(plan),
        Stages::Full => scratch_len(plan),
    };
    if scratch.len() < needed {
        return Err(Error::ScratchTooSmall {
            needed,
            got: scratch.len(),
        });
    }
    let hyps = epi::estimate_with_progress(plan, lf, disparity, confidence, scratch, progress)?;
    if stages == Stages::Epi {
        return Ok(());
    }
    let pixels = plan.pixels();
    let needed = map_scratch_len(plan);
    if maps.len() < needed {
        return Err(Error::ScratchTooSmall {
            needed,
            got: maps.len(),
        });
    }
    let (mid_d, rest) = maps.split_at_mut(pixels);
    let mid_c = &mut rest[..pixels];
    if plan.params().refine.enabled {
        refine::refine_with_progress(
            plan,
            lf,
            (hyps.min(), hyps.max()),
            disparity,
            mid_d,
            mid_c,
            scratch,
            progress,
        )?;
    } else {
        mid_d.copy_from_slice(disparity);
        mid_c.copy_from_slice(confidence);
    }
    confidence.copy_from_slice(mid_c);

    let layout = plan.layout();
    let tv_maps = Maps::new(layout.width, layout.height, mid_d, mid_c)?;
    let guide = Guide::View(lf.center_view());
    let (cols, rows) = tv::tile_count(plan);
    let tiles = checked_product(&[cols, rows], "the TV tiles")?;
    history.fill(0.0);
    for index in 0..tiles {
        report(progress, tv::STAGE, index, tiles)?;
        let (core, _) = tv::tile_rects(plan, index)?;
        let start = core.y * layout.width + core.x;
        tv::refine_tile(
            plan,
            &tv_maps,
            &guide,
            index,
            SolveOutput {
                disparity: &mut disparity[start..],
                stride: layout.width,
                history: &mut *history,
                dual: None,
            },
            scratch,
        )?;
    }
    tv::normalise_history(plan, history);
    report(progress, tv::STAGE, tiles, tiles)
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

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec;
    use std::vec::Vec;

    use super::*;
    use crate::epi::test_scenes::strips;
    use crate::lightfield::Grid;
    use crate::plan::Params;
    use crate::refine::RefineParams;

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
}
