//! The solver's state over one rectangle of the pixel graph: the buffers it carves out of
//! the scratch and the scale of the iterated dual.

use crate::scalar::Scalar;

use super::super::params::TvNorm;

/// Buffers of the graph size the solver keeps in scratch.
pub(super) const BUFFERS: usize = 11;

/// Rows of the region's width the fused sweep keeps in scratch: the node residuals of
/// two rows, one row of each proximity result (the last row's), and on a checking
/// iteration the dual update of the row (both components) and of the row above
/// (vertical).
pub(super) const ROW_BUFFERS: usize = 11;

/// Elements beyond [`ROW_BUFFERS`] rows: each residual row holds one more, a zero after
/// its last node (the residual "beyond" the last column, whose horizontal edge is cut),
/// so that the horizontal proximity reads the far ends of a row's edges as one shifted
/// row.
pub(super) const ROW_EXTRA: usize = 2;

/// The solver iterates on `DUAL_SCALE · F` (constraint radius `DUAL_SCALE`, targets
/// `DUAL_SCALE · τ`): every iterate scales exactly, so nothing changes in f32 (a power of
/// two), while Q16.16 gains five bits of resolution on the dual — which matters because
/// the primal `D − λ A⁻¹ WᵀF` amplifies dual errors by `λ/a`, up to `λ/ℸ`.
pub(super) const DUAL_SCALE: f32 = 32.0;

/// The solver state over one rectangle, every buffer `width × height`, row-major.
pub(super) struct Graph<'s, S> {
    pub(super) width: usize,
    pub(super) height: usize,
    /// Edge weights `i → i+1` and `i → i+width` (zero where the edge leaves the region).
    pub(super) wh: &'s mut [S],
    pub(super) wv: &'s mut [S],
    /// `τ_i = a_i D_i / λ`.
    pub(super) tau: &'s mut [S],
    /// `σ_i = γκ_i/ω / (1 + γκ_i/ω ‖c_i‖²)`, the rank-one prox factor of node `i` in the
    /// quadratic part of its colour.
    pub(super) sig: &'s mut [S],
    /// Range of `D` over the region: the minimiser lies inside it (truncating to it lowers
    /// both terms), so the primal of a not yet converged dual is clamped to it.
    pub(super) range: (f32, f32),
    /// The norm of the TV (what `bound` holds).
    pub(super) norm: TvNorm,
    /// PPXA copies of the dual for the three functions; their average
    /// `F = ½y₁ + ¼y₂ + ¼y₃` is formed once after the last iteration, into `y1h`, `y1v`
    /// (PPXA keeps `F` equal to that average, so the iteration forms it on the fly
    /// instead of storing it).
    ///
    /// The copies of the two quadratic parts are stored by colour relative to the node
    /// that owns the edges: `own` holds at node `i` the copy of the part of `i`'s colour,
    /// `other` that of the other colour. A node's residual then reads `own` on its own
    /// edges and `other` on its left and upper neighbours' edges (those neighbours have
    /// the other colour), so one pass serves both colours; the PPXA combination treats
    /// the two parts alike (both weigh ¼), so swapping them node by node changes nothing.
    pub(super) y1h: &'s mut [S],
    pub(super) y1v: &'s mut [S],
    pub(super) own_h: &'s mut [S],
    pub(super) own_v: &'s mut [S],
    pub(super) other_h: &'s mut [S],
    pub(super) other_v: &'s mut [S],
    /// Per node, the bound of the projection in the iterated variable `G` (see
    /// [`metric_shift`](super::nodes::metric_shift)): the constraint radius `DUAL_SCALE / s_i` for ℓ1 (a clamp), its
    /// inverse `s_i / DUAL_SCALE` for ℓ2 (the disc test works in units of the radius).
    pub(super) bound: &'s mut [S],
    /// [`ROW_BUFFERS`] rows of `width` for the fused sweep.
    pub(super) rows: &'s mut [S],
}

impl<'s, S: Scalar> Graph<'s, S> {
    pub(super) fn split(scratch: &'s mut [S], width: usize, height: usize) -> Self {
        let n = width * height;
        let (full, rows) = scratch.split_at_mut((n * BUFFERS).min(scratch.len()));
        let mut chunks = full.chunks_exact_mut(n.max(1));
        let mut next = || chunks.next().unwrap_or_default();
        Graph {
            width,
            height,
            wh: next(),
            wv: next(),
            tau: next(),
            sig: next(),
            range: (0.0, 0.0),
            norm: TvNorm::L2,
            y1h: next(),
            y1v: next(),
            own_h: next(),
            own_v: next(),
            other_h: next(),
            other_v: next(),
            bound: next(),
            rows,
        }
    }

    /// `F / G = s_i / DUAL_SCALE` of node `i` (a power of two).
    pub(super) fn factor(&self, i: usize) -> f32 {
        let b = self.bound.get(i).map_or(1.0, |b| b.to_f32());
        match self.norm {
            TvNorm::L1 => 1.0 / b,
            TvNorm::L2 => b,
        }
    }
}
