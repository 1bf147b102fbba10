use super::tests::run;
use super::*;
use crate::lightfield::Grid;

#[test]
fn auto_leaves_a_rectified_array_alone_and_aligns_a_misaligned_one() {
    let grid = Grid::new(5, 5);
    let params = AlignParams::default();
    let (data, layout, _) = testscene::render(grid, 96, 96, None, 2);
    let (report, hs) = run(&data, layout, &params);
    let report = report.unwrap();
    assert!(report.skipped && report.warning.is_none(), "{report:?}");
    assert!(report.identity_rms < params.rectified_rms, "{report:?}");
    assert!(hs.iter().all(|h| *h == Homography::IDENTITY));

    let (data, layout, truth) = testscene::render(grid, 128, 128, Some((1.0, 2.0, 0.005, 0.0)), 3);
    let (report, hs) = run(&data, layout, &params);
    let report = report.unwrap();
    assert!(!report.skipped, "{report:?}");
    let err = reprojection_rms(&hs, &truth, grid, 128, 128, &[-0.8, 1.5]).unwrap();
    assert!(err < 0.1, "{err} {report:?}");
}

#[test]
fn off_writes_identities() {
    let grid = Grid::new(3, 3);
    let (data, layout, _) = testscene::render(grid, 32, 32, Some((2.0, 3.0, 0.01, 0.0)), 4);
    let params = AlignParams {
        mode: AlignMode::Off,
        ..AlignParams::default()
    };
    let (report, hs) = run(&data, layout, &params);
    assert!(report.unwrap().skipped);
    assert!(hs.iter().all(|h| *h == Homography::IDENTITY));
}

#[test]
fn textureless_and_unrelated_views_are_alignment_errors() {
    let grid = Grid::new(3, 3);
    let layout = Layout::packed(grid, 64, 64, 1);
    let flat = vec![128u8; layout.validate().unwrap()];
    let on = AlignParams {
        mode: AlignMode::On,
        ..AlignParams::default()
    };
    let (r, _) = run(&flat, layout, &on);
    assert!(matches!(r, Err(Error::Alignment { view: 4, .. })), "{r:?}");
    // Auto falls back to the unaligned path with a warning.
    let (r, hs) = run(&flat, layout, &AlignParams::default());
    let r = r.unwrap();
    assert!(r.skipped && matches!(r.warning, Some(Error::Alignment { .. })));
    assert!(hs.iter().all(|h| *h == Homography::IDENTITY));

    // View 2 shows a different scene.
    let (mut data, layout, _) = testscene::render(grid, 64, 64, None, 5);
    for (k, v) in data[2 * 64 * 64..3 * 64 * 64].iter_mut().enumerate() {
        let (x, y) = ((k % 64) as f32, (k / 64) as f32);
        *v = (testscene::texture(y * 1.7 + 300.0, x * 0.6, 77) * 255.0) as u8;
    }
    let (r, _) = run(&data, layout, &on);
    assert!(matches!(r, Err(Error::Alignment { view: 2, .. })), "{r:?}");
}

#[test]
fn bad_arguments_are_errors_not_panics() {
    let grid = Grid::new(3, 3);
    let (data, layout, _) = testscene::render(grid, 32, 32, None, 6);
    let lf = LightField::new(&data[..], layout).unwrap();
    let params = AlignParams::default();
    let need = scratch_len(&layout, &params).unwrap();
    let mut scratch = vec![0.0f32; need - 1];
    let mut hs = vec![Homography::IDENTITY; 9];
    assert!(matches!(
        estimate(&lf, &params, &mut hs, &mut scratch),
        Err(Error::ScratchTooSmall { .. })
    ));
    let mut scratch = vec![0.0f32; need];
    assert!(matches!(
        estimate(&lf, &params, &mut hs[..8], &mut scratch),
        Err(Error::OutputSize { .. })
    ));
    let bad = AlignParams {
        features: 4,
        ..params
    };
    assert!(matches!(
        bad.validate(),
        Err(Error::InvalidParameter { .. })
    ));
    let bad = AlignParams {
        inlier_threshold: f32::NAN,
        ..params
    };
    assert!(bad.validate().is_err());
    // Tiny views: estimation may fail, but only with an error.
    let _ = estimate(&lf, &params, &mut hs, &mut scratch);
}

