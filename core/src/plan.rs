//! A [`Plan`]: dimensions and parameters validated once, from which every buffer size
//! follows. Stages take `&Plan` and report their own scratch needs
//! (`epi::scratch_len(&plan)`, `tv::scratch_len(&plan)`).

use crate::align::{AlignMode, AlignParams};
use crate::epi::EpiParams;
use crate::error::{checked_product, Result};
use crate::lightfield::Layout;
use crate::refine::RefineParams;
use crate::tv::TvParams;

/// Parameters of every stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    /// Alignment of an imperfect array before the other stages (used by
    /// `pipeline::run_aligned`; `pipeline::run` takes the array as rectified). The
    /// default here is [`AlignMode::Off`]: a library caller opts in (the CLI and the page
    /// default to [`AlignMode::Auto`]).
    pub align: AlignParams,
    /// Initial disparity from EPIs.
    pub epi: EpiParams,
    /// Photometric refinement of the EPI disparity over many views.
    pub refine: RefineParams,
    /// Total-variation refinement.
    pub tv: TvParams,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            align: AlignParams {
                mode: AlignMode::Off,
                ..AlignParams::default()
            },
            epi: EpiParams::default(),
            refine: RefineParams::default(),
            tv: TvParams::default(),
        }
    }
}

/// Validated dimensions and parameters of one estimation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    layout: Layout,
    params: Params,
    pixels: usize,
}

impl Plan {
    /// Validates the layout and every stage's parameters.
    pub fn new(layout: Layout, params: Params) -> Result<Self> {
        layout.validate()?;
        params.align.validate()?;
        params.epi.validate()?;
        params.refine.validate()?;
        params.tv.validate()?;
        let pixels = checked_product(&[layout.width, layout.height], "the disparity map")?;
        Ok(Plan {
            layout,
            params,
            pixels,
        })
    }
    /// The light-field layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }
    /// Stage parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }
    /// Pixels of the centre view: the length of every per-pixel output.
    pub fn pixels(&self) -> usize {
        self.pixels
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::Grid;
    use crate::Error;

    #[test]
    fn plan_validates_layout() {
        let layout = Layout::packed(Grid::new(9, 9), 64, 48, 3);
        let plan = Plan::new(layout, Params::default()).unwrap();
        assert_eq!(plan.pixels(), 64 * 48);
        let bad = Layout::packed(Grid::new(2, 9), 64, 48, 3);
        assert!(matches!(
            Plan::new(bad, Params::default()),
            Err(Error::GridSize { .. })
        ));
    }
}
