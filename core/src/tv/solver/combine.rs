//! The PPXA combination step over a row, in fixed-size lanes, and the projection onto
//! the constraint sets.

use crate::scalar::Scalar;

use super::super::params::TvNorm;
use super::rows::copy_row;

/// Constants of the PPXA combination step.
pub(super) struct Constants<S> {
    pub(super) rho: S,
    pub(super) two: S,
    pub(super) half: S,
    pub(super) quarter: S,
    pub(super) norm: TvNorm,
}

/// Lanes of the blocks the combination step walks, so the `f32` loop vectorises
/// (fixed-length blocks, per-lane sums).
pub(super) const LANES: usize = 16;

/// The PPXA combination on one row: `p₁ = P_B(y₁)`, `p = ½p₁ + ¼p₂ + ¼p₃`,
/// `y_k += ρ(2p − F − p_k)`, `F += ρ(p − F)`; adds `‖ΔF‖²` (scaled units) to `sums`
/// when `RECORD` and writes `ΔF = ρ(p − F)` (both components) into `delta` when `CHECK`
/// (the update of `F = Σ ω_k y_k` is exactly that: `Σ ω_k (2p − F − p_k) = p − F`).
/// `p1` is room for `p₁` (two rows). The projection couples the two components of a
/// node, the rest does not: the horizontal and the vertical components are combined in
/// separate passes, each few enough streams to stay in registers.
#[inline(never)]
pub(super) fn combine<S: Scalar, const RECORD: bool, const CHECK: bool>(
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
    // The fourth input is not read (any row will do).
    let (h, v) = ([&*p1h, p2h, p3h, p3h], [&*p1v, p2v, p3v, p3v]);
    combine_component::<S, RECORD, CHECK, false>(c, [y1h, y2h, y3h], h, dh, sums);
    combine_component::<S, RECORD, CHECK, false>(c, [y1v, y2v, y3v], v, dv, sums);
}