#[test]
fn random_and_non_finite_inputs_never_panic() {
    let layout = Layout::packed(Grid::new(3, 3), 40, 36, 3);
    let len = layout.validate().unwrap();
    let mut state = 0x1234_5678_u32;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state
    };
    let noise: std::vec::Vec<u8> = (0..len).map(|_| next() as u8).collect();
    let specials = [f32::NAN, f32::INFINITY, -1e30, 1e30, 0.5, -0.0];
    let floats: std::vec::Vec<f32> = (0..len)
        .map(|i| {
            if i % 7 == 0 {
                specials[i % 6]
            } else {
                (next() % 1000) as f32 / 999.0
            }
        })
        .collect();
    for mode in [AlignMode::On, AlignMode::Auto] {
        for model in [AlignModel::PerView, AlignModel::PlanePatches] {
            let params = AlignParams {
                mode,
                model,
                ..AlignParams::default()
            };
            let mut hs = vec![Homography::IDENTITY; 9];
            let mut scratch = vec![0.0f32; scratch_len(&layout, &params).unwrap()];
            let lf = LightField::new(&noise[..], layout).unwrap();
            if let Ok(r) = estimate(&lf, &params, &mut hs, &mut scratch) {
                assert!(
                    hs.iter().all(|h| h.m.iter().all(|v| v.is_finite())),
                    "{r:?}"
                );
            }
            let lf = LightField::new(&floats[..], layout).unwrap();
            if let Ok(r) = estimate(&lf, &params, &mut hs, &mut scratch) {
                assert!(
                    hs.iter().all(|h| h.m.iter().all(|v| v.is_finite())),
                    "{r:?}"
                );
            }
            let mut out = vec![0.0f32; 9 * 36 * 40 * 3];
            warp_band(&lf, &hs, 0..36, &mut out).unwrap();
        }
    }
}

/// Runs `estimate_present` with only the views `present` accepts, the others holding
/// `fill` (which must not matter).
fn run_present(
    data: &[u8],
    layout: Layout,
    params: &AlignParams,
    present: &dyn Fn(usize) -> bool,
    fill: u8,
) -> (Result<AlignReport>, std::vec::Vec<Homography>) {
    let mut data = data.to_vec();
    for (v, view) in data.chunks_mut(layout.view_stride).enumerate() {
        if !present(v) {
            view.fill(fill);
        }
    }
    let lf = LightField::new(&data[..], layout).unwrap();
    let mut hs = std::vec![Homography::IDENTITY; layout.grid.len()];
    let mut scratch = std::vec![0.0f32; scratch_len(&layout, params).unwrap()];
    let r = estimate_present(&lf, params, present, &mut hs, &mut scratch, &mut Serial);
    (r, hs)
}

#[test]
fn alignment_uses_the_views_that_exist() {
    let grid = Grid::new(5, 5);
    let (data, layout, truth) = testscene::render(grid, 128, 128, Some((1.0, 2.0, 0.005, 0.0)), 3);
    let cross = |v: usize| v / 5 == 2 || v % 5 == 2;
    for mode in [AlignMode::Auto, AlignMode::On] {
        let params = AlignParams {
            mode,
            views: AlignedViews::Cross,
            ..AlignParams::default()
        };
        // Only the centre row and column exist: the probe's corners are left out.
        let (report, hs) = run_present(&data, layout, &params, &cross, 0);
        let report = report.unwrap();
        assert!(!report.skipped, "{mode:?}: {report:?}");
        let (again, hs_noise) = run_present(&data, layout, &params, &cross, 200);
        assert_eq!(again.unwrap().rms, report.rms);
        assert_eq!(hs, hs_noise, "absent views are never read");
        for v in (0..25).filter(|&v| !cross(v)) {
            assert_eq!(hs[v], Homography::IDENTITY);
        }
        // Only the cross is estimated: its registration modulo the gauge.
        let fit = gauge_fit_where(&hs, &truth, grid, 128, 128, &cross).unwrap();
        std::eprintln!("{mode:?}: {report:?} cross registration {}", fit.rms);
        assert!(fit.rms < 0.2, "{mode:?}: {}", fit.rms);
    }
    // Every view present: exactly `estimate`.
    let params = AlignParams::default();
    let (a, ha) = run_present(&data, layout, &params, &|_| true, 0);
    let (b, hb) = run(&data, layout, &params);
    assert_eq!((a.unwrap().rms, ha), (b.unwrap().rms, hb));
}

