//! Shear hypotheses: the structure tensor is only accurate for small slopes, so the EPIs
//! are sheared to several disparities and each sample keeps the best-scoring hypothesis.

use super::EpiParams;
use crate::error::{Error, Result};

/// Most shear hypotheses one estimation may test.
pub const MAX_HYPOTHESES: usize = 64;
/// Largest disparity magnitude (px between adjacent views) a range may reach.
pub const MAX_DISPARITY: f32 = 8.0;

/// The resolved set of shears and the output range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hypotheses {
    min: f32,
    max: f32,
    first: f32,
    step: f32,
    count: usize,
    window: f32,
}

impl Hypotheses {
    /// Shears at the multiples of `params.shear_step` nearest to every disparity of
    /// `[min, max]` (a single unsheared EPI when `params.shear` is off). Estimates are
    /// clamped to `[min, max]`.
    pub fn new(params: &EpiParams, min: f32, max: f32) -> Result<Self> {
        if !(min.is_finite() && max.is_finite() && min <= max)
            || min < -MAX_DISPARITY
            || max > MAX_DISPARITY
        {
            return Err(Error::InvalidParameter {
                name: "disparity range",
                reason: "must be finite with min <= max, both within -8..8 px",
            });
        }
        if !params.shear {
            return Ok(Hypotheses {
                min,
                max,
                first: 0.0,
                step: 0.0,
                count: 1,
                window: f32::MAX,
            });
        }
        Self::sheared(min, max, params.shear_step, params.window)
    }

    /// Multiples of `step` covering `[min, max]`, accepting residual slopes up to
    /// `window · step`.
    pub(crate) fn sheared(min: f32, max: f32, step: f32, window: f32) -> Result<Self> {
        if !(step.is_finite() && (0.1..=2.0).contains(&step)) {
            return Err(Error::InvalidParameter {
                name: "shear_step",
                reason: "must be between 0.1 and 2 px",
            });
        }
        if !(window.is_finite() && (0.5..=2.0).contains(&window)) {
            return Err(Error::InvalidParameter {
                name: "window",
                reason: "must be between 0.5 and 2 shear steps",
            });
        }
        let lo = libm::roundf(min / step);
        let hi = libm::roundf(max / step);
        let count = (hi - lo) as usize + 1;
        if count > MAX_HYPOTHESES {
            return Err(Error::InvalidParameter {
                name: "shear_step",
                reason: "gives more than 64 hypotheses over the disparity range: increase it",
            });
        }
        Ok(Hypotheses {
            min,
            max,
            first: lo * step,
            step,
            count,
            window: window * step,
        })
    }

    /// The fewest shears `step` apart, centred on `[min, max]`, that leave every disparity
    /// of it within `step / 2` of one (up to the rounding of the shears to multiples of
    /// `grid`, the fine shears' step, so that they read the planes the fine ones read).
    /// The coarse pass's set: a range 3.65 px wide takes 2 shears where the multiples of
    /// `step` covering it take 3.
    pub(crate) fn centred(min: f32, max: f32, step: f32, window: f32, grid: f32) -> Result<Self> {
        let mut h = Self::sheared(min, max, step, window)?;
        let count = libm::ceilf((max - min) / step).max(1.0);
        if !(count.is_finite() && grid > 0.0) || count as usize >= h.count {
            return Ok(h);
        }
        let first = 0.5 * (min + max) - 0.5 * (count - 1.0) * step;
        h.first = libm::roundf(first / grid) * grid;
        h.count = count as usize;
        Ok(h)
    }

    /// Number of shears.
    pub fn count(&self) -> usize {
        self.count
    }
    /// Shear `i` (px between adjacent views).
    pub fn shear(&self, i: usize) -> f32 {
        self.first + i as f32 * self.step
    }
    /// Smallest output disparity.
    pub fn min(&self) -> f32 {
        self.min
    }
    /// Largest output disparity.
    pub fn max(&self) -> f32 {
        self.max
    }
    /// Distance between shears (0 without shear).
    pub fn step(&self) -> f32 {
        self.step
    }
    /// Largest residual slope a hypothesis accepts.
    pub fn window(&self) -> f32 {
        self.window
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shears_cover_the_range_on_step_multiples() {
        let p = EpiParams::default();
        let h = Hypotheses::sheared(-1.55, 0.53, 1.0, 1.0).unwrap();
        assert_eq!(h.count(), 4);
        assert_eq!((h.shear(0), h.shear(3)), (-2.0, 1.0));
        let h = Hypotheses::sheared(-4.0, 4.0, 0.5, 1.0).unwrap();
        assert_eq!(h.count(), 17);
        assert!(Hypotheses::new(&p, 1.0, -1.0).is_err());
        assert!(Hypotheses::new(&p, f32::NAN, 1.0).is_err());
        assert!(Hypotheses::sheared(-8.0, 8.0, 0.1, 1.0).is_err());
        let zero_step = EpiParams {
            shear_step: 0.0,
            ..p
        };
        assert!(Hypotheses::new(&zero_step, -1.0, 1.0).is_err());
        let plain = EpiParams { shear: false, ..p };
        let h = Hypotheses::new(&plain, -2.0, 3.0).unwrap();
        assert_eq!((h.count(), h.shear(0)), (1, 0.0));
    }

    #[test]
    fn centred_shears_are_fewer_and_still_cover_the_range() {
        // HCI cotton's range: 2 shears at ±1 instead of the multiples −2, 0, 2.
        let h = Hypotheses::centred(-1.9, 1.75, 2.0, 1.0, 0.5).unwrap();
        assert_eq!((h.count(), h.shear(0), h.shear(1)), (2, -1.0, 1.0));
        for i in 0..=160 {
            for width in [0.0f32, 0.3, 1.0, 2.0, 3.65, 4.0, 5.5, 9.9, 16.0] {
                let min = -8.0 + 0.1 * i as f32;
                let max = min + width;
                if max > 8.0 {
                    continue;
                }
                let h = Hypotheses::centred(min, max, 2.0, 1.0, 0.5).unwrap();
                let old = Hypotheses::sheared(min, max, 2.0, 1.0).unwrap();
                assert!(h.count() <= old.count(), "{min}..{max}");
                for j in 0..h.count() {
                    let s = h.shear(j);
                    assert!(
                        (s / 0.5 - libm::roundf(s / 0.5)).abs() < 1e-4,
                        "{s} off the grid"
                    );
                    assert!(s.abs() <= MAX_DISPARITY + 0.25, "{s}");
                }
                for k in 0..=20 {
                    let d = min + width * k as f32 / 20.0;
                    let nearest = (0..h.count())
                        .map(|j| (h.shear(j) - d).abs())
                        .fold(f32::MAX, f32::min);
                    assert!(
                        nearest <= 1.25 + 1e-4,
                        "{min}..{max}: {d} is {nearest} away"
                    );
                }
            }
        }
    }
}
