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
}
