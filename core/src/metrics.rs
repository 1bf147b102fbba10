//! HCI 4D Light Field Benchmark metrics: BadPix, MSE×100, Q25.
//!
//! A re-implementation of `shared/tools/hci_metrics.py`, which itself reproduces the
//! general metrics of the official evaluation toolkit (lightfield-analysis/evaluation-toolkit
//! f070f23), quirks included:
//!
//! * only pixels at least `border` (15 by default) pixels from every image edge are
//!   evaluated, further restricted to the nonzero pixels of an optional mask;
//! * BadPix(t) = 100 · #{|est − gt| > t} / #window. A NaN estimate (or gt) makes the
//!   comparison false, so it counts as a GOOD pixel; ±∞ counts as bad;
//! * MSE×100 = 100 · mean((gt − est)²) over window pixels where both are finite;
//! * Q25 = element `int(n · 25 / 100)` of the ascending |est − gt|·100 over the `n` window
//!   pixels where est and gt are finite (no interpolation);
//! * invalid_pct = 100 · #{est is NaN or ±∞} / #window.
//!
//! Everything is accumulated in f64 from the f32 inputs, as numpy does after reading the
//! PFM files. MSE is a sequential sum whereas numpy sums pairwise, so MSE may differ from
//! the Python script in the last few bits (relative ~1e-15); all other scores are computed
//! with the same IEEE operations in the same order and match exactly.

use crate::error::{check_map_lengths, check_scratch, checked_product, Error, Result};

/// The HCI toolkit's evaluation border in pixels (at ground-truth scale 1).
pub const BORDER: usize = 15;

/// The general HCI scores of one disparity estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scores {
    /// Percentage of evaluated pixels with |est − gt| > 0.07.
    pub badpix_007: f64,
    /// Percentage of evaluated pixels with |est − gt| > 0.03.
    pub badpix_003: f64,
    /// Percentage of evaluated pixels with |est − gt| > 0.01.
    pub badpix_001: f64,
    /// Mean squared error × 100 over pixels where estimate and gt are finite
    /// (NaN when there is no such pixel).
    pub mse100: f64,
    /// 25th percentile of |est − gt| × 100 over pixels where estimate and gt are finite
    /// (NaN when there is no such pixel).
    pub q25: f64,
    /// Percentage of evaluated pixels whose estimate is NaN or infinite.
    pub invalid_pct: f64,
}

/// Which pixels are evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EvalOptions<'a> {
    /// Pixels closer than this to an image edge are ignored ([`BORDER`] in the benchmark).
    pub border: usize,
    /// Optional per-pixel mask (row-major, `width · height`); nonzero = evaluate.
    pub mask: Option<&'a [u8]>,
}

impl Default for EvalOptions<'_> {
    fn default() -> Self {
        EvalOptions {
            border: BORDER,
            mask: None,
        }
    }
}

/// Scratch [`evaluate`] needs, in `f32` elements (one per pixel, used to select Q25).
pub fn scratch_len(width: usize, height: usize) -> usize {
    width.saturating_mul(height)
}

/// The scratch holds pixel indices stored as `f32` bit patterns; indices at or above
/// this value would be NaN patterns, whose bits are not guaranteed to survive a copy.
const MAX_PIXELS: usize = 0x7F80_0000;

