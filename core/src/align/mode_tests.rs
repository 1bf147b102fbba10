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
