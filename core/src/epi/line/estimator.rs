//! What a line estimator holds: everything that does not change from line to line, the
//! coarse pass's hypotheses among it.

use crate::epi::band::Band;
use crate::epi::hypotheses::Hypotheses;
use crate::epi::kernels::Kernel;
use crate::lightfield::GRID_MAX;
use crate::scalar::Scalar;

/// Everything that does not change from line to line, converted to `T` once.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LineEstimator<T: Scalar> {
    pub(super) derivative: Kernel<T>,
    pub(super) smoothing: Kernel<T>,
    pub(super) outer: Kernel<T>,
    pub(super) band: Band<T>,
    pub(super) views: usize,
    pub(super) centre: usize,
    pub(super) channels: usize,
    pub(super) hypotheses: Hypotheses,
    pub(super) interpolate: bool,
    /// Whether some hypothesis shifts a view by a half-integer.
    pub(super) half_shifts: bool,
    /// The views some hypothesis (fine, or coarse when its gray planes read them) shifts
    /// by a half-integer: only their half-shifted planes are filled.
    pub(super) half_views: [bool; GRID_MAX],
    /// Whether some hypothesis reads a view at an offset the stored planes do not hold
    /// (the fallback planes then exist).
    pub(super) fallback: bool,
    pub(super) coarse: Option<Coarse<T>>,
}

/// The coarse pass tests shears `COARSE_STEPS` shear steps apart (at most 2 px, the
/// largest step the residual window still covers), as few as cover the range centred on
/// it: 2 and 3 steps gave the same HCI scores as 4 (docs/stages/epi.md).
pub(super) const COARSE_STEPS: f32 = 4.0;
/// The coarse pass sums the tensor of the views at most this far from the centre.
pub(super) const COARSE_VIEWS: usize = 2;

/// The coarse pass: its hypotheses and the reach of the fine ones around its estimate.
#[derive(Clone, Copy, Debug)]
pub(super) struct Coarse<T> {
    pub(super) hypotheses: Hypotheses,
    pub(super) reach: T,
    /// The reach around an estimate within `NEAR` steps of a fine shear: that shear only
    /// (with the margin's extra reach).
    pub(super) near_reach: T,
    /// Whether its gray planes need the half-shifted kinds (only when the fine ones have
    /// them too; otherwise half shifts take the fallback planes).
    pub(super) half_shifts: bool,
}