/// Scores the estimate `est` against the ground truth `gt` (both `width · height` f32,
/// row-major, same orientation).
///
/// Errors: maps or mask of the wrong length ([`Error::OutputSize`]), a scratch shorter
/// than [`scratch_len`] ([`Error::ScratchTooSmall`]), a border or mask that leaves no pixel
/// to evaluate ([`Error::InvalidParameter`]).
pub fn evaluate(
    est: &[f32],
    gt: &[f32],
    width: usize,
    height: usize,
    options: &EvalOptions,
    scratch: &mut [f32],
) -> Result<Scores> {
    let pixels = checked_product(&[width, height], "the disparity map")?;
    if pixels >= MAX_PIXELS {
        return Err(Error::SizeOverflow {
            what: "the disparity map to evaluate",
        });
    }
    check_map_lengths(
        pixels,
        &[("the estimate", est.len()), ("the ground truth", gt.len())],
    )?;
    if let Some(mask) = options.mask {
        if mask.len() != pixels {
            return Err(Error::OutputSize {
                what: "the evaluation mask",
                needed: pixels,
                got: mask.len(),
            });
        }
    }
    check_scratch(pixels, scratch.len())?;
    let border = options.border;
    let cols = border..width.saturating_sub(border);
    let rows = border..height.saturating_sub(border);
    if cols.is_empty() || rows.is_empty() {
        return Err(Error::InvalidParameter {
            name: "border",
            reason: "leaves no pixel to evaluate: use a border smaller than half the image size",
        });
    }

    let mut window = 0usize;
    let mut bad = [0usize; 3];
    let mut invalid = 0usize;
    let mut finite = 0usize;
    let mut squared_sum = 0.0f64;
    for y in rows {
        for x in cols.clone() {
            let i = y * width + x;
            if options
                .mask
                .is_some_and(|m| m.get(i).copied().unwrap_or(0) == 0)
            {
                continue;
            }
            let (e, g) = (pixel(est, i), pixel(gt, i));
            window += 1;
            let abs_err = libm::fabs(e - g);
            for (count, threshold) in bad.iter_mut().zip([0.07, 0.03, 0.01]) {
                // NaN compares false: a NaN estimate is a good pixel, as in the toolkit.
                if abs_err > threshold {
                    *count += 1;
                }
            }
            if !e.is_finite() {
                invalid += 1;
            }
            if e.is_finite() && g.is_finite() {
                let d = g - e;
                squared_sum += d * d;
                if let Some(slot) = scratch.get_mut(finite) {
                    *slot = f32::from_bits(i as u32);
                }
                finite += 1;
            }
        }
    }
    if window == 0 {
        return Err(Error::InvalidParameter {
            name: "mask",
            reason: "selects no pixel inside the evaluation border: mark pixels to evaluate with nonzero values",
        });
    }

    let window_f = window as f64;
    let badpix = bad.map(|b| 100.0 * b as f64 / window_f);
    let (mse100, q25) = if finite == 0 {
        (f64::NAN, f64::NAN)
    } else {
        let scaled_error = |slot: &f32| {
            let i = slot.to_bits() as usize;
            libm::fabs(pixel(est, i) - pixel(gt, i)) * 100.0
        };
        let candidates = scratch.get_mut(..finite).unwrap_or(&mut []);
        // Python: int(n * 25 / 100.0); exact in f64 for any pixel count.
        let k = (finite as f64 * 25.0 / 100.0) as usize;
        let (_, nth, _) = candidates
            .select_nth_unstable_by(k, |a, b| scaled_error(a).total_cmp(&scaled_error(b)));
        (squared_sum / finite as f64 * 100.0, scaled_error(nth))
    };
    Ok(Scores {
        badpix_007: badpix[0],
        badpix_003: badpix[1],
        badpix_001: badpix[2],
        mse100,
        q25,
        invalid_pct: 100.0 * invalid as f64 / window_f,
    })
}

