//! Weighted total-variation refinement in the dual, solved with PPXA.
//!
//! # Model
//! On the 4-neighbour pixel graph (forward edges `h(i) = i → i+1`, `v(i) = i → i+W`) the
//! refined disparity `x` minimises
//!
//! ```text
//! λ · sup_{F ∈ B} Fᵀ W x  +  ½ Σ_i a_i (x_i − D_i)²,      a_i = m_i v_i + ℸ
//! ```
//!
//! with `D` the EPI disparity, `W` the incidence matrix of the graph with edge weights
//! `w_e` from the centre view ([`TvParams::edge_sigma`]), `v_i = c_i^p` from the EPI
//! confidence `c_i` ([`TvParams::confidence_power`]; the data weights `V⁻¹`),
//! `m_i ∈ {0, 1}` the reliable-pixel selection `M` (`c_i ≥`
//! [`TvParams::confidence_threshold`]) and `ℸ` ([`TvParams::tikhonov`]) a weak
//! fidelity `ℸ/2 ‖Z(x − D)‖²` with `Z = I` that keeps the problem strictly convex where
//! `M` selects nothing. `B` is the product over nodes of the constraint sets of each
//! node's two forward edges: the unit ℓ∞ box ([`TvNorm::L1`], anisotropic TV) or the
//! unit ℓ2 disc ([`TvNorm::L2`], isotropic TV).
//!
//! Minimising over `x` in closed form gives the primal from the dual
//! `x(F) = D − λ A⁻¹ WᵀF` and the dual problem
//!
//! ```text
//! min_{F ∈ B}  Σ_i κ_i/2 ((WᵀF)_i − τ_i)²,        κ_i = λ²/a_i,  τ_i = a_i D_i / λ .
//! ```
//!
//! PPXA (Combettes & Pesquet) minimises it as a sum of three functions whose proximity
//! operators are closed form: `ι_B` (per-node projection) and the quadratic split over
//! the two colours of the checkerboard — the edges incident to nodes of one colour are
//! disjoint, so each node's term is a rank-one quadratic on its own edges. See
//! [`solver`]. The primal of a not fully converged dual is clamped to the range of `D`
//! over the region, where the minimiser lies.
//!
//! # Residuals
//! Each solve adds `‖Fₙ − Fₙ₋₁‖²` of every iteration to a history; [`refine`] (or a
//! parallel caller summing tile histories in tile order, then [`normalise_history`])
//! turns it into the RMS dual update per node and iteration.
//!
//! # Tiles
//! The image is cut into `tile × tile` cores, each solved on the core plus a `halo` of
//! pixels on every side (clipped at the image border) and only the core written back.
//! A tile's result depends only on the inputs inside its core + halo, so tiles can be
//! solved in any order or in parallel with bit-identical results.
//!
//! # Outer sweeps
//! A tile sees a free border (its cut edges carry no flow), which the halo only pushes
//! away from the core: on HCI cotton, run close to convergence, tiles of 128 + 16 still
//! differ from the untiled solve by up to 0.026 px. [`TvParams::sweeps`] solves every tile
//! again from the dual of the previous pass over the whole map ([`Maps::with_dual`]),
//! holding the flows of the edges that cross the tile's region (and those of its last
//! column and row, so that no node's coupled ℓ2 pair is split) at that dual's values: they
//! enter each border node's target as a constant. The untiled optimum is a fixed point of
//! this (test), and two sweeps bring cotton within 0.003 px. Each pass reads only the
//! previous pass's dual, so tiles stay independent within a pass and the result is
//! bit-identical for any order or thread count. The sweeps need two duals of the whole
//! map ([`dual_len`]), so the firmware stream runs without them.

/// Progress stage name.
pub const STAGE: &str = "tv";
/// Most outer sweeps ([`TvParams::sweeps`]).
pub const MAX_SWEEPS: usize = 8;

mod params;
pub mod solver;
mod tiles;

pub use params::{TvNorm, TvParams};
pub use solver::{scratch_len_for, solve, Guide, Maps, Rect, SolveOutput, SolveReport};
pub use tiles::{
    dual_len, normalise_history, refine, refine_tile, refine_with_progress, scratch_len,
    tile_count, tile_rects, RefineReport, TvScratch,
};
