//! What a solve writes: the refined disparity and the dual of its core, and its report.

use crate::float::clamp_f32;
use crate::lightfield::Sample;
use crate::scalar::Scalar;

use super::super::params::TvParams;
use super::edges::external_flow;
use super::graph::{Graph, DUAL_SCALE};
use super::inputs::{Guide, Maps, Rect};
use super::nodes::data_weight;
use super::rows::divergence_row;

/// Where one solve writes.
#[derive(Debug)]
pub struct SolveOutput<'o> {
    /// Refined disparity of the core rectangle: pixel `(x, y)` of the core at
    /// `disparity[y · stride + x]`.
    pub disparity: &'o mut [f32],
    /// Row stride of `disparity` (≥ core width).
    pub stride: usize,
    /// Per iteration `n`, the squared norm of the dual update `‖Fₙ − Fₙ₋₁‖²` over the
    /// region is ADDED to `history[n]` (nothing after the solve stopped), so tiles can
    /// accumulate into one history in tile order. Entries past its length are not recorded.
    pub history: &'o mut [f32],
    /// When given, the final dual variable of the core, `(F_h, F_v)` of core pixel
    /// `(x, y)` at `dual[2 · (y · stride + x)]` (same layout as `disparity`, two values
    /// per pixel), for [`Maps::with_dual`] of the next sweep.
    pub dual: Option<&'o mut [f32]>,
}

/// What one solve did.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct SolveReport {
    /// Iterations run.
    pub iterations: usize,
    /// Whether the stopping rule was met before `max_iterations`.
    pub converged: bool,
}

impl<S: Scalar> Graph<'_, S> {
    /// The dual of the core, unscaled, `(F_h, F_v)` per pixel at `2 · (y · stride + x)`.
    pub(super) fn write_dual(&self, region: Rect, core: Rect, dual: &mut [f32], stride: usize) {
        for y in 0..core.height {
            for x in 0..core.width {
                let i = (core.y - region.y + y) * self.width + core.x - region.x + x;
                let factor = self.factor(i);
                let (fh, fv) = (
                    self.y1h.get(i).map_or(0.0, |v| v.to_f32()) * factor,
                    self.y1v.get(i).map_or(0.0, |v| v.to_f32()) * factor,
                );
                if let Some(pair) = dual.get_mut(2 * (y * stride + x)..2 * (y * stride + x) + 2) {
                    pair[0] = fh;
                    pair[1] = fv;
                }
            }
        }
    }

    /// `x = D − λ A⁻¹ WᵀF` on the core (Eq. 16), clamped to the range of `D`, into
    /// `out.disparity`.
    pub(super) fn write_primal<P: Sample>(
        &mut self,
        maps: &Maps<'_>,
        guide: &Guide<'_, P>,
        params: &TvParams,
        region: Rect,
        core: Rect,
        out: &mut SolveOutput<'_>,
    ) {
        let (out, stride) = (&mut *out.disparity, out.stride);
        let w = self.width;
        let div = self.rows.get_mut(..w).unwrap_or_default();
        let simple = params.confidence_power == 1.0 && params.confidence_threshold == 0.0;
        for y in 0..core.height {
            let ry = core.y - region.y + y;
            let gy = core.y + y;
            divergence_row(ry, w, self.wh, self.wv, self.y1h, self.y1v, div);
            let start = gy * maps.width + core.x;
            let r = start..start + core.width;
            let (Some(d), Some(conf), Some(u), Some(o)) = (
                maps.disparity.get(r.clone()),
                maps.confidence.get(r),
                div.get(core.x - region.x..),
                out.get_mut(y * stride..y * stride + core.width),
            ) else {
                continue;
            };
            let pixels = o.iter_mut().zip(d).zip(conf).zip(u);
            if maps.dual.is_none() && simple {
                // The defaults without fixed flows: data_weight's branch-free form and no
                // per-pixel test, so the loop vectorises (the same operations per pixel).
                for (((o, &d), &c), &u) in pixels {
                    let a = c.clamp(0.0, 1.0) + params.tikhonov;
                    let u = u.to_f32() / DUAL_SCALE + 0.0;
                    *o = clamp_f32(d - params.lambda * u / a, self.range.0, self.range.1);
                }
                continue;
            }
            for (x, (((o, &d), &c), &u)) in pixels.enumerate() {
                let a = data_weight(c, params);
                // The fixed flows of a previous dual (zero without one).
                let outside = if maps.dual.is_some() {
                    external_flow(maps, guide, params, region, core.x - region.x + x, ry)
                } else {
                    0.0
                };
                let u = u.to_f32() / DUAL_SCALE + outside;
                *o = clamp_f32(d - params.lambda * u / a, self.range.0, self.range.1);
            }
        }
    }
}
