//! The proximity operators of the two quadratic parts, row by row: node residuals and
//! proximity results.

use crate::scalar::Scalar;

use super::rows::{copy_row, part};

/// Row `y` of the node residuals `s = σ ⊙ (Wᵀy − τ)`, each node in the quadratic part
/// of its own colour: its own edges from `own`, its left and upper neighbours' edges from
/// `other` (see [`Graph`](super::graph::Graph)). `weights` = `[w_h, w_v]`, `nodes` =
/// `[τ, σ]` and `copies` = `[own_h, own_v, other_h, other_v]`, each of the whole graph.
pub(super) fn residual_row<S: Scalar>(
    y: usize,
    width: usize,
    weights: [&[S]; 2],
    nodes: [&[S]; 2],
    copies: [&[S]; 4],
    out: &mut [S],
) {
    let [wh, wv] = weights;
    let [tau, sig] = nodes;
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
pub(super) fn prox_row<S: Scalar>(
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
