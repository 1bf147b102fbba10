//! The per-node constants of the dual: the data weights, the targets `τ`, the prox
//! factors `σ`, and the per-node metric.

use crate::lightfield::Sample;
use crate::scalar::Scalar;

use super::super::params::{TvNorm, TvParams};
use super::edges::{external_flow, STEP_BLOCK};
use super::graph::{Graph, DUAL_SCALE};
use super::inputs::{Guide, Maps, Rect};
use super::rows::{part, part_mut};

impl<S: Scalar> Graph<'_, S> {
    /// `τ` and `σ` node by node, with the fixed flows of a previous dual; returns the
    /// range of `D` over the region.
    pub(super) fn node_constants_by_node<P: Sample>(
        &mut self,
        maps: &Maps<'_>,
        guide: &Guide<'_, P>,
        params: &TvParams,
        region: Rect,
    ) -> (f32, f32) {
        let (w, h) = (self.width, self.height);
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        let lambda = params.lambda;
        let gamma = 4.0 * params.step; // γ / ω with ω = 1/4 for each quadratic part
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let gi = (region.y + y) * maps.width + region.x + x;
                let d = maps.disparity.get(gi).copied().unwrap_or(0.0);
                lo = lo.min(d);
                hi = hi.max(d);
                let conf = maps.confidence.get(gi).copied().unwrap_or(0.0);
                let a = data_weight(conf, params);
                let sq = |v: S| {
                    let f = v.to_f32();
                    f * f
                };
                // Every index is a node of the region (`i < w·h`, the buffers' length).
                let weight = |buf: &[S], j: usize| buf.get(j).copied().map_or(0.0, sq);
                let mut c2 = weight(self.wh, i) + weight(self.wv, i);
                if x > 0 {
                    c2 += weight(self.wh, i - 1);
                }
                if y > 0 {
                    c2 += weight(self.wv, i - w);
                }
                let gk = gamma * lambda * lambda / a;
                let sig = gk / (1.0 + gk * c2);
                // The fixed flows across the region's border enter `(WᵀF)_i` as a
                // constant, i.e. they shift the node's target.
                let outside = external_flow(maps, guide, params, region, x, y);
                if let (Some(t), Some(s)) = (self.tau.get_mut(i), self.sig.get_mut(i)) {
                    *t = S::from_f32(DUAL_SCALE * (a * d / lambda - outside));
                    *s = S::from_f32(sig);
                }
            }
        }
        (lo, hi)
    }

    /// `τ` and `σ` of every node without a previous dual (no fixed flows), a row at a
    /// time (the same values as [`Self::node_constants_by_node`]); returns the range of
    /// `D` over the region.
    pub(super) fn node_constants_by_row(
        &mut self,
        maps: &Maps<'_>,
        params: &TvParams,
        region: Rect,
    ) -> (f32, f32) {
        let (w, h) = (self.width, self.height);
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        let lambda = params.lambda;
        let gamma = 4.0 * params.step; // γ / ω with ω = 1/4 for each quadratic part
        let sq = |v: S| {
            let f = v.to_f32();
            f * f
        };
        // The row above the first: no upper edges (adding `sq(0) = 0` changes nothing).
        let zeros = self.rows.get_mut(..w).unwrap_or_default();
        zeros.fill(S::ZERO);
        // `a_i` of the defaults in data_weight's branch-free form, chosen once per block
        // so that the loop vectorises.
        let simple = params.confidence_power == 1.0 && params.confidence_threshold == 0.0;
        for y in 0..h {
            let start = (region.y + y) * maps.width + region.x;
            let r = y * w..(y + 1) * w;
            let above = if y > 0 {
                part(self.wv, r.start - w..r.start)
            } else {
                &*zeros
            };
            let (wh, wv) = (part(self.wh, r.clone()), part(self.wv, r.clone()));
            let (Some(tau), Some(sig), Some(d), Some(conf)) = (
                self.tau.get_mut(r.clone()),
                self.sig.get_mut(r),
                maps.disparity.get(start..start + w),
                maps.confidence.get(start..start + w),
            ) else {
                continue;
            };
            for &d in d {
                lo = if d < lo { d } else { lo };
                hi = if d > hi { d } else { hi };
            }
            // Blocks of nodes through `f32` arrays on the stack: the data weights and
            // `‖c_i‖²` first, then `τ` and `σ` (the same operations per node as one loop).
            for first in (0..w).step_by(STEP_BLOCK) {
                let n = STEP_BLOCK.min(w - first);
                let block = first..first + n;
                let mut a = [1.0f32; STEP_BLOCK];
                let conf = part(conf, block.clone());
                if simple {
                    for (a, &c) in a.iter_mut().zip(conf) {
                        *a = c.clamp(0.0, 1.0) + params.tikhonov;
                    }
                } else {
                    for (a, &c) in a.iter_mut().zip(conf) {
                        *a = data_weight(c, params);
                    }
                }
                // The left neighbour's own edge (the row's first node has none: 0).
                let mut left = [0.0f32; STEP_BLOCK];
                let (to, from) = if first == 0 {
                    (part_mut(&mut left, 1..n), part(wh, 0..n.saturating_sub(1)))
                } else {
                    (
                        part_mut(&mut left, 0..n),
                        part(wh, first - 1..first + n - 1),
                    )
                };
                for (l, &e) in to.iter_mut().zip(from) {
                    *l = sq(e);
                }
                // `‖c_i‖²`: the node's own edges, then its left and upper neighbours', in
                // the order of `node_constants_by_node`.
                let mut c2 = [0.0f32; STEP_BLOCK];
                let own = part(wh, block.clone()).iter().zip(part(wv, block.clone()));
                let others = left.iter().zip(part(above, block.clone()));
                for (c2, ((&eh, &ev), (&left, &up))) in c2.iter_mut().zip(own.zip(others)) {
                    *c2 = sq(eh) + sq(ev) + left + sq(up);
                }
                let outs = part_mut(tau, block.clone())
                    .iter_mut()
                    .zip(part_mut(sig, block.clone()));
                let nodes = part(d, block).iter().zip(a.iter().zip(&c2));
                for ((t, s), (&d, (&a, &c2))) in outs.zip(nodes) {
                    let gk = gamma * lambda * lambda / a;
                    *t = S::from_f32(DUAL_SCALE * (a * d / lambda));
                    *s = S::from_f32(gk / (1.0 + gk * c2));
                }
            }
        }
        (lo, hi)
    }

    /// The per-node metric (see [`metric_shift`]): node `i`'s pair is iterated as
    /// `G = DUAL_SCALE · F / s_i`, so its edge weights are multiplied by `s_i` and its
    /// constraint radius is `DUAL_SCALE / s_i` (`bound`). `(WᵀF)` — the targets, the
    /// residuals, the primal — is the same function of `G` with the scaled weights.
    pub(super) fn set_metric(&mut self, maps: &Maps<'_>, params: &TvParams, region: Rect) {
        let (w, h) = (self.width, self.height);
        let a_at = |x: usize, y: usize| {
            let gi = (region.y + y) * maps.width + region.x + x;
            data_weight(maps.confidence.get(gi).copied().unwrap_or(0.0), params)
        };
        // `a_i` grows with the confidence, so the least confident node of the region is
        // the stiffest; when even it gets `k = 0` (the default pipeline's inputs), the
        // weights stay as they are and one bound serves every pair.
        let mut least = f32::INFINITY;
        for y in 0..h {
            let start = (region.y + y) * maps.width + region.x;
            if let Some(row) = maps.confidence.get(start..start + w) {
                least = row.iter().fold(least, |m, &c| m.min(c));
            }
        }
        let stiffest = params.step * params.lambda * params.lambda / data_weight(least, params);
        if metric_shift(stiffest) == 0 {
            let bound = S::from_f32(match params.norm {
                TvNorm::L1 => DUAL_SCALE,
                TvNorm::L2 => 1.0 / DUAL_SCALE,
            });
            self.bound.fill(bound);
            return;
        }
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let (Some(wh), Some(wv), Some(bound)) = (
                    self.wh.get_mut(i),
                    self.wv.get_mut(i),
                    self.bound.get_mut(i),
                ) else {
                    continue;
                };
                // The stiffest node the pair's edges touch sets its step.
                let mut a = a_at(x, y);
                if *wh != S::ZERO {
                    a = a.min(a_at(x + 1, y));
                }
                if *wv != S::ZERO {
                    a = a.min(a_at(x, y + 1));
                }
                let stiffness = params.step * params.lambda * params.lambda / a;
                let s = libm::ldexpf(1.0, -metric_shift(stiffness));
                *wh *= S::from_f32(s);
                *wv *= S::from_f32(s);
                *bound = S::from_f32(match params.norm {
                    TvNorm::L1 => DUAL_SCALE / s,
                    TvNorm::L2 => s / DUAL_SCALE,
                });
            }
        }
    }
}

