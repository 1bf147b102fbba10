//! The parameters of the refill and their limits.

use crate::error::{Error, Result};
use crate::setup::StageParams;

/// Widest band (px).
pub const MAX_BAND: usize = 32;
/// Most sweep pairs.
pub const MAX_SWEEPS: usize = 8;

/// Parameters of the geodesic band refill.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeoFillParams {
    /// Run the stage (after the refinement, before the median and TV).
    pub enabled: bool,
    /// A disparity difference between 4-neighbours larger than this (px) is a depth
    /// step whose band is refilled.
    pub step: f32,
    /// A depth step with a colour step (largest channel difference, unit intensity) of
    /// at least this within 2 px of it, on the line across it, sits on a colour edge and
    /// gets no band, 0.001…1.
    pub edge: f32,
    /// Pixels within this city-block distance (px) of a step are refilled, 1…[`MAX_BAND`].
    pub band: usize,
    /// Largest horizontal or vertical offset (px) between a pixel and the seed it takes
    /// its value from, `band`…`4·MAX_BAND`.
    pub reach: usize,
    /// Cost of one pixel of path length, in unit intensity: breaks ties in flat colour
    /// towards the nearer seed, 0.0001…1 (positive, so that every band pixel's path
    /// cost is above a seed's 0).
    pub spatial: f32,
    /// A band pixel whose cheapest path to a seed costs more than this (unit intensity)
    /// keeps its value, 0.001…16: a fattened pixel reaches the background through
    /// uniform colour, while a thin structure inside a band (no seed of its own) would
    /// have to cross its own colour edge, 0.15 ≈ two edges of 20 levels.
    pub max_cost: f32,
    /// Forward + backward sweep pairs of the distance transform, 1…[`MAX_SWEEPS`]: one
    /// pair finds paths that turn at most once between the sweep directions.
    pub sweeps: usize,
    /// Extrapolate the seed's disparity to the pixel along the seed's slope (measured
    /// over up to two seeds on each side) instead of copying it.
    pub planar: bool,
}

impl Default for GeoFillParams {
    /// Chosen by measurement on HCI cotton and backgammon (docs/stages/refill.md): steps
    /// above 0.8 px (smaller ones are slants and noise that the median and TV handle),
    /// colour edges of 8 levels, a 5 px band (wider bands reach across thin structures),
    /// and copied values (the slopes of seeds next to a band are too noisy to
    /// extrapolate over several pixels).
    fn default() -> Self {
        GeoFillParams {
            enabled: true,
            step: 0.8,
            edge: 0.03,
            band: 5,
            reach: 16,
            spatial: 0.004,
            max_cost: 0.15,
            sweeps: 2,
            planar: false,
        }
    }
}

impl StageParams for GeoFillParams {
    fn validate(&self) -> Result<()> {
        GeoFillParams::validate(self)
    }
}

impl GeoFillParams {
    /// The stage switched off (the paper's pipeline has no such step).
    pub fn off() -> Self {
        GeoFillParams {
            enabled: false,
            ..Self::default()
        }
    }

    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, reason| Err(Error::InvalidParameter { name, reason });
        if !(self.step.is_finite() && (0.01..=16.0).contains(&self.step)) {
            return bad("geofill.step", "must be in [0.01, 16] pixels");
        }
        if !(self.edge.is_finite() && (0.001..=1.0).contains(&self.edge)) {
            return bad("geofill.edge", "must be in [0.001, 1] (unit intensity)");
        }
        if !(1..=MAX_BAND).contains(&self.band) {
            return bad("geofill.band", "must be in 1..=32 pixels");
        }
        if !(self.band..=4 * MAX_BAND).contains(&self.reach) {
            return bad("geofill.reach", "must be in band..=128 pixels");
        }
        if !(self.spatial.is_finite() && (0.0001..=1.0).contains(&self.spatial)) {
            return bad(
                "geofill.spatial",
                "must be in [0.0001, 1] (unit intensity per pixel)",
            );
        }
        if !(self.max_cost.is_finite() && (0.001..=16.0).contains(&self.max_cost)) {
            return bad(
                "geofill.max_cost",
                "must be in [0.001, 16] (unit intensity)",
            );
        }
        if !(1..=MAX_SWEEPS).contains(&self.sweeps) {
            return bad("geofill.sweeps", "must be in 1..=8");
        }
        Ok(())
    }
}
