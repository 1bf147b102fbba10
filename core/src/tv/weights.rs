//! Edge weights of the pixel graph from the centre view: depth edges may follow image
//! edges, so a colour step between two pixels lowers the weight of their edge.

use crate::lightfield::Sample;

/// Weight of the edge between two pixels whose largest channel difference is `step`
/// (unit intensity): `max(floor, 1 / (1 + (step/σ)²))`, or 1 when `sigma` is zero.
#[inline]
pub(crate) fn edge_weight(step: f32, sigma: f32, floor: f32) -> f32 {
    if sigma <= 0.0 {
        return 1.0;
    }
    let r = step / sigma;
    let w = 1.0 / (1.0 + r * r);
    if w > floor {
        w
    } else {
        floor
    }
}

/// Largest absolute difference over the first `channels` samples of two pixels
/// (unit intensity).
#[inline]
pub(crate) fn colour_step<P: Sample>(a: &[P], b: &[P], channels: usize) -> f32 {
    let mut step = 0.0f32;
    for (pa, pb) in a.iter().zip(b).take(channels) {
        let d = libm::fabsf(pa.to_unit() - pb.to_unit());
        if d > step {
            step = d;
        }
    }
    step
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_fall_with_the_colour_step_down_to_the_floor() {
        assert_eq!(edge_weight(0.0, 0.05, 0.1), 1.0);
        assert!((edge_weight(0.05, 0.05, 0.1) - 0.5).abs() < 1e-6);
        assert_eq!(edge_weight(1.0, 0.05, 0.1), 0.1);
        assert_eq!(edge_weight(1.0, 0.0, 0.1), 1.0);
    }
}
