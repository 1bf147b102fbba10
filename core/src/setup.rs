//! What one stage needs of a run: the validated layout, its pixel count and the stage's
//! own parameters; and [`DisparityOut`], where the stages that estimate write. A stage takes a [`Setup`] of its parameters (`Setup<'_, EpiParams>`),
//! never the whole plan, so the stages sit below the plan that holds them all
//! (`Plan::epi()`, `Plan::tv()`, … hand each stage its part).

use crate::error::{checked_product, Result};
use crate::lightfield::Layout;

/// Parameters of one stage: checked once, before the stage runs.
pub trait StageParams {
    /// Checks every parameter; the error names the one to change.
    fn validate(&self) -> Result<()>;
}

/// A validated layout and one stage's validated parameters.
#[derive(Debug)]
pub struct Setup<'a, P> {
    layout: &'a Layout,
    params: &'a P,
    pixels: usize,
}

// Derived `Clone`/`Copy` would require `P: Copy`; the setup only borrows `P`.
impl<P> Clone for Setup<'_, P> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<P> Copy for Setup<'_, P> {}

impl<'a, P: StageParams> Setup<'a, P> {
    /// Validates `layout` and `params`.
    pub fn new(layout: &'a Layout, params: &'a P) -> Result<Self> {
        layout.validate()?;
        params.validate()?;
        let pixels = checked_product(&[layout.width, layout.height], "the disparity map")?;
        Ok(Setup {
            layout,
            params,
            pixels,
        })
    }
}

impl<'a, P> Setup<'a, P> {
    /// A setup of a layout and parameters the caller validated (the plan does, once, for
    /// every stage); `pixels` is `layout.width · layout.height`, checked.
    pub(crate) fn validated(layout: &'a Layout, params: &'a P, pixels: usize) -> Self {
        Setup {
            layout,
            params,
            pixels,
        }
    }

    /// The same layout with other valid parameters of the same stage.
    pub(crate) fn with_params<'b>(&self, params: &'b P) -> Setup<'b, P>
    where
        'a: 'b,
    {
        Setup {
            layout: self.layout,
            params,
            pixels: self.pixels,
        }
    }

    /// The light-field layout.
    pub fn layout(&self) -> &'a Layout {
        self.layout
    }
    /// The stage's parameters.
    pub fn params(&self) -> &'a P {
        self.params
    }
    /// Pixels of the centre view: the length of every per-pixel map.
    pub fn pixels(&self) -> usize {
        self.pixels
    }
}

/// Where a stage writes its two per-pixel maps: `disparity` and its `confidence`, the
/// same length each (a band's values or the whole map, as the stage says).
#[derive(Debug)]
pub struct DisparityOut<'a> {
    /// The disparity (px between adjacent views).
    pub disparity: &'a mut [f32],
    /// The confidence of each disparity, in `[0, 1]`.
    pub confidence: &'a mut [f32],
}

/// An owned layout and one stage's parameters, validated: what the stages' unit tests
/// hold where a run holds a plan.
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct TestSetup<P> {
    layout: Layout,
    params: P,
    pixels: usize,
}

#[cfg(test)]
impl<P: StageParams> TestSetup<P> {
    /// Panics (a test failure) when `layout` or `params` is invalid.
    pub(crate) fn new(layout: Layout, params: P) -> Self {
        let pixels = Setup::new(&layout, &params).unwrap().pixels();
        TestSetup {
            layout,
            params,
            pixels,
        }
    }
    /// The setup a stage takes.
    pub(crate) fn setup(&self) -> Setup<'_, P> {
        Setup::validated(&self.layout, &self.params, self.pixels)
    }
    pub(crate) fn layout(&self) -> &Layout {
        &self.layout
    }
    pub(crate) fn params(&self) -> &P {
        &self.params
    }
    pub(crate) fn pixels(&self) -> usize {
        self.pixels
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::Grid;
    use crate::Error;

    struct Positive(f32);
    impl StageParams for Positive {
        fn validate(&self) -> Result<()> {
            if self.0 > 0.0 {
                Ok(())
            } else {
                Err(Error::InvalidParameter {
                    name: "positive",
                    reason: "must be > 0",
                })
            }
        }
    }

    #[test]
    fn new_validates_layout_and_params() {
        let layout = Layout::packed(Grid::new(9, 9), 64, 48, 3);
        let setup = Setup::new(&layout, &Positive(1.0)).unwrap();
        assert_eq!(setup.pixels(), 64 * 48);
        assert_eq!(setup.layout(), &layout);
        assert!(matches!(
            Setup::new(&layout, &Positive(0.0)),
            Err(Error::InvalidParameter {
                name: "positive",
                ..
            })
        ));
        let bad = Layout::packed(Grid::new(2, 9), 64, 48, 3);
        assert!(matches!(
            Setup::new(&bad, &Positive(1.0)),
            Err(Error::GridSize { .. })
        ));
    }
}
