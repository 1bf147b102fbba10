//! The frame of the solution, which no single view fixes: the gauge set after each view
//! step, the distortion common to every view removed, and the disparity offset moved onto
//! the EPI stage's shears.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::observations::State;
use super::views::baseline;
use crate::align::model::{self, Mat};
use crate::align::{Reference, MAX_FEATURES};
use crate::geometry::Homography;

/// Shortest mean phase vector of the points' disparities (0 … 1) for which
/// [`snap_disparity_offset`] moves the gauge offset. Measured: 0.46–0.51 on the
/// synthetic `planes` arrays (fronto-parallel planes, +6…12 % BadPix0.07 off the
/// shears), 0.18–0.19 on `mixed` (no measurable preference); 256 random phases give
/// about 0.06.
const MIN_DISPARITY_COHERENCE: f32 = 0.3;

/// Fixes the gauge: the centre view is the identity ([`Reference::CentreView`]) or keeps
/// its scale and the position of its image centre, and view translations have no mean
/// component along the baselines.
pub(super) fn fix_gauge(
    state: &State<'_>,
    maps: &mut [Homography],
    width: usize,
    height: usize,
    reference: Reference,
) -> Option<()> {
    let grid = state.grid;
    let (r0, c0) = grid.center();
    let centre = grid.index(r0, c0);
    let o = ((width as f32 - 1.0) * 0.5, (height as f32 - 1.0) * 0.5);
    let mc = model::from_homography(maps.get(centre)?);
    let at = model::apply(&mc, o.0, o.1)?;
    let ax = model::apply(&mc, o.0 + 1.0, o.1)?;
    let ay = model::apply(&mc, o.0, o.1 + 1.0)?;
    let det = (ax.0 - at.0) * (ay.1 - at.1) - (ax.1 - at.1) * (ay.0 - at.0);
    if det.abs().partial_cmp(&1e-6) != Some(core::cmp::Ordering::Greater) {
        return None;
    }
    let g = match reference {
        // Express everything in the centre view's frame: its map becomes the identity.
        Reference::CentreView => mc.try_inverse()?,
        Reference::Estimated => {
            let s = 1.0 / crate::float::sqrtf(det.abs());
            Mat::new(
                s,
                0.0,
                o.0 - s * at.0,
                0.0,
                s,
                o.1 - s * at.1,
                0.0,
                0.0,
                1.0,
            )
        }
    };

    let (mut num, mut den) = (0.0f32, 0.0f32);
    for (v, map) in maps.iter_mut().enumerate().take(grid.len()) {
        if !state.is_tracked(v) {
            continue;
        }
        let m = g * model::from_homography(map);
        *map = model::to_homography(&m)?;
        let b = baseline(grid, v);
        let t = model::apply(&m, o.0, o.1)?;
        num += b.0 * (t.0 - o.0) + b.1 * (t.1 - o.1);
        den += b.0 * b.0 + b.1 * b.1;
    }
    let delta = if den > 0.0 { -num / den } else { 0.0 };
    for (v, map) in maps.iter_mut().enumerate().take(grid.len()) {
        if !state.is_tracked(v) {
            continue;
        }
        let b = baseline(grid, v);
        let shift = Mat::new(1.0, 0.0, delta * b.0, 0.0, 1.0, delta * b.1, 0.0, 0.0, 1.0);
        *map = model::to_homography(&(shift * model::from_homography(map)))?;
    }
    Some(())
}

/// The distortions common to every view that are not gauge: rotation and the two
/// shears, `x ↦ o + (I + A)(x − o)` (uniform scale is gauge). A common perspective is
/// not fitted: its effect on the parallax is second order, and fitting it was measured
/// to make the frame noisier (registration 0.08–0.36 px instead of 0.01–0.33 px) at the
/// same BadPix.
pub(super) const COMMON_MODES: usize = 3;

/// Derivatives of the common distortion at `p = u − o` with respect to its parameters
/// (rotation, shear along the axes, symmetric shear).
pub(super) fn common_mode_derivatives(px: f64, py: f64) -> [[f64; 2]; COMMON_MODES] {
    [[-py, px], [px, -py], [py, px]]
}

