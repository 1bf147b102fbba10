//! A tiny seeded generator (SplitMix64): the same numbers on every platform.

/// SplitMix64 (Steele, Lea & Flood 2014): 64-bit state, passes BigCrush, a few lines.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Rng {
    state: u64,
    spare_normal: Option<f64>,
}

impl Rng {
    /// An independent stream for `(seed, purpose, index)`, so that e.g. the noise of view 7
    /// does not depend on how many numbers the scene builder drew.
    pub(crate) fn stream(seed: u64, purpose: u64, index: u64) -> Self {
        let mut mixer = Rng {
            state: seed ^ purpose.wrapping_mul(0xA24B_AED4_963E_E407),
            spare_normal: None,
        };
        let a = mixer.next_u64();
        mixer.state ^= index.wrapping_mul(0x9FB2_1C65_1E98_DF25);
        let b = mixer.next_u64();
        Rng {
            state: a ^ b.rotate_left(17),
            spare_normal: None,
        }
    }

    pub(crate) fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)` with 53 random bits.
    pub(crate) fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[lo, hi)`.
    pub(crate) fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Uniform in `[-magnitude, magnitude)`.
    pub(crate) fn symmetric(&mut self, magnitude: f64) -> f64 {
        self.range(-magnitude, magnitude)
    }

    /// Standard normal deviate (Box–Muller; the second value of each pair is kept).
    pub(crate) fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare_normal.take() {
            return z;
        }
        // 1 − unit() lies in (0, 1], so the logarithm is finite.
        let radius = crate::float::sqrt(-2.0 * libm::log(1.0 - self.unit()));
        let (cos, sin) = super::trig::sincos(core::f64::consts::TAU * self.unit());
        self.spare_normal = Some(radius * sin);
        radius * cos
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let mut a = Rng::stream(1, 2, 3);
        let mut b = Rng::stream(1, 2, 3);
        let mut c = Rng::stream(1, 2, 4);
        let (x, y, z) = (a.next_u64(), b.next_u64(), c.next_u64());
        assert_eq!(x, y);
        assert_ne!(x, z);
        assert_ne!(Rng::stream(1, 3, 3).next_u64(), x);
    }

    #[test]
    fn normal_has_unit_variance() {
        let mut rng = Rng::stream(7, 0, 0);
        let n = 20_000;
        let (mut sum, mut sq) = (0.0, 0.0);
        for _ in 0..n {
            let z = rng.normal();
            sum += z;
            sq += z * z;
        }
        let mean = sum / n as f64;
        let var = sq / n as f64 - mean * mean;
        assert!(
            mean.abs() < 0.03 && (var - 1.0).abs() < 0.05,
            "{mean} {var}"
        );
    }
}
