//! Parameters of the photometric refinement stage.

use crate::error::{Error, Result};
use crate::setup::StageParams;

/// Which views enter the photo-consistency.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewSet {
    /// The centre row and column of the grid (the views the EPI stage saw).
    Cross,
    /// The cross and both diagonals through the centre.
    CrossDiagonals,
    /// Every view of the grid.
    All,
}

impl ViewSet {
    /// Whether the view at offset `(dr, dc)` from the centre belongs to the set
    /// (the centre itself never does).
    pub fn contains(&self, dr: isize, dc: isize) -> bool {
        if dr == 0 && dc == 0 {
            return false;
        }
        match self {
            ViewSet::Cross => dr == 0 || dc == 0,
            ViewSet::CrossDiagonals => dr == 0 || dc == 0 || dr == dc || dr == -dc,
            ViewSet::All => true,
        }
    }
}

/// Parameters of the refinement stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefineParams {
    /// Run the stage (off: the paper's EPI → TV pipeline).
    pub enabled: bool,
    /// Views compared with the centre view.
    pub views: ViewSet,
    /// Gauss–Newton iterations, 1…16.
    pub iterations: usize,
    /// Radius of the square aggregation window (px), 0…4.
    pub radius: usize,
    /// Rounds of propagation before the iterations (0…4): each pixel tries its
    /// neighbours' disparities at jumps of 1, 2, 4, 8 px (the last `propagation` of
    /// them, largest first) and keeps the one the views agree on best.
    pub propagation: usize,
    /// Largest disparity change of one iteration (px), in (0, 2].
    pub max_step: f32,
    /// Per pixel, drop the half of the views (left/right, up/down) whose residual is much
    /// larger than the other half's: those views see an occluder.
    pub occlusion: bool,
    /// Residual scale (unit intensity) of the Cauchy weight of each view and pixel:
    /// views that disagree by much more count little. Zero: plain least squares.
    pub robust_scale: f32,
    /// Disparity error (px) at which the output confidence is one half.
    pub confidence_scale: f32,
    /// Image rows per band (the unit of parallel work), 1…4096.
    pub band_rows: usize,
    /// Sampling slack (px of image motion, 0…1): a view's residual counts only by how
    /// far it falls outside the centre view's values over `±sampling_slack` px along
    /// the view's motion (its linear interpolation towards the neighbours, after
    /// Birchfield and Tomasi's sampling-insensitive dissimilarity), in the Cauchy
    /// weights, the residual energy and the propagation's costs. For views that were
    /// resampled (aligned arrays: the pipelines set [`RESAMPLED_SLACK`] when they
    /// warped the views), whose occlusion edges no interpolation reproduces. Zero (the
    /// default): the plain residual.
    pub sampling_slack: f32,
    /// Settled windows (px, 0…1; 0 = off): in the Gauss–Newton iterations after the
    /// first, a pixel that kept its statistics (it moved by less than the settle
    /// threshold, 10⁻² px, 2·10⁻² before the last iteration) and whose window's other
    /// pixels each moved by less than this (or the settle threshold, where that is
    /// larger) keeps its disparity and the previous iteration's confidence instead of
    /// being updated again: its window sums would change only by those small moves (to
    /// first order the statistics' `B` does not depend on `d`), the window gate and the
    /// damping. 0 updates every pixel in every iteration. Measured on HCI in
    /// `docs/stages/refine.md`.
    pub skip_settled: f32,
    /// Slanted window: each pixel's window transfers its neighbours' Gauss–Newton
    /// statistics along the local slope of the disparity (the gated central
    /// differences of its 3 × 3 neighbourhood), `B_j − o_j·A_j` with
    /// `o_j = g_x·Δx_j + g_y·Δy_j`, and gates them by their distance from that plane
    /// instead of from the pixel's disparity. Off: the fronto-parallel window, which
    /// pulls a sloping surface towards its better-textured neighbours by up to the
    /// slope times the window radius.
    pub slanted: bool,
}

/// The default [`RefineParams::skip_settled`] (px).
pub const SKIP_SETTLED: f32 = 0.05;

/// The [`RefineParams::sampling_slack`] the pipelines use on warped views.
pub const RESAMPLED_SLACK: f32 = 0.5;

