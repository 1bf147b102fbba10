//! The native engine's EPI stage: same bits for any thread count, same bits as the core's
//! serial estimate, progress reported, outputs in range.

mod epi_support;

use std::ops::ControlFlow;

use lfdepth::epi::{DisparityRange, EpiParams};
use lfdepth::{Grid, LightField, Params, Plan};
use lfdepth_cli::engine::{estimate, EstimateOptions, Stages};

fn options(threads: usize, epi: EpiParams) -> EstimateOptions {
    EstimateOptions {
        params: Params {
            epi,
            sweep: lfdepth::planesweep::PlaneSweepParams::off(),
            ..Params::default()
        },
        stage: Stages::Epi,
        threads: Some(threads),
    }
}

#[test]
fn any_thread_count_gives_the_serial_core_result_bit_for_bit() {
    let (data, layout) = epi_support::plane_scene(Grid::new(7, 9), 53, 41, -1.1);
    let lf = LightField::new(&data, layout).unwrap();
    let epi = EpiParams::default();
    let plan = Plan::new(
        layout,
        Params {
            epi,
            sweep: lfdepth::planesweep::PlaneSweepParams::off(),
            ..Params::default()
        },
    )
    .unwrap();
    let mut d = vec![0.0; plan.pixels()];
    let mut c = vec![0.0; plan.pixels()];
    let mut scratch = vec![0.0f32; lfdepth::pipeline::scratch_len(&plan)];
    let mut maps =
        vec![
            0.0f32;
            lfdepth::pipeline::stage_map_scratch_len(&plan, lfdepth::pipeline::Stages::Epi)
        ];
    lfdepth::pipeline::estimate(
        &plan,
        &lf,
        lfdepth::setup::DisparityOut {
            disparity: &mut d,
            confidence: &mut c,
        },
        lfdepth::pipeline::RunScratch {
            kernel: &mut scratch,
            maps: &mut maps,
        },
        &mut |_| ControlFlow::Continue(()),
    )
    .unwrap();
    for threads in [1, 2, 3] {
        let mut reports = 0;
        let e = estimate(&lf, &options(threads, epi), &mut |_, done, total| {
            assert!(done <= total);
            reports += 1;
        })
        .unwrap();
        assert!(reports >= 1);
        assert_eq!((e.width, e.height), (53, 41));
        let same = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(
            same(&e.disparity, &d),
            "{threads} threads: disparity differs"
        );
        assert!(
            same(&e.confidence, &c),
            "{threads} threads: confidence differs"
        );
        assert!(!e.timings.is_empty());
    }
}

#[test]
fn full_stage_outputs_stay_inside_the_given_range() {
    let (data, layout) = epi_support::plane_scene(Grid::new(5, 5), 40, 32, 0.4);
    let lf = LightField::new(&data, layout).unwrap();
    let epi = EpiParams {
        range: DisparityRange::Fixed { min: 0.0, max: 1.0 },
        ..EpiParams::default()
    };
    let mut opts = options(2, epi);
    opts.stage = Stages::Full;
    let e = estimate(&lf, &opts, &mut |_, _, _| {}).unwrap();
    assert!(e.disparity.iter().all(|v| (0.0..=1.0).contains(v)));
    assert!(e.confidence.iter().all(|v| (0.0..=1.0).contains(v)));
    // The background (left and right thirds, away from the strip edges) is at 0.4 px.
    let good = (0..32)
        .flat_map(|y| (4..10).map(move |x| y * 40 + x))
        .filter(|&i| (e.disparity[i] - 0.4).abs() < 0.05)
        .count();
    assert!(good > 32 * 6 * 8 / 10, "{good}");
}
