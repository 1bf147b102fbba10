//! The stopping rule: when it is evaluated, and the weighted primal change it measures.

use crate::scalar::Scalar;

use super::super::params::TvParams;
use super::combine::LANES;
use super::graph::DUAL_SCALE;
use super::inputs::Rect;
use super::nodes::data_weight;
use super::rows::divergence_of_row;

/// Iterations between two evaluations of the stopping rule once a solve has run
/// [`EARLY_CHECKS_UNTIL`] iterations: the primal change costs about a seventh of an
/// iteration (`WᵀΔF` and `λ/a` of the update that the combination step writes), so it is
/// measured on every fourth iteration only.
const CHECK_EVERY: usize = 4;

/// The first evaluation of the stopping rule, after this many iterations.
pub(super) const FIRST_CHECK: usize = 4;

/// Up to this many iterations the rule is checked every [`EARLY_CHECK_EVERY`]
/// iterations: a solve that needs few (a tile of confident pixels: 6–8 on HCI
/// backgammon) would otherwise run up to three iterations past its stop, a third more.
const EARLY_CHECKS_UNTIL: usize = 8;

/// See [`EARLY_CHECKS_UNTIL`].
const EARLY_CHECK_EVERY: usize = 2;

/// Whether the stopping rule is evaluated after `iterations` iterations: at
/// [`FIRST_CHECK`], then every [`EARLY_CHECK_EVERY`] up to [`EARLY_CHECKS_UNTIL`], then
/// every [`CHECK_EVERY`].
pub(super) fn is_check(iterations: usize) -> bool {
    let every = if iterations <= EARLY_CHECKS_UNTIL {
        EARLY_CHECK_EVERY
    } else {
        CHECK_EVERY
    };
    iterations >= FIRST_CHECK && iterations % every == 0
}

/// What turns a dual update into a primal one: `Δx_i = λ/a_i · (WᵀΔF)_i` (Eq. 16).
pub(super) struct PrimalScale<'m> {
    pub(super) confidence: &'m [f32],
    pub(super) stride: usize,
    pub(super) region: Rect,
    pub(super) params: &'m TvParams,
}

impl PrimalScale<'_> {
    /// The confidences of region row `y`.
    fn row(&self, y: usize) -> &[f32] {
        let start = (self.region.y + y) * self.stride + self.region.x;
        self.confidence
            .get(start..start + self.region.width)
            .unwrap_or_default()
    }

    /// `a_i` of `L` confidences: the default power 1 and threshold 0 make it
    /// `clamp(c, 0, 1) + ℸ`, which vectorises (the general form through [`data_weight`]).
    #[inline(always)]
    fn data_weights<const L: usize>(&self, confidence: &[f32; L]) -> [f32; L] {
        let p = self.params;
        let mut a = [1.0f32; L];
        if p.confidence_power == 1.0 && p.confidence_threshold == 0.0 {
            for (a, &c) in a.iter_mut().zip(confidence) {
                *a = c.clamp(0.0, 1.0) + p.tikhonov;
            }
        } else {
            for (a, &c) in a.iter_mut().zip(confidence) {
                *a = data_weight(c, p);
            }
        }
        a
    }
}

/// `Σ a_i Δx_i²` over region row `y` for the dual update `ΔF` of one iteration:
/// `Δx = λA⁻¹WᵀΔF` (unscaled). `weights` and `update` are the row's `[h, v]`, `above` the
/// row above's vertical weights and updates (`None` on the first row); `div` is room for
/// one row.
pub(super) fn primal_change_row<S: Scalar>(
    weights: [&[S]; 2],
    update: [&[S]; 2],
    above: Option<(&[S], &[S])>,
    scale: &PrimalScale<'_>,
    y: usize,
    div: &mut [S],
) -> f32 {
    // `(WᵀΔF)_i`.
    divergence_of_row(weights, update, above, div);
    let confidence = scale.row(y);
    let n = confidence.len().min(div.len());
    let full = n - n % LANES;
    let factor = scale.params.lambda / DUAL_SCALE;
    let mut sums = [0.0f32; LANES];
    // `full ≤ n` ≤ both lengths, so the checked splits never fail.
    let (Some((lanes, rest)), Some((conf_lanes, conf_rest))) = (
        div.get(..n).and_then(|d| d.split_at_checked(full)),
        confidence.split_at_checked(full),
    ) else {
        return 0.0;
    };
    for (u, c) in lanes
        .chunks_exact(LANES)
        .zip(conf_lanes.chunks_exact(LANES))
    {
        let (Ok(u), Ok(c)) = (<&[S; LANES]>::try_from(u), <&[f32; LANES]>::try_from(c)) else {
            continue; // chunks_exact yields exactly LANES elements
        };
        let a = scale.data_weights(c);
        for ((sum, &u), &a) in sums.iter_mut().zip(u).zip(&a) {
            let dx = factor * u.to_f32() / a;
            *sum += a * dx * dx;
        }
    }
    for (&u, &c) in rest.iter().zip(conf_rest) {
        let a = data_weight(c, scale.params);
        let dx = factor * u.to_f32() / a;
        sums[0] += a * dx * dx;
    }
    sums.iter().sum()
}
