//! Per-view camera imperfections: misalignment homographies and photometric changes.
//!
//! The centre view is the reference: it is never misaligned nor photometrically changed
//! (so the ground truth describes it exactly); every other view draws its own changes from
//! the seed. Noise (see `raster`) applies to every view, the centre included.

use super::rng::Rng;
use super::SynthSpec;
use crate::Homography;

/// Random-stream purposes, so the draws of one effect never shift another's.
pub(crate) const MISALIGN_STREAM: u64 = 0x4D15_A116;
pub(crate) const PHOTOMETRIC_STREAM: u64 = 0x9407_0E7C;
pub(crate) const NOISE_STREAM: u64 = 0x0153_5EED;

/// What happens to one view between the ideal rectified camera and the stored pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ViewCamera {
    /// Ideal → misaligned pixel coordinates (row-major 3×3), identity when aligned.
    pub(crate) forward: [f64; 9],
    /// Misaligned → ideal pixel coordinates.
    pub(crate) inverse: [f64; 9],
    pub(crate) misaligned: bool,
    /// Multiplicative brightness and contrast (about mid-gray) of the linear radiance.
    pub(crate) brightness: f64,
    pub(crate) contrast: f64,
}

const IDENTITY: [f64; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

impl ViewCamera {
    /// The camera of view `(row, col)` of a validated spec.
    pub(crate) fn new(spec: &SynthSpec, row: usize, col: usize) -> Self {
        let index = spec.grid.index(row, col) as u64;
        let is_centre = (row, col) == spec.grid.center();
        let mut camera = ViewCamera {
            forward: IDENTITY,
            inverse: IDENTITY,
            misaligned: false,
            brightness: 1.0,
            contrast: 1.0,
        };
        if is_centre {
            return camera;
        }
        if spec.photometric > 0.0 {
            let mut rng = Rng::stream(spec.seed, PHOTOMETRIC_STREAM, index);
            let p = spec.photometric as f64;
            camera.brightness = 1.0 + rng.symmetric(p);
            camera.contrast = 1.0 + rng.symmetric(p);
        }
        if let Some(m) = spec.misalign {
            let mut rng = Rng::stream(spec.seed, MISALIGN_STREAM, index);
            let angle = rng.symmetric(m.max_rotation_deg as f64).to_radians();
            let tx = rng.symmetric(m.max_translation_px as f64);
            let ty = rng.symmetric(m.max_translation_px as f64);
            let scale = 1.0 + rng.symmetric(m.max_scale as f64);
            let (half_w, half_h) = (spec.width as f64 / 2.0, spec.height as f64 / 2.0);
            // Perspective terms change the homogeneous w by at most ±max_perspective
            // (each axis) at the image edges.
            let px = rng.symmetric(m.max_perspective as f64) / half_w;
            let py = rng.symmetric(m.max_perspective as f64) / half_h;
            let (cos, sin) = (libm::cos(angle) * scale, libm::sin(angle) * scale);
            // About the image centre o: H = T(o) · M · T(−o).
            let relative = [cos, -sin, tx, sin, cos, ty, px, py, 1.0];
            let (ox, oy) = (
                (spec.width as f64 - 1.0) / 2.0,
                (spec.height as f64 - 1.0) / 2.0,
            );
            let to_centre = [1.0, 0.0, -ox, 0.0, 1.0, -oy, 0.0, 0.0, 1.0];
            let from_centre = [1.0, 0.0, ox, 0.0, 1.0, oy, 0.0, 0.0, 1.0];
            let forward = normalise(mul(&from_centre, &mul(&relative, &to_centre)));
            // Small, well-conditioned maps: the inverse always exists.
            let inverse = normalise(adjugate(&forward));
            camera.forward = forward;
            camera.inverse = inverse;
            camera.misaligned = true;
        }
        camera
    }

    /// The ideal → misaligned homography as the crate's f32 type.
    pub(crate) fn homography(&self) -> Homography {
        Homography {
            m: self.forward.map(|v| v as f32),
        }
    }

    /// Ideal-view coordinates of stored-view point `(x, y)`.
    #[inline]
    pub(crate) fn ideal_point(&self, x: f64, y: f64) -> (f64, f64) {
        if self.misaligned {
            apply(&self.inverse, x, y)
        } else {
            (x, y)
        }
    }

    /// Jacobian `[∂x/∂x', ∂x/∂y', ∂y/∂x', ∂y/∂y']` of stored → ideal coordinates at
    /// stored point `(x', y')`: the footprint of a stored pixel (for box filtering).
    #[inline]
    pub(crate) fn jacobian_at(&self, x: f64, y: f64) -> [f64; 4] {
        if !self.misaligned {
            return [1.0, 0.0, 0.0, 1.0];
        }
        let m = &self.inverse;
        let w = m[6] * x + m[7] * y + m[8];
        let (ix, iy) = apply(m, x, y);
        [
            (m[0] - m[6] * ix) / w,
            (m[1] - m[7] * ix) / w,
            (m[3] - m[6] * iy) / w,
            (m[4] - m[7] * iy) / w,
        ]
    }

    /// The stored linear radiance for ideal linear radiance `value` (after saturation).
    #[inline]
    pub(crate) fn photometric(&self, value: f64) -> f64 {
        (0.5 + (value - 0.5) * self.contrast) * self.brightness
    }
}

/// Applies a homography; the maps built here keep w near 1.
#[inline]
fn apply(m: &[f64; 9], x: f64, y: f64) -> (f64, f64) {
    let w = m[6] * x + m[7] * y + m[8];
    (
        (m[0] * x + m[1] * y + m[2]) / w,
        (m[3] * x + m[4] * y + m[5]) / w,
    )
}

fn mul(a: &[f64; 9], b: &[f64; 9]) -> [f64; 9] {
    let mut m = [0.0; 9];
    for r in 0..3 {
        for c in 0..3 {
            m[r * 3 + c] = a[r * 3] * b[c] + a[r * 3 + 1] * b[3 + c] + a[r * 3 + 2] * b[6 + c];
        }
    }
    m
}

/// The adjugate: the inverse up to scale.
fn adjugate(m: &[f64; 9]) -> [f64; 9] {
    [
        m[4] * m[8] - m[5] * m[7],
        m[2] * m[7] - m[1] * m[8],
        m[1] * m[5] - m[2] * m[4],
        m[5] * m[6] - m[3] * m[8],
        m[0] * m[8] - m[2] * m[6],
        m[2] * m[3] - m[0] * m[5],
        m[3] * m[7] - m[4] * m[6],
        m[1] * m[6] - m[0] * m[7],
        m[0] * m[4] - m[1] * m[3],
    ]
}

fn normalise(m: [f64; 9]) -> [f64; 9] {
    let s = m[8];
    m.map(|v| v / s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::{Misalignment, SceneKind};
    use crate::Grid;

    #[test]
    fn jacobian_matches_finite_differences_and_inverse_undoes_forward() {
        let mut spec = SynthSpec::new(SceneKind::Planes, Grid::new(5, 5), 200, 100);
        spec.misalign = Some(Misalignment {
            max_rotation_deg: 3.0,
            max_translation_px: 5.0,
            max_scale: 0.05,
            max_perspective: 0.05,
        });
        spec.photometric = 0.1;
        let camera = ViewCamera::new(&spec, 0, 3);
        assert!(camera.misaligned);
        assert!(camera.brightness != 1.0 && camera.contrast != 1.0);
        for (x, y) in [(0.0, 0.0), (150.0, 20.0), (199.0, 99.0)] {
            let (ix, iy) = camera.ideal_point(x, y);
            let (bx, by) = apply(&camera.forward, ix, iy);
            assert!((bx - x).abs() < 1e-9 && (by - y).abs() < 1e-9);
            let j = camera.jacobian_at(x, y);
            let h = 1e-4;
            let (rx, ry) = camera.ideal_point(x + h, y);
            let (dx, dy) = camera.ideal_point(x, y + h);
            let numeric = [(rx - ix) / h, (dx - ix) / h, (ry - iy) / h, (dy - iy) / h];
            for (a, b) in j.iter().zip(numeric) {
                assert!((a - b).abs() < 1e-6, "{j:?} {numeric:?}");
            }
        }
        let centre = ViewCamera::new(&spec, 2, 2);
        assert!(!centre.misaligned && centre.brightness == 1.0);
    }
}
