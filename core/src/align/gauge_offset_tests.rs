extern crate std;
use super::*;
use crate::lightfield::Grid;
use crate::synth::{self, Misalignment, SceneKind, SynthSpec};
use std::vec;

/// A misaligned `planes` array whose surfaces all lie on multiples of 0.5 px: with
/// `disparity_step` 0.5 the estimate's disparity offset (against the truth) is a
/// multiple of 0.5, so the surfaces land on the EPI stage's shears; with 0 it is
/// wherever the zero-mean convention puts it. The reprojection error is the same.
#[test]
fn the_disparity_offset_lands_on_the_step() {
    let mut spec = SynthSpec::new(SceneKind::Planes, Grid::new(5, 5), 128, 128);
    // Levels −1.5 + 2.5·k/5: −1.5, −1, −0.5, 0, 0.5, 1.
    spec.disparity_min = -1.5;
    spec.disparity_max = 1.0;
    spec.seed = 3;
    spec.misalign = Some(Misalignment {
        max_rotation_deg: 2.0,
        max_translation_px: 3.0,
        max_scale: 0.01,
        max_perspective: 0.002,
    });
    let layout = spec.layout();
    let mut data = vec![0u8; layout.validate().unwrap()];
    let mut gt = vec![0.0f32; 128 * 128];
    let mut truth = vec![Homography::IDENTITY; 25];
    synth::render(&spec, &mut data, &mut gt, &mut truth).unwrap();
    let mut offsets = [0.0f32; 2];
    let mut rms = [0.0f32; 2];
    for (k, step) in [0.0f32, 0.5].into_iter().enumerate() {
        let params = AlignParams {
            mode: AlignMode::On,
            views: AlignedViews::All,
            disparity_step: step,
            ..AlignParams::default()
        };
        let (report, hs) = tests::run(&data, layout, &params);
        rms[k] = report.unwrap().rms;
        offsets[k] = gauge_fit(&hs, &truth, spec.grid, 128, 128)
            .unwrap()
            .disparity_offset;
    }
    std::eprintln!("offsets {offsets:?}, track RMS {rms:?}");
    let off_grid = |d: f32| libm::fabsf(d - 0.5 * libm::roundf(d / 0.5));
    assert!(off_grid(offsets[1]) < 0.03, "{offsets:?}");
    assert!(
        libm::fabsf(offsets[1] - offsets[0]) <= 0.25 + 1e-3,
        "{offsets:?}"
    );
    assert!(libm::fabsf(rms[1] - rms[0]) < 1e-3, "{rms:?}");
}

#[test]
fn bad_disparity_steps_are_parameter_errors() {
    for step in [-0.5, f32::NAN, f32::INFINITY, 5.0] {
        let params = AlignParams {
            disparity_step: step,
            ..AlignParams::default()
        };
        assert!(
            matches!(params.validate(), Err(Error::InvalidParameter { .. })),
            "{step}"
        );
    }
}
