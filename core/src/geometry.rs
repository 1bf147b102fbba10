//! Plane projective geometry shared by the synthetic renderer and alignment.

/// A 3×3 homography, row-major, acting on pixel coordinates `(x, y, 1)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Homography {
    /// Row-major entries `[h00, h01, h02, h10, h11, h12, h20, h21, h22]`.
    pub m: [f32; 9],
}

impl Default for Homography {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Homography {
    /// The identity map.
    pub const IDENTITY: Homography = Homography {
        m: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
    };

    /// Maps a point; `None` when it lands on or behind the line at infinity.
    pub fn apply(&self, x: f32, y: f32) -> Option<(f32, f32)> {
        let m = &self.m;
        let w = m[6] * x + m[7] * y + m[8];
        if !(w.is_finite() && libm::fabsf(w) > 1e-12) {
            return None;
        }
        let u = (m[0] * x + m[1] * y + m[2]) / w;
        let v = (m[3] * x + m[4] * y + m[5]) / w;
        (u.is_finite() && v.is_finite()).then_some((u, v))
    }

    /// `self ∘ other`: first `other`, then `self`.
    pub fn compose(&self, other: &Homography) -> Homography {
        let (a, b) = (&self.m, &other.m);
        let mut m = [0.0f32; 9];
        for r in 0..3 {
            for c in 0..3 {
                m[r * 3 + c] = a[r * 3] * b[c] + a[r * 3 + 1] * b[3 + c] + a[r * 3 + 2] * b[6 + c];
            }
        }
        Homography { m }
    }

    /// The inverse map, or `None` when the matrix is (numerically) singular.
    pub fn inverse(&self) -> Option<Homography> {
        let m = self.m.map(|v| v as f64);
        let cof = [
            m[4] * m[8] - m[5] * m[7],
            m[5] * m[6] - m[3] * m[8],
            m[3] * m[7] - m[4] * m[6],
        ];
        let det = m[0] * cof[0] + m[1] * cof[1] + m[2] * cof[2];
        if !det.is_finite() || det.abs() < 1e-18 {
            return None;
        }
        let inv = [
            cof[0],
            m[2] * m[7] - m[1] * m[8],
            m[1] * m[5] - m[2] * m[4],
            cof[1],
            m[0] * m[8] - m[2] * m[6],
            m[2] * m[3] - m[0] * m[5],
            cof[2],
            m[1] * m[6] - m[0] * m[7],
            m[0] * m[4] - m[1] * m[3],
        ];
        Some(Homography {
            m: inv.map(|v| (v / det) as f32),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_undoes_the_map() {
        let h = Homography {
            m: [1.01, 0.02, 3.0, -0.015, 0.99, -2.0, 1e-5, -2e-5, 1.0],
        };
        let inv = h.inverse().unwrap();
        let (u, v) = h.apply(100.0, 200.0).unwrap();
        let (x, y) = inv.apply(u, v).unwrap();
        assert!((x - 100.0).abs() < 1e-3 && (y - 200.0).abs() < 1e-3);
        let id = h.compose(&inv);
        for (a, b) in id.m.iter().zip(Homography::IDENTITY.m.iter()) {
            assert!((a / id.m[8] - b).abs() < 1e-5);
        }
        assert!(Homography { m: [0.0; 9] }.inverse().is_none());
        assert!(Homography { m: [0.0; 9] }.apply(1.0, 1.0).is_none());
    }
}
