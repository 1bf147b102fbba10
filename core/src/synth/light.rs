//! Illumination of a scene and the sensor that records it.
//!
//! * [`Lighting`] belongs to the scene: a gain on the surface radiance as a function of the
//!   surface point (centre-view coordinates), so every view sees the same lit surface and
//!   the ground truth stays exact. Inside a pixel the gain is taken at the surface point of
//!   the pixel centre (it changes by well under 1 % per pixel).
//! * [`Sensor`] belongs to the camera: vignetting by position in the view, then shot noise
//!   whose variance grows with the signal, read noise, and 8-bit quantisation.

/// A light whose illuminance falls off with distance from a point of the scene, over an
/// ambient floor: `gain = ambient + (1 − ambient) / (1 + |p − centre|² / radius²)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Lighting {
    pub(crate) x: f64,
    pub(crate) y: f64,
    pub(crate) radius: f64,
    pub(crate) ambient: f64,
}

impl Lighting {
    /// The gain at surface point `(x, y)`, within `(ambient, 1]`.
    #[inline]
    pub(crate) fn gain(&self, x: f64, y: f64) -> f64 {
        let (dx, dy) = (x - self.x, y - self.y);
        let falloff = 1.0 / (1.0 + (dx * dx + dy * dy) / (self.radius * self.radius));
        self.ambient + (1.0 - self.ambient) * falloff
    }
}

/// A camera sensor's response, in 8-bit levels of the stored value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensor {
    /// Standard deviation of the signal-independent read noise, levels (at most 16).
    pub read_noise: f32,
    /// Shot noise: variance added per level of signal, levels² per level (at most 1;
    /// 0.03 gives σ ≈ 2 levels at mid-gray).
    pub shot_noise: f32,
    /// Relative darkening at the image corners, `1 − vignetting · r²/r²_corner` (at most
    /// 0.9).
    pub vignetting: f32,
}

impl Sensor {
    /// A consumer camera's 8-bit output at base ISO: read noise 0.8 levels, shot noise
    /// σ ≈ 2 levels at mid-gray, corners 30 % darker.
    pub const REALISTIC: Sensor = Sensor {
        read_noise: 0.8,
        shot_noise: 0.03,
        vignetting: 0.3,
    };

    /// The vignetting gain at pixel `(i, j)` of a `width × height` view.
    #[inline]
    pub(crate) fn vignette(&self, i: f64, j: f64, width: usize, height: usize) -> f64 {
        let (cx, cy) = ((width as f64 - 1.0) / 2.0, (height as f64 - 1.0) / 2.0);
        let corner = (cx * cx + cy * cy).max(1.0);
        let (dx, dy) = (i - cx, j - cy);
        1.0 - self.vignetting as f64 * (dx * dx + dy * dy) / corner
    }

    /// The variance of the noise at a signal of `level` 8-bit levels.
    #[inline]
    pub(crate) fn variance(&self, level: f64) -> f64 {
        let read = self.read_noise as f64;
        read * read + self.shot_noise as f64 * level.max(0.0)
    }

    /// The standard deviation of the noise at a signal of `level` 8-bit levels.
    #[cfg(test)]
    fn sigma(&self, level: f64) -> f64 {
        crate::float::sqrt(self.variance(level))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn light_falls_off_to_the_ambient_level() {
        let light = Lighting {
            x: 10.0,
            y: 20.0,
            radius: 50.0,
            ambient: 0.2,
        };
        assert_eq!(light.gain(10.0, 20.0), 1.0);
        assert!((light.gain(60.0, 20.0) - 0.6).abs() < 1e-12);
        assert!(light.gain(1e6, 0.0) < 0.2001);
    }

    #[test]
    fn sensor_noise_grows_with_the_signal_and_corners_are_darker() {
        let s = Sensor::REALISTIC;
        assert!((s.sigma(0.0) - 0.8).abs() < 1e-6);
        assert!(s.sigma(128.0) > 2.0 && s.sigma(128.0) < 2.2);
        assert!(s.sigma(255.0) > s.sigma(128.0));
        assert!((s.vignette(49.5, 49.5, 100, 100) - 1.0).abs() < 1e-12);
        assert!((s.vignette(0.0, 0.0, 100, 100) - 0.7).abs() < 1e-6);
    }
}
