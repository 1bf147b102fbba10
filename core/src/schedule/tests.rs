extern crate std;
use std::vec;
use std::vec::Vec;

use core::ops::ControlFlow;

use super::*;
use crate::align::testscene;
use crate::lightfield::{Grid, Layout};
use crate::median::MedianParams;
use crate::pipeline;
use crate::plan::Params;
use crate::refine::RefineParams;
use crate::scalar::Q16;
use crate::tv::TvParams;

/// A textured 5×5 array of 64×48 views with several depths (every stage has work).
fn scene() -> (Vec<u8>, Layout) {
    let (data, layout, _) = testscene::render(Grid::new(5, 5), 64, 48, None, 7);
    (data, layout)
}

/// Every step of `schedule` by parts: each step's parts run in reverse order into their
/// own buffers, then placed in index order (as a parallel driver does).
fn by_parts<T: Scalar>(
    schedule: &Schedule,
    lf: &LightField<'_, u8>,
) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    by_parts_through::<T>(schedule, lf, None)
}

/// The current disparity and confidence once `last` has finished.
fn by_parts_until<T: Scalar>(
    schedule: &Schedule,
    lf: &LightField<'_, u8>,
    last: Step,
) -> (Vec<f32>, Vec<f32>) {
    let (d, c, _) = by_parts_through::<T>(schedule, lf, Some(last));
    (d, c)
}

/// Runs `schedule`'s steps by parts (all of them, or through `last`). As the page's
/// workers, every part runs from a state of its own that holds only the maps
/// [`Schedule::reads`] declares for its step (the rest NaN), so a map a step reads
/// without declaring it fails the comparison with the serial run.
fn by_parts_through<T: Scalar>(
    schedule: &Schedule,
    lf: &LightField<'_, u8>,
    last: Option<Step>,
) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let mut buffer = vec![0.0f32; schedule.state_len()];
    let mut state = State::new(schedule, &mut buffer).unwrap();
    for &step in schedule.steps() {
        let parts = schedule.parts(step);
        let lens = schedule.scratch_len(step);
        let reads = schedule.reads(step);
        let mut inputs = vec![f32::NAN; schedule.state_len()];
        let mut worker = State::new(schedule, &mut inputs).unwrap();
        let (other_disparity, other_confidence) = state.other();
        worker
            .set(
                schedule.plan(),
                StateMaps {
                    disparity: reads.disparity.then_some(state.disparity()),
                    confidence: reads.confidence.then_some(state.confidence()),
                    other_disparity: reads.other.then_some(other_disparity),
                    other_confidence: reads.other.then_some(other_confidence),
                    dual: reads.dual.then_some(state.dual()),
                },
                state.range(),
            )
            .unwrap();
        let mut outputs: Vec<Vec<f32>> = vec![Vec::new(); parts];
        for index in (0..parts).rev() {
            let len = schedule.part_len(step, index).unwrap();
            let mut output = vec![f32::NAN; len.total()];
            let mut out = PartOutput::split(&mut output, len).unwrap();
            let mut kernel = vec![T::ZERO; lens.kernel];
            let mut maps = vec![f32::NAN; lens.maps];
            let mut flags = vec![7u8; lens.flags];
            let scratch = PartScratch {
                kernel: &mut kernel,
                maps: &mut maps,
                flags: &mut flags,
            };
            schedule
                .run_part(step, index, lf, &worker, &mut out, scratch)
                .unwrap();
            outputs[index] = output;
        }
        for (index, output) in outputs.iter_mut().enumerate() {
            let out = PartOutput::split(output, schedule.part_len(step, index).unwrap()).unwrap();
            schedule.place(step, index, &out, &mut state).unwrap();
        }
        schedule.finish(step, &mut state);
        if last == Some(step) {
            break;
        }
    }
    (
        state.disparity().to_vec(),
        state.confidence().to_vec(),
        state.history().to_vec(),
    )
}

