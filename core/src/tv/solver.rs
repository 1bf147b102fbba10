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

use core::ops::Range;

use crate::error::{check_scratch, checked_product, Error, Result};
use crate::float::clamp_f32;
use crate::lightfield::{Sample, View};
use crate::scalar::Scalar;

use super::params::{TvNorm, TvParams};
use super::weights::{colour_step, edge_weight};

/// Buffers of the graph size the solver keeps in scratch.
const BUFFERS: usize = 11;

/// Rows of the region's width the fused sweep keeps in scratch: the node residuals of
/// two rows, one row of each proximity result (the last row's), and on a checking
/// iteration the dual update of the row (both components) and of the row above
/// (vertical).
const ROW_BUFFERS: usize = 11;

/// Elements beyond [`ROW_BUFFERS`] rows: each residual row holds one more, a zero after
/// its last node (the residual "beyond" the last column, whose horizontal edge is cut),
/// so that the horizontal proximity reads the far ends of a row's edges as one shifted
/// row.
const ROW_EXTRA: usize = 2;

/// The solver iterates on `DUAL_SCALE · F` (constraint radius `DUAL_SCALE`, targets
/// `DUAL_SCALE · τ`): every iterate scales exactly, so nothing changes in f32 (a power of
/// two), while Q16.16 gains five bits of resolution on the dual — which matters because
/// the primal `D − λ A⁻¹ WᵀF` amplifies dual errors by `λ/a`, up to `λ/ℸ`.
const DUAL_SCALE: f32 = 32.0;

/// Scale `ε` (px of weighted disparity step) of the cold start's dual
/// `F = g / max(ε, ‖g‖)` (see `Graph::gradient_start`): steps of `D` larger than this
/// start saturated. 0.02 px measured best of 0.005 / 0.02 / 0.1 / 0.5 on the HCI scenes
/// with every PPXA copy started at `F`; with the copies at their fixed point
/// (`consistent_copies`) 0.05 of 0.01 / 0.02 / 0.05 / 0.1 (docs/stages/tv.md).
const GRADIENT_START_SCALE: f32 = 0.05;

/// The per-pixel inputs of the stage: EPI disparity and confidence, row-major, top row
/// first, `width × height` each.
#[derive(Clone, Copy, Debug)]
pub struct Maps<'a> {
    width: usize,
    height: usize,
    disparity: &'a [f32],
    confidence: &'a [f32],
    /// The dual `(F_h, F_v)` per pixel of a previous sweep over the whole map (see
    /// [`Maps::with_dual`]).
    dual: Option<&'a [f32]>,
}

impl<'a> Maps<'a> {
    /// Checks sizes and that every value is finite (confidence is clamped to [0, 1] when used).
    pub fn new(
        width: usize,
        height: usize,
        disparity: &'a [f32],
        confidence: &'a [f32],
    ) -> Result<Self> {
        let pixels = checked_product(&[width, height], "the disparity map")?;
        if width == 0 || height == 0 {
            return Err(Error::ViewTooSmall { width, height });
        }
        for (what, map) in [("disparity", disparity), ("confidence", confidence)] {
            if map.len() != pixels {
                return Err(Error::OutputSize {
                    what,
                    needed: pixels,
                    got: map.len(),
                });
            }
            if map.iter().any(|v| !v.is_finite()) {
                return Err(Error::NonFinite { what });
            }
        }
        Ok(Maps {
            width,
            height,
            disparity,
            confidence,
            dual: None,
        })
    }

    /// Adds the dual `(F_h, F_v)` per pixel (`2 × width × height`, row-major, as
    /// [`SolveOutput::dual`] writes it) of a previous sweep over the whole map. A solve
    /// then starts from it and holds the flows on the edges that cross its region's border
    /// fixed at its values (an outer sweep that exchanges halos, see [`TvParams::sweeps`]):
    /// a tile no longer sees a free border, so tiled results approach the untiled one.
    pub fn with_dual(self, dual: &'a [f32]) -> Result<Self> {
        let needed = 2 * self.width * self.height;
        if dual.len() != needed {
            return Err(Error::OutputSize {
                what: "the previous sweep's dual",
                needed,
                got: dual.len(),
            });
        }
        if dual.iter().any(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                what: "the previous sweep's dual",
            });
        }
        Ok(Maps {
            dual: Some(dual),
            ..self
        })
    }
    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }
}

/// Where the edge weights come from.
#[derive(Clone, Copy, Debug)]
pub enum Guide<'a, P: Sample> {
    /// The centre view (same size as the maps), through [`TvParams::edge_sigma`].
    View(View<'a, P>),
    /// Given weights (≥ 0, finite): `horizontal[i]` for the edge `i → i+1`, `vertical[i]`
    /// for `i → i+width`, row-major like the maps (entries of edges leaving the image
    /// are ignored).
    Weights {
        /// Right-neighbour edge weights.
        horizontal: &'a [f32],
        /// Down-neighbour edge weights.
        vertical: &'a [f32],
    },
}

/// A rectangle of pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Rect {
    /// Left column.
    pub x: usize,
    /// Top row.
    pub y: usize,
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
}

impl Rect {
    fn pixels(&self) -> usize {
        self.width.saturating_mul(self.height)
    }
    fn contains(&self, other: &Rect) -> bool {
        let end = |start: usize, len: usize| start.checked_add(len);
        match (
            end(self.x, self.width),
            end(self.y, self.height),
            end(other.x, other.width),
            end(other.y, other.height),
        ) {
            (Some(sx), Some(sy), Some(ox), Some(oy)) => {
                other.x >= self.x && other.y >= self.y && ox <= sx && oy <= sy
            }
            _ => false,
        }
    }
}

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
#[allow(clippy::too_many_arguments)]
pub fn solve<S: Scalar, P: Sample>(
    maps: &Maps<'_>,
    guide: &Guide<'_, P>,
    params: &TvParams,
    region: Rect,
    core: Rect,
    out: SolveOutput<'_>,
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
    graph.write_primal(maps, guide, params, region, core, out.disparity, out.stride);
    if let Some(dual) = out.dual {
        graph.write_dual(region, core, dual, out.stride);
    }
    Ok(report)
}

fn check_guide<P: Sample>(maps: &Maps<'_>, guide: &Guide<'_, P>, region: Rect) -> Result<()> {
    match guide {
        Guide::View(view) => {
            if view.width() != maps.width || view.height() != maps.height {
                return Err(Error::InvalidParameter {
                    name: "guide view",
                    reason: "must have the size of the disparity map",
                });
            }
            // Only the region (one row and column beyond it for the edges) is read.
            let ch = view.channels();
            let x0 = region.x * ch;
            let x1 = ((region.x + region.width + 1).min(view.width())) * ch;
            let mut finite = true;
            for y in region.y..(region.y + region.height + 1).min(view.height()) {
                if let Some(row) = view.row(y).and_then(|r| r.get(x0..x1)) {
                    finite &= row.iter().all(|s| s.is_finite());
                }
            }
            if !finite {
                return Err(Error::NonFinite {
                    what: "the guide view",
                });
            }
        }
        Guide::Weights {
            horizontal,
            vertical,
        } => {
            let pixels = maps.width * maps.height;
            for (what, w) in [
                ("horizontal edge weights", horizontal),
                ("vertical edge weights", vertical),
            ] {
                if w.len() != pixels {
                    return Err(Error::OutputSize {
                        what,
                        needed: pixels,
                        got: w.len(),
                    });
                }
                if w.iter().any(|v| !v.is_finite() || *v < 0.0) {
                    return Err(Error::InvalidParameter {
                        name: "edge weights",
                        reason: "must be finite and non-negative",
                    });
                }
            }
        }
    }
    Ok(())
}

/// The solver state over one rectangle, every buffer `width × height`, row-major.
struct Graph<'s, S> {
    width: usize,
    height: usize,
    /// Edge weights `i → i+1` and `i → i+width` (zero where the edge leaves the region).
    wh: &'s mut [S],
    wv: &'s mut [S],
    /// `τ_i = a_i D_i / λ`.
    tau: &'s mut [S],
    /// `σ_i = γκ_i/ω / (1 + γκ_i/ω ‖c_i‖²)`, the rank-one prox factor of node `i` in the
    /// quadratic part of its colour.
    sig: &'s mut [S],
    /// Range of `D` over the region: the minimiser lies inside it (truncating to it lowers
    /// both terms), so the primal of a not yet converged dual is clamped to it.
    range: (f32, f32),
    /// The norm of the TV (what `bound` holds).
    norm: TvNorm,
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
    y1h: &'s mut [S],
    y1v: &'s mut [S],
    own_h: &'s mut [S],
    own_v: &'s mut [S],
    other_h: &'s mut [S],
    other_v: &'s mut [S],
    /// Per node, the bound of the projection in the iterated variable `G` (see
    /// [`metric_shift`]): the constraint radius `DUAL_SCALE / s_i` for ℓ1 (a clamp), its
    /// inverse `s_i / DUAL_SCALE` for ℓ2 (the disc test works in units of the radius).
    bound: &'s mut [S],
    /// [`ROW_BUFFERS`] rows of `width` for the fused sweep.
    rows: &'s mut [S],
}