/// Solves for the distortion common to every view's map directly and removes it.
///
/// A distortion `C` applied to every map moves a point's observations by
/// `C(X − d·b) ≈ C(X) − d·A·b`: only the parallax `d·b` of each point sees the linear
/// part `A`, so the alternation between the view and the point blocks, each of which
/// re-absorbs what the other changed, creeps towards it by a fraction of the error per
/// round and stops when the improvement stalls (measured: the common rotation stayed
/// 0.2° off on the synthetic tests, 0.76 px at the image corners, costing 3–4 %
/// relative BadPix). Here the three non-gauge modes are fitted jointly by linear least
/// squares on the residuals, each point's own unknowns `(X, d)` projected out, and
/// every map is corrected. `None` (maps untouched) when the system is degenerate.
///
/// The projection is applied through inner products, `⟨Pz, Pw⟩ = ⟨z, w⟩ −
/// (Fᵀz)ᵀ(FᵀF)⁻¹(Fᵀw)` (`P` the projector onto the complement of the point's columns
/// `F`), so each observation is added to a few sums and no per-view table is kept:
/// the stack frame stays small enough for a microcontroller (it held ≈ 60 KB of
/// tables before, docs/EMBEDDED.md).
pub(super) fn correct_common_distortion(
    state: &State<'_>,
    maps: &mut [Homography],
    width: usize,
    height: usize,
) -> Option<()> {
    let grid = state.grid;
    let o = ((width as f32 - 1.0) * 0.5, (height as f32 - 1.0) * 0.5);
    let mut ata = SMatrix::<f64, COMMON_MODES, COMMON_MODES>::zeros();
    let mut atb = SVector::<f64, COMMON_MODES>::zeros();
    // The stacked vectors of one point: the three mode derivatives and the residual.
    const STACKED: usize = COMMON_MODES + 1;
    for i in 0..state.corners.len().min(MAX_FEATURES) {
        if !state.is_solved(i) {
            continue;
        }
        // Per point: the Gram matrix of the stacked vectors, their products with the
        // point's columns `F` (per observation (1, 0), (0, 1), −b) and `FᵀF`.
        let mut gram = SMatrix::<f64, STACKED, STACKED>::zeros();
        let mut ftz = [Vector3::<f64>::zeros(); STACKED];
        let (mut n, mut sbx, mut sby, mut sbb) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for (v, map) in maps.iter().enumerate().take(grid.len()) {
            if !state.is_tracked(v) || !state.inlier(v, i) {
                continue;
            }
            let Some(q) = state.ob(v, i) else { continue };
            let Some(u) = model::apply(&model::from_homography(map), q.0, q.1) else {
                continue;
            };
            let b = baseline(grid, v);
            let (px, py) = (f64::from(u.0 - o.0), f64::from(u.1 - o.1));
            let a = common_mode_derivatives(px, py);
            let r = [
                f64::from(u.0 - (state.x[i] - state.d[i] * b.0)),
                f64::from(u.1 - (state.y[i] - state.d[i] * b.1)),
            ];
            let z = [a[0], a[1], a[2], r];
            let (bx, by) = (f64::from(b.0), f64::from(b.1));
            for p in 0..STACKED {
                ftz[p] += Vector3::new(z[p][0], z[p][1], -(bx * z[p][0] + by * z[p][1]));
                for q in 0..STACKED {
                    gram[(p, q)] += z[p][0] * z[q][0] + z[p][1] * z[q][1];
                }
            }
            n += 1.0;
            sbx += bx;
            sby += by;
            sbb += bx * bx + by * by;
        }
        if n < 3.0 {
            continue;
        }
        let ftf = Matrix3::new(n, 0.0, -sbx, 0.0, n, -sby, -sbx, -sby, sbb);
        let Some(ftf_inv) = ftf.try_inverse() else {
            continue;
        };
        let projected = |p: usize, q: usize| match (gram.get((p, q)), ftz.get(p), ftz.get(q)) {
            (Some(g), Some(zp), Some(zq)) => g - zp.dot(&(ftf_inv * zq)),
            // Indices below `STACKED`: never taken.
            _ => 0.0,
        };
        for k in 0..COMMON_MODES {
            atb[k] += projected(k, COMMON_MODES);
            for l in 0..COMMON_MODES {
                ata[(k, l)] += projected(k, l);
            }
        }
    }
    let phi = model::lu_solve(&ata, &(-atb))?;
    let (r, e, h) = (phi[0] as f32, phi[1] as f32, phi[2] as f32);
    // A small, finite correction or none.
    let largest = r.abs().max(e.abs()).max(h.abs());
    if !phi.iter().all(|p| p.is_finite())
        || largest.partial_cmp(&0.05) != Some(core::cmp::Ordering::Less)
    {
        return None;
    }
    let c = Mat::new(
        1.0 + e,
        h - r,
        o.0 - (1.0 + e) * o.0 - (h - r) * o.1,
        h + r,
        1.0 - e,
        o.1 - (h + r) * o.0 - (1.0 - e) * o.1,
        0.0,
        0.0,
        1.0,
    );
    let corrected = |v: usize, map: &Homography| {
        if state.is_tracked(v) {
            model::to_homography(&(c * model::from_homography(map)))
        } else {
            Some(*map)
        }
    };
    // Every map or none: check them all before writing any (no table of the results).
    if !maps
        .iter()
        .enumerate()
        .take(grid.len())
        .all(|(v, map)| corrected(v, map).is_some())
    {
        return None;
    }
    for (v, map) in maps.iter_mut().enumerate().take(grid.len()) {
        if let Some(h) = corrected(v, map) {
            *map = h;
        }
    }
    Some(())
}

