//! The parameters of the plane sweep and their limits.

use crate::error::{Error, Result};
use crate::setup::StageParams;

/// Largest aggregation radius (px): a `(2·8 + 1)²` box.
pub const MAX_RADIUS: usize = 8;
/// Longest line window factor.
pub const MAX_LINE: usize = 4;
/// Widest window (px) of the per-pixel candidate ([`PlaneSweepParams::candidate`]).
pub const MAX_CANDIDATE: usize = 9;

/// Parameters of the plane-sweep start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneSweepParams {
    /// Start the pipeline from the plane sweep instead of the EPI stage (the automatic
    /// range of the EPI stage still sets the hypotheses).
    pub enabled: bool,
    /// Largest distance between hypotheses (px), 0.05…1.
    pub step: f32,
    /// Aggregation window radius (px), 0…[`MAX_RADIUS`].
    pub radius: usize,
    /// Truncation of each channel's absolute difference (unit intensity), 0.001…1.
    pub truncate: f32,
    /// A one-axis volume's winner replaces the combined one's when its confidence
    /// exceeds the combined one's times this (and the other one-axis volumes'), 1…4.
    pub select: f32,
    /// Line windows of the one-axis volumes: this many times the radius on each side, 1…4.
    pub line: usize,
    /// Sweep confidence (0…1) below which the refinement's confidence of a pixel is
    /// scaled by `(sweep confidence / trust)²`, so that TV weighs a start the sweep was
    /// unsure of (a flat cost curve whose window-wide winner a whole patch shares) less
    /// than its neighbours. 0 (the default): the refinement's confidence as it is.
    /// Measured in docs/stages/sweep.md ("Distrusting flat cost curves"): it fixes the
    /// 256² dusk poster and lowers the 512² suite's mean, but worsens 256² hall and six
    /// of the seven synthetic demo scenes, so it is off.
    pub trust: f32,
    /// Side (px, odd, at most [`MAX_CANDIDATE`]) of a small square window whose winner
    /// the sweep keeps per pixel beside its map, and which the refinement's first
    /// propagation round offers each pixel as one more candidate (accepted by the rule
    /// of a neighbour's) where the candidates of two opposite neighbours agree with it
    /// (a line of them): structures narrower than every window of the sweep are lost
    /// to its map and held by no neighbour. 1: the per-pixel cost `e_h + e_v` alone.
    /// 0: off. Only when the sweep alone starts the pipeline and the refinement
    /// propagates. Where the small window's cost curve is flat (confidence below 0.5)
    /// the map's own disparity stands in (no offer). Measured in docs/stages/sweep.md
    /// ("A per-pixel candidate"): it improves both HCI scenes and every scene of the
    /// 512² suite, but not demo `thin` or the 256² dusk, and 256² hall, relief and
    /// tabletop get worse, so it is off.
    pub candidate: usize,
    /// What a view is matched on: the three colour channels, or their mean
    /// ([`SweepColor`]).
    pub color: SweepColor,
}

/// What the plane sweep matches per view and pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SweepColor {
    /// Each colour channel's truncated difference (up to three channels), summed.
    #[default]
    Rgb,
    /// One truncated difference of luminance, the mean of the (up to three) colour
    /// channels, converted once per band: a third of the matching's samples. The mean
    /// rather than Rec. 601 weights: under equal noise in every channel it has the least
    /// noise (σ/√3 against 0.67·σ) and keeps blue edges' weight. Its difference is
    /// truncated at `truncate/√3`: the same multiple of its noise as a channel's.
    /// Measured in docs/stages/sweep.md ("Matching on luminance"): the sweep takes about
    /// 40 % fewer instructions and both suites' means and both HCI scenes' BadPix0.07
    /// improve, but dusk (both sizes), 256² tabletop and six of the seven demo scenes
    /// get worse, so it is not the default.
    Gray,
}

impl Default for PlaneSweepParams {
    fn default() -> Self {
        PlaneSweepParams {
            enabled: false,
            step: 0.25,
            radius: 4,
            truncate: 0.1,
            select: 1.0,
            line: 2,
            trust: 0.0,
            candidate: 0,
            color: SweepColor::Rgb,
        }
    }
}

impl StageParams for PlaneSweepParams {
    fn validate(&self) -> Result<()> {
        PlaneSweepParams::validate(self)
    }
}

impl PlaneSweepParams {
    /// The stage switched off: the EPI stage starts the pipeline.
    pub fn off() -> Self {
        PlaneSweepParams {
            enabled: false,
            ..Self::default()
        }
    }

    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, reason| Err(Error::InvalidParameter { name, reason });
        if !(self.step.is_finite() && (0.05..=1.0).contains(&self.step)) {
            return bad("sweep.step", "must be in [0.05, 1] pixels");
        }
        if self.radius > MAX_RADIUS {
            return bad("sweep.radius", "must be in 0..=8 pixels");
        }
        if !(self.truncate.is_finite() && (0.001..=1.0).contains(&self.truncate)) {
            return bad("sweep.truncate", "must be in [0.001, 1] (unit intensity)");
        }
        if !(self.select.is_finite() && (1.0..=4.0).contains(&self.select)) {
            return bad("sweep.select", "must be in [1, 4]");
        }
        if !(1..=4).contains(&self.line) {
            return bad("sweep.line", "must be in 1..=4");
        }
        if !(self.trust.is_finite() && (0.0..=1.0).contains(&self.trust)) {
            return bad("sweep.trust", "must be in [0, 1] (0: off)");
        }
        if self.candidate > MAX_CANDIDATE || (self.candidate > 0 && self.candidate % 2 == 0) {
            return bad(
                "sweep.candidate",
                "must be 0 (off) or an odd window side of at most 9 pixels (1, 3, …)",
            );
        }
        Ok(())
    }
}