/// The rows the proximity results of the two quadratic parts are formed from, node by
/// node as [`prox_row`](super::quadratic::prox_row) forms them: `p_own = own + w s` and
/// `p_other = other − w s_far`.
pub(super) struct QuadraticRows<'a, S> {
    /// `[w_h, w_v]` of the row.
    pub(super) weights: [&'a [S]; 2],
    /// `[s, s_right, s_below]`: the row's residuals, the same shifted by one node (the
    /// far ends of the horizontal edges; zero after the last node, whose edge is cut, so
    /// that `p_other = other − w·0 = other` there), and the next row's (the far ends of
    /// the vertical edges; not the last row).
    pub(super) residuals: [&'a [S]; 3],
}

/// [`combine`] with the proximity results of the two quadratic parts formed from
/// `quadratic` instead of read from rows of them (two passes and four streams less).
#[inline(never)]
pub(super) fn combine_with_prox<S: Scalar, const RECORD: bool, const CHECK: bool>(
    c: &Constants<S>,
    state: [&mut [S]; 6],
    quadratic: QuadraticRows<'_, S>,
    bound: &[S],
    p1: [&mut [S]; 2],
    delta: [&mut [S]; 2],
    sums: &mut Sums,
) {
    let [y1h, y1v, y2h, y2v, y3h, y3v] = state;
    let [wh, wv] = quadratic.weights;
    let [s, s_right, s_below] = quadratic.residuals;
    let [p1h, p1v] = p1;
    let [dh, dv] = delta;
    project_row(c, [&mut *p1h, &mut *p1v], [y1h, y1v], bound);
    let (h, v) = ([&*p1h, wh, s, s_right], [&*p1v, wv, s, s_below]);
    combine_component::<S, RECORD, CHECK, true>(c, [y1h, y2h, y3h], h, dh, sums);
    combine_component::<S, RECORD, CHECK, true>(c, [y1v, y2v, y3v], v, dv, sums);
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

/// `½a + ¼(b + c)`: the PPXA average of the three copies (weights ω).
#[inline(always)]
pub(super) fn average<S: Scalar>(c: &Constants<S>, a: S, b: S, d: S) -> S {
    a * c.half + (b + d) * c.quarter
}

/// Per-lane sums of `‖ΔF‖²` (the residual history).
pub(super) struct Sums {
    pub(super) change: [f32; LANES],
}

/// The combination of one component (all horizontal or all vertical duals of a row),
/// in groups of [`LANES`] nodes and then node by node. `inputs` = `[p₁, p₂, p₃, _]`: the
/// proximity results as rows (the last slice, one row, is not read); or when `FORMED`
/// `[p₁, w, s_own, s_far]`: the weights and the residuals they are formed from (see
/// [`combine_with_prox`]). `delta` is one row, written only when `CHECK`.
#[inline(always)]
fn combine_component<S: Scalar, const RECORD: bool, const CHECK: bool, const FORMED: bool>(
    c: &Constants<S>,
    y: [&mut [S]; 3],
    inputs: [&[S]; 4],
    delta: &mut [S],
    sums: &mut Sums,
) {
    let [y1, y2, y3] = y;
    let n = y1.len();
    let full = n - n % LANES;
    // One row each, all the same length (the checked splits never fail).
    let (y1, y1r) = y1.split_at_mut(full);
    let (Some((y2, y2r)), Some((y3, y3r)), Some((d, dr))) = (
        y2.split_at_mut_checked(full),
        y3.split_at_mut_checked(full),
        delta
            .get_mut(..n)
            .and_then(|d| d.split_at_mut_checked(full)),
    ) else {
        return;
    };
    let [Some((p1, p1r)), Some((a, ar)), Some((b, br)), Some((e, er))] =
        inputs.map(|row| row.split_at_checked(full))
    else {
        return;
    };
    let lanes = [y1, y2, y3];
    combine_lanes::<S, LANES, RECORD, CHECK, FORMED>(c, lanes, [p1, a, b, e], d, sums);
    let rest = [y1r, y2r, y3r];
    combine_lanes::<S, 1, RECORD, CHECK, FORMED>(c, rest, [p1r, ar, br, er], dr, sums);
}

/// [`combine_component`] on fixed-size groups of `L` nodes (`L` divides the slice
/// lengths): every buffer is seen as `[S; L]` so the `f32` loop has no bounds checks and
/// vectorises. The constants choose what the loop streams: a checking iteration writes
/// `delta`, the others never touch it, nor is the unread input of the rows read.
#[inline(always)]
fn combine_lanes<
    S: Scalar,
    const L: usize,
    const RECORD: bool,
    const CHECK: bool,
    const FORMED: bool,
>(
    c: &Constants<S>,
    y: [&mut [S]; 3],
    inputs: [&[S]; 4],
    delta: &mut [S],
    sums: &mut Sums,
) {
    let [y1, y2, y3] = y;
    let [p1, a, b, e] = inputs;
    let groups = y1
        .chunks_exact_mut(L)
        .zip(y2.chunks_exact_mut(L))
        .zip(y3.chunks_exact_mut(L))
        .zip(
            p1.chunks_exact(L)
                .zip(a.chunks_exact(L))
                .zip(b.chunks_exact(L).zip(e.chunks_exact(L))),
        )
        .zip(delta.chunks_exact_mut(L));
    for ((((y1, y2), y3), ((p1, a), (b, e))), delta) in groups {
        let (Ok(y1), Ok(y2), Ok(y3), Ok(p1), Ok(a), Ok(b), Ok(e), Ok(delta)) = (
            <&mut [S; L]>::try_from(y1),
            <&mut [S; L]>::try_from(y2),
            <&mut [S; L]>::try_from(y3),
            <&[S; L]>::try_from(p1),
            <&[S; L]>::try_from(a),
            <&[S; L]>::try_from(b),
            <&[S; L]>::try_from(e),
            <&mut [S; L]>::try_from(delta),
        ) else {
            continue; // chunks_exact yields exactly L elements
        };
        for j in 0..L {
            // `p_own = own + w s`, `p_other = other − w s_far`, or the rows' values.
            let (p2, p3) = if FORMED {
                (y2[j] + a[j] * b[j], y3[j] - a[j] * e[j])
            } else {
                (a[j], b[j])
            };
            let d = combine_node(c, [&mut y1[j], &mut y2[j], &mut y3[j]], [p1[j], p2, p3]);
            if CHECK {
                delta[j] = d;
            }
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
pub(super) fn project_lanes<S: Scalar, const L: usize>(
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
