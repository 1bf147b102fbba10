//! Weighted total-variation refinement in the dual, solved with PPXA.

use crate::error::Result;

/// Parameters of the TV stage.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TvParams {}

impl TvParams {
    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        Ok(())
    }
}