/// Pixel `i` widened to f64 (NaN if out of range, which the callers rule out).
fn pixel(map: &[f32], i: usize) -> f64 {
    map.get(i).map_or(f64::NAN, |&v| v as f64)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec;
    use std::vec::Vec;

    fn score(est: &[f32], gt: &[f32], w: usize, h: usize, options: &EvalOptions) -> Result<Scores> {
        let mut scratch = vec![0.0f32; scratch_len(w, h)];
        evaluate(est, gt, w, h, options, &mut scratch)
    }

    fn no_border() -> EvalOptions<'static> {
        EvalOptions {
            border: 0,
            mask: None,
        }
    }

    #[test]
    fn hand_computed_scores() {
        // Errors 0, 0.02, 0.05, 0.1 (as f32 differences), NaN estimate, +inf estimate.
        let gt = [1.0f32, 1.0, 1.0, 1.0, 1.0, 1.0];
        let est = [1.0f32, 1.02, 0.95, 1.1, f32::NAN, f32::INFINITY];
        let s = score(&est, &gt, 3, 2, &no_border()).unwrap();
        // > 0.07: 0.1 and inf -> 2/6; > 0.03: 0.05, 0.1, inf -> 3/6;
        // > 0.01: 0.02, 0.05, 0.1, inf -> 4/6. NaN is counted as good.
        assert!((s.badpix_007 - 200.0 / 6.0).abs() < 1e-12, "{s:?}");
        assert!((s.badpix_003 - 300.0 / 6.0).abs() < 1e-12, "{s:?}");
        assert!((s.badpix_001 - 400.0 / 6.0).abs() < 1e-12, "{s:?}");
        // Finite pixels: errors 0, .02, .05, .1 -> n = 4, index int(4*25/100) = 1 -> 2.0.
        let errs: Vec<f64> = est[..4]
            .iter()
            .map(|&e| (e as f64 - 1.0).abs() * 100.0)
            .collect();
        assert_eq!(s.q25, errs[1]);
        let mse = errs.iter().map(|e| (e / 100.0).powi(2)).sum::<f64>() / 4.0 * 100.0;
        assert!((s.mse100 - mse).abs() < 1e-12, "{} vs {mse}", s.mse100);
        assert!((s.mse100 - 0.3225).abs() < 1e-5);
        assert!((s.invalid_pct - 200.0 / 6.0).abs() < 1e-12);
    }

    #[test]
    fn border_and_mask_restrict_the_window() {
        // 20x20, border 5 -> window 10x10 = 100 pixels; errors outside must not count.
        let (w, h) = (20, 20);
        let gt = vec![0.5f32; w * h];
        let mut est = vec![9.0f32; w * h];
        for y in 5..15 {
            for x in 5..15 {
                est[y * w + x] = if x < 7 { 0.6 } else { 0.5 };
            }
        }
        let options = EvalOptions {
            border: 5,
            mask: None,
        };
        let s = score(&est, &gt, w, h, &options).unwrap();
        assert!((s.badpix_007 - 20.0).abs() < 1e-12, "{s:?}");
        assert_eq!(s.q25, 0.0);
        assert_eq!(s.invalid_pct, 0.0);
        // A mask keeping only the x < 7 columns makes every evaluated pixel bad.
        let mask: Vec<u8> = (0..w * h).map(|i| u8::from(i % w < 7)).collect();
        let options = EvalOptions {
            border: 5,
            mask: Some(&mask),
        };
        let s = score(&est, &gt, w, h, &options).unwrap();
        assert_eq!(s.badpix_007, 100.0);
        assert!((s.q25 - (0.6f32 as f64 - 0.5) * 100.0).abs() < 1e-12);
    }

    #[test]
    fn q25_picks_the_truncated_index_without_interpolation() {
        // Errors 0..20 (x0.01) on 21 pixels, shuffled: index int(21*25/100) = 5.
        let n = 21;
        let gt = vec![0.0f32; n];
        let est: Vec<f32> = (0..n).map(|i| ((i * 8) % n) as f32 * 0.01).collect();
        let s = score(&est, &gt, n, 1, &no_border()).unwrap();
        assert_eq!(s.q25, (5.0f32 * 0.01) as f64 * 100.0);
    }

    #[test]
    fn matches_python_reference_on_pseudo_random_maps() {
        // Expected values: /work/shared/tools/hci_metrics.py `compute(est, gt, offset=4)` run
        // offline (numpy) on exactly these maps built with the same float32 formulas:
        // gt = ((i*37) % 101)/50 - 1, est = gt + ((i*53) % 97 - 48)/400, est = NaN where
        // i % 29 == 0, else +inf where i % 31 == 0; 40x30, then widened to float64.
        let (w, h) = (40usize, 30usize);
        let mut gt = vec![0.0f32; w * h];
        let mut est = vec![0.0f32; w * h];
        for i in 0..w * h {
            gt[i] = ((i * 37) % 101) as f32 / 50.0 - 1.0;
            let err = ((i * 53) % 97) as f32 - 48.0;
            est[i] = gt[i] + err / 400.0;
            if i % 29 == 0 {
                est[i] = f32::NAN;
            } else if i % 31 == 0 {
                est[i] = f32::INFINITY;
            }
        }
        let options = EvalOptions {
            border: 4,
            mask: None,
        };
        let s = score(&est, &gt, w, h, &options).unwrap();
        let expected = PYTHON_REFERENCE;
        let got = [
            s.badpix_007,
            s.badpix_003,
            s.badpix_001,
            s.mse100,
            s.q25,
            s.invalid_pct,
        ];
        for (g, e) in got.iter().zip(expected.iter()) {
            assert!(
                (g - e).abs() <= 1e-9 * e.abs().max(1.0),
                "{got:?} vs {expected:?}"
            );
        }
    }

    /// See `matches_python_reference_on_pseudo_random_maps`.
    const PYTHON_REFERENCE: [f64; 6] = [
        41.76136363636363,
        73.1534090909091,
        88.49431818181819,
        0.4884588460812097,
        2.999997138977051,
        6.392045454545454,
    ];

    #[test]
    fn bad_inputs_are_errors() {
        let gt = vec![0.0f32; 16 * 16];
        let est = gt.clone();
        let mut scratch = vec![0.0f32; 16 * 16];
        let o = no_border();
        assert!(matches!(
            evaluate(&est[1..], &gt, 16, 16, &o, &mut scratch),
            Err(Error::OutputSize { .. })
        ));
        assert!(matches!(
            evaluate(&est, &gt[1..], 16, 16, &o, &mut scratch),
            Err(Error::OutputSize { .. })
        ));
        assert!(matches!(
            evaluate(&est, &gt, 16, 16, &o, &mut scratch[1..]),
            Err(Error::ScratchTooSmall { .. })
        ));
        let big = EvalOptions {
            border: 8,
            mask: None,
        };
        assert!(matches!(
            evaluate(&est, &gt, 16, 16, &big, &mut scratch),
            Err(Error::InvalidParameter { name: "border", .. })
        ));
        let zeros = vec![0u8; 256];
        let masked = EvalOptions {
            border: 0,
            mask: Some(&zeros),
        };
        assert!(matches!(
            evaluate(&est, &gt, 16, 16, &masked, &mut scratch),
            Err(Error::InvalidParameter { name: "mask", .. })
        ));
        let short = EvalOptions {
            border: 0,
            mask: Some(&zeros[1..]),
        };
        assert!(matches!(
            evaluate(&est, &gt, 16, 16, &short, &mut scratch),
            Err(Error::OutputSize { .. })
        ));
        assert!(matches!(
            evaluate(&est, &gt, usize::MAX, 2, &o, &mut scratch),
            Err(Error::SizeOverflow { .. })
        ));
    }

    #[test]
    fn all_invalid_estimates_give_nan_mse_and_q25() {
        let gt = vec![0.0f32; 256];
        let est = vec![f32::NAN; 256];
        let s = score(&est, &gt, 16, 16, &no_border()).unwrap();
        assert!(s.mse100.is_nan() && s.q25.is_nan());
        assert_eq!(s.invalid_pct, 100.0);
        assert_eq!(s.badpix_007, 0.0);
    }
}