/// `a_i = m_i v_i + ℸ`: `v_i = confidence^power` where the confidence reaches the
/// threshold, plus the weak fidelity everywhere.
#[inline]
pub(crate) fn data_weight(confidence: f32, params: &TvParams) -> f32 {
    let c = confidence.clamp(0.0, 1.0);
    // The defaults (power 1, threshold 0) in a branch-free form with the same values
    // (`c > 0` selects `c` itself, `c = 0` adds nothing), tested first: the test is the
    // same for every node, so the compiler takes it out of the setup's per-node loops,
    // which then vectorise (the general form below branches per node).
    if params.confidence_power == 1.0 && params.confidence_threshold == 0.0 {
        return c + params.tikhonov;
    }
    let reliable = if c >= params.confidence_threshold && c > 0.0 {
        // `powf(c, 1) == c` exactly; the default power skips the call (a third of setup).
        if params.confidence_power == 1.0 {
            c
        } else {
            libm::powf(c, params.confidence_power)
        }
    } else {
        0.0
    };
    reliable + params.tikhonov
}

/// The per-node metric of PPXA: node `i`'s pair `(F_h, F_v)` is iterated scaled by
/// `1/s_i`, which is PPXA with the step `γ s_i²` on that pair. One step does not suit
/// every node: `κ_i = λ²/a_i` spans 100× between confident pixels (`a ≈ 1`) and
/// unreliable ones (`a ≈ ℸ`); a step large enough for the first (γ 4 instead of 2: the
/// same distance to the minimiser in half the iterations) leaves the second oscillating
/// for hundreds of iterations (cotton, EPI input: single pixels 1–2.5 px from the
/// minimiser when the tile stops). So where the stiffness `γκ` of the stiffest node a
/// pair's edges touch exceeds [`METRIC_STIFFNESS`], `s_i² ≈ METRIC_STIFFNESS / (γκ)`,
/// rounded to a power of two `s_i = 2^-k` — exact in f32 and Q16.16, so the metric
/// changes no rounding. Below it (every node of the default pipeline's input, whose
/// confidences are high) nothing changes.
pub(super) fn metric_shift(stiffness: f32) -> i32 {
    let ratio = stiffness / METRIC_STIFFNESS;
    if ratio.is_nan() || ratio <= 1.0 {
        return 0;
    }
    // s = 2^-k with s² ≈ 1/ratio  ⇔  k ≈ log2(ratio) / 2.
    let k = libm::roundf(0.5 * libm::log2f(ratio));
    (k as i32).clamp(0, METRIC_MAX_SHIFT)
}

/// Stiffness `γκ` above which the metric lowers a pair's step (see [`metric_shift`]).
const METRIC_STIFFNESS: f32 = 4.0;

/// Largest `k` of the metric (`s = 2^-k`).
const METRIC_MAX_SHIFT: i32 = 6;
