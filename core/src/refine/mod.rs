//! Photometric refinement of the EPI disparity over many views.
//!
//! The structure tensor measures the slope of EPI lines to a few hundredths of a pixel
//! at best, and fails in whole regions near occlusions. This stage compares the centre
//! view with many views ([`ViewSet`]) directly, in two steps.
//!
//! **Propagation** ([`RefineParams::propagation`] rounds, jump flooding with jumps 8, 4,
//! 2, 1 px): each pixel tries the disparities of its four neighbours at the jump and
//! keeps one whose robust photometric cost (the pixel alone) is below
//! `PROPAGATION_ACCEPT` times its own, which pulls wrong regions to their surroundings.
//!
//! **Gauss–Newton** ([`RefineParams::iterations`]): for view `v` at camera offset
//! `(u, v)` the residual `r = I_v(x − d·u, y − d·v) − I_c(x, y)` per colour channel
//! (bilinear sample) and `g = ∂r/∂d` (a central difference over ±½ px of image motion),
//! each view weighted by the Cauchy weight `s² / (s² + Σ r²)`
//! ([`RefineParams::robust_scale`]) so that occluded or specular views hardly count,
//! give normal equations summed over the views and a square window:
//!
//! ```text
//! d ← Σ_w (A_j d_j − b_j) / Σ_w A_j,     A_j = Σ_v g², b_j = Σ_v g·r   (at d_j)
//! ```
//!
//! i.e. the window average of the per-pixel Gauss–Newton updates weighted by their
//! curvature. The window only takes neighbours within `WINDOW_GATE` of the pixel's
//! disparity (it never straddles a depth edge); the step is clamped to
//! [`RefineParams::max_step`] and the result to the EPI range. Views are summed in four
//! half-plane groups (left, right, up, down): with [`RefineParams::occlusion`] a half
//! that fits much worse than its opposite is dropped, and when the horizontal and
//! vertical views disagree, only the axis with the smaller error is used.
//!
//! The output confidence is `1 / (1 + ε²/s²)` with `ε² = E / A` the squared disparity
//! error the final residual energy `E` amounts to and `s`
//! [`RefineParams::confidence_scale`]: near 1 where the views agree on a textured
//! surface, low in occlusions, textureless areas and wrong regions.
//!
//! # Bands
//! Work is cut into bands of [`RefineParams::band_rows`] image rows. A band is computed
//! on its rows plus a halo of `iterations · radius + Σ jumps` rows on each side ([`halo`],
//! clipped at the image), which is exactly the reach of its result, so bands are
//! independent and the map is bit-identical for any banding and thread count.
//!
//! # Numbers
//! The stage computes in `f32` only (bilinear sampling of sub-pixel positions): a
//! Q16.16 version would need a fixed-point bilinear kernel and is not written yet.

mod params;
mod photo;

pub use params::{RefineParams, ViewSet};

use core::ops::{ControlFlow, Range};

use crate::error::{checked_product, Error, Result};
use crate::lightfield::{LightField, Sample};
use crate::pipeline::Progress;
use crate::plan::Plan;
use photo::{Views, GROUPS, STATS};

/// Progress stage name.
pub const STAGE: &str = "refine";

/// A half of a pair of groups is dropped when its mean squared residual exceeds the
/// other's by this factor plus [`OCCLUSION_FLOOR`].
const OCCLUSION_RATIO: f32 = 2.0;
/// Mean squared residual (unit intensity²) below which groups are never dropped:
/// about the noise of 8-bit images with a little aliasing.
const OCCLUSION_FLOOR: f32 = 1.0e-4;
/// Neighbours whose disparity differs by more than this (px) are left out of a pixel's
/// window: they lie across a depth edge.
const WINDOW_GATE: f32 = 0.1;
/// Horizontal and vertical solutions further apart than this (px) disagree.
const AXIS_AGREEMENT: f32 = 0.05;
/// Curvature added per term so that textureless pixels keep their disparity.
const DAMPING_PER_TERM: f32 = 1.0e-6;

/// Jumps (px) of the propagation rounds, largest first (jump flooding).
const JUMPS: [usize; 4] = [8, 4, 2, 1];
/// A neighbour's disparity replaces a pixel's when its photometric cost is below this
/// share of the pixel's own.
const PROPAGATION_ACCEPT: f32 = 0.7;