/// Moves the gauge's disparity offset by `δ ∈ (−step/2, step/2]` so that the solved
/// points' disparities lie as near as possible to multiples of `step`: `δ` maximises
/// `Σ cos(2π(d_i + δ)/step)` (the circular mean of the phases `d_i / step`). Adding `δ`
/// to every disparity is the gauge transform `M_v ↦ M_v − δ·b_v` (view → rectified), so
/// the reprojection error does not change. Why: the EPI stage shears at multiples of its
/// step and its estimates near occlusion edges are best for surfaces that lie on a
/// shear; the offset is unobservable, so the estimate may as well put the scene's
/// dominant disparities there (measured on the synthetic `planes` array: a rectified
/// scene shifted by 0.1 px off the shears scores +12 % BadPix0.07 in the EPI stage,
/// docs/stages/align.md). Points with too few views are left out. Only
/// when the phases cluster (their mean vector at least [`MIN_DISPARITY_COHERENCE`]
/// long): disparities spread over every phase gain nothing from the move (measured:
/// the rectified `mixed` array scores within ±2 % at any offset), and then the
/// zero-mean convention, which is nearer the true offset on average, stays. Returns the
/// shift and the coherence.
pub(super) fn snap_disparity_offset(
    state: &mut State<'_>,
    maps: &mut [Homography],
    step: f32,
) -> (f32, f32) {
    let grid = state.grid;
    let n = state.corners.len().min(MAX_FEATURES);
    let turn = core::f32::consts::TAU / step;
    let (mut sin, mut cos, mut count) = (0.0f32, 0.0f32, 0.0f32);
    for i in (0..n).filter(|&i| state.is_solved(i)) {
        let phase = turn * state.d[i];
        sin += libm::sinf(phase);
        cos += libm::cosf(phase);
        count += 1.0;
    }
    let coherence = crate::float::sqrtf(sin * sin + cos * cos) / count.max(1.0);
    // NaN (no solved point) compares as not coherent.
    if coherence.partial_cmp(&MIN_DISPARITY_COHERENCE) == Some(core::cmp::Ordering::Less)
        || coherence.is_nan()
    {
        return (0.0, coherence);
    }
    let delta = -libm::atan2f(sin, cos) / turn;
    if !delta.is_finite() {
        return (0.0, coherence);
    }
    for (v, map) in maps.iter_mut().enumerate().take(grid.len()) {
        if !state.is_tracked(v) {
            continue;
        }
        let b = baseline(grid, v);
        let shift = Mat::new(
            1.0,
            0.0,
            -delta * b.0,
            0.0,
            1.0,
            -delta * b.1,
            0.0,
            0.0,
            1.0,
        );
        if let Some(h) = model::to_homography(&(shift * model::from_homography(map))) {
            *map = h;
        }
    }
    for d in state.d.iter_mut().take(n) {
        *d += delta;
    }
    (delta, coherence)
}
