//! Band-limited procedural texture: a seeded sum of oriented sinusoids per surface.
//!
//! Sinusoids keep the texture strictly band-limited (wavelengths 5…40 px), and, more
//! usefully, their integral over an affinely mapped pixel is known in closed form, so
//! pixels inside a planar surface are box-filtered exactly (see `raster`).

use super::rng::Rng;

/// Sinusoids per texture.
pub(crate) const WAVES: usize = 8;
/// Shortest and longest wavelength in pixels (band limit well below Nyquist).
const SHORTEST_WAVELENGTH: f64 = 5.0;
const LONGEST_WAVELENGTH: f64 = 40.0;

/// One sinusoid `amplitude · colour · cos(fx·x + fy·y + phase)`, frequencies in rad/px.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Wave {
    pub(crate) fx: f64,
    pub(crate) fy: f64,
    pub(crate) phase: f64,
    /// Amplitude per channel (red, green, blue; gray uses the first).
    pub(crate) amplitude: [f64; 3],
}

/// Linear radiance in nominal `[0, 1]` per channel as a function of the surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Texture {
    pub(crate) base: [f64; 3],
    pub(crate) waves: [Wave; WAVES],
}

impl Texture {
    pub(crate) const FLAT: Texture = Texture {
        base: [0.5; 3],
        waves: [Wave {
            fx: 0.0,
            fy: 0.0,
            phase: 0.0,
            amplitude: [0.0; 3],
        }; WAVES],
    };

    /// A random texture whose radiance has standard deviation about `contrast` around a
    /// random base colour. `gray` makes every channel equal.
    pub(crate) fn random(rng: &mut Rng, contrast: f64, gray: bool) -> Texture {
        let mut texture = Texture::FLAT;
        let mut base = [0.0; 3];
        for b in base.iter_mut() {
            *b = rng.range(0.3, 0.7);
        }
        let mut energy = 0.0;
        for wave in texture.waves.iter_mut() {
            // Log-uniform wavelength, uniform orientation and phase.
            let wavelength = SHORTEST_WAVELENGTH
                * libm::pow(LONGEST_WAVELENGTH / SHORTEST_WAVELENGTH, rng.unit());
            let angle = rng.range(0.0, core::f64::consts::PI);
            let omega = core::f64::consts::TAU / wavelength;
            wave.fx = omega * libm::cos(angle);
            wave.fy = omega * libm::sin(angle);
            wave.phase = rng.range(0.0, core::f64::consts::TAU);
            let strength = rng.range(0.5, 1.0);
            for a in wave.amplitude.iter_mut() {
                // Positive colour weights: mostly luminance, tinted per wave.
                *a = strength * rng.range(0.5, 1.0);
            }
            energy += strength * strength * 0.5625 / 2.0;
        }
        // Normalise so the sum of waves has standard deviation ≈ `contrast`.
        let scale = contrast / crate::float::sqrt(energy);
        for wave in texture.waves.iter_mut() {
            for a in wave.amplitude.iter_mut() {
                *a *= scale;
            }
        }
        if gray {
            let mean = |v: [f64; 3]| (v[0] + v[1] + v[2]) / 3.0;
            base = [mean(base); 3];
            for wave in texture.waves.iter_mut() {
                wave.amplitude = [mean(wave.amplitude); 3];
            }
        }
        texture.base = base;
        texture
    }

    /// The texture with its radiance multiplied by `k` (a darker or brighter material).
    pub(crate) fn scaled(mut self, k: f64) -> Texture {
        self.base = self.base.map(|b| b * k);
        for wave in self.waves.iter_mut() {
            wave.amplitude = wave.amplitude.map(|a| a * k);
        }
        self
    }

    /// Radiance at surface point `(x, y)` (a point sample).
    pub(crate) fn at(&self, x: f64, y: f64) -> [f64; 3] {
        let mut value = self.base;
        for wave in &self.waves {
            let c = super::trig::cos(wave.fx * x + wave.fy * y + wave.phase);
            for (v, a) in value.iter_mut().zip(wave.amplitude) {
                *v += a * c;
            }
        }
        value
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_has_the_requested_contrast_and_band_limit() {
        let mut rng = Rng::stream(3, 0, 0);
        let t = Texture::random(&mut rng, 0.2, false);
        let n = 200;
        let (mut sum, mut sq) = (0.0, 0.0);
        for y in 0..n {
            for x in 0..n {
                let v = t.at(x as f64, y as f64)[1];
                sum += v;
                sq += v * v;
            }
        }
        let count = (n * n) as f64;
        let std = crate::float::sqrt(sq / count - (sum / count) * (sum / count));
        assert!(std > 0.12 && std < 0.3, "{std}");
        for w in &t.waves {
            let omega = crate::float::sqrt(w.fx * w.fx + w.fy * w.fy);
            assert!(omega <= core::f64::consts::TAU / SHORTEST_WAVELENGTH + 1e-12);
        }
        let g = Texture::random(&mut rng, 0.2, true);
        let v = g.at(3.0, 4.0);
        assert!(v[0] == v[1] && v[1] == v[2]);
    }
}