#[test]
fn reads_view_names_the_probe_and_the_set() {
    let grid = Grid::new(5, 5);
    let on_cross = AlignParams {
        mode: AlignMode::On,
        views: AlignedViews::Cross,
        ..AlignParams::default()
    };
    let count = |p: &AlignParams| (0..30).filter(|&v| reads_view(grid, p, v)).count();
    assert_eq!(count(&on_cross), 9);
    // Auto adds the probe's four corners.
    let auto_cross = AlignParams {
        mode: AlignMode::Auto,
        ..on_cross
    };
    assert_eq!(count(&auto_cross), 13);
    assert!(reads_view(grid, &auto_cross, 0) && !reads_view(grid, &auto_cross, 1));
    assert_eq!(count(&AlignParams::default()), 25);
    let off = AlignParams {
        mode: AlignMode::Off,
        ..AlignParams::default()
    };
    assert_eq!(count(&off), 0);
}

/// The auto mode's probe on a rail (a grid of one row or one column) picks only views
/// of the grid, and the estimate on a rectified rail succeeds: a step along the missing
/// axis must pick nothing (found by the `align` fuzz target: it underflowed).
#[test]
fn auto_probes_only_views_of_a_rail() {
    for grid in [
        Grid::new(1, 5),
        Grid::new(5, 1),
        Grid::new(1, 3),
        Grid::new(3, 1),
    ] {
        let order = solve::view_order(grid, solve::ViewSet::Probe, &|_| true);
        let (r0, c0) = grid.center();
        let centre = grid.index(r0, c0);
        assert!(!order.is_empty(), "{grid:?}");
        assert!(
            order.iter().all(|&v| v < grid.len() && v != centre),
            "{grid:?}: {order:?}"
        );
        let (data, layout, _) = testscene::render(grid, 64, 64, None, 7);
        let (report, hs) = run(&data, layout, &AlignParams::default());
        let report = report.unwrap();
        assert!(report.warning.is_none(), "{grid:?}: {report:?}");
        assert!(hs.iter().all(|h| h.m.iter().all(|v| v.is_finite())));
    }
}

/// Without its centre view no view can be aligned: mode on says so, auto goes on
/// unaligned with that warning, and no view is read (they are all NaN here).
#[test]
fn an_absent_centre_view_is_an_alignment_error() {
    let grid = Grid::new(3, 3);
    let layout = Layout::packed(grid, 32, 32, 1);
    let data = vec![f32::NAN; layout.validate().unwrap()];
    let lf = LightField::new(&data[..], layout).unwrap();
    let mut hs = vec![Homography::IDENTITY; 9];
    let mut scratch = vec![0.0f32; scratch_len(&layout, &AlignParams::default()).unwrap()];
    let absent_centre = |v: usize| v != 4;
    let on = AlignParams {
        mode: AlignMode::On,
        ..AlignParams::default()
    };
    let r = estimate_present(&lf, &on, &absent_centre, &mut hs, &mut scratch, &mut Serial);
    assert!(
        matches!(r, Err(Error::Alignment { view: 4, reason }) if reason.contains("centre view is absent")),
        "{r:?}"
    );
    let auto = AlignParams::default();
    let r = estimate_present(
        &lf,
        &auto,
        &absent_centre,
        &mut hs,
        &mut scratch,
        &mut Serial,
    )
    .unwrap();
    assert!(r.skipped && matches!(r.warning, Some(Error::Alignment { view: 4, .. })));
    assert!(hs.iter().all(|h| *h == Homography::IDENTITY));
}