impl<'s, S: Scalar> Graph<'s, S> {
    fn split(scratch: &'s mut [S], width: usize, height: usize) -> Self {
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
    fn consistent_copies(&mut self, maps: &Maps<'_>, params: &TvParams, region: Rect) {
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

    /// The edge weights node by node: given weights, or a previous sweep's dual (which
    /// fixes the pairs of the region's last column and row).
    fn weights_by_node<P: Sample>(
        &mut self,
        maps: &Maps<'_>,
        guide: &Guide<'_, P>,
        params: &TvParams,
        region: Rect,
    ) {
        let (w, h) = (self.width, self.height);
        for y in 0..h {
            let gy = region.y + y;
            // The guide's rows are fetched once per row, not per pixel (setup was a fifth
            // of a default solve once the iterations were few).
            let view_rows = match guide {
                Guide::View(view) => Some((
                    view.row(gy).unwrap_or_default(),
                    view.row(gy + 1).unwrap_or_default(),
                    view.channels(),
                )),
                Guide::Weights { .. } => None,
            };
            for x in 0..w {
                let gx = region.x + x;
                let i = y * w + x;
                let (eh, ev) = match view_rows {
                    Some((row, below, ch)) => {
                        let (eh, ev) = row_weights(row, below, ch, gx, params);
                        (
                            if gx + 1 < maps.width { eh } else { 0.0 },
                            if gy + 1 < maps.height { ev } else { 0.0 },
                        )
                    }
                    None => edge_weights(maps, guide, params, gx, gy),
                };
                // Without a previous dual the region's border edges are cut; with one,
                // every edge owned by a node of the last column or row is held fixed
                // (see `external_flow`), and is therefore not a variable here.
                let (free_h, free_v) = if maps.dual.is_some() {
                    let inner = !fixed_pair(maps, region, x, y);
                    (inner && x + 1 < w, inner && y + 1 < h)
                } else {
                    (x + 1 < w, y + 1 < h)
                };
                if let (Some(oh), Some(ov)) = (self.wh.get_mut(i), self.wv.get_mut(i)) {
                    *oh = S::from_f32(if free_h { eh } else { 0.0 });
                    *ov = S::from_f32(if free_v { ev } else { 0.0 });
                }
            }
        }
    }

    /// The edge weights from the guide view without a previous dual (the same values as
    /// [`Self::weights_by_node`]), a block of columns at a time down the region
    /// ([`Self::view_weights_by_block`]) for every layout a view has (1, 3 or 4 samples
    /// per pixel).
    fn weights_from_view<P: Sample>(
        &mut self,
        maps: &Maps<'_>,
        view: &View<'_, P>,
        params: &TvParams,
        region: Rect,
    ) {
        match view.channels() {
            1 => self.view_weights_by_block::<P, 1, 1>(view, params, region),
            3 => self.view_weights_by_block::<P, 3, 3>(view, params, region),
            4 => self.view_weights_by_block::<P, 4, 3>(view, params, region),
            _ => self.weights_by_node(maps, &Guide::View(*view), params, region),
        }
    }

    /// [`Self::weights_from_view`] for `CH` samples per pixel, `USED` of them compared: the
    /// region is walked in blocks of [`STEP_BLOCK`] columns, each from its top row down,
    /// so every image row of a block is turned into unit intensity once — as the lower
    /// row of one row's vertical steps and then as the next row's own — instead of twice
    /// (row by row, each row was converted again as the one below the previous row).
    /// The same values as [`colour_step`] per pixel: the largest of non-negative
    /// differences (the samples are finite) does not depend on the order it is taken in,
    /// so the differences and the largest of them run in vector lanes, a channel at a time.
    fn view_weights_by_block<P: Sample, const CH: usize, const USED: usize>(
        &mut self,
        view: &View<'_, P>,
        params: &TvParams,
        region: Rect,
    ) {
        let (w, h) = (self.width, self.height);
        let weight =
            |step: f32| S::from_f32(edge_weight(step, params.edge_sigma, params.edge_floor));
        // The block's pixels of image row `gy` and the one right of the block (when the
        // image has them) into `out`, in unit intensity; returns how many there were.
        let load = |gy: usize, first: usize, n: usize, out: &mut [[f32; STEP_BLOCK + 1]; USED]| {
            let row = view.row(gy).unwrap_or_default();
            let pixels = row.get((region.x + first) * CH..).unwrap_or_default();
            let mut known = 0;
            for (x, pixel) in pixels.chunks_exact(CH).take(n + 1).enumerate() {
                for (channel, &v) in out.iter_mut().zip(pixel) {
                    if let Some(u) = channel.get_mut(x) {
                        *u = v.to_unit();
                    }
                }
                known = x + 1;
            }
            known
        };
        let mut here = [[0.0f32; STEP_BLOCK + 1]; USED];
        let mut under = [[0.0f32; STEP_BLOCK + 1]; USED];
        for first in (0..w).step_by(STEP_BLOCK) {
            let n = STEP_BLOCK.min(w - first);
            let mut known = load(region.y, first, n, &mut here);
            for y in 0..h {
                let r = y * w + first..y * w + first + n;
                let (Some(oh), Some(ov)) = (self.wh.get_mut(r.clone()), self.wv.get_mut(r)) else {
                    continue;
                };
                // The last row's vertical edges are cut (the region's or the map's end).
                let known_below = if y + 1 < h {
                    load(region.y + y + 1, first, n, &mut under)
                } else {
                    0
                };
                let (mut right, mut down) = ([0.0f32; STEP_BLOCK], [0.0f32; STEP_BLOCK]);
                // A missing neighbour leaves its step at 0.
                let with_right = n.min(known.saturating_sub(1));
                let with_down = n.min(known_below);
                if let (Some(right), Some(down)) =
                    (right.get_mut(..with_right), down.get_mut(..with_down))
                {
                    for (channel, channel_below) in here.iter().zip(&under) {
                        let next = channel.iter().skip(1);
                        for ((r, &a), &b) in right.iter_mut().zip(channel).zip(next) {
                            let d = libm::fabsf(a - b);
                            *r = if d > *r { d } else { *r };
                        }
                        for ((r, &a), &b) in down.iter_mut().zip(channel).zip(channel_below) {
                            let d = libm::fabsf(a - b);
                            *r = if d > *r { d } else { *r };
                        }
                    }
                }
                for (e, &step) in oh.iter_mut().zip(right.iter()) {
                    *e = weight(step);
                }
                if y + 1 < h {
                    for (e, &step) in ov.iter_mut().zip(down.iter()) {
                        *e = weight(step);
                    }
                } else {
                    ov.fill(S::ZERO);
                }
                // The region's last column: its horizontal edge is cut.
                if first + n == w {
                    if let Some(last) = oh.last_mut() {
                        *last = S::ZERO;
                    }
                }
                core::mem::swap(&mut here, &mut under);
                known = known_below;
            }
        }
    }

    /// `τ` and `σ` node by node, with the fixed flows of a previous dual; returns the
    /// range of `D` over the region.
    fn node_constants_by_node<P: Sample>(
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
    fn node_constants_by_row(
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
    fn set_metric(&mut self, maps: &Maps<'_>, params: &TvParams, region: Rect) {
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

    /// `F / G = s_i / DUAL_SCALE` of node `i` (a power of two).
    fn factor(&self, i: usize) -> f32 {
        let b = self.bound.get(i).map_or(1.0, |b| b.to_f32());
        match self.norm {
            TvNorm::L1 => 1.0 / b,
            TvNorm::L2 => b,
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
    fn gradient_start(&mut self, maps: &Maps<'_>, region: Rect, norm: TvNorm) {
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

    fn iterate(
        &mut self,
        params: &TvParams,
        scale: &PrimalScale<'_>,
        history: &mut [f32],
    ) -> SolveReport {
        // PPXA weights ω = (1/2, 1/4, 1/4): powers of two, so the average is exact in
        // both f32 and Q16.16 (a rounded 1/3 would bias the fixed point towards zero).
        let constants = Constants {
            rho: S::from_f32(params.relaxation),
            two: S::from_i32(2),
            half: S::from_f32(0.5),
            quarter: S::from_f32(0.25),
            norm: params.norm,
        };
        // The stopping rule is on the primal, the map the stage returns: an iteration's
        // dual update moves pixel `i` by `λ/a_i · (WᵀΔF)_i`, weighed here by the data
        // weight `a_i` (the energy of the data term), i.e. `λ(WᵀΔF)_i/√a_i`. Confident
        // pixels (small `λ/a`) stop mattering early, weakly confident ones keep a tile
        // running longer (a relative dual rule was blind to both: it ran the default
        // pipeline's confident input 2× longer and stopped the paper's EPI input further
        // from the minimiser). Unweighted (`λ/a_i`), scattered outliers of confidence ≈ 0
        // held tiles for 40 % more iterations on the synthetic bench for no accuracy.
        let nodes = self.y1h.len().max(1) as f32;
        let tol2 = params.tolerance * params.tolerance * nodes;
        let mut report = SolveReport::default();
        for it in 0..params.max_iterations {
            let record = it < history.len();
            let check = is_check(it + 1);
            let (change, primal) = match (record, check) {
                (true, true) => self.sweep::<true, true>(&constants, scale),
                (true, false) => self.sweep::<true, false>(&constants, scale),
                (false, true) => self.sweep::<false, true>(&constants, scale),
                (false, false) => self.sweep::<false, false>(&constants, scale),
            };
            if let Some(h) = history.get_mut(it) {
                // Back to the units of F.
                *h += change / (DUAL_SCALE * DUAL_SCALE);
            }
            report.iterations = it + 1;
            if check && primal <= tol2 {
                report.converged = true;
                break;
            }
        }
        self.form_average(&constants);
        report
    }

    /// `F = ½y₁ + ¼y₂ + ¼y₃` (the expression the iteration uses), into `y₁`.
    fn form_average(&mut self, c: &Constants<S>) {
        let ys = self.own_h.iter().zip(self.other_h.iter());
        for (f, (&y2, &y3)) in self.y1h.iter_mut().zip(ys) {
            *f = average(c, *f, y2, y3);
        }
        let ys = self.own_v.iter().zip(self.other_v.iter());
        for (f, (&y2, &y3)) in self.y1v.iter_mut().zip(ys) {
            *f = average(c, *f, y2, y3);
        }
    }

    /// One PPXA iteration in a single pass over the rows: row `y` of both quadratic
    /// proximity results needs the node residuals `s` of rows `y` and `y + 1` only, and
    /// the residuals of row `y + 1` read the copies `y₂`, `y₃` of rows `y` and `y + 1`,
    /// so computing them before row `y` is combined keeps every read on the previous
    /// iterate while each buffer is walked once (no full-size temporaries).
    /// Returns `‖ΔF‖²` in the scaled units when `RECORD` (for the residual history), and
    /// when `CHECK` the weighted squared primal change `Σ a_i (xₙ − xₙ₋₁)_i²` in pixels²
    /// (stopping rule).
    fn sweep<const RECORD: bool, const CHECK: bool>(
        &mut self,
        c: &Constants<S>,
        scale: &PrimalScale<'_>,
    ) -> (f32, f32) {
        let (w, rows) = (self.width, self.height);
        let mut sums = Sums {
            change: [0.0; LANES],
        };
        let mut primal = 0.0f32;
        // Two residual rows of `w + 1`, the last element zero (never written).
        let (residuals, row_rest) = self.rows.split_at_mut((2 * (w + 1)).min(self.rows.len()));
        let (mut s_ext, mut s_below_ext) = residuals.split_at_mut(residuals.len() / 2);
        for s in [&mut *s_ext, &mut *s_below_ext] {
            if let Some(last) = s.last_mut() {
                *last = S::ZERO;
            }
        }
        let mut row_bufs = row_rest.chunks_exact_mut(w.max(1));
        let mut next = || row_bufs.next().unwrap_or_default();
        let (p_own_h, p_own_v, p_other_h, p_other_v) = (next(), next(), next(), next());
        let (p1h, p1v) = (next(), next());
        let (dh, mut dv, mut dv_above) = (next(), next(), next());
        let (wh, wv, tau, sig) = (&*self.wh, &*self.wv, &*self.tau, &*self.sig);
        let copies = [&*self.own_h, &*self.own_v, &*self.other_h, &*self.other_v];
        residual_row(0, w, wh, wv, tau, sig, copies, part_mut(s_ext, 0..w));
        for y in 0..rows {
            let below = y + 1 < rows;
            if below {
                let copies = [&*self.own_h, &*self.own_v, &*self.other_h, &*self.other_v];
                let s_below = part_mut(s_below_ext, 0..w);
                residual_row(y + 1, w, wh, wv, tau, sig, copies, s_below);
            }
            let r = y * w..(y + 1) * w;
            let state = [
                part_mut(self.y1h, r.clone()),
                part_mut(self.y1v, r.clone()),
                part_mut(self.own_h, r.clone()),
                part_mut(self.own_v, r.clone()),
                part_mut(self.other_h, r.clone()),
                part_mut(self.other_v, r.clone()),
            ];
            let weights = [part(wh, r.clone()), part(wv, r.clone())];
            let s = part(s_ext, 0..w);
            if below {
                // The proximity results are formed inside the combination (no rows of
                // them): `s_ext` shifted by one holds each horizontal edge's far end.
                combine_with_prox::<S, RECORD, CHECK>(
                    c,
                    state,
                    weights,
                    [s, part(s_ext, 1..w + 1), part(s_below_ext, 0..w)],
                    part(self.bound, r.clone()),
                    [&mut *p1h, &mut *p1v],
                    [&mut *dh, &mut *dv],
                    &mut sums,
                );
            } else {
                // The last row has no vertical edges (no residuals below).
                let [y1h, y1v, own_h, own_v, other_h, other_v] = state;
                prox_row(
                    weights,
                    [&*own_h, &*own_v, &*other_h, &*other_v],
                    s,
                    None,
                    [
                        &mut *p_own_h,
                        &mut *p_own_v,
                        &mut *p_other_h,
                        &mut *p_other_v,
                    ],
                );
                combine::<S, RECORD, CHECK>(
                    c,
                    [y1h, y1v, own_h, own_v, other_h, other_v],
                    [&*p_own_h, &*p_own_v, &*p_other_h, &*p_other_v],
                    part(self.bound, r.clone()),
                    [&mut *p1h, &mut *p1v],
                    [&mut *dh, &mut *dv],
                    &mut sums,
                );
            }
            if CHECK {
                let above = if y > 0 {
                    Some((part(wv, r.start - w..r.start), &*dv_above))
                } else {
                    None
                };
                primal += primal_change_row(
                    [part(wh, r.clone()), part(wv, r.clone())],
                    [&*dh, &*dv],
                    above,
                    scale,
                    y,
                    p1h,
                );
                core::mem::swap(&mut dv, &mut dv_above);
            }
            core::mem::swap(&mut s_ext, &mut s_below_ext);
        }
        (sums.change.iter().sum(), primal)
    }

    /// Every PPXA copy and `F` set to the previous sweep's dual (scaled), so that
    /// `F = ½y₁ + ¼y₂ + ¼y₃` holds from the start. Flows of edges that leave the region
    /// stay zero inside it: they are held fixed through the targets instead.
    fn warm_start(&mut self, maps: &Maps<'_>, region: Rect, dual: &[f32]) {
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

    /// The dual of the core, unscaled, `(F_h, F_v)` per pixel at `2 · (y · stride + x)`.
    fn write_dual(&self, region: Rect, core: Rect, dual: &mut [f32], stride: usize) {
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

    /// `x = D − λ A⁻¹ WᵀF` on the core (Eq. 16), clamped to the range of `D`.
    #[allow(clippy::too_many_arguments)]
    fn write_primal<P: Sample>(
        &mut self,
        maps: &Maps<'_>,
        guide: &Guide<'_, P>,
        params: &TvParams,
        region: Rect,
        core: Rect,
        out: &mut [f32],
        stride: usize,
    ) {
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

/// The weights of the edges `(gx, gy) → (gx + 1, gy)` and `→ (gx, gy + 1)` of the whole
/// map (zero where they leave it).
fn edge_weights<P: Sample>(
    maps: &Maps<'_>,
    guide: &Guide<'_, P>,
    params: &TvParams,
    gx: usize,
    gy: usize,
) -> (f32, f32) {
    let (eh, ev) = match guide {
        Guide::Weights {
            horizontal,
            vertical,
        } => {
            let gi = gy * maps.width + gx;
            (
                horizontal.get(gi).copied().unwrap_or(0.0),
                vertical.get(gi).copied().unwrap_or(0.0),
            )
        }
        Guide::View(view) => view_weights(view, gx, gy, params),
    };
    (
        if gx + 1 < maps.width { eh } else { 0.0 },
        if gy + 1 < maps.height { ev } else { 0.0 },
    )
}

/// Whether the pair `(F_h, F_v)` of region node `(x, y)` is held fixed by an outer sweep:
/// the node lies in the region's last column or row, and that is not the map's (a node on
/// the map's border has no edge to the outside, so its pair stays free).
fn fixed_pair(maps: &Maps<'_>, region: Rect, x: usize, y: usize) -> bool {
    let (gx, gy) = (region.x + x, region.y + y);
    (x + 1 == region.width && gx + 1 < maps.width)
        || (y + 1 == region.height && gy + 1 < maps.height)
}

/// `(WᵀF)_i` of the edges of region node `(x, y)` that the solve holds fixed at the
/// previous sweep's flows ([`Maps::with_dual`]); zero without one. Fixed are the edges
/// owned by a node outside the region and every edge owned by a node of the region's last
/// column or row: those nodes' pairs `(F_h, F_v)` then lie wholly outside the problem, so
/// the coupled (ℓ2) constraint of a pair is never split between a fixed and a free edge.
/// The incidence convention is the solver's: a node's own forward edges count `−w F`, its
/// left and upper neighbours' `+w F`.
fn external_flow<P: Sample>(
    maps: &Maps<'_>,
    guide: &Guide<'_, P>,
    params: &TvParams,
    region: Rect,
    x: usize,
    y: usize,
) -> f32 {
    let Some(dual) = maps.dual else {
        return 0.0;
    };
    let (gx, gy) = (region.x + x, region.y + y);
    let flow = |px: usize, py: usize, component: usize| {
        dual.get(2 * (py * maps.width + px) + component)
            .copied()
            .unwrap_or(0.0)
    };
    let (last_x, last_y) = (
        x + 1 == region.width && gx + 1 < maps.width,
        y + 1 == region.height && gy + 1 < maps.height,
    );
    let mut e = 0.0;
    if last_x || last_y {
        let (eh, ev) = edge_weights(maps, guide, params, gx, gy);
        e -= eh * flow(gx, gy, 0) + ev * flow(gx, gy, 1);
    }
    if gx > 0 && (x == 0 || last_y) {
        e += edge_weights(maps, guide, params, gx - 1, gy).0 * flow(gx - 1, gy, 0);
    }
    if gy > 0 && (y == 0 || last_x) {
        e += edge_weights(maps, guide, params, gx, gy - 1).1 * flow(gx, gy - 1, 1);
    }
    e
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
fn metric_shift(stiffness: f32) -> i32 {
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

/// Pixels per block of columns of [`Graph::view_weights_by_block`] in the setup (`f32`
/// arrays on the stack).
const STEP_BLOCK: usize = 64;

/// Edge weights to the right and down neighbours of `(x, y)` from the guide view.
fn view_weights<P: Sample>(
    view: &View<'_, P>,
    x: usize,
    y: usize,
    params: &TvParams,
) -> (f32, f32) {
    row_weights(
        view.row(y).unwrap_or(&[]),
        view.row(y + 1).unwrap_or(&[]),
        view.channels(),
        x,
        params,
    )
}

/// [`view_weights`] of pixel `x` of image row `row` (`ch` channels per pixel), `below`
/// the next row (empty on the last).
#[inline(always)]
fn row_weights<P: Sample>(
    row: &[P],
    below: &[P],
    ch: usize,
    x: usize,
    params: &TvParams,
) -> (f32, f32) {
    let used = ch.min(3);
    let here = row.get(x * ch..x * ch + ch).unwrap_or(&[]);
    let weight = |other: &[P]| {
        if other.is_empty() {
            0.0
        } else {
            edge_weight(
                colour_step(here, other, used),
                params.edge_sigma,
                params.edge_floor,
            )
        }
    };
    let right = row.get((x + 1) * ch..(x + 2) * ch).unwrap_or(&[]);
    let below = below.get(x * ch..x * ch + ch).unwrap_or(&[]);
    (weight(right), weight(below))
}

/// Iterations between two evaluations of the stopping rule once a solve has run
/// [`EARLY_CHECKS_UNTIL`] iterations: the primal change costs about a seventh of an
/// iteration (`WᵀΔF` and `λ/a` of the update that the combination step writes), so it is
/// measured on every fourth iteration only.
const CHECK_EVERY: usize = 4;

/// The first evaluation of the stopping rule, after this many iterations.
const FIRST_CHECK: usize = 4;

/// Up to this many iterations the rule is checked every [`EARLY_CHECK_EVERY`]
/// iterations: a solve that needs few (a tile of confident pixels: 6–8 on HCI
/// backgammon) would otherwise run up to three iterations past its stop, a third more.
const EARLY_CHECKS_UNTIL: usize = 8;

/// See [`EARLY_CHECKS_UNTIL`].
const EARLY_CHECK_EVERY: usize = 2;

/// Whether the stopping rule is evaluated after `iterations` iterations: at
/// [`FIRST_CHECK`], then every [`EARLY_CHECK_EVERY`] up to [`EARLY_CHECKS_UNTIL`], then
/// every [`CHECK_EVERY`].
fn is_check(iterations: usize) -> bool {
    let every = if iterations <= EARLY_CHECKS_UNTIL {
        EARLY_CHECK_EVERY
    } else {
        CHECK_EVERY
    };
    iterations >= FIRST_CHECK && iterations % every == 0
}

/// What turns a dual update into a primal one: `Δx_i = λ/a_i · (WᵀΔF)_i` (Eq. 16).
struct PrimalScale<'m> {
    confidence: &'m [f32],
    stride: usize,
    region: Rect,
    params: &'m TvParams,
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
fn primal_change_row<S: Scalar>(
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

/// Constants of the PPXA combination step.
struct Constants<S> {
    rho: S,
    two: S,
    half: S,
    quarter: S,
    norm: TvNorm,
}

/// Lanes of the blocks the combination step walks, so the `f32` loop vectorises
/// (fixed-length blocks, per-lane sums).
const LANES: usize = 16;

/// The PPXA combination on one row: `p₁ = P_B(y₁)`, `p = ½p₁ + ¼p₂ + ¼p₃`,
/// `y_k += ρ(2p − F − p_k)`, `F += ρ(p − F)`; adds `‖ΔF‖²` (scaled units) to `sums`
/// when `RECORD` and writes `ΔF = ρ(p − F)` (both components) into `delta` when `CHECK`
/// (the update of `F = Σ ω_k y_k` is exactly that: `Σ ω_k (2p − F − p_k) = p − F`).
/// `p1` is room for `p₁` (two rows). The projection couples the two components of a
/// node, the rest does not: the horizontal and the vertical components are combined in
/// separate passes, each few enough streams to stay in registers.
#[inline(never)]
fn combine<S: Scalar, const RECORD: bool, const CHECK: bool>(
    c: &Constants<S>,
    state: [&mut [S]; 6],
    prox: [&[S]; 4],
    bound: &[S],
    p1: [&mut [S]; 2],
    delta: [&mut [S]; 2],
    sums: &mut Sums,
) {
    let [y1h, y1v, y2h, y2v, y3h, y3v] = state;
    let [p2h, p2v, p3h, p3v] = prox;
    let [p1h, p1v] = p1;
    let [dh, dv] = delta;
    project_row(c, [&mut *p1h, &mut *p1v], [y1h, y1v], bound);
    combine_component::<S, RECORD, CHECK>(c, [y1h, y2h, y3h], [p1h, p2h, p3h], dh, sums);
    combine_component::<S, RECORD, CHECK>(c, [y1v, y2v, y3v], [p1v, p2v, p3v], dv, sums);
}

/// [`combine`] with the proximity results of the two quadratic parts formed node by
/// node as [`prox_row`] forms them, `p_own = own + w s` and `p_other = other − w s_far`,
/// instead of read from rows of them (two passes and four streams less). `weights` =
/// `[w_h, w_v]` of the row; `residuals` = `[s, s_right, s_below]`: the row's residuals,
/// the same shifted by one node (the far ends of the horizontal edges; zero after the
/// last node, whose edge is cut, so that `p_other = other − w·0 = other` there), and the
/// next row's (the far ends of the vertical edges; not the last row).
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn combine_with_prox<S: Scalar, const RECORD: bool, const CHECK: bool>(
    c: &Constants<S>,
    state: [&mut [S]; 6],
    weights: [&[S]; 2],
    residuals: [&[S]; 3],
    bound: &[S],
    p1: [&mut [S]; 2],
    delta: [&mut [S]; 2],
    sums: &mut Sums,
) {
    let [y1h, y1v, y2h, y2v, y3h, y3v] = state;
    let [wh, wv] = weights;
    let [s, s_right, s_below] = residuals;
    let [p1h, p1v] = p1;
    let [dh, dv] = delta;
    project_row(c, [&mut *p1h, &mut *p1v], [y1h, y1v], bound);
    combine_component_with_prox::<S, RECORD, CHECK>(
        c,
        [y1h, y2h, y3h],
        p1h,
        wh,
        [s, s_right],
        dh,
        sums,
    );
    combine_component_with_prox::<S, RECORD, CHECK>(
        c,
        [y1v, y2v, y3v],
        p1v,
        wv,
        [s, s_below],
        dv,
        sums,
    );
}

/// `p₁ = P_B(y₁)` of one row (both components) into `p1`.
#[inline(always)]
fn project_row<S: Scalar>(c: &Constants<S>, p1: [&mut [S]; 2], y1: [&[S]; 2], bound: &[S]) {
    let [p1h, p1v] = p1;
    let [y1h, y1v] = y1;
    copy_row(p1h, y1h);
    copy_row(p1v, y1v);
    let full = p1h.len() - p1h.len() % LANES;
    // Both are one row (the checked split of `p1v` never fails).
    let (lanes_h, rest_h) = p1h.split_at_mut(full);
    let (Some((lanes_v, rest_v)), Some((lanes_b, rest_b))) =
        (p1v.split_at_mut_checked(full), bound.split_at_checked(full))
    else {
        return;
    };
    for ((h, v), b) in lanes_h
        .chunks_exact_mut(LANES)
        .zip(lanes_v.chunks_exact_mut(LANES))
        .zip(lanes_b.chunks_exact(LANES))
    {
        if let (Ok(h), Ok(v), Ok(b)) = (
            <&mut [S; LANES]>::try_from(h),
            <&mut [S; LANES]>::try_from(v),
            <&[S; LANES]>::try_from(b),
        ) {
            project_lanes(h, v, b, c.norm);
        }
    }
    for ((h, v), &b) in rest_h.iter_mut().zip(rest_v.iter_mut()).zip(rest_b) {
        let (mut h1, mut v1) = ([*h], [*v]);
        project_lanes(&mut h1, &mut v1, &[b], c.norm);
        (*h, *v) = (h1[0], v1[0]);
    }
}

/// [`combine_component`] with the proximity results formed from the weights `w` and
/// the residuals `[s_own, s_far]` (see [`combine_with_prox`]).
#[inline(always)]
fn combine_component_with_prox<S: Scalar, const RECORD: bool, const CHECK: bool>(
    c: &Constants<S>,
    y: [&mut [S]; 3],
    p1: &[S],
    w: &[S],
    s: [&[S]; 2],
    delta: &mut [S],
    sums: &mut Sums,
) {
    let [y1, y2, y3] = y;
    let [s0, s1] = s;
    let n = y1.len();
    let full = n - n % LANES;
    // One row each, all the same length (the checked splits never fail; `delta` is
    // only written when `CHECK`).
    let (y1, y1r) = y1.split_at_mut(full);
    let (Some((y2, y2r)), Some((y3, y3r)), Some((p1, p1r)), Some((w, wr)), Some((s0, s0r))) = (
        y2.split_at_mut_checked(full),
        y3.split_at_mut_checked(full),
        p1.split_at_checked(full),
        w.split_at_checked(full),
        s0.split_at_checked(full),
    ) else {
        return;
    };
    let Some((s1, s1r)) = s1.split_at_checked(full) else {
        return;
    };
    if CHECK {
        let Some((d, dr)) = delta
            .get_mut(..n)
            .and_then(|d| d.split_at_mut_checked(full))
        else {
            return;
        };
        combine_prox_lanes_with_delta::<S, LANES, RECORD>(
            c,
            [y1, y2, y3],
            [p1, w, s0, s1],
            d,
            sums,
        );
        combine_prox_lanes_with_delta::<S, 1, RECORD>(
            c,
            [y1r, y2r, y3r],
            [p1r, wr, s0r, s1r],
            dr,
            sums,
        );
    } else {
        combine_prox_lanes::<S, LANES, RECORD>(c, [y1, y2, y3], [p1, w, s0, s1], sums);
        combine_prox_lanes::<S, 1, RECORD>(c, [y1r, y2r, y3r], [p1r, wr, s0r, s1r], sums);
    }
}

/// [`combine_lanes`] with the proximity results formed in the loop: `inputs` =
/// `[p₁, w, s_own, s_far]`.
#[inline(always)]
fn combine_prox_lanes<S: Scalar, const L: usize, const RECORD: bool>(
    c: &Constants<S>,
    y: [&mut [S]; 3],
    inputs: [&[S]; 4],
    sums: &mut Sums,
) {
    let [y1, y2, y3] = y;
    let [p1, w, s0, s1] = inputs;
    let groups = y1
        .chunks_exact_mut(L)
        .zip(y2.chunks_exact_mut(L))
        .zip(y3.chunks_exact_mut(L))
        .zip(
            p1.chunks_exact(L)
                .zip(w.chunks_exact(L))
                .zip(s0.chunks_exact(L).zip(s1.chunks_exact(L))),
        );
    for (((y1, y2), y3), ((p1, w), (s0, s1))) in groups {
        let (Ok(y1), Ok(y2), Ok(y3), Ok(p1), Ok(w), Ok(s0), Ok(s1)) = (
            <&mut [S; L]>::try_from(y1),
            <&mut [S; L]>::try_from(y2),
            <&mut [S; L]>::try_from(y3),
            <&[S; L]>::try_from(p1),
            <&[S; L]>::try_from(w),
            <&[S; L]>::try_from(s0),
            <&[S; L]>::try_from(s1),
        ) else {
            continue; // chunks_exact yields exactly L elements
        };
        for j in 0..L {
            let p2 = y2[j] + w[j] * s0[j];
            let p3 = y3[j] - w[j] * s1[j];
            let d = combine_node(c, [&mut y1[j], &mut y2[j], &mut y3[j]], [p1[j], p2, p3]);
            if RECORD {
                let d = d.to_f32();
                sums.change[j % LANES] += d * d;
            }
        }
    }
}

/// [`combine_prox_lanes`] that also writes `ΔF` of every node into `delta`.
#[inline(always)]
fn combine_prox_lanes_with_delta<S: Scalar, const L: usize, const RECORD: bool>(
    c: &Constants<S>,
    y: [&mut [S]; 3],
    inputs: [&[S]; 4],
    delta: &mut [S],
    sums: &mut Sums,
) {
    let [y1, y2, y3] = y;
    let [p1, w, s0, s1] = inputs;
    let groups = y1
        .chunks_exact_mut(L)
        .zip(y2.chunks_exact_mut(L))
        .zip(y3.chunks_exact_mut(L))
        .zip(
            p1.chunks_exact(L)
                .zip(w.chunks_exact(L))
                .zip(s0.chunks_exact(L).zip(s1.chunks_exact(L))),
        )
        .zip(delta.chunks_exact_mut(L));
    for ((((y1, y2), y3), ((p1, w), (s0, s1))), delta) in groups {
        let (Ok(y1), Ok(y2), Ok(y3), Ok(p1), Ok(w), Ok(s0), Ok(s1), Ok(delta)) = (
            <&mut [S; L]>::try_from(y1),
            <&mut [S; L]>::try_from(y2),
            <&mut [S; L]>::try_from(y3),
            <&[S; L]>::try_from(p1),
            <&[S; L]>::try_from(w),
            <&[S; L]>::try_from(s0),
            <&[S; L]>::try_from(s1),
            <&mut [S; L]>::try_from(delta),
        ) else {
            continue; // chunks_exact yields exactly L elements
        };
        for j in 0..L {
            let p2 = y2[j] + w[j] * s0[j];
            let p3 = y3[j] - w[j] * s1[j];
            let d = combine_node(c, [&mut y1[j], &mut y2[j], &mut y3[j]], [p1[j], p2, p3]);
            delta[j] = d;
            if RECORD {
                let d = d.to_f32();
                sums.change[j % LANES] += d * d;
            }
        }
    }
}

/// The combination of one component (all horizontal or all vertical duals of a row).
#[inline(always)]
fn combine_component<S: Scalar, const RECORD: bool, const CHECK: bool>(
    c: &Constants<S>,
    y: [&mut [S]; 3],
    p: [&[S]; 3],
    delta: &mut [S],
    sums: &mut Sums,
) {
    let [y1, y2, y3] = y;
    let [p1, p2, p3] = p;
    let n = y1.len();
    let full = n - n % LANES;
    // One row each, all the same length (the checked splits never fail; `delta` is
    // only written when `CHECK`).
    let (y1, y1r) = y1.split_at_mut(full);
    let (Some((y2, y2r)), Some((y3, y3r)), Some((p1, p1r)), Some((p2, p2r)), Some((p3, p3r))) = (
        y2.split_at_mut_checked(full),
        y3.split_at_mut_checked(full),
        p1.split_at_checked(full),
        p2.split_at_checked(full),
        p3.split_at_checked(full),
    ) else {
        return;
    };
    if CHECK {
        let Some((d, dr)) = delta
            .get_mut(..n)
            .and_then(|d| d.split_at_mut_checked(full))
        else {
            return;
        };
        combine_lanes_with_delta::<S, LANES, RECORD>(c, [y1, y2, y3], [p1, p2, p3], d, sums);
        combine_lanes_with_delta::<S, 1, RECORD>(c, [y1r, y2r, y3r], [p1r, p2r, p3r], dr, sums);
    } else {
        combine_lanes::<S, LANES, RECORD>(c, [y1, y2, y3], [p1, p2, p3], sums);
        combine_lanes::<S, 1, RECORD>(c, [y1r, y2r, y3r], [p1r, p2r, p3r], sums);
    }
}

/// `½a + ¼(b + c)`: the PPXA average of the three copies (weights ω).
#[inline(always)]
fn average<S: Scalar>(c: &Constants<S>, a: S, b: S, d: S) -> S {
    a * c.half + (b + d) * c.quarter
}

/// Per-lane sums of `‖ΔF‖²` (the residual history).
struct Sums {
    change: [f32; LANES],
}

/// Fixed-size groups of `L` nodes (`L` divides the slice length): every buffer is seen as
/// `[S; L]` so the `f32` loop has no bounds checks and vectorises.
#[inline(always)]
fn combine_lanes<S: Scalar, const L: usize, const RECORD: bool>(
    c: &Constants<S>,
    y: [&mut [S]; 3],
    p: [&[S]; 3],
    sums: &mut Sums,
) {
    let [y1, y2, y3] = y;
    let [p1, p2, p3] = p;
    let groups = y1
        .chunks_exact_mut(L)
        .zip(y2.chunks_exact_mut(L))
        .zip(y3.chunks_exact_mut(L))
        .zip(
            p1.chunks_exact(L)
                .zip(p2.chunks_exact(L))
                .zip(p3.chunks_exact(L)),
        );
    for (((y1, y2), y3), ((p1, p2), p3)) in groups {
        let (Ok(y1), Ok(y2), Ok(y3), Ok(p1), Ok(p2), Ok(p3)) = (
            <&mut [S; L]>::try_from(y1),
            <&mut [S; L]>::try_from(y2),
            <&mut [S; L]>::try_from(y3),
            <&[S; L]>::try_from(p1),
            <&[S; L]>::try_from(p2),
            <&[S; L]>::try_from(p3),
        ) else {
            continue; // chunks_exact yields exactly L elements
        };
        for j in 0..L {
            let d = combine_node(
                c,
                [&mut y1[j], &mut y2[j], &mut y3[j]],
                [p1[j], p2[j], p3[j]],
            );
            if RECORD {
                let d = d.to_f32();
                sums.change[j % LANES] += d * d;
            }
        }
    }
}

/// [`combine_lanes`] that also writes `ΔF` of every node into `delta` (a checking
/// iteration; a separate loop so the others stream one buffer less).
#[inline(always)]
fn combine_lanes_with_delta<S: Scalar, const L: usize, const RECORD: bool>(
    c: &Constants<S>,
    y: [&mut [S]; 3],
    p: [&[S]; 3],
    delta: &mut [S],
    sums: &mut Sums,
) {
    let [y1, y2, y3] = y;
    let [p1, p2, p3] = p;
    let groups = y1
        .chunks_exact_mut(L)
        .zip(y2.chunks_exact_mut(L))
        .zip(y3.chunks_exact_mut(L))
        .zip(
            p1.chunks_exact(L)
                .zip(p2.chunks_exact(L))
                .zip(p3.chunks_exact(L)),
        )
        .zip(delta.chunks_exact_mut(L));
    for ((((y1, y2), y3), ((p1, p2), p3)), delta) in groups {
        let (Ok(y1), Ok(y2), Ok(y3), Ok(p1), Ok(p2), Ok(p3), Ok(delta)) = (
            <&mut [S; L]>::try_from(y1),
            <&mut [S; L]>::try_from(y2),
            <&mut [S; L]>::try_from(y3),
            <&[S; L]>::try_from(p1),
            <&[S; L]>::try_from(p2),
            <&[S; L]>::try_from(p3),
            <&mut [S; L]>::try_from(delta),
        ) else {
            continue; // chunks_exact yields exactly L elements
        };
        for j in 0..L {
            let d = combine_node(
                c,
                [&mut y1[j], &mut y2[j], &mut y3[j]],
                [p1[j], p2[j], p3[j]],
            );
            delta[j] = d;
            if RECORD {
                let d = d.to_f32();
                sums.change[j % LANES] += d * d;
            }
        }
    }
}

/// One node's PPXA combination: `y_k += ρ(2p − F − p_k)`; returns `ΔF = ρ(p − F)`.
#[inline(always)]
fn combine_node<S: Scalar>(c: &Constants<S>, y: [&mut S; 3], p: [S; 3]) -> S {
    let [y1, y2, y3] = y;
    let [p1, p2, p3] = p;
    let p = average(c, p1, p2, p3);
    let f0 = average(c, *y1, *y2, *y3);
    let t = c.two * p - f0;
    *y1 += c.rho * (t - p1);
    *y2 += c.rho * (t - p2);
    *y3 += c.rho * (t - p3);
    c.rho * (p - f0)
}

/// Projects `L` dual pairs onto their constraint sets in place; `bound` per pair (see
/// `Graph::bound`): the radius for ℓ1, its inverse for ℓ2.
#[inline(always)]
fn project_lanes<S: Scalar, const L: usize>(
    h: &mut [S; L],
    v: &mut [S; L],
    bound: &[S; L],
    norm: TvNorm,
) {
    match norm {
        TvNorm::L1 => {
            for ((h, v), &r) in h.iter_mut().zip(v.iter_mut()).zip(bound) {
                *h = h.clamp(-r, r);
                *v = v.clamp(-r, r);
            }
        }
        TvNorm::L2 => {
            // Squared norms in units of the radius (so Q16.16 squares stay in range).
            let mut n2 = [S::ZERO; L];
            for (((n2, &h), &v), &inv) in n2.iter_mut().zip(h.iter()).zip(v.iter()).zip(bound) {
                let (uh, uv) = (h * inv, v * inv);
                *n2 = uh * uh + uv * uv;
            }
            // A branch-free fold (not a short-circuiting `all`), so the test vectorises.
            let outside = n2.iter().fold(false, |any, &n| any | (n > S::ONE));
            if !outside {
                return;
            }
            // `1/√n2` by Newton's method in f32 (`inverse_sqrt`), not a square root and
            // two divisions: plain arithmetic, so the 16 lanes vectorise (libm's `sqrtf`
            // is a scalar instruction), and Q16.16 is spared two 64-bit divisions.
            for ((h, v), &n2) in h.iter_mut().zip(v.iter_mut()).zip(n2.iter()) {
                let outside = n2 > S::ONE;
                let scale = S::from_f32(inverse_sqrt(n2.to_f32()));
                let scale = if outside { scale } else { S::ONE };
                *h *= scale;
                *v *= scale;
            }
        }
    }
}

/// `1/√x` for `x ≥ 1` (smaller `x` are taken as 1) to within a few ulp of f32: the
/// classic bit-level first guess (≈ 3.4 % off) and three Newton steps, each squaring the
/// relative error (3e-2 → 2e-3 → 5e-6 → f32 rounding).
#[inline(always)]
fn inverse_sqrt(x: f32) -> f32 {
    let x = if x > 1.0 { x } else { 1.0 };
    let mut y = f32::from_bits(0x5f37_5a86u32.wrapping_sub(x.to_bits() >> 1));
    for _ in 0..3 {
        y *= 1.5 - 0.5 * x * y * y;
    }
    y
}

/// Row `y` of `WᵀF` into `out` (`width` long):
/// `(WᵀF)_i = w_h(i−1) F_h(i−1) + w_v(i−W) F_v(i−W) − w_h(i) F_h(i) − w_v(i) F_v(i)`.
fn divergence_row<S: Scalar>(
    y: usize,
    width: usize,
    wh: &[S],
    wv: &[S],
    fh: &[S],
    fv: &[S],
    out: &mut [S],
) {
    let r = y * width..(y + 1) * width;
    let above = (y > 0).then(|| {
        let p = (y - 1) * width..y * width;
        (part(wv, p.clone()), part(fv, p))
    });
    divergence_of_row(
        [part(wh, r.clone()), part(wv, r.clone())],
        [part(fh, r.clone()), part(fv, r)],
        above,
        out,
    );
}

/// [`divergence_row`] from the row's own weights and flows `[h, v]` and the row above's
/// vertical weights and flows (`None` on the first row).
#[inline(always)]
fn divergence_of_row<S: Scalar>(
    weights: [&[S]; 2],
    flows: [&[S]; 2],
    above: Option<(&[S], &[S])>,
    out: &mut [S],
) {
    let [wh, wv] = weights;
    let [fh, fv] = flows;
    let own = |a: S, b: S, c: S, d: S| -(a * c + b * d);
    // The node's own edges and its left neighbour's in one pass (every node but the
    // first has one), then the upper neighbour's: the order of the sums of
    // `((own) + left) + up`.
    if let (Some(o), Some(&a), Some(&b), Some(&c), Some(&d)) = (
        out.first_mut(),
        wh.first(),
        wv.first(),
        fh.first(),
        fv.first(),
    ) {
        *o = own(a, b, c, d);
    }
    let after_first = 1..wh.len();
    let nodes = part(wh, after_first.clone())
        .iter()
        .zip(part(wv, after_first.clone()))
        .zip(
            part(fh, after_first.clone())
                .iter()
                .zip(part(fv, after_first)),
        );
    for ((o, ((&a, &b), (&c, &d))), (&wl, &fl)) in
        out.iter_mut().skip(1).zip(nodes).zip(wh.iter().zip(fh))
    {
        *o = own(a, b, c, d) + wl * fl;
    }
    if let Some((wa, fa)) = above {
        for ((o, &b), &d) in out.iter_mut().zip(wa).zip(fa) {
            *o += b * d;
        }
    }
}

/// Row `y` of the node residuals `s = σ ⊙ (Wᵀy − τ)`, each node in the quadratic part
/// of its own colour: its own edges from `own`, its left and upper neighbours' edges from
/// `other` (see [`Graph`]). `copies` = `[own_h, own_v, other_h, other_v]`.
#[allow(clippy::too_many_arguments)]
fn residual_row<S: Scalar>(
    y: usize,
    width: usize,
    wh: &[S],
    wv: &[S],
    tau: &[S],
    sig: &[S],
    copies: [&[S]; 4],
    out: &mut [S],
) {
    let [own_h, own_v, other_h, other_v] = copies;
    let r = y * width..(y + 1) * width;
    let (whr, wvr) = (part(wh, r.clone()), part(wv, r.clone()));
    let (oh, ov) = (part(own_h, r.clone()), part(own_v, r.clone()));
    let own = |a: S, b: S, c: S, d: S| -(a * c + b * d);
    // Two passes, in the order of the sums `((own) + left) + up`: the node's own edges
    // and its left neighbour's (every node but the first has one), then its upper
    // neighbour's with `σ(· − τ)`.
    if let (Some(o), Some(&a), Some(&b), Some(&c), Some(&d)) = (
        out.first_mut(),
        whr.first(),
        wvr.first(),
        oh.first(),
        ov.first(),
    ) {
        *o = own(a, b, c, d);
    }
    let after_first = 1..width;
    let nodes = part(whr, after_first.clone())
        .iter()
        .zip(part(wvr, after_first.clone()))
        .zip(
            part(oh, after_first.clone())
                .iter()
                .zip(part(ov, after_first)),
        );
    let left = whr.iter().zip(part(other_h, r.clone()));
    for ((o, ((&a, &b), (&c, &d))), (&wl, &fl)) in out.iter_mut().skip(1).zip(nodes).zip(left) {
        *o = own(a, b, c, d) + wl * fl;
    }
    let targets = part(tau, r.clone()).iter().zip(part(sig, r));
    if y > 0 {
        let p = (y - 1) * width..y * width;
        let up = part(wv, p.clone()).iter().zip(part(other_v, p));
        for ((s, (&b, &d)), (&t, &g)) in out.iter_mut().zip(up).zip(targets) {
            *s = g * ((*s + b * d) - t);
        }
    } else {
        for (s, (&t, &g)) in out.iter_mut().zip(targets) {
            *s = g * (*s - t);
        }
    }
}

/// One row of the proximity operators of both quadratic parts, `p = y − W∇s` with `s`
/// zero off the part's colour: on an edge of node `i`, the part of `i`'s colour sees
/// `s(i)` only and the other part the residual of the edge's far end only, so
/// `p_own = own + w s(i)` and `p_other = other − w s(far end)`. `s` is this row's
/// residuals, `below` the next row's (`None` on the last row, which has no vertical
/// edges); the last column has no horizontal edge. All slices are one row, in the
/// order `[own_h, own_v, other_h, other_v]`.
fn prox_row<S: Scalar>(
    weights: [&[S]; 2],
    copies: [&[S]; 4],
    s: &[S],
    below: Option<&[S]>,
    out: [&mut [S]; 4],
) {
    let [whr, wvr] = weights;
    let [own_h, own_v, other_h, other_v] = copies;
    let [p_own_h, p_own_v, p_other_h, p_other_v] = out;
    for (((p, &y), &w), &s0) in p_own_h.iter_mut().zip(own_h).zip(whr).zip(s) {
        *p = y + w * s0;
    }
    for (((p, &y), &w), &s1) in p_other_h
        .iter_mut()
        .zip(other_h)
        .zip(whr)
        .zip(s.iter().skip(1))
    {
        *p = y - w * s1;
    }
    if let (Some(p), Some(&y)) = (p_other_h.last_mut(), other_h.last()) {
        *p = y;
    }
    match below {
        Some(below) => {
            for (((p, &y), &w), &s0) in p_own_v.iter_mut().zip(own_v).zip(wvr).zip(s) {
                *p = y + w * s0;
            }
            for (((p, &y), &w), &s1) in p_other_v.iter_mut().zip(other_v).zip(wvr).zip(below) {
                *p = y - w * s1;
            }
        }
        None => {
            copy_row(p_own_v, own_v);
            copy_row(p_other_v, other_v);
        }
    }
}

/// `out = WᵀF` over the whole graph (the row kernel, row after row).
/// `buf[range]`, empty where the range is outside `buf`. The solver's rows always lie
/// inside its buffers (all `width × height`); the checked form keeps panics out.
#[inline(always)]
fn part<S>(buf: &[S], range: Range<usize>) -> &[S] {
    buf.get(range).unwrap_or_default()
}

/// [`part`], mutable.
#[inline(always)]
fn part_mut<S>(buf: &mut [S], range: Range<usize>) -> &mut [S] {
    buf.get_mut(range).unwrap_or_default()
}

/// `dst = src` for rows of equal length (a shorter `src` leaves `dst` alone).
#[inline(always)]
fn copy_row<S: Copy>(dst: &mut [S], src: &[S]) {
    if let Some(src) = src.get(..dst.len()) {
        dst.copy_from_slice(src);
    }
}

#[cfg(test)]
fn divergence<S: Scalar>(width: usize, wh: &[S], wv: &[S], fh: &[S], fv: &[S], out: &mut [S]) {
    for (y, row) in out.chunks_exact_mut(width).enumerate() {
        divergence_row(y, width, wh, wv, fh, fv, row);
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::scalar::Q16;
    use std::vec;
    use std::vec::Vec;

    /// A deterministic pseudo-random sequence in [0, 1).
    fn lcg(seed: &mut u64) -> f32 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*seed >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Both quadratic parts' proximity operators over the whole graph through the row
    /// kernels of the sweep: copies `y2` (black part) and `y3` (white part) in, `(p2, p3)`
    /// out, each as `(h, v)`; the kernels' own/other layout is formed and undone here.
    #[allow(clippy::type_complexity)]
    fn prox_parts(
        w: usize,
        wh: &[f32],
        wv: &[f32],
        tau: &[f32],
        sig: &[f32],
        y2: (&[f32], &[f32]),
        y3: (&[f32], &[f32]),
    ) -> ((Vec<f32>, Vec<f32>), (Vec<f32>, Vec<f32>)) {
        let n = wh.len();
        let black = |i: usize| (i % w + i / w) % 2 == 0;
        let pick = |i: usize, own: bool, a: &[f32], b: &[f32]| {
            if black(i) == own {
                a[i]
            } else {
                b[i]
            }
        };
        let own_h: Vec<f32> = (0..n).map(|i| pick(i, true, y2.0, y3.0)).collect();
        let own_v: Vec<f32> = (0..n).map(|i| pick(i, true, y2.1, y3.1)).collect();
        let other_h: Vec<f32> = (0..n).map(|i| pick(i, false, y2.0, y3.0)).collect();
        let other_v: Vec<f32> = (0..n).map(|i| pick(i, false, y2.1, y3.1)).collect();
        let copies = [&own_h[..], &own_v[..], &other_h[..], &other_v[..]];
        let mut s = vec![0.0f32; n];
        for (y, row) in s.chunks_exact_mut(w).enumerate() {
            residual_row(y, w, wh, wv, tau, sig, copies, row);
        }
        let mut out = [vec![0.0f32; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let rows = n / w;
        for y in 0..rows {
            let r = y * w..(y + 1) * w;
            let below = (y + 1 < rows).then(|| &s[(y + 1) * w..(y + 2) * w]);
            let [a, b, c, d] = &mut out;
            prox_row(
                [&wh[r.clone()], &wv[r.clone()]],
                copies.map(|c| &c[r.clone()]),
                &s[r.clone()],
                below,
                [
                    &mut a[r.clone()],
                    &mut b[r.clone()],
                    &mut c[r.clone()],
                    &mut d[r.clone()],
                ],
            );
        }
        let [poh, pov, pxh, pxv] = &out;
        let part = |own: bool, o: &[f32], x: &[f32]| -> Vec<f32> {
            (0..n).map(|i| pick(i, own, o, x)).collect()
        };
        (
            (part(true, poh, pxh), part(true, pov, pxv)),
            (part(false, poh, pxh), part(false, pov, pxv)),
        )
    }

    #[test]
    fn quadratic_prox_solves_its_optimality_condition() {
        // prox_{γg}(y) = p  ⇔  p − y + γ ∇g(p) = 0 with g = Σ_{colour} κ/2 ((Wᵀp)_i − τ_i)²,
        // for the black part (copy y2) and the white part (copy y3) at once.
        let (w, h) = (5usize, 4usize);
        let n = w * h;
        let mut seed = 7;
        let mut r = |s: f32| (lcg(&mut seed) - 0.5) * s;
        let mut wh: Vec<f32> = (0..n).map(|_| r(1.0).abs() + 0.1).collect();
        let mut wv: Vec<f32> = (0..n).map(|_| r(1.0).abs() + 0.1).collect();
        for y in 0..h {
            wh[y * w + w - 1] = 0.0;
        }
        for x in 0..w {
            wv[(h - 1) * w + x] = 0.0;
        }
        let tau: Vec<f32> = (0..n).map(|_| r(4.0)).collect();
        let kappa: Vec<f32> = (0..n).map(|_| r(2.0).abs() + 0.2).collect();
        let gamma = 0.7f32;
        let mut sig = vec![0.0f32; n];
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let mut c2 = wh[i] * wh[i] + wv[i] * wv[i];
                if x > 0 {
                    c2 += wh[i - 1] * wh[i - 1];
                }
                if y > 0 {
                    c2 += wv[i - w] * wv[i - w];
                }
                sig[i] = gamma * kappa[i] / (1.0 + gamma * kappa[i] * c2);
            }
        }
        let copies: Vec<Vec<f32>> = (0..4).map(|_| (0..n).map(|_| r(2.0)).collect()).collect();
        let (y2, y3) = (
            (&copies[0][..], &copies[1][..]),
            (&copies[2][..], &copies[3][..]),
        );
        let (p2, p3) = prox_parts(w, &wh, &wv, &tau, &sig, y2, y3);
        for (colour, (yh, yv), (ph, pv)) in [(0, y2, p2), (1, y3, p3)] {
            // ∇g(p) = W∇(mask κ (Wᵀp − τ)) in the sign convention of `divergence`.
            let mut u = vec![0.0; n];
            divergence(w, &wh, &wv, &ph, &pv, &mut u);
            let r_node: Vec<f32> = (0..n)
                .map(|i| {
                    let (x, y) = (i % w, i / w);
                    if (x + y) % 2 == colour {
                        kappa[i] * (u[i] - tau[i])
                    } else {
                        0.0
                    }
                })
                .collect();
            for i in 0..n {
                let (x, y) = (i % w, i / w);
                let gh = if x + 1 < w {
                    wh[i] * (r_node[i + 1] - r_node[i])
                } else {
                    0.0
                };
                let gv = if y + 1 < h {
                    wv[i] * (r_node[i + w] - r_node[i])
                } else {
                    0.0
                };
                assert!(
                    (ph[i] - yh[i] + gamma * gh).abs() < 1e-4,
                    "colour {colour} h {i}"
                );
                assert!(
                    (pv[i] - yv[i] + gamma * gv).abs() < 1e-4,
                    "colour {colour} v {i}"
                );
            }
        }
    }

    /// A region solved with the optimal dual of the whole map on its border flows (and as
    /// its start) returns the whole map's solution on its core: the outer sweeps' fixed
    /// point is the untiled optimum.
    #[test]
    fn a_region_with_the_optimal_border_flows_reproduces_the_whole_solution() {
        for norm in [TvNorm::L2, TvNorm::L1] {
            region_with_optimal_border_flows(norm);
        }
    }

    fn region_with_optimal_border_flows(norm: TvNorm) {
        let (w, h) = (24usize, 20usize);
        let mut state = 12345u32;
        let mut rand = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        let d: Vec<f32> = (0..w * h)
            .map(|i| if i % w < 11 { 1.0 } else { -0.5 } + 0.6 * rand())
            .collect();
        let c: Vec<f32> = (0..w * h).map(|_| rand()).collect();
        let wh: Vec<f32> = (0..w * h).map(|_| 0.2 + rand()).collect();
        let wv: Vec<f32> = (0..w * h).map(|_| 0.2 + rand()).collect();
        let guide: Guide<'_, u8> = Guide::Weights {
            horizontal: &wh,
            vertical: &wv,
        };
        let maps = Maps::new(w, h, &d, &c).unwrap();
        let params = TvParams {
            lambda: 0.5,
            norm,
            max_iterations: 8_000,
            tolerance: 0.0,
            ..TvParams::default()
        };
        let full = Rect {
            x: 0,
            y: 0,
            width: w,
            height: h,
        };
        let mut whole = vec![0.0f32; w * h];
        let mut dual = vec![0.0f32; 2 * w * h];
        let mut scratch = vec![0.0f32; scratch_len_for(w, h)];
        let out = SolveOutput {
            disparity: &mut whole,
            stride: w,
            history: &mut [],
            dual: Some(&mut dual),
        };
        solve(&maps, &guide, &params, full, full, out, &mut scratch).unwrap();

        let region = Rect {
            x: 5,
            y: 4,
            width: 12,
            height: 10,
        };
        let core = Rect {
            x: 8,
            y: 7,
            width: 6,
            height: 4,
        };
        let solve_region = |maps: &Maps<'_>, scratch: &mut [f32]| {
            let mut part = vec![0.0f32; core.pixels()];
            let out = SolveOutput {
                disparity: &mut part,
                stride: core.width,
                history: &mut [],
                dual: None,
            };
            solve(maps, &guide, &params, region, core, out, scratch).unwrap();
            part
        };
        let error = |part: &[f32]| {
            let mut worst = 0.0f32;
            for y in 0..core.height {
                for x in 0..core.width {
                    let g = (core.y + y) * w + core.x + x;
                    worst = worst.max((part[y * core.width + x] - whole[g]).abs());
                }
            }
            worst
        };
        let free = error(&solve_region(&maps, &mut scratch));
        assert!(maps.with_dual(&dual[1..]).is_err());
        let with = maps.with_dual(&dual).unwrap();
        let fixed = error(&solve_region(&with, &mut scratch));
        assert!(
            fixed < 2e-4,
            "{norm:?}: with the optimal border flows: {fixed} px off"
        );
        assert!(
            free > 10.0 * fixed,
            "{norm:?}: free border {free} px vs fixed {fixed} px"
        );
    }

    /// Started from the optimal dual, the PPXA copies start at their fixed point
    /// (`consistent_copies`), so the solve stops at its first check, still at the optimum
    /// (with every copy equal to the dual, PPXA first moved them: from HCI cotton's
    /// converged dual it ran 24 of the cold start's 28 iterations).
    #[test]
    fn a_solve_started_at_the_optimum_stops_at_its_first_check() {
        for norm in [TvNorm::L2, TvNorm::L1] {
            let (w, h) = (24usize, 20usize);
            let mut seed = 99;
            let d: Vec<f32> = (0..w * h)
                .map(|i| if i % w < 11 { 1.0 } else { -0.5 } + 0.6 * lcg(&mut seed))
                .collect();
            let c: Vec<f32> = (0..w * h).map(|_| lcg(&mut seed)).collect();
            let wh: Vec<f32> = (0..w * h).map(|_| 0.2 + lcg(&mut seed)).collect();
            let wv: Vec<f32> = (0..w * h).map(|_| 0.2 + lcg(&mut seed)).collect();
            let guide: Guide<'_, u8> = Guide::Weights {
                horizontal: &wh,
                vertical: &wv,
            };
            let maps = Maps::new(w, h, &d, &c).unwrap();
            let full = Rect {
                x: 0,
                y: 0,
                width: w,
                height: h,
            };
            let mut scratch = vec![0.0f32; scratch_len_for(w, h)];
            let mut solve_with = |maps: &Maps<'_>, params: &TvParams, dual: Option<&mut [f32]>| {
                let mut x = vec![0.0f32; w * h];
                let out = SolveOutput {
                    disparity: &mut x,
                    stride: w,
                    history: &mut [],
                    dual,
                };
                let report = solve(maps, &guide, params, full, full, out, &mut scratch).unwrap();
                (x, report)
            };
            let converged = TvParams {
                norm,
                max_iterations: 8_000,
                tolerance: 0.0,
                ..TvParams::default()
            };
            let mut dual = vec![0.0f32; 2 * w * h];
            let (optimum, _) = solve_with(&maps, &converged, Some(&mut dual));
            let default = TvParams {
                norm,
                ..TvParams::default()
            };
            let (_, cold) = solve_with(&maps, &default, None);
            let warm_maps = maps.with_dual(&dual).unwrap();
            let (warm, report) = solve_with(&warm_maps, &default, None);
            assert!(
                report.converged && report.iterations == FIRST_CHECK,
                "{norm:?}: {report:?}"
            );
            assert!(cold.iterations > FIRST_CHECK, "{norm:?}: cold {cold:?}");
            let off = warm
                .iter()
                .zip(&optimum)
                .fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
            // Up to the first check, each iteration moving the map by less than the
            // tolerance (RMS).
            let bound = report.iterations as f32 * default.tolerance;
            assert!(off < bound, "{norm:?}: {off} px from the optimum");
        }
    }

    #[test]
    fn edge_weights_by_blocks_of_columns_equal_those_node_by_node() {
        // A 150 × 9 image (more than two blocks of columns, a partial last one) with
        // regions inside it, at its right and bottom edges and across all of it, for
        // every layout of a view (1, 3, 4 samples).
        let (mw, mh) = (150usize, 9usize);
        let d = vec![0.0f32; mw * mh];
        let c = vec![1.0f32; mw * mh];
        let maps = Maps::new(mw, mh, &d, &c).unwrap();
        let params = TvParams::default();
        let regions = [
            Rect {
                x: 3,
                y: 2,
                width: 140,
                height: 5,
            },
            Rect {
                x: 10,
                y: 4,
                width: 140,
                height: 5,
            },
            Rect {
                x: 0,
                y: 0,
                width: mw,
                height: mh,
            },
            Rect {
                x: 149,
                y: 0,
                width: 1,
                height: 3,
            },
        ];
        let mut seed = 7u64;
        for ch in [1usize, 3, 4] {
            // Small steps (weights between the floor and 1) and a few large ones.
            let data: Vec<u8> = (0..mw * mh * ch)
                .map(|i| {
                    let jump = if lcg(&mut seed) < 0.1 { 100.0 } else { 0.0 };
                    ((i / ch % mw) as f32 * 0.5 + lcg(&mut seed) * 8.0 + jump) as u8
                })
                .collect();
            let view = View::new(&data, mw, mh, ch, mw * ch).unwrap();
            let guide = Guide::View(view);
            for region in regions {
                let n = region.width * region.height;
                let mut a = vec![0.0f32; scratch_len_for(region.width, region.height)];
                let mut b = a.clone();
                let mut by_view = Graph::split(&mut a, region.width, region.height);
                by_view.weights_from_view(&maps, &view, &params, region);
                let mut by_node = Graph::split(&mut b, region.width, region.height);
                by_node.weights_by_node(&maps, &guide, &params, region);
                assert_eq!(
                    by_view.wh[..n],
                    by_node.wh[..n],
                    "{ch} channels, {region:?}"
                );
                assert_eq!(
                    by_view.wv[..n],
                    by_node.wv[..n],
                    "{ch} channels, {region:?}"
                );
                // The large regions see both kinds of steps.
                if n > 100 {
                    let (wh, wv) = (&by_view.wh[..n], &by_view.wv[..n]);
                    let between = |w: &f32| *w > params.edge_floor && *w < 1.0;
                    assert!(wh.iter().chain(wv).any(between), "{ch} ch., {region:?}");
                    let floor = |w: &f32| *w == params.edge_floor;
                    assert!(wh.iter().chain(wv).any(floor), "{ch} ch., {region:?}");
                }
            }
        }
    }

    #[test]
    fn projections_land_in_the_constraint_sets() {
        let (mut h, mut v) = ([3.0f32, 0.3], [-0.5f32, 0.4]);
        project_lanes(&mut h, &mut v, &[1.0; 2], TvNorm::L1);
        assert_eq!((h, v), ([1.0, 0.3], [-0.5, 0.4]));
        let (mut h, mut v) = ([3.0f32, 0.3], [4.0f32, 0.4]);
        project_lanes(&mut h, &mut v, &[1.0; 2], TvNorm::L2);
        assert!((h[0] - 0.6).abs() < 1e-6 && (v[0] - 0.8).abs() < 1e-6);
        assert_eq!((h[1], v[1]), (0.3, 0.4));
        let q = Q16::from_f32;
        let (mut h, mut v) = ([q(96.0)], [q(128.0)]);
        project_lanes(&mut h, &mut v, &[q(1.0 / 32.0)], TvNorm::L2);
        assert!((h[0].to_f32() - 19.2).abs() < 1e-3 && (v[0].to_f32() - 25.6).abs() < 1e-3);
    }

    #[test]
    fn bad_buffers_are_errors_not_panics() {
        let (w, h) = (8usize, 8usize);
        let d = vec![0.5f32; w * h];
        let c = vec![1.0f32; w * h];
        let maps = Maps::new(w, h, &d, &c).unwrap();
        let ones = vec![1.0f32; w * h];
        let guide: Guide<'_, u8> = Guide::Weights {
            horizontal: &ones,
            vertical: &ones,
        };
        let rect = Rect {
            x: 0,
            y: 0,
            width: w,
            height: h,
        };
        let params = TvParams::default();
        let mut out = vec![0.0f32; w * h];
        let mut hist = vec![0.0f32; 4];
        let mut small = vec![0.0f32; 10];
        let res = solve(
            &maps,
            &guide,
            &params,
            rect,
            rect,
            SolveOutput {
                disparity: &mut out,
                stride: w,
                history: &mut hist,
                dual: None,
            },
            &mut small,
        );
        assert!(matches!(res, Err(Error::ScratchTooSmall { .. })));
        let mut scratch = vec![0.0f32; scratch_len_for(w, h)];
        let outside = Rect { x: 4, ..rect };
        let res = solve(
            &maps,
            &guide,
            &params,
            outside,
            outside,
            SolveOutput {
                disparity: &mut out,
                stride: w,
                history: &mut hist,
                dual: None,
            },
            &mut scratch,
        );
        assert!(matches!(res, Err(Error::InvalidParameter { .. })));
        // A constant map is its own refinement.
        let report = solve(
            &maps,
            &guide,
            &params,
            rect,
            rect,
            SolveOutput {
                disparity: &mut out,
                stride: w,
                history: &mut hist,
                dual: None,
            },
            &mut scratch,
        )
        .unwrap();
        assert!(report.converged, "{report:?}");
        assert!(out.iter().all(|&v| (v - 0.5).abs() < 1e-3), "{out:?}");
        assert!(Maps::new(w, h, &d[1..], &c).is_err());
    }

    proptest::proptest! {
        #[test]
        fn solve_never_panics(
            w in 1usize..10, h in 1usize..10,
            rx in 0usize..12, ry in 0usize..12, rw in 0usize..12, rh in 0usize..12,
            cx in 0usize..12, cy in 0usize..12, cw in 0usize..12, ch in 0usize..12,
            stride in 0usize..12, out_len in 0usize..120, scratch_len in 0usize..2000,
            huge in proptest::bool::ANY,
        ) {
            let d: Vec<f32> = (0..w * h).map(|i| (i % 7) as f32 * 0.3 - 1.0).collect();
            let c: Vec<f32> = (0..w * h).map(|i| (i % 5) as f32 * 0.25).collect();
            let maps = Maps::new(w, h, &d, &c).unwrap();
            let ones = vec![0.5f32; w * h];
            let guide: Guide<'_, u8> = Guide::Weights { horizontal: &ones, vertical: &ones };
            let params = TvParams { max_iterations: 3, ..TvParams::default() };
            let region = Rect { x: rx, y: ry, width: if huge { usize::MAX } else { rw }, height: rh };
            let core = Rect { x: cx, y: cy, width: cw, height: ch };
            let mut out = vec![0.0f32; out_len];
            let mut hist = vec![0.0f32; 2];
            let mut scratch = vec![Q16::ZERO; scratch_len];
            let _ = solve(&maps, &guide, &params, region, core, SolveOutput {
                disparity: &mut out, stride, history: &mut hist, dual: None,
            }, &mut scratch);
        }
    }
}
