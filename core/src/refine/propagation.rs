//! Propagation: jump flooding of disparities between neighbours, each pixel keeping a
//! neighbour's disparity when its photometric cost is well below its own (see [the
//! module](super)).

use crate::scalar::Scalar;

use super::photo::{Photometric, GROUPS, STATS};
use super::state::{OwnCost, Planes, Region};
use super::{Measure, MEMORY};

/// The propagation rounds of a band, one per jump of `jumps`: each pixel tries the
/// disparities of its four neighbours at the jump and keeps the one the views agree on
/// best (robust cost of the pixel alone), which pulls wrong regions to their
/// surroundings' disparity. `settle`: the rows the iterations reach afterwards
/// (`iterations · radius`).
///
/// Each pixel's [`OwnCost`] and the last candidates it rejected live in its
/// `planes.memory` values; they are read and written only for that pixel, so the order
/// of pixels does not matter.
/// A round only visits the rows that the later rounds and the iterations can still
/// carry to the band (it reads its neighbours up to `jump` rows further, which the
/// round before visited): the rows outside would not change the result.
/// The cost of a pixel at its own disparity is only needed once a neighbour offers
/// another one. It comes from the statistics, not from `Photometric::cost`: the
/// first iteration needs them at that disparity unless a candidate wins (HCI
/// backgammon: 154 k of its 271 k measurements), and they cost about 1.5 times a cost.
/// Always, whatever row the pixel is in, so that every band decides alike.
/// `candidate` (the region's rows of a map, as `current`): in the first round each
/// pixel also tries its own value there (the plane sweep's per-pixel candidate), by the
/// rule of a neighbour's offer.
/// The rejected candidates (`MAX` for none) are kept across rounds: a round visits a
/// subset of the rows the round before visited, so every band sees the same history
/// for the rows it keeps.
pub(super) fn propagate<T: Scalar, P: Photometric<T>>(
    measure: &Measure<'_, T, P>,
    region: &Region,
    planes: &mut Planes<'_, T>,
    jumps: &[usize],
    settle: usize,
    candidate: Option<&[f32]>,
) {
    let (photo, k) = (measure.photo, &measure.k);
    let (stat_robust, cost_robust) = (measure.stat_robust, measure.cost_robust);
    let cost_per_energy = measure.cost_per_energy;
    let (width, first, region_rows) = (region.width, region.first, region.len());
    let Planes {
        current,
        previous,
        stats,
        memory,
    } = planes;
    let reach_after = |round: usize| -> usize {
        settle
            + jumps
                .get(round + 1..)
                .map_or(0, |j| j.iter().sum::<usize>())
    };
    if !jumps.is_empty() {
        let span = region.near(reach_after(0));
        let near_memory = memory
            .get_mut(span.start * width * MEMORY..span.end * width * MEMORY)
            .unwrap_or_default();
        for kept in near_memory.chunks_exact_mut(MEMORY) {
            kept[0] = OwnCost::Unknown.value();
            if let Some(rejected) = kept.get_mut(1..) {
                rejected.fill(T::MAX);
            }
        }
    }
    for (round, &jump) in jumps.iter().enumerate() {
        // The planes have one length (the band's region, cut from one scratch); the zip keeps
        // `copy_from_slice`'s panic path out of the firmware image.
        for (p, c) in previous.iter_mut().zip(current.iter()) {
            *p = *c;
        }
        let rows = region.near(reach_after(round));
        let previous = &*previous;
        let own_candidate = if round == 0 { candidate } else { None };
        for y in rows {
            // `near` rows lie within the region, which `previous` covers; a missing
            // neighbour (past the region) offers the pixel's own value, which the gate
            // skips.
            let row_of = |yy: usize| previous.get(yy * width..(yy + 1) * width);
            let Some(row) = row_of(y) else {
                continue;
            };
            let up = y.checked_sub(jump).and_then(row_of);
            let down = (y + jump < region_rows).then(|| row_of(y + jump)).flatten();
            // Rows with both vertical neighbours: the pixels whose horizontal
            // neighbours lie in the row too read all four side by side, without
            // per-neighbour tests (the same values as the sides take).
            let inner = match (up, down, width.checked_sub(2 * jump)) {
                (Some(up), Some(down), Some(n)) if n > 0 => Some((up, down, n)),
                _ => None,
            };
            let edge = |x: usize| {
                let own = *row.get(x)?;
                let at = |v: Option<&T>| v.copied().unwrap_or(own);
                let candidates = [
                    at(x.checked_sub(jump).and_then(|xx| row.get(xx))),
                    at(row.get(x + jump)),
                    at(up.and_then(|u| u.get(x))),
                    at(down.and_then(|d| d.get(x))),
                ];
                Some((x, own, candidates))
            };
            fn from<T>(s: &[T], at: usize) -> &[T] {
                s.get(at..).unwrap_or_default()
            }
            let (up, down, n) = inner.unwrap_or((&[], &[], 0));
            let (split, resume) = if inner.is_some() {
                (jump, jump + n)
            } else {
                (width, width)
            };
            let lanes = (from(row, 0).iter().zip(from(row, jump)))
                .zip(from(row, 2 * jump))
                .zip(from(up, jump).iter().zip(from(down, jump)))
                .take(n)
                .zip(jump..)
                .map(|((((&left, &own), &right), (&above, &below)), x)| {
                    (x, own, [left, right, above, below])
                });
            let pixels = ((0..split).filter_map(edge))
                .chain(lanes)
                .chain((resume..width).filter_map(edge));
            for (x, own, candidates) in pixels {
                let i = y * width + x;
                // Most pixels agree with all four: one test for them (fewer mispredicted
                // branches than four). A loop rather than `array::map`, which the
                // compiler left as a call per pixel (1.8 % of the stage's instructions).
                // A pair of opposite neighbours on a line through the pixel (second
                // difference within the offer's gate) offers nothing: on a slanted
                // surface their disparities are those of other points of the same
                // plane, which do not fit this pixel better (cotton: 9 % fewer first-round
                // costs, BadPix0.07 1.910 → 1.892, `docs/stages/refine.md`).
                let bent = (
                    (candidates[0] + candidates[1] - own - own).abs() > k.offer,
                    (candidates[2] + candidates[3] - own - own).abs() > k.offer,
                );
                let mut offers = [false; 4];
                for (n, (offer, &d)) in offers.iter_mut().zip(&candidates).enumerate() {
                    let pair_bent = if n < 2 { bent.0 } else { bent.1 };
                    *offer = pair_bent && (d - own).abs() > k.offer;
                }
                // The pixel's own candidate, offered as a neighbour's disparity is
                // where a line of candidates runs through it (no line test of
                // neighbours: it is no neighbour's).
                let extra = match own_candidate {
                    Some(c) => supported(c, width, region_rows, x, y)
                        .map(T::from_f32)
                        .filter(|&e| (e - own).abs() > k.offer),
                    None => None,
                };
                if offers == [false; 4] && extra.is_none() {
                    continue;
                }
                let ([left, right, above, below], [l, r, a, b]) = (candidates, offers);
                let candidates = [left, right, above, below, extra.unwrap_or(own)];
                let offers = [l, r, a, b, extra.is_some()];
                let (Some(kept), Some(stat)) = (
                    memory
                        .get_mut(i * MEMORY..)
                        .and_then(|s| s.first_chunk_mut::<MEMORY>()),
                    stats
                        .get_mut(i * STATS..)
                        .and_then(|s| s.first_chunk_mut::<STATS>()),
                ) else {
                    continue;
                };
                // Disparities already tried this round, and the last ones rejected in
                // earlier rounds: one within `SAME_CANDIDATE` of those is not tried (an
                // equal one would give the same cost, which cannot pass the bar a second
                // time: the bar only falls).
                let mut tried = [own; 5];
                let mut bar = None;
                for (n, (d, offer)) in candidates.into_iter().zip(offers).enumerate() {
                    let near = |t: &T| (*t - d).abs() <= k.same;
                    if !offer
                        || tried.get(..n).is_some_and(|t| t.iter().any(near))
                        || kept[1..].iter().any(near)
                    {
                        continue;
                    }
                    if let Some(t) = tried.get_mut(n) {
                        *t = d;
                    }
                    if OwnCost::read(kept[0]) == OwnCost::Unknown {
                        photo.pixel(x, first + y, own, stat_robust, stat);
                        kept[0] = OwnCost::Fresh.value();
                    }
                    let limit = *bar.get_or_insert_with(|| {
                        let own_cost = match OwnCost::read(kept[0]) {
                            OwnCost::Fresh => {
                                (0..GROUPS).fold(T::ZERO, |e, g| e + stat[3 * g + 2])
                                    * cost_per_energy
                            }
                            other => other.value(),
                        };
                        own_cost * k.accept
                    });
                    if let Some(c) = photo.cost(x, first + y, d, cost_robust, Some(limit)) {
                        bar = Some(c);
                        kept[0] = OwnCost::Known(c).value();
                        if let Some(current) = current.get_mut(i) {
                            *current = d;
                        }
                    } else {
                        // The newest first, the oldest dropped (element by element:
                        // `rotate_right` costs a call per rejection).
                        for j in (2..MEMORY).rev() {
                            kept[j] = kept[j - 1];
                        }
                        kept[1] = d;
                    }
                }
            }
        }
    }
}

