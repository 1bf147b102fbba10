//! Row kernels and checked row access shared by every part of the solver.

use core::ops::Range;

use crate::scalar::Scalar;

/// Row `y` of `WᵀF` into `out` (`width` long):
/// `(WᵀF)_i = w_h(i−1) F_h(i−1) + w_v(i−W) F_v(i−W) − w_h(i) F_h(i) − w_v(i) F_v(i)`.
pub(super) fn divergence_row<S: Scalar>(
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
pub(super) fn divergence_of_row<S: Scalar>(
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

/// `buf[range]`, empty where the range is outside `buf`. The solver's rows always lie
/// inside its buffers (all `width × height`); the checked form keeps panics out.
#[inline(always)]
pub(super) fn part<S>(buf: &[S], range: Range<usize>) -> &[S] {
    buf.get(range).unwrap_or_default()
}

/// [`part`], mutable.
#[inline(always)]
pub(super) fn part_mut<S>(buf: &mut [S], range: Range<usize>) -> &mut [S] {
    buf.get_mut(range).unwrap_or_default()
}

/// `dst = src` for rows of equal length (a shorter `src` leaves `dst` alone).
#[inline(always)]
pub(super) fn copy_row<S: Copy>(dst: &mut [S], src: &[S]) {
    if let Some(src) = src.get(..dst.len()) {
        dst.copy_from_slice(src);
    }
}
