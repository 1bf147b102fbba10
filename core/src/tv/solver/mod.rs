//! PPXA on the dual of the weighted-TV model of one rectangle of the pixel graph.
//!
//! The dual `min_{F∈B} Σ_i κ_i/2 ((WᵀF)_i − τ_i)²` (see [the module](super)) is the sum of
//! three functions with closed-form proximity operators:
//! - `f₁ = ι_B`: projection of each node's pair `(F_h, F_v)` onto the unit box or disc;
//! - `f₂`, `f₃`: the quadratic restricted to the black, resp. white, nodes of the
//!   checkerboard. Every edge joins a black and a white node, so the edge sets of the
//!   nodes of one colour are disjoint and the proximity operator of `γ f₂` is, node by
//!   node, that of a rank-one quadratic: with `c_i` the coefficients of `(WᵀF)_i`,
//!   `P ↦ P − c_i s_i`, `s_i = γκ_i (c_iᵀP − τ_i) / (1 + γκ_i ‖c_i‖²)`; over the whole
//!   graph `P ↦ P − W∇s` with `s` zero on the other colour.
//!
//! PPXA (Combettes & Pesquet, Algorithm 10.27 of "Proximal splitting methods in signal
//! processing", weights ω = (1/2, 1/4, 1/4)): `p_k = prox_{γf_k/ω}(y_k)`, `p = Σ ω p_k`,
//! `y_k += ρ(2p − F − p_k)`, `F += ρ(p − F)`. The primal follows from the dual as
//! `x = D − λ A⁻¹ WᵀF` (Eq. 16). `F` is not stored: PPXA keeps it equal to `Σ ω y_k`,
//! which the iteration forms where it needs it.
//!
//! Two choices of the iteration that PPXA leaves open (Combettes & Pesquet allow any
//! starting point and any fixed metric): it starts from the dual of `D`'s own smoothed
//! gradients (`Graph::gradient_start`) instead of `F = 0`, with the PPXA copies at the
//! fixed point that start would have if it were the solution (`Graph::consistent_copies`);
//! and a pair whose edges touch a very stiff node (large `γκ`, unreliable pixels) is
//! iterated in a scaled variable — a per-node step (`metric_shift`), so that the default
//! step γ 4 suits confident and unreliable pixels alike.
//!
//! One iteration is one pass over the rows (`Graph::sweep`): the residuals of row
//! `y + 1`, then the proximity results and the combination of row `y`. The copies of the
//! two quadratic parts are stored by colour relative to each edge's owning node (see
//! `Graph`), so one residual pass serves both parts. Every loop walks rows of
//! structure-of-arrays buffers in short fixed-size groups, so the `f32` instantiation
//! vectorises without spilling.

mod combine;
mod edges;
mod graph;
mod inputs;
mod iterate;
mod nodes;
mod output;
mod quadratic;
mod rows;
mod start;
mod stopping;
#[cfg(test)]
mod tests;

use crate::error::{check_scratch, checked_product, Error, Result};
use crate::lightfield::Sample;
use crate::scalar::Scalar;

use super::params::TvParams;
use graph::{Graph, BUFFERS, ROW_BUFFERS, ROW_EXTRA};
use inputs::check_guide;
use stopping::PrimalScale;

pub use inputs::{Guide, Maps, Rect};
pub use output::{SolveOutput, SolveReport};

/// Scratch elements (of the scalar type) a solve over `width × height` pixels needs.
pub fn scratch_len_for(width: usize, height: usize) -> usize {
    width
        .saturating_mul(height)
        .saturating_mul(BUFFERS)
        .saturating_add(width.saturating_mul(ROW_BUFFERS))
        .saturating_add(ROW_EXTRA)
}

/// Solves the model on `region` (a rectangle of the maps, its border edges cut) and writes
/// the refined disparity of `core` (inside `region`) into `out`.
pub fn solve<S: Scalar, P: Sample>(
    maps: &Maps<'_>,
    guide: &Guide<'_, P>,
    params: &TvParams,
    region: Rect,
    core: Rect,
    mut out: SolveOutput<'_>,
    scratch: &mut [S],
) -> Result<SolveReport> {
    params.validate()?;
    let full = Rect {
        x: 0,
        y: 0,
        width: maps.width,
        height: maps.height,
    };
    if region.pixels() == 0 || !full.contains(&region) || !region.contains(&core) {
        return Err(Error::InvalidParameter {
            name: "region",
            reason: "must be a non-empty rectangle inside the maps that contains the core",
        });
    }
    if out.stride < core.width {
        return Err(Error::Stride {
            which: "output row stride",
            stride: out.stride,
            needed: core.width,
        });
    }
    let out_needed = if core.pixels() == 0 {
        0
    } else {
        checked_product(&[core.height - 1, out.stride], "the output")?
            .checked_add(core.width)
            .ok_or(Error::SizeOverflow { what: "the output" })?
    };
    if out.disparity.len() < out_needed {
        return Err(Error::BufferTooSmall {
            what: "the refined-disparity output",
            needed: out_needed,
            got: out.disparity.len(),
        });
    }
    if let Some(dual) = &out.dual {
        if dual.len() < 2 * out_needed {
            return Err(Error::BufferTooSmall {
                what: "the dual output",
                needed: 2 * out_needed,
                got: dual.len(),
            });
        }
    }
    let needed = scratch_len_for(region.width, region.height);
    check_scratch(needed, scratch.len())?;
    check_guide(maps, guide, region)?;

    let mut graph = Graph::split(&mut scratch[..needed], region.width, region.height);
    graph.setup(maps, guide, params, region);
    let scale = PrimalScale {
        confidence: maps.confidence,
        stride: maps.width,
        region,
        params,
    };
    let report = graph.iterate(params, &scale, out.history);
    graph.write_primal(maps, guide, params, region, core, &mut out);
    if let Some(dual) = out.dual {
        graph.write_dual(region, core, dual, out.stride);
    }
    Ok(report)
}

impl<S: Scalar> Graph<'_, S> {
    /// Edge weights, node constants, and the start: the dual of `D`'s smoothed gradients
    /// (`gradient_start`), or the previous sweep's dual when the maps carry one.
    fn setup<P: Sample>(
        &mut self,
        maps: &Maps<'_>,
        guide: &Guide<'_, P>,
        params: &TvParams,
        region: Rect,
    ) {
        match (guide, maps.dual) {
            (Guide::View(view), None) => self.weights_from_view(maps, view, params, region),
            _ => self.weights_by_node(maps, guide, params, region),
        }
        self.norm = params.norm;
        self.set_metric(maps, params, region);
        self.range = if maps.dual.is_none() {
            self.node_constants_by_row(maps, params, region)
        } else {
            self.node_constants_by_node(maps, guide, params, region)
        };
        match maps.dual {
            Some(dual) => self.warm_start(maps, region, dual),
            None => self.gradient_start(maps, region, params.norm),
        }
        self.consistent_copies(maps, params, region);
    }
}