/// How close (px) the candidates of two opposite neighbours must be to a pixel's
/// own for it to be offered (half a hypothesis step of the plane sweep's default grid).
const SUPPORT: f32 = 0.125;

/// The candidate of pixel `(x, y)` of the region's rows `candidate` (`width` a row,
/// `rows` rows) where both neighbours on one side of a line through it (left and
/// right, above and below, or either diagonal's two) hold a candidate within
/// [`SUPPORT`] of it: a wire or a bar runs through the pixel. The per-pixel winners of
/// noise rarely line up. `None` elsewhere. In `f32` for every scalar type: the same
/// decision in Q16.16.
fn supported(candidate: &[f32], width: usize, rows: usize, x: usize, y: usize) -> Option<f32> {
    let own = *candidate.get(y * width + x)?;
    if x == 0 || y == 0 || x + 1 >= width || y + 1 >= rows {
        return None;
    }
    let near = |xx: usize, yy: usize| {
        candidate
            .get(yy * width + xx)
            .is_some_and(|&c| (c - own).abs() <= SUPPORT)
    };
    let lines = [
        ((x - 1, y), (x + 1, y)),
        ((x, y - 1), (x, y + 1)),
        ((x - 1, y - 1), (x + 1, y + 1)),
        ((x + 1, y - 1), (x - 1, y + 1)),
    ];
    lines
        .iter()
        .any(|&(a, b)| near(a.0, a.1) && near(b.0, b.1))
        .then_some(own)
}