fn jumps(plan: &Plan) -> &'static [usize] {
    let rounds = plan.params().refine.propagation.min(JUMPS.len());
    &JUMPS[JUMPS.len() - rounds..]
}

/// Rows of context a band needs on each side.
pub fn halo(plan: &Plan) -> usize {
    let p = &plan.params().refine;
    p.iterations * p.radius + jumps(plan).iter().sum::<usize>()
}

fn region_rows(plan: &Plan) -> usize {
    let rows = plan.params().refine.band_rows + 2 * halo(plan);
    rows.min(plan.layout().height)
}

/// Scratch (`f32` elements) one band needs: `2 + 12` values per pixel of the band and
/// its halo; independent of the image height.
pub fn scratch_len(plan: &Plan) -> usize {
    region_rows(plan)
        .saturating_mul(plan.layout().width)
        .saturating_mul(2 + STATS)
}

/// Number of bands.
pub fn band_count(plan: &Plan) -> usize {
    plan.layout()
        .height
        .div_ceil(plan.params().refine.band_rows)
}

/// Image rows of band `index`.
pub fn band_rows(plan: &Plan, index: usize) -> Result<Range<usize>> {
    let count = band_count(plan);
    if index >= count {
        return Err(Error::OutOfRange {
            what: "refine band",
            index,
            len: count,
        });
    }
    let rows = plan.params().refine.band_rows;
    let start = index * rows;
    Ok(start..(start + rows).min(plan.layout().height))
}

fn check_inputs<S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    disparity: &[f32],
) -> Result<()> {
    if lf.layout() != plan.layout() {
        return Err(Error::InvalidParameter {
            name: "plan",
            reason: "was made for a different light-field layout: build it from this light field",
        });
    }
    if !(range.0.is_finite() && range.1.is_finite() && range.0 <= range.1) {
        return Err(Error::InvalidParameter {
            name: "disparity range",
            reason: "must be finite with min <= max",
        });
    }
    if disparity.len() != plan.pixels() {
        return Err(Error::OutputSize {
            what: "the input disparity",
            needed: plan.pixels(),
            got: disparity.len(),
        });
    }
    Ok(())
}

