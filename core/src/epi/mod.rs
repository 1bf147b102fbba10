//! Initial disparity from epipolar-plane images (structure tensor).

use crate::error::Result;

/// Parameters of the EPI stage.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EpiParams {}

impl EpiParams {
    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        Ok(())
    }
}