impl Default for RefineParams {
    fn default() -> Self {
        RefineParams {
            enabled: true,
            views: ViewSet::Cross,
            iterations: 3,
            radius: 1,
            propagation: 4,
            max_step: 0.5,
            occlusion: true,
            robust_scale: 0.01,
            confidence_scale: 1.0,
            band_rows: 128,
            sampling_slack: 0.0,
            skip_settled: SKIP_SETTLED,
            slanted: false,
        }
    }
}

impl StageParams for RefineParams {
    fn validate(&self) -> Result<()> {
        RefineParams::validate(self)
    }
}

impl RefineParams {
    /// These parameters for views that were warped (aligned): the sampling slack at
    /// [`RESAMPLED_SLACK`] unless they set one themselves.
    pub fn for_resampled_views(self) -> Self {
        let sampling_slack = if self.sampling_slack == 0.0 {
            RESAMPLED_SLACK
        } else {
            self.sampling_slack
        };
        RefineParams {
            sampling_slack,
            ..self
        }
    }

    /// The stage switched on with the default settings (as [`Default`]).
    pub fn on() -> Self {
        Self::default()
    }

    /// The stage switched off: the paper's EPI → TV pipeline.
    pub fn off() -> Self {
        RefineParams {
            enabled: false,
            ..Self::default()
        }
    }

    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, reason| Err(Error::InvalidParameter { name, reason });
        if !(1..=16).contains(&self.iterations) {
            return bad("refine.iterations", "must be in 1..=16");
        }
        if self.propagation > 4 {
            return bad("refine.propagation", "must be at most 4 rounds");
        }
        if self.radius > 4 {
            return bad("refine.radius", "must be at most 4 pixels");
        }
        if !(self.max_step.is_finite() && self.max_step > 0.0 && self.max_step <= 2.0) {
            return bad("refine.max_step", "must be in (0, 2] pixels");
        }
        if !(self.confidence_scale.is_finite()
            && self.confidence_scale > 0.0
            && self.confidence_scale <= 10.0)
        {
            return bad("refine.confidence_scale", "must be in (0, 10] pixels");
        }
        if !(self.robust_scale.is_finite() && (0.0..=1.0).contains(&self.robust_scale)) {
            return bad("refine.robust_scale", "must be in [0, 1] (unit intensity)");
        }
        if !(self.sampling_slack.is_finite() && (0.0..=1.0).contains(&self.sampling_slack)) {
            return bad("refine.sampling_slack", "must be in [0, 1] pixels");
        }
        if !(self.skip_settled.is_finite() && (0.0..=1.0).contains(&self.skip_settled)) {
            return bad("refine.skip_settled", "must be in [0, 1] pixels");
        }
        if !(1..=4096).contains(&self.band_rows) {
            return bad("refine.band_rows", "must be in 1..=4096");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_bad_values_are_named() {
        RefineParams::default().validate().unwrap();
        RefineParams::off().validate().unwrap();
        for (bad, name) in [
            (
                RefineParams {
                    iterations: 0,
                    ..RefineParams::default()
                },
                "refine.iterations",
            ),
            (
                RefineParams {
                    max_step: f32::NAN,
                    ..RefineParams::default()
                },
                "refine.max_step",
            ),
            (
                RefineParams {
                    radius: 9,
                    ..RefineParams::default()
                },
                "refine.radius",
            ),
            (
                RefineParams {
                    sampling_slack: 1.5,
                    ..RefineParams::default()
                },
                "refine.sampling_slack",
            ),
            (
                RefineParams {
                    sampling_slack: f32::NAN,
                    ..RefineParams::default()
                },
                "refine.sampling_slack",
            ),
            (
                RefineParams {
                    skip_settled: -0.1,
                    ..RefineParams::default()
                },
                "refine.skip_settled",
            ),
        ] {
            assert!(
                matches!(bad.validate(), Err(Error::InvalidParameter { name: n, .. }) if n == name)
            );
        }
    }

    #[test]
    fn view_sets_nest() {
        let mut counts = [0; 3];
        for dr in -4..=4 {
            for dc in -4..=4 {
                for (i, set) in [ViewSet::Cross, ViewSet::CrossDiagonals, ViewSet::All]
                    .iter()
                    .enumerate()
                {
                    counts[i] += usize::from(set.contains(dr, dc));
                }
            }
        }
        assert_eq!(counts, [16, 32, 80]);
    }
}
