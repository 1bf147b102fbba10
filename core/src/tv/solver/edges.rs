//! Edge weights of the pixel graph, from the centre view or given, and the flows an outer
//! sweep holds fixed on the edges that cross a region's border. Depth edges may follow
//! image edges, so a colour step between two pixels lowers the weight of their edge.

use crate::lightfield::{Sample, View};
use crate::scalar::Scalar;

use super::super::params::TvParams;
use super::graph::Graph;
use super::inputs::{Guide, Maps, Rect};

impl<S: Scalar> Graph<'_, S> {
    /// The edge weights node by node: given weights, or a previous sweep's dual (which
    /// fixes the pairs of the region's last column and row).
    pub(super) fn weights_by_node<P: Sample>(
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
    pub(super) fn weights_from_view<P: Sample>(
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
pub(super) fn fixed_pair(maps: &Maps<'_>, region: Rect, x: usize, y: usize) -> bool {
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
pub(super) fn external_flow<P: Sample>(
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

/// Pixels per block of columns of [`Graph::view_weights_by_block`] in the setup (`f32`
/// arrays on the stack).
pub(super) const STEP_BLOCK: usize = 64;

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

/// Weight of the edge between two pixels whose largest channel difference is `step`
/// (unit intensity): `max(floor, 1 / (1 + (step/σ)²))`, or 1 when `sigma` is zero.
#[inline]
fn edge_weight(step: f32, sigma: f32, floor: f32) -> f32 {
    if sigma <= 0.0 {
        return 1.0;
    }
    let r = step / sigma;
    let w = 1.0 / (1.0 + r * r);
    if w > floor {
        w
    } else {
        floor
    }
}

/// Largest absolute difference over the first `channels` samples of two pixels
/// (unit intensity).
#[inline]
fn colour_step<P: Sample>(a: &[P], b: &[P], channels: usize) -> f32 {
    let mut step = 0.0f32;
    for (pa, pb) in a.iter().zip(b).take(channels) {
        let d = libm::fabsf(pa.to_unit() - pb.to_unit());
        if d > step {
            step = d;
        }
    }
    step
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_fall_with_the_colour_step_down_to_the_floor() {
        assert_eq!(edge_weight(0.0, 0.05, 0.1), 1.0);
        assert!((edge_weight(0.05, 0.05, 0.1) - 0.5).abs() < 1e-6);
        assert_eq!(edge_weight(1.0, 0.05, 0.1), 0.1);
        assert_eq!(edge_weight(1.0, 0.0, 0.1), 1.0);
    }
}
