//! Parameters of the TV stage.

use crate::error::{Error, Result};
use crate::setup::StageParams;

/// Which norm couples the two forward edges of a node (the α-norm of the constraint sets).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TvNorm {
    /// ℓ1 TV (anisotropic): the dual of each edge lies in `[-1, 1]`.
    L1,
    /// ℓ2 TV (isotropic): the dual pair of each node lies in the unit disc.
    L2,
}

/// Parameters of the TV stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TvParams {
    /// Weight λ of the total variation against the data term.
    pub lambda: f32,
    /// Weak fidelity ℸ on every pixel (keeps unreliable pixels well posed).
    pub tikhonov: f32,
    /// Pixels whose confidence is below this are unreliable (`M` drops them).
    pub confidence_threshold: f32,
    /// Data weight of a reliable pixel: `confidence^power` (structure-tensor coherence
    /// crowds near 1, a power spreads it).
    pub confidence_power: f32,
    /// Scale σ of the centre-view colour step for edge weights `1 / (1 + (Δ/σ)²)`,
    /// Δ in unit intensity (max over channels). Zero disables edge weighting.
    pub edge_sigma: f32,
    /// Smallest edge weight, so strong image edges still couple a little.
    pub edge_floor: f32,
    /// The norm of the TV.
    pub norm: TvNorm,
    /// Most PPXA iterations per tile.
    pub max_iterations: usize,
    /// Stop a tile when one iteration moves the primal by less than this, in pixels, RMS
    /// over the tile's region with each pixel weighted by its data weight `a_i` (≤ 1 + ℸ):
    /// `√(Σ a_i (xₙ − xₙ₋₁)_i² / n)` with `x = D − λA⁻¹WᵀF` (checked every fourth
    /// iteration). Zero runs every iteration. The default 7e-4 is affordable because
    /// the PPXA copies start at their fixed point for the start dual (and the start's
    /// scale ε is 0.05): the default pipeline's TV runs 1.14× (cotton) to 1.34×
    /// (backgammon) fewer cycles than at 5e-4 with BadPix0.07 −0.013 / +0.006 points on
    /// the HCI scenes (docs/stages/tv.md).
    pub tolerance: f32,
    /// PPXA step γ.
    pub step: f32,
    /// PPXA relaxation (in (0, 2)).
    pub relaxation: f32,
    /// Side of a tile's core in pixels. 256 (+ 16 halo) does a fifth fewer node-iterations
    /// than 128 + 16 on a 512² map (the halo adds 27 % nodes instead of 56 %) and agrees
    /// better with an untiled solve; each tile's solver state is then ≈ 3.6 MB of `f32`.
    pub tile: usize,
    /// Pixels of context around each core.
    pub halo: usize,
    /// Outer sweeps after the first pass over the tiles (0…8): each solves every tile
    /// again, starting from the previous pass's dual and holding the flows across its
    /// region's border at the neighbours' values, so the tiles agree where they meet.
    /// They need [`crate::tv::dual_len`] floats of caller memory; zero keeps tiles fully
    /// independent (streaming, firmware).
    pub sweeps: usize,
}

impl Default for TvParams {
    fn default() -> Self {
        TvParams {
            lambda: 0.5,
            tikhonov: 0.01,
            confidence_threshold: 0.0,
            confidence_power: 1.0,
            edge_sigma: 0.02,
            edge_floor: 0.05,
            norm: TvNorm::L2,
            max_iterations: 300,
            tolerance: 7e-4,
            step: 4.0,
            relaxation: 1.9,
            tile: 256,
            halo: 16,
            sweeps: 0,
        }
    }
}

fn finite_in(name: &'static str, v: f32, ok: bool, reason: &'static str) -> Result<()> {
    if v.is_finite() && ok {
        Ok(())
    } else {
        Err(Error::InvalidParameter { name, reason })
    }
}

impl StageParams for TvParams {
    fn validate(&self) -> Result<()> {
        TvParams::validate(self)
    }
}

impl TvParams {
    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        finite_in(
            "tv.lambda",
            self.lambda,
            self.lambda > 0.0 && self.lambda <= 1000.0,
            "must be in (0, 1000]",
        )?;
        finite_in(
            "tv.tikhonov",
            self.tikhonov,
            self.tikhonov >= 1e-4 && self.tikhonov <= 100.0,
            "must be in [1e-4, 100] (it keeps unreliable pixels well posed)",
        )?;
        finite_in(
            "tv.confidence_threshold",
            self.confidence_threshold,
            (0.0..=1.0).contains(&self.confidence_threshold),
            "must be in [0, 1]",
        )?;
        finite_in(
            "tv.confidence_power",
            self.confidence_power,
            self.confidence_power > 0.0 && self.confidence_power <= 1000.0,
            "must be in (0, 1000]",
        )?;
        finite_in(
            "tv.edge_sigma",
            self.edge_sigma,
            self.edge_sigma >= 0.0,
            "must be zero (no edge weighting) or positive",
        )?;
        finite_in(
            "tv.edge_floor",
            self.edge_floor,
            self.edge_floor > 0.0 && self.edge_floor <= 1.0,
            "must be in (0, 1]",
        )?;
        if self.max_iterations == 0 || self.max_iterations > 100_000 {
            return Err(Error::InvalidParameter {
                name: "tv.max_iterations",
                reason: "must be in 1..=100000",
            });
        }
        finite_in(
            "tv.tolerance",
            self.tolerance,
            self.tolerance >= 0.0,
            "must be zero (run every iteration) or a positive change in pixels",
        )?;
        finite_in(
            "tv.step",
            self.step,
            self.step > 0.0 && self.step <= 1000.0,
            "must be in (0, 1000]",
        )?;
        finite_in(
            "tv.relaxation",
            self.relaxation,
            self.relaxation > 0.0 && self.relaxation < 2.0,
            "must be in (0, 2)",
        )?;
        if !(8..=4096).contains(&self.tile) {
            return Err(Error::InvalidParameter {
                name: "tv.tile",
                reason: "must be in 8..=4096 pixels",
            });
        }
        if self.halo > 256 {
            return Err(Error::InvalidParameter {
                name: "tv.halo",
                reason: "must be at most 256 pixels",
            });
        }
        if self.sweeps > super::MAX_SWEEPS {
            return Err(Error::InvalidParameter {
                name: "tv.sweeps",
                reason: "must be at most 8 outer sweeps",
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_bad_values_are_named() {
        TvParams::default().validate().unwrap();
        let bad = TvParams {
            relaxation: 2.0,
            ..TvParams::default()
        };
        assert!(matches!(
            bad.validate(),
            Err(Error::InvalidParameter {
                name: "tv.relaxation",
                ..
            })
        ));
        let bad = TvParams {
            lambda: f32::NAN,
            ..TvParams::default()
        };
        assert!(bad.validate().is_err());
        let bad = TvParams {
            tile: 4,
            ..TvParams::default()
        };
        assert!(bad.validate().is_err());
    }
}
