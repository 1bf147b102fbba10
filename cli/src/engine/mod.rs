//! The native engine: runs the core pipeline over a loaded light field, bands and tiles
//! in parallel with rayon, and reports progress and per-stage timings.

use std::time::Duration;

use lfdepth::{LightField, Params, Sample};

/// How far the pipeline runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StageSelect {
    /// Initial disparity from EPIs only.
    Epi,
    /// Everything: (alignment when asked) → EPI → TV.
    Full,
}

/// What to run and with how many threads.
#[derive(Clone, Copy, Debug)]
pub struct EstimateOptions {
    /// Parameters of every stage.
    pub params: Params,
    /// How far to run.
    pub stage: StageSelect,
    /// Worker threads; `None` uses every core.
    pub threads: Option<usize>,
}

/// The result of one estimation.
#[derive(Clone, Debug, Default)]
pub struct Estimate {
    /// Centre-view width.
    pub width: usize,
    /// Centre-view height.
    pub height: usize,
    /// Disparity per pixel, row-major, top row first.
    pub disparity: Vec<f32>,
    /// Confidence per pixel in [0, 1].
    pub confidence: Vec<f32>,
    /// Wall time of each stage, in order.
    pub timings: Vec<(&'static str, Duration)>,
    /// TV residual norm per iteration (empty when TV did not run).
    pub residuals: Vec<f32>,
}

/// Estimates the disparity of the centre view. `progress(stage, done, total)` is called
/// as work completes.
pub fn estimate<S: Sample + Sync>(
    lf: &LightField<'_, S>,
    options: &EstimateOptions,
    progress: &mut dyn FnMut(&str, u64, u64),
) -> Result<Estimate, lfdepth::Error> {
    // Replaced by the EPI stage as it lands; until then no estimator exists.
    let _ = (lf, options, progress);
    Err(lfdepth::Error::InvalidParameter {
        name: "stage",
        reason: "has no estimator built in yet",
    })
}
