//! The start of the iteration: the dual of `D`'s smoothed gradients or a previous sweep's
//! dual, and the PPXA copies at the fixed point that start would have.

use crate::scalar::Scalar;

use super::super::params::{TvNorm, TvParams};
use super::edges::{fixed_pair, STEP_BLOCK};
use super::graph::Graph;
use super::inputs::{Maps, Rect};
use super::nodes::data_weight;
use super::rows::{copy_row, divergence_row, part, part_mut};

/// Scale `ε` (px of weighted disparity step) of the cold start's dual
/// `F = g / max(ε, ‖g‖)` (see `Graph::gradient_start`): steps of `D` larger than this
/// start saturated. 0.02 px measured best of 0.005 / 0.02 / 0.1 / 0.5 on the HCI scenes
/// with every PPXA copy started at `F`; with the copies at their fixed point
/// (`consistent_copies`) 0.05 of 0.01 / 0.02 / 0.05 / 0.1 (docs/stages/tv.md).
const GRADIENT_START_SCALE: f32 = 0.05;

impl<S: Scalar> Graph<'_, S> {
    /// Moves the copies of the two quadratic parts (and `y₁`, keeping `F = ½y₁ + ¼y₂ +
    /// ¼y₃`) from the start `F` to where PPXA's fixed point would hold them if `F` were
    /// the solution: `y_k = F + (γ/ω_k)∇f_k(F)` for the quadratic parts, so that their
    /// proximity operators return `F` itself, and `y₁ = F − (γ/ω₁)(∇f₂ + ∇f₃)(F)`, so
    /// that the first iteration is a projected gradient step from `F`. Started with
    /// every copy equal to `F`, the copies are far from that fixed point, and PPXA spends
    /// its first iterations moving them there: from the converged dual of HCI cotton
    /// (equal copies) a solve still ran 24 of the cold start's 28 iterations.
    ///
    /// Node `i`'s gradient is `c_i t_i r_i` with `r_i = (WᵀF)_i − τ_i` and
    /// `t_i = γκ_i/ω = σ_i / (1 − σ_i‖c_i‖²)`; in the storage of [`Graph`] the own copy
    /// of an edge takes its owning node's term (`c = −w`), the other copy its far end's
    /// (`c = +w`).
    pub(super) fn consistent_copies(&mut self, maps: &Maps<'_>, params: &TvParams, region: Rect) {
        let (w, h) = (self.width, self.height);
        let mut row_bufs = self.rows.chunks_exact_mut(w.max(1));
        let (Some(mut u), Some(mut u_below)) = (row_bufs.next(), row_bufs.next()) else {
            return;
        };
        let gain = 4.0 * params.step * params.lambda * params.lambda; // γ/ω · λ²
        let half = S::from_f32(0.5);
        let node_gradients = |y: usize, y1h: &[S], y1v: &[S], out: &mut [S]| {
            divergence_row(y, w, self.wh, self.wv, y1h, y1v, out);
            let start = (region.y + y) * maps.width + region.x;
            let conf = maps.confidence.get(start..start + w).unwrap_or_default();
            let tau = part(self.tau, y * w..(y + 1) * w);
            for ((o, &t), &c) in out.iter_mut().zip(tau).zip(conf) {
                *o = S::from_f32(gain / data_weight(c, params)) * (*o - t);
            }
        };
        node_gradients(0, self.y1h, self.y1v, u);
        for y in 0..h {
            let below = y + 1 < h;
            if below {
                node_gradients(y + 1, self.y1h, self.y1v, u_below);
            } else {
                // The last row has no vertical edges (zero weight): no far end.
                u_below.fill(S::ZERO);
            }
            let r = y * w..(y + 1) * w;
            let (wh, wv) = (part(self.wh, r.clone()), part(self.wv, r.clone()));
            let (Some(y1h), Some(y1v), Some(own_h), Some(own_v), Some(other_h), Some(other_v)) = (
                self.y1h.get_mut(r.clone()),
                self.y1v.get_mut(r.clone()),
                self.own_h.get_mut(r.clone()),
                self.own_v.get_mut(r.clone()),
                self.other_h.get_mut(r.clone()),
                self.other_v.get_mut(r),
            ) else {
                continue;
            };
            // Horizontal: the far end is the right neighbour; the last column's edge is
            // cut (zero weight), so its far end reads as zero. Vertical: the node below
            // (`u_below` is zero on the last row, whose edges are cut).
            let right = u.get(1..).unwrap_or_default();
            let copies = |f: &mut [S], own: &mut [S], other: &mut [S], e: &[S], far: &[S]| {
                let copies = own.iter_mut().zip(other.iter_mut());
                let ends = e.iter().zip(u.iter().zip(far));
                for ((f, (o, t)), (&e, (&here, &far))) in f.iter_mut().zip(copies).zip(ends) {
                    let (a, b) = (e * here, e * far);
                    *o = *f - a;
                    *t = *f + b;
                    *f += half * (a - b);
                }
            };
            copies(y1h, own_h, other_h, wh, right);
            if let (Some(f), Some(o), Some(t), Some(&e), Some(&here)) = (
                y1h.last_mut(),
                own_h.last_mut(),
                other_h.last_mut(),
                wh.last(),
                u.last(),
            ) {
                let (a, b) = (e * here, e * S::ZERO);
                *o = *f - a;
                *t = *f + b;
                *f += half * (a - b);
            }
            copies(y1v, own_v, other_v, wv, u_below);
            core::mem::swap(&mut u, &mut u_below);
        }
    }

    /// Node `i`'s flows `(fh, fv)` (unscaled) as the start of every PPXA copy and of
    /// `F`, so that `F = ½y₁ + ¼y₂ + ¼y₃` holds from the first iteration.
    fn start_dual_at(&mut self, i: usize, fh: f32, fv: f32) {
        let to_g = 1.0 / self.factor(i);
        let (fh, fv) = (S::from_f32(to_g * fh), S::from_f32(to_g * fv));
        for (buf, v) in [
            (&mut *self.y1h, fh),
            (&mut *self.own_h, fh),
            (&mut *self.other_h, fh),
            (&mut *self.y1v, fv),
            (&mut *self.own_v, fv),
            (&mut *self.other_v, fv),
        ] {
            if let Some(b) = buf.get_mut(i) {
                *b = v;
            }
        }
    }

    /// The cold start: `F` set to the dual that the total variation
    /// of a Huber-smoothed TV would take at `x = D`, per node `F = g / max(ε, ‖g‖)` with
    /// `g` the node's forward differences of `D` (ℓ2: the pair's norm; ℓ1: each edge on
    /// its own) and `ε` = [`GRADIENT_START_SCALE`]. (Differences weighted by the edge
    /// weights measured worse: backgammon 1005 instead of 817 tile-iterations for the
    /// same distance to the minimiser.) Where `D` already has a clear
    /// step the dual starts saturated along it, where it is flat near zero — which is
    /// where most of the optimal dual lies, so fewer iterations reach a given distance to
    /// the minimiser than from `F = 0`. Edges that leave the region (zero weight) start
    /// at zero. The PPXA copies are set from `F` by `consistent_copies`.
    pub(super) fn gradient_start(&mut self, maps: &Maps<'_>, region: Rect, norm: TvNorm) {
        let w = self.width;
        let eps = GRADIENT_START_SCALE;
        let floor = |n: f32| if n > eps { n } else { eps };
        // Only `F` (in `y₁`) is written: `consistent_copies` sets the copies from it.
        // A row at a time, in blocks of `STEP_BLOCK` nodes through `f32` arrays on the
        // stack: the differences, the divisions and the scaling in vector lanes, the
        // square roots (libm's `sqrtf` is a scalar instruction) in a pass of their own —
        // the same operations per node as one scalar loop.
        let rows = self
            .y1h
            .chunks_exact_mut(w.max(1))
            .zip(self.y1v.chunks_exact_mut(w.max(1)));
        let weights = self
            .wh
            .chunks_exact(w.max(1))
            .zip(self.wv.chunks_exact(w.max(1)));
        for (y, ((y1h, y1v), (wh, wv))) in rows.zip(weights).enumerate() {
            let r = y * w..(y + 1) * w;
            let bound = part(self.bound, r);
            let start = (region.y + y) * maps.width + region.x;
            // From the region's first pixel to the map's end: holds the right neighbours.
            let d_row = maps.disparity.get(start..).unwrap_or_default();
            let Some(d) = d_row.get(..w) else {
                continue;
            };
            // Without a row below (the map's last) every vertical edge is cut.
            let below = maps
                .disparity
                .get(start + maps.width..start + maps.width + w)
                .unwrap_or(d);
            for first in (0..w).step_by(STEP_BLOCK) {
                let n = STEP_BLOCK.min(w - first);
                let block = first..first + n;
                // Every node but the row's last has its right neighbour in the row; the
                // last one's edge is cut (zero weight) or, at the map's edge, missing.
                let mut right = [0.0f32; STEP_BLOCK];
                let known = part(d_row, first + 1..(first + n + 1).min(d_row.len()));
                copy_row(part_mut(&mut right, 0..known.len()), known);
                let (mut gh, mut gv) = ([0.0f32; STEP_BLOCK], [0.0f32; STEP_BLOCK]);
                let steps = gh.iter_mut().zip(gv.iter_mut());
                let ends = part(d, block.clone()).iter().zip(right.iter());
                let edges = part(wh, block.clone()).iter().zip(part(wv, block.clone()));
                let downs = part(below, block.clone());
                for (((gh, gv), (&d, &right)), ((eh, ev), &down)) in
                    steps.zip(ends).zip(edges.zip(downs))
                {
                    *gh = if eh.to_f32() > 0.0 { right - d } else { 0.0 };
                    *gv = if ev.to_f32() > 0.0 { down - d } else { 0.0 };
                }
                // The divisor of each component: ℓ2 the pair's norm, ℓ1 each on its own.
                let (mut nh, mut nv) = ([0.0f32; STEP_BLOCK], [0.0f32; STEP_BLOCK]);
                match norm {
                    TvNorm::L2 => {
                        for ((n2, &gh), &gv) in nh.iter_mut().zip(&gh).zip(&gv) {
                            *n2 = gh * gh + gv * gv;
                        }
                        for n in nh.iter_mut() {
                            *n = crate::float::sqrtf(*n);
                        }
                        for (n, nv) in nh.iter_mut().zip(nv.iter_mut()) {
                            *n = floor(*n);
                            *nv = *n;
                        }
                    }
                    TvNorm::L1 => {
                        for (((nh, nv), &gh), &gv) in
                            nh.iter_mut().zip(nv.iter_mut()).zip(&gh).zip(&gv)
                        {
                            *nh = floor(libm::fabsf(gh));
                            *nv = floor(libm::fabsf(gv));
                        }
                    }
                }
                // `start_dual_at`'s scaling into the iterated variable.
                let outs = part_mut(y1h, block.clone())
                    .iter_mut()
                    .zip(part_mut(y1v, block.clone()));
                let steps = gh.iter().zip(&gv).zip(nh.iter().zip(&nv));
                for (((fh, fv), ((&gh, &gv), (&nh, &nv))), b) in
                    outs.zip(steps).zip(part(bound, block))
                {
                    let b = b.to_f32();
                    let factor = match norm {
                        TvNorm::L1 => 1.0 / b,
                        TvNorm::L2 => b,
                    };
                    let to_g = 1.0 / factor;
                    (*fh, *fv) = (S::from_f32(to_g * (gh / nh)), S::from_f32(to_g * (gv / nv)));
                }
            }
        }
    }

    /// Every PPXA copy and `F` set to the previous sweep's dual (scaled), so that
    /// `F = ½y₁ + ¼y₂ + ¼y₃` holds from the start. Flows of edges that leave the region
    /// stay zero inside it: they are held fixed through the targets instead.
    pub(super) fn warm_start(&mut self, maps: &Maps<'_>, region: Rect, dual: &[f32]) {
        let (w, h) = (self.width, self.height);
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let gi = (region.y + y) * maps.width + region.x + x;
                let pair = dual.get(2 * gi..2 * gi + 2).unwrap_or(&[0.0, 0.0]);
                // Pairs of the last column and row are fixed (zero weight here).
                let inner = !fixed_pair(maps, region, x, y);
                let (fh, fv) = if inner {
                    (pair[0], pair[1])
                } else {
                    (0.0, 0.0)
                };
                self.start_dual_at(i, fh, fv);
            }
        }
    }
}
