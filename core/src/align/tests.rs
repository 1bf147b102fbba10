extern crate std;
use super::*;
use crate::lightfield::Grid;
use std::vec;

/// Runs `estimate` on a packed buffer; shared with `mode_tests`.
pub(super) fn run(
    data: &[u8],
    layout: Layout,
    params: &AlignParams,
) -> (Result<AlignReport>, std::vec::Vec<Homography>) {
    let lf = LightField::new(data, layout).unwrap();
    let mut hs = vec![Homography::IDENTITY; layout.grid.len()];
    let mut scratch = vec![0.0f32; scratch_len(&layout, params).unwrap()];
    let r = estimate(&lf, params, &mut hs, &mut scratch);
    (r, hs)
}

#[test]
fn recovers_misalignment_modulo_gauge() {
    let grid = Grid::new(5, 5);
    let (data, layout, truth) = testscene::render(grid, 128, 128, Some((2.0, 3.0, 0.01, 1e-5)), 1);
    let before = reprojection_rms(
        &[Homography::IDENTITY; 25],
        &truth,
        grid,
        128,
        128,
        &[-0.8, 0.0, 1.5],
    )
    .unwrap();
    for model in [AlignModel::PerView, AlignModel::PlanePatches] {
        let params = AlignParams {
            mode: AlignMode::On,
            model,
            ..AlignParams::default()
        };
        let (report, hs) = run(&data, layout, &params);
        let report = report.unwrap();
        let after = reprojection_rms(&hs, &truth, grid, 128, 128, &[-0.8, 0.0, 1.5]).unwrap();
        let registration = gauge_rms(&hs, &truth, grid, 128, 128).unwrap();
        std::eprintln!(
            "{model:?}: {report:?} before {before} after {after} registration {registration}"
        );
        assert!(!report.skipped);
        assert!(before > 1.0, "{before}");
        assert!(after < 0.1, "{model:?}: {after}");
    }
}

#[test]
fn a_started_report_equals_a_new_one() {
    assert_eq!(AlignReport::EMPTY, AlignReport::default());
    let mut report = AlignReport {
        skipped: true,
        warning: Some(Error::NonFinite { what: "test" }),
        features: 3,
        identity_rms: 1.0,
        rms: 2.0,
        iterations: 4,
        disparity_shift: 0.5,
        disparity_coherence: 0.25,
        ..AlignReport::default()
    };
    report
        .views
        .push(ViewReport {
            inliers: 9,
            rms: 0.5,
        })
        .unwrap();
    report.start(7);
    assert_eq!(
        report,
        AlignReport {
            features: 7,
            ..AlignReport::default()
        }
    );
}
