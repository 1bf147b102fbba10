extern crate std;
use std::vec;
use std::vec::Vec;

use super::*;
use crate::align::{testscene, AlignMode, AlignParams, AlignReport, AlignedViews};
use crate::epi::test_scenes::strips;
use crate::geometry::Homography;
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
