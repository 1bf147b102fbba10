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