/// Refines the rows `rows` of `disparity` (the whole EPI map, row-major) into `out`
/// and `confidence` (`rows.len() · width` each, first row of the band first), keeping
/// the result in `range` (the EPI stage's output range). `scratch` needs
/// [`scratch_len`] elements.
#[allow(clippy::too_many_arguments)]
pub fn refine_band<S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    disparity: &[f32],
    rows: Range<usize>,
    out: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [f32],
) -> Result<()> {
    check_inputs(plan, lf, range, disparity)?;
    let (width, height) = (plan.layout().width, plan.layout().height);
    if rows.start >= rows.end || rows.end > height {
        return Err(Error::OutOfRange {
            what: "band end row",
            index: rows.end,
            len: height,
        });
    }
    let p = plan.params().refine;
    if rows.len() > p.band_rows {
        return Err(Error::InvalidParameter {
            name: "rows",
            reason: "a band may not have more rows than refine.band_rows",
        });
    }
    let needed = checked_product(&[rows.len(), width], "the band")?;
    if out.len() != needed || confidence.len() != needed {
        return Err(Error::OutputSize {
            what: "the band disparity/confidence",
            needed,
            got: out.len().min(confidence.len()),
        });
    }
    let halo = halo(plan);
    let first = rows.start.saturating_sub(halo);
    let last = (rows.end + halo).min(height);
    let region = last - first;
    let pixels = region * width;
    let needed = pixels * (2 + STATS);
    if scratch.len() < needed {
        return Err(Error::ScratchTooSmall {
            needed,
            got: scratch.len(),
        });
    }
    let (current, rest) = scratch.split_at_mut(pixels);
    let (previous, rest) = rest.split_at_mut(pixels);
    let stats = &mut rest[..pixels * STATS];
    current.copy_from_slice(&disparity[first * width..last * width]);
    if current.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            what: "the input disparity",
        });
    }

    let views = Views::new(plan.layout(), p.views);
    let data = lf.data();
    let r = p.radius;
    let area = ((2 * r + 1) * (2 * r + 1)) as f32;
    let robust = if p.robust_scale > 0.0 {
        p.robust_scale * p.robust_scale * plan.layout().channels.min(3) as f32
    } else {
        f32::MAX
    };
    // Propagation: each pixel tries the disparities of its four neighbours at each
    // jump and keeps the one the views agree on best (robust cost of the pixel alone),
    // which pulls wrong regions to their surroundings' disparity.
    // `stats[i · STATS]` caches the cost of pixel i at its current disparity: it is
    // read and written only for pixel i, so the order of pixels does not matter.
    let cost = |x: usize, y: usize, d: f32| -> f32 {
        let mut s = [0.0f32; STATS];
        views.pixel(data, x, first + y, d, robust, &mut s);
        (0..GROUPS).map(|k| s[3 * k + 2]).sum()
    };
    if !jumps(plan).is_empty() {
        for y in 0..region {
            for x in 0..width {
                let i = y * width + x;
                stats[i * STATS] = cost(x, y, current[i]);
            }
        }
    }
    for &jump in jumps(plan) {
        previous.copy_from_slice(current);
        for y in 0..region {
            for x in 0..width {
                let i = y * width + x;
                let own = previous[i];
                let mut best = (stats[i * STATS], own);
                let mut bar = best.0 * PROPAGATION_ACCEPT;
                let candidates = [
                    x.checked_sub(jump).map(|xx| y * width + xx),
                    (x + jump < width).then(|| y * width + x + jump),
                    y.checked_sub(jump).map(|yy| yy * width + x),
                    (y + jump < region).then(|| (y + jump) * width + x),
                ];
                for j in candidates.into_iter().flatten() {
                    let d = previous[j];
                    if libm::fabsf(d - own) <= WINDOW_GATE {
                        continue;
                    }
                    let c = cost(x, y, d);
                    if c < bar {
                        bar = c;
                        best = (c, d);
                    }
                }
                current[i] = best.1;
                stats[i * STATS] = best.0;
            }
        }
    }
    // Region rows (relative to `first`) within `reach` rows of the band.
    let near = |reach: usize| -> Range<usize> {
        let lo = rows.start.saturating_sub(reach).max(first) - first;
        let hi = (rows.end + reach).min(last) - first;
        lo..hi
    };
    for iteration in 0..p.iterations {
        // Rows whose statistics the remaining iterations can still reach the band from.
        let measured = near((p.iterations - iteration) * r);
        let updated = near((p.iterations - iteration - 1) * r);
        // Per-pixel normal equations at each pixel's own disparity.
        for y in measured.clone() {
            for x in 0..width {
                let i = y * width + x;
                let mut s = [0.0f32; STATS];
                views.pixel(data, x, first + y, current[i], robust, &mut s);
                stats[i * STATS..(i + 1) * STATS].copy_from_slice(&s);
            }
        }
        let span = measured.start * width..measured.end * width;
        previous[span.clone()].copy_from_slice(&current[span]);
        let last_iteration = iteration + 1 == p.iterations;
        for y in updated {
            for x in 0..width {
                // Window sum over the neighbours whose disparity is within
                // `WINDOW_GATE` of this pixel's: the window does not reach across depth
                // edges. Summed in a fixed order, so every band sums alike.
                let d = previous[y * width + x];
                let mut sum = [0.0f32; STATS];
                for yy in y.saturating_sub(r)..(y + r + 1).min(region) {
                    for xx in x.saturating_sub(r)..(x + r + 1).min(width) {
                        let j = yy * width + xx;
                        if libm::fabsf(previous[j] - d) > WINDOW_GATE {
                            continue;
                        }
                        for (s, v) in sum.iter_mut().zip(&stats[j * STATS..(j + 1) * STATS]) {
                            *s += v;
                        }
                    }
                }
                let i = y * width + x;
                let (a, b, e, terms) =
                    select(&sum, &views.terms, area, p.occlusion, d, DAMPING_PER_TERM);
                let damping = DAMPING_PER_TERM * terms;
                let target = (b + damping * d) / (a + damping);
                let step = (target - d).clamp(-p.max_step, p.max_step);
                let next = (d + step).clamp(range.0, range.1);
                current[i] = if next.is_finite() { next } else { d };
                if last_iteration {
                    let o = (first + y - rows.start) * width + x;
                    out[o] = current[i];
                    let err2 = e / (a + damping);
                    let s2 = p.confidence_scale * p.confidence_scale;
                    let c = 1.0 / (1.0 + err2 / s2);
                    confidence[o] = if c.is_finite() { c } else { 0.0 };
                }
            }
        }
    }
    Ok(())
}