/// `pipeline::run`, the serial driver.
fn serial<T: Scalar>(
    plan: &Plan,
    lf: &LightField<'_, u8>,
    stages: Stages,
) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let mut d = vec![0.0; plan.pixels()];
    let mut c = vec![0.0; plan.pixels()];
    let mut scratch = vec![T::ZERO; pipeline::stage_scratch_len(plan, stages)];
    let mut maps = vec![0.0f32; pipeline::stage_map_scratch_len(plan, stages)];
    let mut history = vec![0.0f32; plan.params().tv.max_iterations];
    pipeline::run(
        plan,
        lf,
        stages,
        pipeline::RunOutput {
            disparity: &mut d,
            confidence: &mut c,
            history: &mut history,
        },
        pipeline::RunScratch {
            kernel: &mut scratch,
            maps: &mut maps,
        },
        &mut |_| ControlFlow::Continue(()),
    )
    .unwrap();
    (d, c, history)
}

fn bits(values: &[f32]) -> Vec<u32> {
    values.iter().map(|v| v.to_bits()).collect()
}

fn variants() -> [(&'static str, Params); 11] {
    let small = Params {
        refine: RefineParams {
            band_rows: 10,
            ..RefineParams::default()
        },
        tv: TvParams {
            tile: 24,
            halo: 6,
            max_iterations: 40,
            ..Params::default().tv
        },
        ..Params::default()
    };
    [
        ("defaults", Params::default()),
        ("small bands and tiles", small),
        (
            "two TV sweeps",
            Params {
                tv: TvParams {
                    sweeps: 2,
                    ..small.tv
                },
                ..small
            },
        ),
        (
            "median after TV",
            Params {
                median: MedianParams {
                    before_tv: false,
                    ..MedianParams::default()
                },
                ..small
            },
        ),
        ("the paper's pipeline", Params::paper()),
        (
            "EPI start",
            Params {
                sweep: crate::planesweep::PlaneSweepParams::off(),
                ..small
            },
        ),
        (
            "fused start",
            Params {
                sweep: crate::planesweep::PlaneSweepParams {
                    enabled: true,
                    ..Default::default()
                },
                fused: true,
                ..small
            },
        ),
        (
            "sweep start distrusting flat cost curves",
            Params {
                sweep: crate::planesweep::PlaneSweepParams {
                    trust: 0.6,
                    ..Params::default().sweep
                },
                ..small
            },
        ),
        (
            "sweep start with a per-pixel candidate",
            Params {
                sweep: crate::planesweep::PlaneSweepParams {
                    candidate: 1,
                    ..Params::default().sweep
                },
                ..small
            },
        ),
        (
            "sweep start with a 3×3 candidate, distrusting flat cost curves",
            Params {
                sweep: crate::planesweep::PlaneSweepParams {
                    candidate: 3,
                    trust: 0.6,
                    ..Params::default().sweep
                },
                ..small
            },
        ),
        (
            "half-resolution EPI",
            Params {
                epi: crate::epi::EpiParams {
                    half_resolution: true,
                    ..Params::default().epi
                },
                sweep: crate::planesweep::PlaneSweepParams::off(),
                ..small
            },
        ),
    ]
}

#[test]
fn parts_in_any_order_on_any_number_of_workers_give_the_serial_bits() {
    let (data, layout) = scene();
    let lf = LightField::new(&data[..], layout).unwrap();
    for (name, params) in variants() {
        let plan = Plan::new(layout, params).unwrap();
        for stages in [Stages::Epi, Stages::Full] {
            let (d, c, h) = serial::<f32>(&plan, &lf, stages);
            assert!(d.iter().all(|v| v.is_finite()), "{name}");
            for workers in [1, 2, 5] {
                let schedule = Schedule::new(&plan, stages, workers).unwrap();
                let (pd, pc, ph) = by_parts::<f32>(&schedule, &lf);
                assert_eq!(bits(&pd), bits(&d), "{name}, {stages:?}, {workers} workers");
                assert_eq!(bits(&pc), bits(&c), "{name}, {stages:?}, {workers} workers");
                if stages == Stages::Full {
                    assert_eq!(bits(&ph[..h.len()]), bits(&h), "{name}: history");
                    assert!(h[0] > 0.0, "{name}: TV ran");
                }
            }
        }
    }
}

#[test]
fn fixed_point_parts_give_the_serial_bits() {
    let (data, layout) = scene();
    let lf = LightField::new(&data[..], layout).unwrap();
    let plan = Plan::new(layout, variants()[1].1).unwrap();
    let (d, c, _) = serial::<Q16>(&plan, &lf, Stages::Full);
    let (pd, pc, _) = by_parts::<Q16>(&Schedule::new(&plan, Stages::Full, 3).unwrap(), &lf);
    assert_eq!(bits(&pd), bits(&d));
    assert_eq!(bits(&pc), bits(&c));
}

#[test]
fn the_steps_follow_the_enabled_stages() {
    let layout = Layout::packed(Grid::new(5, 5), 64, 48, 1);
    let stages_of = |params: Params, stages| {
        let plan = Plan::new(layout, params).unwrap();
        let schedule = Schedule::new(&plan, stages, 1).unwrap();
        schedule
            .steps()
            .iter()
            .map(|s| s.stage())
            .collect::<Vec<_>>()
    };
    let epi = [
        crate::epi::STAGE_RANGE,
        crate::epi::STAGE_HORIZONTAL,
        crate::epi::STAGE_VERTICAL,
    ];
    let sweep = [crate::epi::STAGE_RANGE, crate::planesweep::STAGE];
    let epi_start = Params {
        sweep: crate::planesweep::PlaneSweepParams::off(),
        ..Params::default()
    };
    assert_eq!(stages_of(Params::default(), Stages::Epi), sweep);
    assert_eq!(stages_of(epi_start, Stages::Epi), epi);
    let mut full = sweep.to_vec();
    full.extend(["refine", "geofill", "median", "tv"]);
    assert_eq!(stages_of(Params::default(), Stages::Full), full);
    let mut full = epi.to_vec();
    full.extend(["refine", "geofill", "median", "tv"]);
    assert_eq!(stages_of(epi_start, Stages::Full), full);
    let mut paper = epi.to_vec();
    paper.push("tv");
    assert_eq!(stages_of(Params::paper(), Stages::Full), paper);
    let mut params = Params::default();
    params.tv.sweeps = 2;
    params.median.before_tv = false;
    let mut swept = sweep.to_vec();
    swept.extend(["refine", "geofill", "tv", "tv", "tv", "median"]);
    assert_eq!(stages_of(params, Stages::Full), swept);
    let mut params = epi_start;
    params.epi.half_resolution = true;
    let mut half = epi.to_vec();
    half.push(crate::epi::STAGE_UPSAMPLE);
    assert_eq!(stages_of(params, Stages::Epi), half);
    half.extend(["refine", "geofill", "median", "tv"]);
    assert_eq!(stages_of(params, Stages::Full), half);
    let params = Params {
        fused: true,
        ..Params::default()
    };
    let mut fused = epi.to_vec();
    fused.extend(["refine", crate::planesweep::STAGE, "fused start"]);
    assert_eq!(stages_of(params, Stages::Epi), fused);
    fused.extend(["geofill", "median", "tv"]);
    assert_eq!(stages_of(params, Stages::Full), fused);
    // The fused start chooses by the refinement's residual: it needs the refinement
    // and the full-resolution EPI, and says so.
    let mut params = Params {
        fused: true,
        ..Params::default()
    };
    params.refine.enabled = false;
    assert!(matches!(
        Plan::new(layout, params),
        Err(Error::InvalidParameter {
            name: "initial",
            ..
        })
    ));
    params.refine.enabled = true;
    params.epi.half_resolution = true;
    assert!(matches!(
        Plan::new(layout, params),
        Err(Error::InvalidParameter {
            name: "initial",
            ..
        })
    ));
}

#[test]
fn the_median_bands_follow_the_workers_and_every_part_has_a_region() {
    let layout = Layout::packed(Grid::new(5, 5), 64, 100, 1);
    let plan = Plan::new(layout, Params::default()).unwrap();
    for (workers, parts) in [(1, 1), (2, 2), (3, 3), (64, 7)] {
        let schedule = Schedule::new(&plan, Stages::Full, workers).unwrap();
        assert_eq!(schedule.parts(Step::Median), parts, "{workers} workers");
        let mut covered = 0;
        for index in 0..parts {
            match schedule.region(Step::Median, index).unwrap() {
                Region::Lines(start, end) => {
                    assert_eq!(start, covered);
                    covered = end;
                }
                other => panic!("{other:?}"),
            }
        }
        assert_eq!(covered, 100);
        assert!(matches!(
            schedule.region(Step::Median, parts),
            Err(Error::OutOfRange { .. })
        ));
    }
}

#[test]
fn the_refinement_bands_thin_for_more_workers_but_not_below_two_halos() {
    let layout = Layout::packed(Grid::new(5, 5), 64, 300, 1);
    let plan = Plan::new(layout, Params::default()).unwrap();
    let halo = crate::refine::halo(plan.refine());
    // The plan's 128 rows while they keep every worker busy, one band per worker after
    // that, never thinner than two halos.
    for (workers, parts) in [(1, 3), (2, 3), (4, 4), (64, 300usize.div_ceil(2 * halo))] {
        let schedule = Schedule::new(&plan, Stages::Full, workers).unwrap();
        assert_eq!(schedule.parts(Step::Refine), parts, "{workers} workers");
        let mut covered = 0;
        for index in 0..parts {
            match schedule.region(Step::Refine, index).unwrap() {
                Region::Lines(start, end) => {
                    assert_eq!(start, covered);
                    assert!(end - start <= 128);
                    covered = end;
                }
                other => panic!("{other:?}"),
            }
        }
        assert_eq!(covered, 300);
    }
}

#[test]
fn misuse_is_an_error_not_a_panic() {
    let (data, layout) = scene();
    let lf = LightField::new(&data[..], layout).unwrap();
    let plan = Plan::new(layout, Params::default()).unwrap();
    let schedule = Schedule::new(&plan, Stages::Full, 1).unwrap();
    let mut short = vec![0.0f32; schedule.state_len() - 1];
    assert!(matches!(
        State::new(&schedule, &mut short),
        Err(Error::ScratchTooSmall { .. })
    ));
    let mut buffer = vec![0.0f32; schedule.state_len()];
    let state = State::new(&schedule, &mut buffer).unwrap();
    // A step after the range needs the range.
    let step = Step::Epi(crate::epi::Direction::Horizontal);
    let len = schedule.part_len(step, 0).unwrap();
    let mut output = vec![0.0f32; len.total()];
    let mut out = PartOutput::split(&mut output, len).unwrap();
    let mut kernel = vec![0.0f32; schedule.scratch_len(step).kernel];
    let scratch = PartScratch {
        kernel: &mut kernel,
        maps: &mut [],
        flags: &mut [],
    };
    assert!(matches!(
        schedule.run_part(step, 0, &lf, &state, &mut out, scratch),
        Err(Error::InvalidParameter { .. })
    ));
    let mut small = vec![0.0f32; len.total() - 1];
    assert!(matches!(
        PartOutput::split(&mut small, len),
        Err(Error::ScratchTooSmall { .. })
    ));
    // Too little kernel scratch for the range.
    let len = schedule.part_len(Step::Range, 0).unwrap();
    let mut output = vec![0.0f32; len.total()];
    let mut out = PartOutput::split(&mut output, len).unwrap();
    let mut kernel = vec![0.0f32; 3];
    let scratch = PartScratch {
        kernel: &mut kernel,
        maps: &mut [],
        flags: &mut [],
    };
    assert!(schedule
        .run_part(Step::Range, 0, &lf, &state, &mut out, scratch)
        .is_err());
}

/// [`range`], the function of the plan a driver may run ahead, is the range step's part
/// (`[min, max]`), in `f32` and Q16.16; with too little scratch it is an error.
#[test]
fn the_range_of_the_plan_is_the_range_step() {
    fn check<T: Scalar>(plan: &Plan, lf: &LightField<'_, u8>, name: &str) {
        let schedule = Schedule::new(plan, Stages::Full, 2).unwrap();
        let len = schedule.part_len(Step::Range, 0).unwrap();
        let mut output = vec![f32::NAN; len.total()];
        let mut out = PartOutput::split(&mut output, len).unwrap();
        let mut kernel = vec![T::ZERO; schedule.scratch_len(Step::Range).kernel];
        let mut buffer = vec![0.0f32; schedule.state_len()];
        let state = State::new(&schedule, &mut buffer).unwrap();
        let scratch = PartScratch {
            kernel: &mut kernel,
            maps: &mut [],
            flags: &mut [],
        };
        schedule
            .run_part(Step::Range, 0, lf, &state, &mut out, scratch)
            .unwrap();
        assert_eq!(
            range_scratch_len(plan),
            schedule.scratch_len(Step::Range).kernel
        );
        let mut kernel = vec![T::ZERO; range_scratch_len(plan)];
        let (min, max) = range(plan, lf, &mut kernel).unwrap();
        assert!(min < max, "{name}: range {min}..{max}");
        assert_eq!(bits(&[min, max]), bits(&output), "{name}");
        let epi = plan.params().epi;
        if epi.range == crate::epi::DisparityRange::Auto && epi.shear {
            assert!(range(plan, lf, &mut [T::ZERO; 3]).is_err(), "{name}");
        }
    }
    let (data, layout) = scene();
    let lf = LightField::new(&data[..], layout).unwrap();
    let fixed = Params {
        epi: crate::epi::EpiParams {
            range: crate::epi::DisparityRange::Fixed {
                min: -1.5,
                max: 2.0,
            },
            ..Params::default().epi
        },
        ..Params::default()
    };
    for (name, params) in variants().into_iter().chain([("fixed range", fixed)]) {
        let plan = Plan::new(layout, params).unwrap();
        check::<f32>(&plan, &lf, name);
        check::<Q16>(&plan, &lf, name);
    }
}

/// A linear array (one row or one column of cameras) runs the EPI direction it has and
/// every later stage; by parts equals the serial run, in `f32` and Q16.16, and the EPI
/// stage's serial `epi::estimate` equals the schedule's EPI steps.
#[test]
fn a_linear_array_runs_its_one_direction_by_parts_as_serially() {
    let epi = |direction| match direction {
        Direction::Horizontal => crate::epi::STAGE_HORIZONTAL,
        Direction::Vertical => crate::epi::STAGE_VERTICAL,
    };
    for (grid, direction) in [
        (Grid::new(1, 5), Direction::Horizontal),
        (Grid::new(5, 1), Direction::Vertical),
    ] {
        let (data, layout, _) = testscene::render(grid, 64, 48, None, 7);
        let lf = LightField::new(&data[..], layout).unwrap();
        for (name, params) in variants() {
            let plan = Plan::new(layout, params).unwrap();
            let schedule = Schedule::new(&plan, Stages::Full, 2).unwrap();
            let stages: Vec<_> = schedule.steps().iter().map(|s| s.stage()).collect();
            let first = if params.sweep.enabled && !params.fused {
                crate::planesweep::STAGE
            } else {
                epi(direction)
            };
            assert_eq!(stages[..2], [crate::epi::STAGE_RANGE, first]);
            assert!(
                !schedule
                    .steps()
                    .iter()
                    .skip(2)
                    .any(|s| matches!(s, Step::Epi(_))),
                "{grid:?}: {stages:?}"
            );
            for stages in [Stages::Epi, Stages::Full] {
                let (d, c, _) = serial::<f32>(&plan, &lf, stages);
                assert!(d.iter().all(|v| v.is_finite()), "{grid:?} {name}");
                assert!(c.iter().any(|&v| v > 0.5), "{grid:?} {name}: confident");
                let schedule = Schedule::new(&plan, stages, 3).unwrap();
                let (pd, pc, _) = by_parts::<f32>(&schedule, &lf);
                assert_eq!(bits(&pd), bits(&d), "{grid:?} {name} {stages:?}");
                assert_eq!(bits(&pc), bits(&c), "{grid:?} {name} {stages:?}");
            }
        }
        // The EPI stage's own serial entry point gives the schedule's EPI maps.
        let epi_start = Params {
            sweep: crate::planesweep::PlaneSweepParams::off(),
            ..Params::default()
        };
        let plan = Plan::new(layout, epi_start).unwrap();
        let (d, c, _) = serial::<f32>(&plan, &lf, Stages::Epi);
        let mut ed = vec![0.0; plan.pixels()];
        let mut ec = vec![0.0; plan.pixels()];
        let mut scratch = vec![0.0f32; crate::epi::scratch_len(plan.epi())];
        crate::epi::estimate(plan.epi(), &lf, &mut ed, &mut ec, &mut scratch).unwrap();
        assert_eq!(bits(&ed), bits(&d), "{grid:?}: epi::estimate");
        assert_eq!(bits(&ec), bits(&c), "{grid:?}: epi::estimate");
        let plan = Plan::new(layout, variants()[1].1).unwrap();
        let (d, _, _) = serial::<Q16>(&plan, &lf, Stages::Full);
        let (pd, _, _) = by_parts::<Q16>(&Schedule::new(&plan, Stages::Full, 3).unwrap(), &lf);
        assert_eq!(bits(&pd), bits(&d), "{grid:?} Q16");
    }
}

/// A row of cameras estimates what the 2-D grid's centre row alone tells: the same
/// planes, within a tenth of a pixel of the full grid's estimate on four pixels in five
/// (a row saw at least 90 %, a column 85 %: one direction has no second view of the edges
/// parallel to it).
#[test]
fn a_row_and_a_column_agree_with_the_grid_they_come_from() {
    let (data, layout, _) = testscene::render(Grid::new(5, 5), 64, 48, None, 7);
    let lf = LightField::new(&data[..], layout).unwrap();
    let plan = Plan::new(layout, Params::default()).unwrap();
    let (grid_d, _, _) = serial::<f32>(&plan, &lf, Stages::Full);
    let view = layout.view_stride;
    let row: Vec<u8> = data[2 * 5 * view..3 * 5 * view].to_vec();
    let column: Vec<u8> = (0..5)
        .flat_map(|r| data[(r * 5 + 2) * view..(r * 5 + 3) * view].to_vec())
        .collect();
    for (grid, views) in [(Grid::new(1, 5), row), (Grid::new(5, 1), column)] {
        let layout = Layout::packed(grid, 64, 48, 1);
        let lf = LightField::new(&views[..], layout).unwrap();
        let plan = Plan::new(layout, Params::default()).unwrap();
        let (d, _, _) = serial::<f32>(&plan, &lf, Stages::Full);
        let close = d
            .iter()
            .zip(&grid_d)
            .filter(|(a, b)| (*a - *b).abs() < 0.1)
            .count();
        assert!(
            close * 5 >= d.len() * 4,
            "{grid:?}: {close} of {} pixels within 0.1 px of the grid's map",
            d.len()
        );
    }
}

#[test]
fn distrust_scales_only_the_confidence_of_flat_sweep_pixels() {
    let start = [0.0, 0.15, 0.3, 0.6, 0.9, -0.2];
    let mut refined = [0.8; 6];
    distrust(0.6, &start, &mut refined);
    let want = [0.0, 0.8 / 16.0, 0.8 / 4.0, 0.8, 0.8, 0.0];
    for (k, (&got, &want)) in refined.iter().zip(&want).enumerate() {
        assert!((got - want).abs() < 1e-6, "pixel {k}: {got} against {want}");
    }
}

#[test]
fn trusting_the_sweep_lowers_the_refined_confidence_where_the_sweep_was_unsure() {
    let (data, layout) = scene();
    let lf = LightField::new(&data[..], layout).unwrap();
    let run = |trust| {
        let params = Params {
            sweep: crate::planesweep::PlaneSweepParams {
                trust,
                ..Params::default().sweep
            },
            ..Params::default()
        };
        let plan = Plan::new(layout, params).unwrap();
        let schedule = Schedule::new(&plan, Stages::Full, 1).unwrap();
        // The maps after the sweep and after the refinement.
        let sweep = by_parts_until::<f32>(&schedule, &lf, Step::PlaneSweep);
        let refined = by_parts_until::<f32>(&schedule, &lf, Step::Refine);
        (sweep, refined)
    };
    let ((_, sweep_c), (off_d, off_c)) = run(0.0);
    let (_, (on_d, on_c)) = run(0.6);
    // The refinement's disparity does not depend on it; its confidence is scaled exactly
    // where the sweep's confidence is below the threshold.
    assert_eq!(bits(&on_d), bits(&off_d));
    let mut lowered = 0;
    for ((&s, &off), &on) in sweep_c.iter().zip(&off_c).zip(&on_c) {
        if s < 0.6 {
            let r = s.max(0.0) / 0.6;
            assert!((on - off * r * r).abs() <= 1e-6 * off.abs().max(1.0));
            lowered += usize::from(off > 0.0 && on < off);
        } else {
            assert_eq!(on.to_bits(), off.to_bits());
        }
    }
    assert!(lowered > 0, "no pixel of the scene had an unsure sweep");
}

/// The candidate's steps: only a refinement that propagates from the sweep alone reads
/// it, and only then does the sweep write it.
#[test]
fn the_sweep_writes_its_candidate_only_for_a_refinement_that_reads_it() {
    let layout = Layout::packed(Grid::new(5, 5), 64, 48, 1);
    let with = |f: fn(&mut Params)| {
        let mut params = Params::default();
        params.sweep.candidate = 3;
        f(&mut params);
        Plan::new(layout, params).unwrap()
    };
    let reads = |plan: &Plan, stages| {
        let schedule = Schedule::new(plan, stages, 1).unwrap();
        let sweep = schedule.part_len(Step::PlaneSweep, 0).unwrap().candidate;
        let refine = schedule
            .steps()
            .contains(&Step::Refine)
            .then(|| schedule.reads(Step::Refine).other);
        (sweep, refine)
    };
    assert_eq!(reads(&with(|_| {}), Stages::Full), (64 * 48, Some(true)));
    assert_eq!(reads(&with(|_| {}), Stages::Epi), (0, None));
    assert_eq!(
        reads(&with(|p| p.refine.propagation = 0), Stages::Full),
        (0, Some(false))
    );
    assert_eq!(
        reads(&with(|p| p.sweep.candidate = 0), Stages::Full),
        (0, Some(false))
    );
    let fused = with(|p| p.fused = true);
    let schedule = Schedule::new(&fused, Stages::Full, 1).unwrap();
    assert_eq!(schedule.part_len(Step::PlaneSweep, 0).unwrap().candidate, 0);
    assert!(!schedule.reads(Step::Refine).other);
}

/// A 2 px diagonal bar in front of a textured plane: the sweep's windows give its pixels
/// the background's disparity, which no neighbour of theirs can correct; the sweep's
/// per-pixel candidate, offered in the first propagation round, brings them back.
#[test]
fn the_refinement_takes_a_thin_bar_back_from_the_sweeps_candidate() {
    let size = 48;
    let (bar, background) = (1.2, -0.6);
    let (data, layout, gt) = crate::planesweep::tests::diagonal_bar(size, 2.0, bar, background);
    let levels: Vec<u8> = data
        .iter()
        .map(|&v| libm::roundf(v * 255.0).clamp(0.0, 255.0) as u8)
        .collect();
    let lf = LightField::new(&levels[..], layout).unwrap();
    let on_bar = |d: &[f32]| {
        let (mut good, mut all) = (0, 0);
        for y in 8..size - 8 {
            for x in 8..size - 8 {
                let i = y * size + x;
                if gt[i] == bar {
                    all += 1;
                    good += usize::from((d[i] - bar).abs() <= 0.1);
                }
            }
        }
        good as f32 / all as f32
    };
    let refined = |candidate| {
        let mut params = Params::default();
        params.sweep.candidate = candidate;
        // The automatic range, sampled every 16th line, need not see a thin bar: the
        // hypotheses must reach it for any start to find it.
        params.epi.range = crate::epi::DisparityRange::Fixed {
            min: -1.5,
            max: 1.5,
        };
        let plan = Plan::new(layout, params).unwrap();
        let schedule = Schedule::new(&plan, Stages::Full, 2).unwrap();
        by_parts_until::<f32>(&schedule, &lf, Step::Refine).0
    };
    let without = on_bar(&refined(0));
    assert!(
        without < 0.5,
        "without the candidate {without} of the bar kept"
    );
    let with = on_bar(&refined(1));
    assert!(with > 0.8, "{with} of the bar kept");
}
