use super::*;
use crate::lightfield::Grid;

/// A rotation by `deg` degrees about `(cx, cy)` followed by a shift.
fn rotation(deg: f32, cx: f32, cy: f32, shift: f32) -> Homography {
    let (s, c) = libm::sincosf(deg.to_radians());
    Homography {
        m: [
            c,
            -s,
            cx - c * cx + s * cy + shift,
            s,
            c,
            cy - s * cx - c * cy - shift,
            0.0,
            0.0,
            1.0,
        ],
    }
}

#[test]
fn a_frame_near_the_centre_camera_is_anchored_on_it_and_a_far_one_is_not() {
    let layout = Layout::packed(Grid::new(3, 3), 200, 100, 3);
    let params = AlignParams::default();
    let view = rotation(1.0, 100.0, 50.0, 2.0);
    // 0.1° about the image centre: 0.19 px at the corners, plus a 0.3 px shift.
    let near = rotation(0.1, 100.0, 50.0, 0.3);
    let mut hs = [view; 9];
    hs[4] = near;
    assert!(anchor_on_centre(
        &layout,
        &params,
        solve::ViewSet::Cross,
        &|_| true,
        &mut hs
    ));
    assert_eq!(hs[4], Homography::IDENTITY);
    // A view of the cross now maps the centre camera's pixels: view ∘ near⁻¹.
    let expect = view.compose(&near.inverse().unwrap());
    for (got, want) in hs[1].m.iter().zip(expect.m) {
        assert!((got - want).abs() < 1e-5, "{:?} vs {:?}", hs[1], expect);
    }
    // Corner views are not estimated with the cross: left alone.
    assert_eq!(hs[0], view);
    // 1° is 1.9 px at the corners: the estimated frame stays.
    let far = rotation(1.0, 100.0, 50.0, 0.0);
    let mut hs = [view; 9];
    hs[4] = far;
    assert!(!anchor_on_centre(
        &layout,
        &params,
        solve::ViewSet::All,
        &|_| true,
        &mut hs
    ));
    assert_eq!(hs[4], far);
    // Off, or another reference: nothing moves.
    let mut hs = [view; 9];
    hs[4] = near;
    let off = AlignParams {
        centre_anchor: 0.0,
        ..params
    };
    assert!(!anchor_on_centre(
        &layout,
        &off,
        solve::ViewSet::All,
        &|_| true,
        &mut hs
    ));
    let centre = AlignParams {
        reference: Reference::CentreView,
        ..params
    };
    assert!(!anchor_on_centre(
        &layout,
        &centre,
        solve::ViewSet::All,
        &|_| true,
        &mut hs
    ));
    assert_eq!(hs[4], near);
    let bad = AlignParams {
        centre_anchor: f32::NAN,
        ..params
    };
    assert!(bad.validate().is_err());
}