/// Sums the groups that see the pixel: all of them, or without the worse half of the
/// left/right and up/down pairs when it fits much worse (an occluder). When the
/// horizontal and vertical views then disagree on the disparity by more than
/// [`AXIS_AGREEMENT`], only the axis with the smaller error `E / A` is kept: along
/// edges parallel to an axis, that axis' views only see aliasing and noise.
/// Returns `(A, B, E, terms)`.
#[inline]
fn select(
    sum: &[f32; STATS],
    terms: &[f32; GROUPS],
    area: f32,
    occlusion: bool,
    d: f32,
    damping: f32,
) -> (f32, f32, f32, f32) {
    let mut keep = [true; GROUPS];
    if occlusion {
        for pair in [[0, 1], [2, 3]] {
            let mean = |k: usize| sum[3 * k + 2] / (terms[k] * area).max(1.0);
            let (m0, m1) = (mean(pair[0]), mean(pair[1]));
            if m0 > OCCLUSION_RATIO * m1 + OCCLUSION_FLOOR {
                keep[pair[0]] = false;
            } else if m1 > OCCLUSION_RATIO * m0 + OCCLUSION_FLOOR {
                keep[pair[1]] = false;
            }
        }
    }
    let axis = |groups: [usize; 2]| {
        let (mut a, mut b, mut e, mut n) = (0.0, 0.0, 0.0, 0.0);
        for k in groups {
            if keep[k] {
                a += sum[3 * k];
                b += sum[3 * k + 1];
                e += sum[3 * k + 2];
                n += terms[k] * area;
            }
        }
        (a, b, e, n)
    };
    let h = axis([0, 1]);
    let v = axis([2, 3]);
    let solve = |s: (f32, f32, f32, f32)| (s.1 + damping * s.3 * d) / (s.0 + damping * s.3);
    let error = |s: (f32, f32, f32, f32)| s.2 / (s.0 + damping * s.3);
    if h.3 > 0.0 && v.3 > 0.0 && libm::fabsf(solve(h) - solve(v)) > AXIS_AGREEMENT {
        return if error(h) <= error(v) { h } else { v };
    }
    (h.0 + v.0, h.1 + v.1, h.2 + v.2, h.3 + v.3)
}

/// The serial stage with progress: every band in order into `out` / `confidence`
/// (row-major, `plan.pixels()` each).
#[allow(clippy::too_many_arguments)]
pub fn refine_with_progress<S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    disparity: &[f32],
    out: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [f32],
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<()> {
    check_inputs(plan, lf, range, disparity)?;
    let pixels = plan.pixels();
    if out.len() != pixels || confidence.len() != pixels {
        return Err(Error::OutputSize {
            what: "the refined disparity/confidence",
            needed: pixels,
            got: out.len().min(confidence.len()),
        });
    }
    let width = plan.layout().width;
    let bands = band_count(plan);
    for band in 0..bands {
        let report = Progress {
            stage: STAGE,
            done: band as u64,
            total: bands as u64,
        };
        if progress(report).is_break() {
            return Err(Error::Cancelled);
        }
        let rows = band_rows(plan, band)?;
        let span = rows.start * width..rows.end * width;
        refine_band(
            plan,
            lf,
            range,
            disparity,
            rows,
            &mut out[span.clone()],
            &mut confidence[span],
            scratch,
        )?;
    }
    match progress(Progress {
        stage: STAGE,
        done: bands as u64,
        total: bands as u64,
    }) {
        ControlFlow::Continue(()) => Ok(()),
        ControlFlow::Break(()) => Err(Error::Cancelled),
    }
}

/// The serial stage: refines `disparity` into `out` with a new `confidence`.
pub fn refine<S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    disparity: &[f32],
    out: &mut [f32],
    confidence: &mut [f32],
    scratch: &mut [f32],
) -> Result<()> {
    refine_with_progress(
        plan,
        lf,
        range,
        disparity,
        out,
        confidence,
        scratch,
        &mut |_| ControlFlow::Continue(()),
    )
}

#[cfg(test)]
mod tests;
