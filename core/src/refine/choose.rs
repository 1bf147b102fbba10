//! The fused start's choice: of two refined starts, per pixel the one the views agree
//! with better (docs/stages/fused.md).

use core::ops::Range;

use super::photo::{cost_scale, Photometric, Rectified, INTENSITY_SCALE};
use super::RefineParams;
use crate::error::{Error, Result};
use crate::lightfield::{LightField, Sample};
use crate::scalar::Scalar;
use crate::setup::{DisparityOut, Setup};

/// Two starts within this many px of each other at a pixel agree: the pixel keeps the
/// first start's (`kept`) without comparing costs (the refinement's window gate).
pub(crate) const AGREE: f32 = 0.1;

/// Radius of the window whose photometric cost decides between two starts that
/// disagree: `(2·1 + 1)²` pixels (a radius of 2 carries foreground further out at
/// silhouettes, 0 follows the noise: docs/stages/fused.md).
pub(crate) const RADIUS: usize = 1;

/// Per pixel of `rows`, of two refined starts the one whose disparity the views agree
/// with better: `out` holds one start's refined disparity and confidence for `rows`
/// (as [`super::refine_band`] wrote them) and takes `kept`'s (the same rows of the other
/// start) where the two are within `AGREE` (0.1) px or where `kept`'s disparity has the
/// lower or equal photometric cost over the `3×3` window around the pixel. The cost at
/// disparity `d` is the refinement's robust cost (Cauchy-weighted residuals of every
/// compared view against the centre view, [`RefineParams::views`]) summed over the
/// window's pixels, each at `d`: one scale for both starts, which their own
/// confidences (the tensor's coherence, the sweep's cost contrast) are not. The chosen
/// start's refinement confidence goes with it.
///
/// Never inlined: its view tables would otherwise share the schedule's frame with the
/// refinement's that is called beside it, and the two frames together take the
/// firmware's whole-frame image past its 16 KiB stack.
#[inline(never)]
pub fn choose<T: Scalar, S: Sample>(
    setup: Setup<'_, RefineParams>,
    lf: &LightField<'_, S>,
    rows: Range<usize>,
    kept: (&[f32], &[f32]),
    out: DisparityOut<'_>,
) -> Result<()> {
    let (width, height) = (setup.layout().width, setup.layout().height);
    let (kd, kc) = kept;
    let len = rows.len().saturating_mul(width);
    if rows.end > height
        || out.disparity.len() != len
        || out.confidence.len() != len
        || kd.len() != len
        || kc.len() != len
    {
        return Err(Error::OutputSize {
            what: "the fused start's candidates",
            needed: len,
            got: kd.len().min(kc.len()).min(out.disparity.len()),
        });
    }
    let p = setup.params();
    super::with_rectified(setup, lf, |photo: &Rectified<'_, T, S>| {
        // The robust scale of the refinement's candidate costs (`refine::band`).
        let used = setup.layout().channels.min(3) as f32;
        let memberships = photo.views().terms.iter().sum::<f32>() / used;
        let robust = p.robust_scale * p.robust_scale * used * INTENSITY_SCALE * INTENSITY_SCALE;
        let (robust, scale) = if p.robust_scale > 0.0 {
            (T::from_f32(robust), cost_scale(robust, memberships))
        } else {
            (T::MAX, 1.0)
        };
        let cost_robust = (robust, robust * T::from_f32(scale));
        // Summed in f32: the window's sum may exceed Q16.16's range.
        let window_cost = |x: usize, y: usize, d: f32| {
            let d = T::from_f32(d);
            let mut sum = 0.0f32;
            for yy in y.saturating_sub(RADIUS)..(y + RADIUS + 1).min(height) {
                for xx in x.saturating_sub(RADIUS)..(x + RADIUS + 1).min(width) {
                    sum += photo
                        .cost(xx, yy, d, cost_robust, None)
                        .map_or(f32::INFINITY, |c| c.to_f32());
                }
            }
            sum
        };
        let outputs = out.disparity.iter_mut().zip(out.confidence.iter_mut());
        let pixels = rows.flat_map(|y| (0..width).map(move |x| (x, y)));
        for (((d, c), (&k, &ck)), (x, y)) in outputs.zip(kd.iter().zip(kc)).zip(pixels) {
            if (*d - k).abs() <= AGREE || window_cost(x, y, *d) >= window_cost(x, y, k) {
                *d = k;
                *c = ck;
            }
        }
        Ok(())
    })
}
